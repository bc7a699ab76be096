//! The client side of [`super::NetPlugin`]: a shared volume's edits go to the
//! server as requests; what the server accepted comes back numbered and is
//! applied in order, each once ([`Replica`]); a gap is asked for again; on
//! joining (and rejoining) the volume takes the server's history.

use super::protocol::{self, ClientWire, Reply, Request, ServerWire};
use super::{
    Cursor, LocalCursor, NetJoined, NetRefused, NetStats, NetVolume, NewShared, PeerCursors,
    CURSOR_PERIOD,
};
use crate::edits::{apply_op, read_ops, RemoteEdits};
use crate::messages::{ApplyEdit, EditApplied, RedoEdit, UndoEdit};
use crate::persist::file;
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::KdContourStep;
use bevy::prelude::*;
use bevy_replicon::prelude::*;
use kdcontour::edit::{EditHistory, EditOp, Replica};
use std::ops::Range;
use std::path::Path;

pub(super) fn build(app: &mut App) {
    app.add_systems(OnExit(ClientState::Connected), dropped)
        .add_systems(
            PostUpdate,
            (
                track_volumes
                    .in_set(KdContourStep::SyncVolumes)
                    .run_if(not(in_state(ClientState::Disconnected))),
                (receive_replies, send_requests)
                    .chain()
                    .in_set(KdContourStep::ReceiveEdits)
                    .before(ClientSystems::Send)
                    .run_if(in_state(ClientState::Connected)),
            ),
        );
}

/// On a client's [`NetVolume`]: where its history stands in the server's.
#[derive(Component, Default)]
pub struct Follower {
    replica: Replica,
    /// The server session the history came from (`None`: not joined yet).
    session: Option<u64>,
    /// The join request went out on this connection.
    asked: bool,
    /// The server answered it.
    joined: bool,
    /// Ops that came before the join's answer.
    early: Vec<(u64, EditOp)>,
    /// The gap last asked for.
    asked_gap: Option<Range<u64>>,
    /// The server has not heard this player's brush cursor since it joined.
    cursor_unsent: bool,
}

impl Follower {
    /// The last server op applied.
    pub fn applied(&self) -> u64 {
        self.replica.applied()
    }

    /// The server answered this connection's join.
    pub fn joined(&self) -> bool {
        self.joined
    }
}

/// A client's shared volumes follow the server from their first frame.
fn track_volumes(mut commands: Commands, new: Query<Entity, NewShared<Follower>>) {
    for e in &new {
        commands
            .entity(e)
            .insert((Follower::default(), RemoteEdits));
    }
}

/// The connection dropped: the other players' cursors go; join again when it
/// is back (asking only for what was missed).
fn dropped(mut followers: Query<&mut Follower>, mut peers: ResMut<PeerCursors>) {
    peers.0.clear();
    for mut f in &mut followers {
        f.asked = false;
        f.joined = false;
        f.asked_gap = None;
    }
}

fn send(out: &mut MessageWriter<ClientWire>, stats: &mut NetStats, request: &Request) {
    let bytes = protocol::encode(request);
    stats.requests += 1;
    stats.bytes_out += bytes.len() as u64;
    out.write(ClientWire(bytes));
}

#[allow(clippy::too_many_arguments)]
fn receive_replies(
    mut wire: MessageReader<ServerWire>,
    mut out: MessageWriter<ClientWire>,
    mut applied: MessageWriter<EditApplied>,
    mut refused: MessageWriter<NetRefused>,
    mut joined: MessageWriter<NetJoined>,
    settings: Res<KdContourSettings>,
    mut stats: ResMut<NetStats>,
    mut peers: ResMut<PeerCursors>,
    mut volumes: Query<(Entity, &NetVolume, &mut VolumeState, &mut Follower)>,
    clock: Res<MainThreadClock>,
) {
    let _time = clock.measure();
    let steps = settings.undo_steps;
    for msg in wire.read() {
        stats.bytes_in += msg.0.len() as u64;
        let reply: Reply = match protocol::decode(&msg.0) {
            Ok(r) => r,
            Err(e) => {
                error!("a server reply does not decode ({e}); is the server the same version?");
                *stats.refused.entry("malformed").or_default() += 1;
                continue;
            }
        };
        let id = match &reply {
            Reply::Joined { volume, .. }
            | Reply::Ops { volume, .. }
            | Reply::Cursors { volume, .. }
            | Reply::Refused { volume, .. } => *volume,
        };
        let found = volumes.iter_mut().find(|v| v.1.id == id);
        let Some((entity, net, mut state, mut follower)) = found else {
            if let Reply::Refused { reason, .. } = reply {
                warn!("the server refused a request: {reason}");
                refused.write(NetRefused {
                    volume: None,
                    reason,
                });
            }
            continue;
        };
        match reply {
            Reply::Cursors { cursors, .. } => {
                peers.0.retain(|(_, c)| c.volume != entity);
                peers
                    .0
                    .extend(cursors.into_iter().map(|(player, at, radius)| {
                        let cursor = Cursor {
                            volume: entity,
                            at,
                            radius,
                        };
                        (player, cursor)
                    }));
            }
            Reply::Refused { reason, .. } => {
                warn!("the server refused a request on volume {id}: {reason}");
                refused.write(NetRefused {
                    volume: Some(entity),
                    reason,
                });
            }
            Reply::Joined {
                session,
                through,
                save,
                ..
            } => {
                let bytes = save.as_ref().map_or(0, Vec::len);
                if let Some(save) = save {
                    let restored = file::decode(Path::new("the server's history"), &save)
                        .map_err(|e| e.to_string())
                        .and_then(|data| {
                            if data.fingerprint != net.fingerprint {
                                return Err(format!(
                                    "the server's history is for {}, this volume is {}",
                                    data.fingerprint, net.fingerprint
                                ));
                            }
                            let base = state.field().prefix(0);
                            EditHistory::restore(base, data.edits, &data.undo)
                                .map_err(|e| e.to_string())
                        });
                    match restored {
                        Ok(history) => {
                            *state.history_mut() = history;
                            state.rebuild_all();
                            follower.replica = Replica::new(through);
                            stats.snapshots += 1;
                            stats.snapshot_bytes += bytes as u64;
                        }
                        Err(reason) => {
                            error!("volume {id}: {reason}");
                            refused.write(NetRefused {
                                volume: Some(entity),
                                reason,
                            });
                            continue;
                        }
                    }
                }
                follower.session = Some(session);
                follower.joined = true;
                follower.cursor_unsent = true;
                follower.asked_gap = None;
                joined.write(NetJoined {
                    volume: entity,
                    through,
                    bytes,
                });
                let early = std::mem::take(&mut follower.early);
                take_ops(
                    &mut state,
                    &mut follower,
                    entity,
                    early,
                    steps,
                    &mut applied,
                    &mut stats,
                );
            }
            Reply::Ops { ops, .. } => {
                if follower.joined {
                    take_ops(
                        &mut state,
                        &mut follower,
                        entity,
                        ops,
                        steps,
                        &mut applied,
                        &mut stats,
                    );
                } else {
                    follower.early.extend(ops);
                }
            }
        }
        // Ask once for a gap (a lost or reordered reply), again when it moves.
        if follower.joined {
            let gap = follower.replica.missing();
            if gap.is_some() && gap != follower.asked_gap {
                let r = gap.clone().expect("checked");
                send(
                    &mut out,
                    &mut stats,
                    &Request::Resend {
                        volume: id,
                        from: r.start,
                        to: r.end,
                    },
                );
            }
            follower.asked_gap = gap;
        }
    }
}

