//! The server side of [`super::NetPlugin`]: each client request is checked,
//! an accepted edit goes into the frame's [`ApplyEdit`] / [`UndoEdit`] /
//! [`RedoEdit`] messages (so it applies in order with the server's own), and
//! every op the frame applied is numbered ([`Sequencer`]) and sent to the
//! clients that joined its volume.

use super::protocol::{self, ClientWire, Reply, Request, ServerWire};
use super::{
    Cursor, LocalCursor, NetSettings, NetStats, NetVolume, NewShared, PeerCursors, RequestRefused,
    CURSOR_PERIOD,
};
use crate::messages::{ApplyEdit, EditApplied, RedoEdit, UndoEdit};
use crate::persist::file::{self, SaveData};
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::KdContourStep;
use bevy::prelude::*;
use bevy_replicon::prelude::*;
use kdcontour::edit::{EditOp, Sequencer};
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};

pub(super) fn build(app: &mut App) {
    app.init_resource::<ClientCursors>()
        .add_systems(OnEnter(ServerState::Running), start_session)
        .add_systems(
            PostUpdate,
            (
                track_volumes.in_set(KdContourStep::SyncVolumes),
                receive_requests.in_set(KdContourStep::ReceiveEdits),
                (send_applied, share_cursors)
                    .in_set(KdContourStep::SendEdits)
                    .before(ServerSystems::Send),
            )
                .run_if(in_state(ServerState::Running)),
        );
}

/// On a server's [`NetVolume`]: the numbering of the ops applied to it, and
/// the clients that joined it.
#[derive(Component)]
pub struct Authority {
    sequencer: Sequencer,
    joined: BTreeSet<Entity>,
}

impl Authority {
    /// The number of the last op applied (0: none since the server started).
    pub fn last(&self) -> u64 {
        self.sequencer.last()
    }

    /// The ops numbered in `range` that the server still keeps, with their
    /// numbers (`None` when it no longer keeps the first).
    pub fn ops(&self, range: std::ops::Range<u64>) -> Option<Vec<(u64, EditOp)>> {
        self.sequencer.ops(range)
    }

    /// Clients that joined the volume (those gone are dropped when the next
    /// op goes out).
    pub fn clients(&self) -> usize {
        self.joined.len()
    }
}

/// This server run's id: a rejoining client's op numbers mean something only
/// in the session that gave them.
#[derive(Resource, Clone, Copy, Debug)]
struct Session(u64);

/// The most ops one resend request gets back.
const MAX_RESEND: u64 = 1024;

/// Takes one request from `client`'s allowance, which refills at the set rate
/// up to the burst; false when it is spent.
fn allow(
    allowances: &mut HashMap<Entity, Allowance>,
    client: Entity,
    now: f64,
    settings: &NetSettings,
) -> bool {
    let (rate, burst) = (settings.edits_per_second, settings.edit_burst.max(1.0));
    let a = allowances.entry(client).or_insert(Allowance {
        tokens: burst,
        at: now,
    });
    a.tokens = (a.tokens + (now - a.at) as f32 * rate).min(burst);
    a.at = now;
    let allowed = a.tokens >= 1.0;
    if allowed {
        a.tokens -= 1.0;
    }
    allowed
}

fn rate_reason(settings: &NetSettings) -> String {
    format!(
        "too many edits: this server takes {} a second from each player (bursts of {})",
        settings.edits_per_second,
        settings.edit_burst.max(1.0)
    )
}

/// Where each client's brush aims: (volume net id, centre, radius).
#[derive(Resource, Default)]
struct ClientCursors(HashMap<Entity, (u64, Vec3, f32)>);

/// A client's allowance of edit requests (a token bucket).
struct Allowance {
    tokens: f32,
    at: f64,
}

fn start_session(mut commands: Commands) {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    commands.insert_resource(Session(now.as_nanos() as u64 | 1));
}

/// Shared volumes get their numbering once they mesh.
fn track_volumes(
    mut commands: Commands,
    settings: Res<NetSettings>,
    new: Query<Entity, NewShared<Authority>>,
) {
    for e in &new {
        commands.entity(e).insert(Authority {
            sequencer: Sequencer::new(settings.keep_ops),
            joined: BTreeSet::new(),
        });
    }
}

