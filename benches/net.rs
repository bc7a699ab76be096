//! What multiplayer costs, over the real transport on 127.0.0.1 (every peer a
//! headless app in this process, stepped in turn at 60 frames a second):
//! - **bytes per edit**: the payload of one edit request and of one numbered
//!   op sent to a client (CBOR; renet and netcode add their packet headers);
//! - **late join**: the compacted history a client receives on joining a
//!   1,000- and a 10,000-edit session (the save format; strokes of 8 dabs, 256
//!   undo steps kept), and the time to restore it;
//! - **latency**: from a client's edit request to the edit applied, and to the
//!   re-meshed chunk shown, on another client (frames and milliseconds);
//! - **server load**: the server's main-thread time per frame (the whole app
//!   update, and the plugin's share) with 8 clients sending 20 edits a second
//!   each.
//!
//! `cargo bench --bench net`

use bevy::prelude::*;
use bevy::state::app::StatesPlugin;
use bevy_kdcontour::headless::HeadlessPlugins;
use bevy_kdcontour::kdcontour::edit::{EditHistory, EditOp, EditedField, Sequencer};
use bevy_kdcontour::kdcontour::field::FnField;
use bevy_kdcontour::kdcontour::Field;
use bevy_kdcontour::net::protocol::{self, Reply, Request};
use bevy_kdcontour::net::{transport, Follower, NetPlugin, NetSettings, NetVolume};
use bevy_kdcontour::persist::file::{self, SaveData};
use bevy_kdcontour::prelude::*;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One frame at 60 a second.
const FRAME: Duration = Duration::from_micros(16_667);

fn hills() -> Arc<dyn Field> {
    Arc::new(FnField(|p: Vec3| {
        p.y - 8.0 - 3.0 * (p.x * 0.19).sin() * (p.z * 0.17).cos()
    }))
}

fn peer() -> (App, Entity) {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        StatesPlugin,
        KdContourPlugins::default(),
        NetPlugin {
            settings: NetSettings {
                edits_per_second: 100.0,
                ..Default::default()
            },
        },
    ));
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(16.0, 20.0, 16.0)));
    let v = app
        .world_mut()
        .spawn((
            KdVolume::new(hills(), UVec3::new(4, 2, 4), 8, 1.0),
            NetVolume::new(1, "hills"),
        ))
        .id();
    app.finish();
    app.cleanup();
    (app, v)
}

/// Dab `i`: a sphere on the hills, strokes of 8 growing over a point.
fn dab(i: usize) -> Brush {
    let t = (i / 8) as f32 * 0.37;
    let at = Vec3::new(16.0 + 11.0 * t.cos(), 8.0, 16.0 + 11.0 * (t * 1.3).sin());
    let op = if (i / 8).is_multiple_of(2) {
        BrushOp::SmoothSubtract { radius: 0.8 }
    } else {
        BrushOp::SmoothAdd { radius: 0.8 }
    };
    Brush::sphere(at, 1.5 + 0.25 * (i % 8) as f32, op)
}

/// Steps every app once and sleeps out the rest of a 60 Hz frame.
fn frame(apps: &mut [&mut App]) {
    let start = Instant::now();
    for a in apps.iter_mut() {
        a.update();
    }
    if let Some(rest) = FRAME.checked_sub(start.elapsed()) {
        std::thread::sleep(rest);
    }
}

fn joined(app: &App, v: Entity) -> bool {
    app.world().get::<Follower>(v).is_some_and(Follower::joined)
}

fn settled(app: &App, v: Entity) -> bool {
    app.world()
        .get::<VolumeState>(v)
        .is_some_and(|s| s.is_settled())
}

fn bytes_per_edit() {
    let brush = dab(3);
    let op = EditOp::Apply {
        brush,
        continues_stroke: true,
    };
    let request = protocol::encode(&Request::Edit {
        volume: 1,
        op: op.clone(),
    });
    let one = protocol::encode(&Reply::Ops {
        volume: 1,
        ops: vec![(1234, op.clone())],
    });
    let four = protocol::encode(&Reply::Ops {
        volume: 1,
        ops: (0..4).map(|n| (1234 + n, op.clone())).collect(),
    });
    println!(
        "bytes per edit: request {} B; one op to a client {} B, four in a frame {} B ({} B each)",
        request.len(),
        one.len(),
        four.len(),
        four.len() / 4
    );
}

fn late_join() {
    for edits in [1_000usize, 10_000] {
        let base = EditedField::new(hills());
        let mut history = EditHistory::new(base.clone());
        let mut sequencer = Sequencer::new(4096);
        for i in 0..edits {
            // As the persist bench's session: strokes of 8 growing dabs, digs
            // and adds alternating.
            let b = dab(i);
            let hard = if (i / 8).is_multiple_of(2) {
                BrushOp::Subtract
            } else {
                BrushOp::Add
            };
            let op = EditOp::Apply {
                brush: Brush { op: hard, ..b },
                continues_stroke: i % 8 != 0,
            };
            sequencer.accept(&mut history, 256, op).unwrap();
        }
        let snap = sequencer.snapshot(&history);
        let kept = snap.log.len();
        let data = SaveData {
            fingerprint: "hills".into(),
            edits: snap.log,
            undo: snap.steps,
        };
        let bytes = file::encode(&data);
        let t = Instant::now();
        let back = file::decode(std::path::Path::new("join"), &bytes).unwrap();
        let restored = EditHistory::restore(base, back.edits, &back.undo).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(restored.saved(), history.saved());
        println!(
            "late join after {edits} edits: {} B of history ({kept} brushes kept of {edits}), restored in {ms:.2} ms",
            bytes.len()
        );
    }
}