/// Applies the server's ops in order, each once.
fn take_ops(
    state: &mut VolumeState,
    follower: &mut Follower,
    volume: Entity,
    ops: Vec<(u64, EditOp)>,
    steps: usize,
    applied: &mut MessageWriter<EditApplied>,
    stats: &mut NetStats,
) {
    for (n, op) in ops {
        let due = follower.replica.ready(n, op);
        if due.is_empty() && n <= follower.replica.applied() {
            stats.ops_ignored += 1;
        }
        for op in due {
            stats.ops_applied += 1;
            match apply_op(state, &op, steps) {
                Ok(rebuilt) => {
                    applied.write(EditApplied {
                        volume,
                        rebuilt,
                        op: Some(op),
                    });
                }
                Err(e) => error!("the server's op {n} does not apply here: {e}"),
            }
        }
    }
}

/// Joins shared volumes, and sends the player's edits, undos and redos on
/// them to the server.
#[allow(clippy::too_many_arguments)]
fn send_requests(
    mut edits: MessageReader<ApplyEdit>,
    mut undos: MessageReader<UndoEdit>,
    mut redos: MessageReader<RedoEdit>,
    mut out: MessageWriter<ClientWire>,
    mut refused: MessageWriter<NetRefused>,
    mut stats: ResMut<NetStats>,
    mut volumes: Query<(&NetVolume, &mut Follower)>,
    cursor: Res<LocalCursor>,
    time: Res<Time<Real>>,
    mut cursor_sent: Local<(f64, LocalCursor)>,
    clock: Res<MainThreadClock>,
) {
    let _time = clock.measure();
    for (net, mut f) in &mut volumes {
        if !f.asked {
            let have = f.session.map(|s| (s, f.replica.applied()));
            let join = Request::Join {
                volume: net.id,
                fingerprint: net.fingerprint.clone(),
                have,
            };
            send(&mut out, &mut stats, &join);
            f.asked = true;
        }
    }
    // The brush cursor, a few times a second: when it moved, and once after
    // joining (a cursor set before the join waits for it).
    let now = time.elapsed_secs_f64();
    if now >= cursor_sent.0 + CURSOR_PERIOD {
        let moved = *cursor != cursor_sent.1;
        let target = cursor.0.or(cursor_sent.1 .0).map(|c| c.volume);
        match target.and_then(|v| volumes.get_mut(v).ok()) {
            Some((net, mut f)) if f.joined && (moved || f.cursor_unsent) => {
                let at = cursor.0.map(|c| (c.at, c.radius));
                send(
                    &mut out,
                    &mut stats,
                    &Request::Cursor { volume: net.id, at },
                );
                f.cursor_unsent = false;
                *cursor_sent = (now, cursor.clone());
            }
            // Not joined yet: sent once it has.
            Some((_, f)) if !f.joined => {}
            // Not a shared volume, or nothing new.
            _ => *cursor_sent = (now, cursor.clone()),
        }
    }
    for (volume, op) in read_ops(&mut edits, &mut undos, &mut redos) {
        let Ok((net, f)) = volumes.get(volume) else {
            continue; // not shared: applied locally
        };
        if !f.joined {
            let reason = format!(
                "volume {} has not joined the server yet; the edit is dropped",
                net.id
            );
            refused.write(NetRefused {
                volume: Some(volume),
                reason,
            });
            continue;
        }
        send(&mut out, &mut stats, &Request::Edit { volume: net.id, op });
    }
}
