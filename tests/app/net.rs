//! Multiplayer, headless, over the real transport on 127.0.0.1: a server and
//! clients in one process, each an app. Clients dig and raise at once, join
//! late, drop and reconnect, or misbehave; every peer ends with the server's
//! edit log and meshes bitwise equal to a from-scratch build of the final
//! field, and bad requests are refused with a reason and counted.

use crate::common::{assert_shown_match_fresh, meshes};
use bevy::prelude::*;
use bevy::state::app::StatesPlugin;
use bevy_kdcontour::bevy_replicon::prelude::ClientState;
use bevy_kdcontour::headless::HeadlessPlugins;
use bevy_kdcontour::net::protocol::{self, ClientWire, Request};
use bevy_kdcontour::net::{
    transport, Authority, Cursor, Follower, LocalCursor, NetPlugin, NetRefused, NetSettings,
    NetStats, NetVolume, PeerCursors,
};
use bevy_kdcontour::prelude::*;
use kdcontour::edit::EditOp;
use kdcontour::field::FnField;
use kdcontour::Field;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Hills around y = 8 in a 32 x 16 x 32 cell volume.
fn hills() -> Arc<dyn Field> {
    Arc::new(FnField(|p: Vec3| {
        p.y - 8.0 - 3.0 * (p.x * 0.19).sin() * (p.z * 0.17).cos()
    }))
}

const FINGERPRINT: &str = "hills 0.19 0.17";

/// The reasons a client was given for refusals, oldest first.
#[derive(Resource, Default)]
struct Refusals(Vec<String>);

fn refusals(app: &App) -> &[String] {
    &app.world().resource::<Refusals>().0
}

/// A headless peer: the plugin group, the net subsystem, a still camera and
/// the shared volume (id 1 with `fingerprint`).
fn peer(settings: NetSettings, fingerprint: &str) -> (App, Entity) {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        StatesPlugin,
        KdContourPlugins::default(),
        NetPlugin { settings },
    ));
    app.init_resource::<Refusals>().add_systems(
        Last,
        |mut r: MessageReader<NetRefused>, mut all: ResMut<Refusals>| {
            all.0.extend(r.read().map(|m| m.reason.clone()));
        },
    );
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(16.0, 20.0, 16.0)));
    let v = app
        .world_mut()
        .spawn((
            KdVolume::new(hills(), UVec3::new(4, 2, 4), 8, 1.0),
            NetVolume::new(1, fingerprint),
        ))
        .id();
    app.finish();
    app.cleanup();
    (app, v)
}

fn server(settings: NetSettings) -> (App, Entity, SocketAddr) {
    let (mut app, v) = peer(settings, FINGERPRINT);
    let addr = transport::host(app.world_mut(), ([127, 0, 0, 1], 0).into(), 16).unwrap();
    app.update();
    (app, v, addr)
}

fn client(addr: SocketAddr, id: u64, fingerprint: &str) -> (App, Entity) {
    let (mut app, v) = peer(NetSettings::default(), fingerprint);
    transport::connect(app.world_mut(), addr, id).unwrap();
    (app, v)
}

/// Steps every app once, `frames` times (a short pause each round so the
/// sockets move).
fn run(apps: &mut [&mut App], frames: usize) {
    for _ in 0..frames {
        for a in apps.iter_mut() {
            a.update();
        }
        std::thread::sleep(Duration::from_micros(300));
    }
}

fn last(server: &App, v: Entity) -> u64 {
    server
        .world()
        .get::<Authority>(v)
        .map_or(0, Authority::last)
}

fn follower(app: &App, v: Entity) -> &Follower {
    app.world().get::<Follower>(v).expect("a follower")
}

fn settled(app: &App, v: Entity) -> bool {
    app.world()
        .get::<VolumeState>(v)
        .is_some_and(|s| s.is_settled())
}

/// Steps until every client has applied the server's last op and every
/// volume has settled (fails after 20 s).
fn converge(server: &mut App, sv: Entity, clients: &mut [(&mut App, Entity)]) {
    let start = Instant::now();
    loop {
        server.update();
        for (c, _) in clients.iter_mut() {
            c.update();
        }
        std::thread::sleep(Duration::from_micros(300));
        let n = last(server, sv);
        let done = settled(server, sv)
            && clients.iter().all(|(c, v)| {
                c.world()
                    .get::<Follower>(*v)
                    .is_some_and(|f| f.joined() && f.applied() == n)
                    && settled(c, *v)
            });
        if done {
            // Two more rounds: nothing may be in flight.
            for _ in 0..2 {
                server.update();
                for (c, _) in clients.iter_mut() {
                    c.update();
                }
            }
            if settled(server, sv) && clients.iter().all(|(c, v)| settled(c, *v)) {
                return;
            }
        }
        if start.elapsed() > Duration::from_secs(20) {
            let status: Vec<_> = clients
                .iter()
                .map(|(c, v)| {
                    let f = c.world().get::<Follower>(*v);
                    (
                        f.map(|f| (f.joined(), f.applied())),
                        settled(c, *v),
                        format!("{:?}", c.world().resource::<State<ClientState>>().get()),
                    )
                })
                .collect();
            panic!(
                "the peers did not converge: server at op {n} (settled {}), clients {status:?}",
                settled(server, sv)
            );
        }
    }
}