fn start(n: usize) -> (App, Entity, Vec<(App, Entity)>) {
    let (mut server, sv) = peer();
    let addr: SocketAddr =
        transport::host(server.world_mut(), ([127, 0, 0, 1], 0).into(), 16).unwrap();
    let mut clients: Vec<(App, Entity)> = (0..n).map(|_| peer()).collect();
    for (i, (c, _)) in clients.iter_mut().enumerate() {
        transport::connect(c.world_mut(), addr, 100 + i as u64).unwrap();
    }
    let t = Instant::now();
    loop {
        let mut all: Vec<&mut App> = vec![&mut server];
        all.extend(clients.iter_mut().map(|c| &mut c.0));
        frame(&mut all);
        if clients.iter().all(|(c, v)| joined(c, *v) && settled(c, *v)) && settled(&server, sv) {
            break;
        }
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "the clients did not join"
        );
    }
    (server, sv, clients)
}

fn latency() {
    let (mut server, _, mut clients) = start(2);
    let (mut a, av) = clients.remove(0);
    let (mut b, bv) = clients.remove(0);
    let mut applied_ms = Vec::new();
    let mut shown_ms = Vec::new();
    let mut frames = Vec::new();
    for i in 0..20 {
        a.world_mut().write_message(ApplyEdit::new(av, dab(8 * i)));
        let t = Instant::now();
        let mut rebuilt: Option<Vec<ChunkKey>> = None;
        let mut n = 0;
        loop {
            frame(&mut [&mut a, &mut server, &mut b]);
            n += 1;
            let w = b.world_mut();
            if rebuilt.is_none() {
                if let Some(e) = w
                    .resource_mut::<Messages<EditApplied>>()
                    .drain()
                    .find(|e| e.volume == bv)
                {
                    applied_ms.push(t.elapsed().as_secs_f64() * 1e3);
                    rebuilt = Some(e.rebuilt);
                }
            }
            if let Some(keys) = &rebuilt {
                let shown = w.resource_mut::<Messages<ChunkMeshed>>().drain().any(|m| {
                    keys.iter()
                        .any(|k| k.coord == m.coord && k.level == m.level)
                });
                if shown {
                    shown_ms.push(t.elapsed().as_secs_f64() * 1e3);
                    frames.push(n);
                    break;
                }
            }
            assert!(n < 600, "edit {i} did not show on the other client");
        }
        // Let everything settle before the next one.
        for _ in 0..10 {
            frame(&mut [&mut a, &mut server, &mut b]);
        }
        let _ = settled(&b, bv);
    }
    let stat = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[v.len() - 1])
    };
    let (am, ax) = stat(&mut applied_ms);
    let (sm, sx) = stat(&mut shown_ms);
    frames.sort();
    println!(
        "latency, request on one client to the other (20 edits, 60 Hz frames, loopback): applied median {am:.0} ms (max {ax:.0}), shown median {sm:.0} ms (max {sx:.0}), {} frames median",
        frames[frames.len() / 2]
    );
}

fn server_load() {
    let (mut server, _, mut clients) = start(8);
    let mut whole = Vec::new();
    let mut plugin = Vec::new();
    // 5 s at 60 Hz; each client sends an edit every third frame (20 a second).
    for f in 0..300usize {
        for (i, (c, v)) in clients.iter_mut().enumerate() {
            if (f + i) % 3 == 0 {
                let brush = dab(f * 8 + i);
                c.world_mut()
                    .write_message(ApplyEdit::continuing(*v, brush));
            }
        }
        let t0 = Instant::now();
        server.update();
        whole.push(t0.elapsed().as_secs_f64() * 1e3);
        plugin.push(server.world().resource::<KdContourStats>().main_thread_ms);
        let start = Instant::now();
        for (c, _) in clients.iter_mut() {
            c.update();
        }
        if let Some(rest) =
            FRAME.checked_sub(start.elapsed() + Duration::from_secs_f64(whole[f] / 1e3))
        {
            std::thread::sleep(rest);
        }
    }
    let stats = |v: &mut Vec<f64>| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.sort_by(f64::total_cmp);
        (mean, v[v.len() * 99 / 100], v[v.len() - 1])
    };
    let (wm, wp, wx) = stats(&mut whole);
    let (pm, pp, px) = stats(&mut plugin);
    let st = server
        .world()
        .resource::<bevy_kdcontour::net::NetStats>()
        .clone();
    println!(
        "server with 8 clients at 20 edits/s each (300 frames): whole update mean {wm:.2} ms, p99 {wp:.2}, max {wx:.2}; plugin systems mean {pm:.2} ms, p99 {pp:.2}, max {px:.2}; {} requests, {} accepted, {} refused; {} B out, {} B in",
        st.requests,
        st.accepted,
        st.refused_total(),
        st.bytes_out,
        st.bytes_in
    );
}

fn main() {
    // `cargo test` runs benches once with `--bench` absent: keep it short there.
    if !std::env::args().any(|a| a == "--bench") {
        bytes_per_edit();
        return;
    }
    bytes_per_edit();
    late_join();
    latency();
    server_load();
}