/// What the server answers and counts.
struct Outbox<'a, 'o, 'r> {
    out: &'a mut MessageWriter<'o, ToClients<ServerWire>>,
    refused: &'a mut MessageWriter<'r, RequestRefused>,
    stats: &'a mut NetStats,
    /// The clients still connected (a reply to one that left this frame is
    /// dropped: the transport takes messages only for connected clients).
    connected: HashSet<Entity>,
}

impl Outbox<'_, '_, '_> {
    fn send(&mut self, client: Entity, reply: &Reply) {
        self.send_bytes(client, protocol::encode(reply));
    }

    /// Sends `client` the volume's whole history, in the save format, as of
    /// the last op.
    fn send_history(
        &mut self,
        client: Entity,
        auth: &Authority,
        net: &NetVolume,
        state: &VolumeState,
        session: u64,
    ) {
        let snap = auth.sequencer.snapshot(state.history());
        let save = file::encode(&SaveData {
            fingerprint: net.fingerprint.clone(),
            edits: snap.log,
            undo: snap.steps,
        });
        self.stats.snapshots += 1;
        self.stats.snapshot_bytes += save.len() as u64;
        let joined = Reply::Joined {
            volume: net.id,
            session,
            through: snap.through,
            save: Some(save),
        };
        self.send(client, &joined);
    }

    /// Sends an encoded reply (encode once, send to many).
    fn send_bytes(&mut self, client: Entity, bytes: Vec<u8>) {
        if !self.connected.contains(&client) {
            return;
        }
        self.stats.bytes_out += bytes.len() as u64;
        self.out.write(ToClients {
            targets: SendTargets::Single(ClientId::Client(client)),
            message: ServerWire(bytes),
        });
    }

    fn refuse(&mut self, client: Entity, volume: u64, kind: &'static str, reason: String) {
        info!("refused a request from client {client}: {reason}");
        *self.stats.refused.entry(kind).or_default() += 1;
        self.send(
            client,
            &Reply::Refused {
                volume,
                reason: reason.clone(),
            },
        );
        self.refused.write(RequestRefused {
            client,
            kind,
            reason,
        });
    }
}