/// The peer's edit log and undo counts.
fn history(app: &App, v: Entity) -> (Vec<Brush>, usize, usize) {
    let s = app.world().get::<VolumeState>(v).unwrap();
    (
        s.edit_log(),
        s.history().undo_steps(),
        s.history().redo_steps(),
    )
}

/// Every peer has the server's history, and meshes equal to a fresh build of
/// its final field (so equal to each other's).
fn assert_same(server: &App, sv: Entity, clients: &[(&App, Entity)]) {
    let field = server
        .world()
        .get::<VolumeState>(sv)
        .unwrap()
        .field()
        .clone();
    assert_shown_match_fresh(server, sv, &field);
    let want = meshes(server, sv);
    let log = history(server, sv);
    for (c, v) in clients {
        let h = history(c, *v);
        let first = h.0.iter().zip(&log.0).position(|(a, b)| a != b);
        assert_eq!(
            (h.0.len(), h.1, h.2, first),
            (log.0.len(), log.1, log.2, None),
            "a client's history differs (length, undo and redo steps, first differing brush)"
        );
        let f = c.world().get::<VolumeState>(*v).unwrap().field().clone();
        assert_shown_match_fresh(c, *v, &f);
        assert_eq!(
            meshes(c, *v),
            want,
            "a client's meshes differ from the server's"
        );
    }
}

/// Dab `i` of player `p`: digs and raises along a line, strokes of four.
fn dab(p: u64, i: usize) -> ApplyEdit {
    let t = i as f32 * 0.37 + p as f32 * 1.9;
    let at = Vec3::new(16.0 + 11.0 * t.cos(), 8.0, 16.0 + 11.0 * (t * 1.3).sin());
    let op = if (i / 4 + p as usize).is_multiple_of(2) {
        BrushOp::SmoothSubtract { radius: 0.8 }
    } else {
        BrushOp::SmoothAdd { radius: 0.8 }
    };
    ApplyEdit {
        volume: Entity::PLACEHOLDER,
        brush: Brush::sphere(at, 1.5 + 0.5 * (i % 3) as f32, op),
        continues_stroke: !i.is_multiple_of(4),
    }
}

fn send(app: &mut App, v: Entity, mut e: ApplyEdit) {
    e.volume = v;
    app.world_mut().write_message(e);
}

fn stats(app: &App) -> NetStats {
    app.world().resource::<NetStats>().clone()
}

/// A brush cursor on `volume` at x.
fn aim(volume: Entity, x: f32) -> LocalCursor {
    LocalCursor(Some(Cursor {
        volume,
        at: Vec3::new(x, 8.0, 5.0),
        radius: 2.0,
    }))
}

