//! Deterministic meshing across processes: one edit log, saved to a file and
//! replayed by two separate processes (one thread and two), meshes a world of
//! chunk levels over the demo terrain to the same bytes, and to the bytes this
//! process builds. Peers that share only an edit log (a save, a multiplayer
//! session) therefore show the same terrain. A separate process shares no
//! memory, caches or hash seeds with this one, so an order that hangs on any of
//! them shows here.

use glam::{IVec3, Vec3};
use kdcontour::edit::{Brush, BrushOp, EditedField};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::world::Layout;
use kdcontour::{IndexedMesh, Settings, World};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// 48 brushes near the origin: digs, raises, smooth ones and paints.
fn session() -> Vec<Brush> {
    (0..48)
        .map(|i| {
            let a = i as f32 * 0.9;
            let at = Vec3::new(14.0 * a.cos(), 2.0 + (i % 5) as f32, 14.0 * a.sin());
            let op = match i % 5 {
                0 => BrushOp::Subtract,
                1 => BrushOp::Add,
                2 => BrushOp::SmoothSubtract { radius: 1.5 },
                3 => BrushOp::SmoothAdd { radius: 1.5 },
                _ => BrushOp::Paint,
            };
            Brush::sphere(at, 3.0 + (i % 3) as f32, op).with_material((i % 4) as u8)
        })
        .collect()
}

/// The log replayed on the demo terrain, meshed in three levels around the
/// origin on `threads` threads; every chunk's mesh (positions, normals,
/// indices, materials), in key order, as bytes.
fn mesh_bytes(log: &[Brush], threads: usize) -> Vec<u8> {
    let base = Arc::new(Density::new(DensityParams::demo(7)));
    let field = EditedField::replay(base, log).unwrap();
    let (lo, hi) = (IVec3::new(-8, 0, -8), IVec3::new(8, 4, 8));
    let origin = Vec3::new(0.0, -36.0, 0.0);
    let settings = Settings {
        threads,
        ..Default::default()
    };
    let probe = World::new(
        origin,
        1.5,
        12,
        Layout::uniform(lo, hi, 2).unwrap(),
        0.01,
        settings.clone(),
    )
    .unwrap();
    let layout = Layout::around(lo, hi, 2, probe.to_chunk_units(Vec3::ZERO), 1.0).unwrap();
    assert_eq!(layout.level_counts().len(), 3, "three levels");
    let mut world = World::new(origin, 1.5, 12, layout, 0.01, settings).unwrap();
    world.build_all(&field).unwrap();
    let mut chunks = world.chunks();
    chunks.sort_by_key(|c| c.order());
    let mut out = Vec::new();
    for c in chunks {
        let mut m = IndexedMesh::default();
        if let Some(s) = world.snapshot(&c) {
            s.extract(&mut m);
        }
        out.extend(c.level.to_le_bytes());
        for v in c.coord.to_array() {
            out.extend(v.to_le_bytes());
        }
        out.extend((m.positions.len() as u64).to_le_bytes());
        for v in m.positions.iter().chain(&m.normals) {
            for x in v.to_array() {
                out.extend(x.to_bits().to_le_bytes());
            }
        }
        out.extend((m.indices.len() as u64).to_le_bytes());
        for i in &m.indices {
            out.extend(i.to_le_bytes());
        }
        for b in &m.materials {
            out.extend(b.ids);
            for w in b.weights {
                out.extend(w.to_bits().to_le_bytes());
            }
        }
    }
    out
}

/// The child: replays the log at `KDCONTOUR_REPLAY_LOG` on
/// `KDCONTOUR_REPLAY_THREADS` threads and writes the mesh bytes to
/// `KDCONTOUR_REPLAY_OUT`. Does nothing unless the test below starts it.
#[test]
#[ignore = "run by two_processes_replaying_one_log_mesh_the_same_bytes"]
fn replay_child() {
    let Ok(log) = std::env::var("KDCONTOUR_REPLAY_LOG") else {
        return;
    };
    let log: Vec<Brush> = serde_json::from_slice(&std::fs::read(log).unwrap()).unwrap();
    let threads = std::env::var("KDCONTOUR_REPLAY_THREADS")
        .unwrap()
        .parse()
        .unwrap();
    let out = std::env::var("KDCONTOUR_REPLAY_OUT").unwrap();
    std::fs::write(out, mesh_bytes(&log, threads)).unwrap();
}

/// Runs [`replay_child`] in a new process; returns what it wrote.
fn replay_in_a_process(log: &Path, threads: usize, out: &Path) -> Vec<u8> {
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "replay_child", "--ignored"])
        .env("KDCONTOUR_REPLAY_LOG", log)
        .env("KDCONTOUR_REPLAY_THREADS", threads.to_string())
        .env("KDCONTOUR_REPLAY_OUT", out)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(600) {
            child.kill().unwrap();
            panic!("the replaying process ran for ten minutes");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "the replaying process failed: {status}");
    std::fs::read(out).unwrap()
}

#[test]
fn two_processes_replaying_one_log_mesh_the_same_bytes() {
    let dir = std::env::temp_dir().join(format!("kdreplay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log_path = dir.join("log.json");
    let log = session();
    std::fs::write(&log_path, serde_json::to_vec(&log).unwrap()).unwrap();

    let one = replay_in_a_process(&log_path, 1, &dir.join("one.bin"));
    let two = replay_in_a_process(&log_path, 2, &dir.join("two.bin"));
    let here = mesh_bytes(&log, 2);
    assert!(here.len() > 100_000, "only {} bytes of meshes", here.len());
    eprintln!(
        "{} brushes replayed in two processes and this one: {} bytes of meshes each, alike",
        log.len(),
        here.len()
    );
    assert!(one == two, "two processes meshed one log differently");
    assert!(one == here, "another process meshed the log differently");
    // The log matters: without its last brush the bytes differ.
    assert!(mesh_bytes(&log[..log.len() - 1], 2) != here);
    std::fs::remove_dir_all(&dir).unwrap();
}