#[allow(clippy::too_many_arguments)]
fn receive_requests(
    mut wire: MessageReader<FromClient<ClientWire>>,
    mut out: MessageWriter<ToClients<ServerWire>>,
    mut refused: MessageWriter<RequestRefused>,
    mut edits: MessageWriter<ApplyEdit>,
    mut undos: MessageWriter<UndoEdit>,
    mut redos: MessageWriter<RedoEdit>,
    settings: Res<NetSettings>,
    session: Option<Res<Session>>,
    time: Res<Time<Real>>,
    mut stats: ResMut<NetStats>,
    mut volumes: Query<(Entity, &NetVolume, &VolumeState, &mut Authority)>,
    clients: Query<Entity, With<ConnectedClient>>,
    mut allowances: Local<HashMap<Entity, Allowance>>,
    mut cursors: ResMut<ClientCursors>,
    clock: Res<MainThreadClock>,
) {
    let _time = clock.measure();
    allowances.retain(|c, _| clients.contains(*c));
    cursors.0.retain(|c, _| clients.contains(*c));
    let session = session.map_or(0, |s| s.0);
    let now = time.elapsed_secs_f64();
    let mut outbox = Outbox {
        out: &mut out,
        refused: &mut refused,
        stats: &mut stats,
        connected: clients.iter().collect(),
    };
    for msg in wire.read() {
        let Some(client) = msg.client_id.entity() else {
            continue; // the server's own (it applies its edits directly)
        };
        outbox.stats.requests += 1;
        outbox.stats.bytes_in += msg.message.0.len() as u64;
        if msg.message.0.len() > settings.max_request_bytes {
            let reason = format!(
                "a request of {} bytes is larger than this server accepts ({} bytes)",
                msg.message.0.len(),
                settings.max_request_bytes
            );
            outbox.refuse(client, 0, "too_large", reason);
            continue;
        }
        let request: Request = match protocol::decode(&msg.message.0) {
            Ok(r) => r,
            Err(e) => {
                let reason = format!("the request does not decode ({e}); is the client the same version as the server?");
                outbox.refuse(client, 0, "malformed", reason);
                continue;
            }
        };
        let id = request.volume();
        let Some((volume, net, state, mut auth)) = volumes.iter_mut().find(|v| v.1.id == id) else {
            let ids: Vec<u64> = volumes.iter().map(|v| v.1.id).collect();
            let reason = format!("this server has no shared volume {id} (it has {ids:?})");
            outbox.refuse(client, id, "unknown_volume", reason);
            continue;
        };
        match request {
            Request::Join {
                fingerprint, have, ..
            } => {
                if fingerprint != net.fingerprint {
                    let reason = format!(
                        "volume {id} here is made on {}, the client's on {fingerprint}: start the client with the server's field (its seed and parameters)",
                        net.fingerprint
                    );
                    outbox.refuse(client, id, "other_field", reason);
                    continue;
                }
                if !auth.joined.insert(client) {
                    let reason = format!(
                        "volume {id} is already joined on this connection (a client joins once, and again after reconnecting)"
                    );
                    outbox.refuse(client, id, "repeated", reason);
                    continue;
                }
                let last = auth.sequencer.last();
                // A client that rejoins this session gets only what it missed,
                // while the server still keeps it.
                let missed = have
                    .filter(|&(s, h)| s == session && h <= last)
                    .and_then(|(_, h)| Some((h, auth.sequencer.ops(h + 1..last + 1)?)));
                match missed {
                    Some((through, ops)) => {
                        let joined = Reply::Joined {
                            volume: id,
                            session,
                            through,
                            save: None,
                        };
                        outbox.send(client, &joined);
                        if !ops.is_empty() {
                            outbox.send(client, &Reply::Ops { volume: id, ops });
                        }
                    }
                    None => {
                        outbox.send_history(client, &auth, net, state, session);
                    }
                }
            }
            Request::Cursor { at, .. } => match at {
                Some((c, r)) if c.is_finite() && r.is_finite() && auth.joined.contains(&client) => {
                    cursors.0.insert(client, (id, c, r));
                }
                _ => {
                    cursors.0.remove(&client);
                }
            },
            Request::Resend { from, to, .. } => {
                if !auth.joined.contains(&client) {
                    let reason = format!("join volume {id} before asking for its edits");
                    outbox.refuse(client, id, "not_joined", reason);
                    continue;
                }
                // A resend costs like an edit, and sends at most MAX_RESEND ops.
                if !allow(&mut allowances, client, now, &settings) {
                    outbox.refuse(client, id, "rate", rate_reason(&settings));
                    continue;
                }
                match auth
                    .sequencer
                    .ops(from..to.min(from.saturating_add(MAX_RESEND)))
                {
                    Some(ops) => outbox.send(client, &Reply::Ops { volume: id, ops }),
                    None => {
                        outbox.send_history(client, &auth, net, state, session);
                    }
                }
            }
            Request::Edit { op, .. } => {
                if !auth.joined.contains(&client) {
                    let reason = format!("join volume {id} before editing it");
                    outbox.refuse(client, id, "not_joined", reason);
                    continue;
                }
                if let EditOp::Apply { brush, .. } = &op {
                    match brush.reach() {
                        Err(e) => {
                            outbox.refuse(
                                client,
                                id,
                                "bad_brush",
                                format!("the brush is refused: {e}"),
                            );
                            continue;
                        }
                        Ok((center, reach))
                            if reach.is_nan()
                                || reach > settings.max_brush_reach
                                || !center.is_finite() =>
                        {
                            let reason = format!(
                                "the brush reaches {reach} units; this server allows {}",
                                settings.max_brush_reach
                            );
                            outbox.refuse(client, id, "too_large", reason);
                            continue;
                        }
                        Ok(_) => {}
                    }
                }
                if !allow(&mut allowances, client, now, &settings) {
                    outbox.refuse(client, id, "rate", rate_reason(&settings));
                    continue;
                }
                outbox.stats.accepted += 1;
                match op {
                    EditOp::Apply {
                        brush,
                        continues_stroke,
                    } => {
                        edits.write(ApplyEdit {
                            volume,
                            brush,
                            continues_stroke,
                        });
                    }
                    EditOp::Undo => {
                        undos.write(UndoEdit { volume });
                    }
                    EditOp::Redo => {
                        redos.write(RedoEdit { volume });
                    }
                }
            }
        }
    }
}