#[test]
fn two_clients_and_the_server_edit_at_once_and_converge() {
    // Frames here are a few milliseconds: allow the dabs a test sends.
    let settings = NetSettings {
        edits_per_second: 1000.0,
        ..Default::default()
    };
    let (mut s, sv, addr) = server(settings);
    let (mut a, av) = client(addr, 1, FINGERPRINT);
    let (mut b, bv) = client(addr, 2, FINGERPRINT);
    // Client b aims before it has joined: the server hears it once it has
    // (b runs past its first cursor period before the server answers).
    b.insert_resource(aim(bv, 3.0));
    for _ in 0..3 {
        b.update();
        std::thread::sleep(Duration::from_millis(60));
    }
    converge(&mut s, sv, &mut [(&mut a, av), (&mut b, bv)]);
    // 300 frames: each client dabs every 3rd frame and undoes now and then,
    // the server (playing too) every 10th.
    for f in 0..300usize {
        if f % 3 == 0 {
            send(&mut a, av, dab(1, f / 3));
            send(&mut b, bv, dab(2, f / 3));
        }
        if f % 37 == 5 {
            a.world_mut().write_message(UndoEdit { volume: av });
        }
        if f % 53 == 7 {
            b.world_mut().write_message(RedoEdit { volume: bv });
        }
        if f % 10 == 0 {
            send(&mut s, sv, dab(3, f / 10));
        }
        run(&mut [&mut s, &mut a, &mut b], 1);
    }
    converge(&mut s, sv, &mut [(&mut a, av), (&mut b, bv)]);
    let n = last(&s, sv);
    let st = stats(&s);
    eprintln!(
        "server: {n} ops, {} requests, {} accepted, refused {:?}; {} payload bytes out, {} in",
        st.requests, st.accepted, st.refused, st.bytes_out, st.bytes_in
    );
    assert!(n >= 200, "only {n} ops");
    assert_eq!(st.refused_total(), 0);
    // The numbered ops replayed on the base field give the server's history.
    {
        let ops = s
            .world()
            .get::<Authority>(sv)
            .unwrap()
            .ops(1..n + 1)
            .unwrap();
        let mut h = kdcontour::edit::EditHistory::new(kdcontour::edit::EditedField::new(hills()));
        for (_, op) in &ops {
            op.apply_to(&mut h, 256).unwrap();
        }
        let log = history(&s, sv);
        assert_eq!(
            (h.field().log(), h.undo_steps()),
            (log.0, log.1),
            "replayed ops"
        );
    }
    assert_eq!(stats(&a).ops_applied, n);
    assert_eq!(stats(&b).ops_applied, n);
    assert_same(&s, sv, &[(&a, av), (&b, bv)]);
    // Each player sees where the others' brushes aim.
    s.insert_resource(aim(sv, 1.0));
    a.insert_resource(aim(av, 2.0));
    let start = Instant::now();
    let seen = |app: &App| {
        let mut xs: Vec<f32> = app
            .world()
            .resource::<PeerCursors>()
            .0
            .iter()
            .map(|c| c.1.at.x)
            .collect();
        xs.sort_by(f32::total_cmp);
        xs
    };
    while seen(&b) != [1.0, 2.0] || seen(&a) != [1.0, 3.0] || seen(&s) != [2.0, 3.0] {
        run(&mut [&mut s, &mut a, &mut b], 1);
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "cursors: {:?} {:?} {:?}",
            seen(&s),
            seen(&a),
            seen(&b)
        );
    }
}

#[test]
fn a_late_joiner_and_a_reconnecting_client_converge() {
    let settings = NetSettings {
        keep_ops: 300,
        edits_per_second: 1000.0,
        ..Default::default()
    };
    let (mut s, sv, addr) = server(settings);
    let (mut a, av) = client(addr, 1, FINGERPRINT);
    converge(&mut s, sv, &mut [(&mut a, av)]);
    // 500 edits by the server, 25 a frame.
    for f in 0..20 {
        for i in 0..25 {
            send(&mut s, sv, dab(3, f * 25 + i));
        }
        run(&mut [&mut s, &mut a], 1);
    }
    converge(&mut s, sv, &mut [(&mut a, av)]);
    assert_eq!(last(&s, sv), 500);
    // A late joiner gets the compacted history, not 500 ops.
    let (mut late, lv) = client(addr, 2, FINGERPRINT);
    converge(&mut s, sv, &mut [(&mut a, av), (&mut late, lv)]);
    let ls = stats(&late);
    eprintln!(
        "late join after 500 edits: {} bytes of history",
        ls.snapshot_bytes
    );
    assert_eq!((ls.snapshots, ls.ops_applied), (1, 0));
    assert_same(&s, sv, &[(&a, av), (&late, lv)]);
    // Client a drops mid-storm (the late client keeps digging), then
    // reconnects: it gets only the ops it missed, each once.
    let histories = stats(&a).snapshots;
    for f in 0..60usize {
        if f % 2 == 0 {
            send(&mut late, lv, dab(2, f));
        }
        if f == 20 {
            transport::disconnect(a.world_mut());
        }
        if f == 45 {
            transport::connect(a.world_mut(), addr, 11).unwrap();
        }
        run(&mut [&mut s, &mut a, &mut late], 1);
    }
    converge(&mut s, sv, &mut [(&mut a, av), (&mut late, lv)]);
    let st = stats(&a);
    eprintln!(
        "reconnect: {} ops applied, {} ignored, {} histories",
        st.ops_applied, st.ops_ignored, st.snapshots
    );
    assert_eq!(
        st.snapshots, histories,
        "the server still kept the missed ops"
    );
    assert_eq!(st.ops_applied, last(&s, sv), "every op applied once");
    assert_same(&s, sv, &[(&a, av), (&late, lv)]);
    // Dropped for longer than the server keeps ops: the whole history again.
    transport::disconnect(a.world_mut());
    run(&mut [&mut s, &mut a], 3);
    for f in 0..400 {
        send(&mut s, sv, dab(3, 1000 + f));
    }
    run(&mut [&mut s, &mut late], 2);
    transport::connect(a.world_mut(), addr, 12).unwrap();
    converge(&mut s, sv, &mut [(&mut a, av), (&mut late, lv)]);
    assert_eq!(stats(&a).snapshots, histories + 1);
    assert_same(&s, sv, &[(&a, av), (&late, lv)]);
}