/// Numbers the ops applied this frame and sends them to the volume's clients.
fn send_applied(
    mut applied: MessageReader<EditApplied>,
    mut out: MessageWriter<ToClients<ServerWire>>,
    mut refused: MessageWriter<RequestRefused>,
    mut stats: ResMut<NetStats>,
    clients: Query<Entity, With<ConnectedClient>>,
    mut volumes: Query<(&NetVolume, &mut Authority)>,
    clock: Res<MainThreadClock>,
) {
    let _time = clock.measure();
    let mut fresh: BTreeMap<Entity, Vec<(u64, EditOp)>> = BTreeMap::new();
    for msg in applied.read() {
        let Ok((net, mut auth)) = volumes.get_mut(msg.volume) else {
            continue;
        };
        match &msg.op {
            Some(op) => {
                let n = auth.sequencer.record(op.clone());
                fresh.entry(msg.volume).or_default().push((n, op.clone()));
            }
            None => warn!(
                "shared volume {}: its field was replaced; clients are not told (give it a new id and fingerprint)",
                net.id
            ),
        }
    }
    let mut outbox = Outbox {
        out: &mut out,
        refused: &mut refused,
        stats: &mut stats,
        connected: clients.iter().collect(),
    };
    for (volume, ops) in fresh {
        let Ok((net, mut auth)) = volumes.get_mut(volume) else {
            continue;
        };
        auth.joined.retain(|c| clients.contains(*c));
        let bytes = protocol::encode(&Reply::Ops {
            volume: net.id,
            ops,
        });
        for &client in &auth.joined {
            outbox.send_bytes(client, bytes.clone());
        }
    }
}

/// A few times a second: every player's brush cursor to the other players of
/// its volume (the server's own as player 0), and the clients' to the server.
#[allow(clippy::too_many_arguments)]
fn share_cursors(
    mut out: MessageWriter<ToClients<ServerWire>>,
    mut refused: MessageWriter<RequestRefused>,
    mut stats: ResMut<NetStats>,
    time: Res<Time<Real>>,
    mut next: Local<f64>,
    local: Res<LocalCursor>,
    cursors: Res<ClientCursors>,
    mut peers: ResMut<PeerCursors>,
    volumes: Query<(Entity, &NetVolume, &Authority)>,
    clients: Query<Entity, With<ConnectedClient>>,
    clock: Res<MainThreadClock>,
) {
    let _time = clock.measure();
    let now = time.elapsed_secs_f64();
    if now < *next {
        return;
    }
    *next = now + CURSOR_PERIOD;
    let mut outbox = Outbox {
        out: &mut out,
        refused: &mut refused,
        stats: &mut stats,
        connected: clients.iter().collect(),
    };
    peers.0.clear();
    for (entity, net, auth) in &volumes {
        let mut all: Vec<(u64, Vec3, f32)> = Vec::new();
        if let Some(c) = local.0.filter(|c| c.volume == entity) {
            all.push((0, c.at, c.radius));
        }
        for (client, &(id, at, radius)) in &cursors.0 {
            if id == net.id {
                all.push((client.to_bits(), at, radius));
                peers.0.push((
                    client.to_bits(),
                    Cursor {
                        volume: entity,
                        at,
                        radius,
                    },
                ));
            }
        }
        for &client in &auth.joined {
            let others: Vec<_> = all
                .iter()
                .copied()
                .filter(|c| c.0 != client.to_bits())
                .collect();
            outbox.send(
                client,
                &Reply::Cursors {
                    volume: net.id,
                    cursors: others,
                },
            );
        }
    }
}