#[test]
fn bad_clients_are_refused_with_a_reason_and_change_nothing() {
    let settings = NetSettings {
        edits_per_second: 0.5,
        edit_burst: 10.0,
        max_brush_reach: 6.0,
        ..Default::default()
    };
    let (mut s, sv, addr) = server(settings);
    let (mut good, gv) = client(addr, 1, FINGERPRINT);
    let (mut bad, bv) = client(addr, 2, FINGERPRINT);
    let (mut other, ov) = client(addr, 3, "hills of another seed");
    converge(&mut s, sv, &mut [(&mut good, gv), (&mut bad, bv)]);
    run(&mut [&mut s, &mut other], 10);
    // The client on another field was refused, with both fingerprints.
    assert!(!follower(&other, ov).joined());
    assert!(
        refusals(&other)
            .iter()
            .any(|r| r.contains("hills of another seed") && r.contains(FINGERPRINT)),
        "{:?}",
        refusals(&other)
    );
    let before = history(&s, sv);
    let sphere = |c: Vec3, r: f32| Brush::sphere(c, r, BrushOp::Subtract);
    let edit = |brush: Brush| {
        protocol::encode(&Request::Edit {
            volume: 1,
            op: EditOp::Apply {
                brush,
                continues_stroke: false,
            },
        })
    };
    let raws = [
        edit(sphere(Vec3::new(f32::NAN, 8.0, 8.0), 1.0)),
        edit(sphere(Vec3::new(8.0, 8.0, 8.0), f32::INFINITY)),
        edit(Brush::sphere(
            Vec3::splat(8.0),
            1.0,
            BrushOp::SmoothAdd { radius: f32::NAN },
        )),
        edit(sphere(Vec3::new(8.0, 8.0, 8.0), 40.0)),
        protocol::encode(&Request::Edit {
            volume: 9,
            op: EditOp::Undo,
        }),
        vec![0xff, 0x00, 0x13, 0x37],
        edit(sphere(Vec3::splat(8.0), 1.0))[..5].to_vec(),
        vec![0x80; 5000],
        protocol::encode(&Request::Join {
            volume: 1,
            fingerprint: FINGERPRINT.into(),
            have: None,
        }),
    ];
    for r in raws {
        bad.world_mut().write_message(ClientWire(r));
    }
    run(&mut [&mut s, &mut good, &mut bad], 5);
    // A flood: 40 valid dabs in one frame, past a burst of 10.
    for i in 0..40 {
        let b = sphere(Vec3::new(4.0 + i as f32 * 0.5, 8.0, 4.0), 1.0);
        bad.world_mut().write_message(ApplyEdit::new(bv, b));
    }
    run(&mut [&mut s, &mut good, &mut bad], 5);
    let st = stats(&s);
    eprintln!("refused: {:?}", st.refused);
    let count = |k: &str| st.refused.get(k).copied().unwrap_or(0);
    assert_eq!(
        count("bad_brush"),
        3,
        "NaN centre, infinite radius, NaN blend"
    );
    assert_eq!(
        count("too_large"),
        2,
        "a brush past the reach, a request past the size"
    );
    assert_eq!(count("unknown_volume"), 1);
    assert_eq!(count("malformed"), 2, "garbage and a cut request");
    assert_eq!(count("other_field"), 1);
    assert_eq!(count("rate"), 30, "40 dabs past a burst of 10");
    assert_eq!(count("repeated"), 1, "a second join on one connection");
    assert_eq!(refusals(&bad).len(), 39, "each refusal is answered");
    for r in refusals(&bad) {
        eprintln!("  {r}");
    }
    // Only the 10 dabs within the burst changed anything.
    assert_eq!(history(&s, sv).0.len(), before.0.len() + 10);
    // Garbage below the protocol, on every channel of the transport, from
    // another client: the server keeps serving the good one.
    let (mut vandal, _) = client(addr, 4, FINGERPRINT);
    run(&mut [&mut s, &mut vandal], 20);
    {
        use bevy_kdcontour::bevy_replicon_renet::RenetClient;
        let mut c = vandal.world_mut().resource_mut::<RenetClient>();
        for ch in 0..3u8 {
            c.send_message(ch, vec![0xde, 0xad, 0xbe, 0xef, ch]);
        }
    }
    run(&mut [&mut s, &mut good, &mut bad, &mut vandal], 10);
    send(&mut good, gv, dab(1, 0));
    converge(&mut s, sv, &mut [(&mut good, gv), (&mut bad, bv)]);
    assert_eq!(history(&s, sv).0.len(), before.0.len() + 11);
    assert_same(&s, sv, &[(&good, gv), (&bad, bv)]);
}
