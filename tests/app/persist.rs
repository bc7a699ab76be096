//! Saving edits, headless: a save survives a restart and
//! gives the same meshes, autosave waits for the strokes to end, a save for
//! another field or a damaged one is refused and left whole, 10,000 edits save
//! and load, and a process killed while it autosaves leaves a whole save.

use crate::common::{app_with, settle, shown};
use bevy::prelude::*;
use bevy_kdcontour::persist::file::{self, SaveData};
use bevy_kdcontour::persist::SaveState;
use bevy_kdcontour::prelude::*;
use kdcontour::field::csg::CsgNode;
use kdcontour::field::terrain::{Density, DensityParams};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// Messages of type `M` the app wrote, in order.
#[derive(Resource)]
struct Seen<M: Message + Clone>(Vec<M>);

fn collect<M: Message + Clone>(app: &mut App) {
    app.insert_resource(Seen::<M>(Vec::new())).add_systems(
        Last,
        |mut r: MessageReader<M>, mut seen: ResMut<Seen<M>>| seen.0.extend(r.read().cloned()),
    );
}

fn seen<M: Message + Clone>(app: &App) -> Vec<M> {
    app.world().resource::<Seen<M>>().0.clone()
}

/// A fresh directory for one test's saves.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kdsave-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn ball() -> CsgNode {
    CsgNode::Sphere {
        radius: 0.7,
        center: Vec3::splat(1.0),
    }
}

/// A headless app meshing [`ball`] in 2 x 2 x 2 chunks, saved at `path`.
fn ball_app(path: &Path, autosave: Option<Duration>) -> (App, Entity) {
    let mut app = app_with(LodSettings::default());
    collect::<EditsSaved>(&mut app);
    collect::<EditsLoaded>(&mut app);
    collect::<PersistFailed>(&mut app);
    let field: Arc<dyn kdcontour::Field> = Arc::new(ball().compile().unwrap());
    let volume = app
        .world_mut()
        .spawn((
            KdVolume::new(field, UVec3::splat(2), 8, 2.0 / 16.0),
            KdSave::new(path, KdSave::fingerprint_of(&ball())).with_autosave(autosave),
        ))
        .id();
    (app, volume)
}

/// Strokes of four dabs that grow over a point, digging and adding: the later
/// dabs of a stroke cover the earlier ones, and each stroke is one undo step.
fn strokes(volume: Entity, n: usize) -> Vec<ApplyEdit> {
    (0..n)
        .map(|i| {
            let stroke = i / 4;
            let a = stroke as f32 * 1.7;
            let at = Vec3::new(
                1.0 + 0.6 * a.cos(),
                1.0 + 0.3 * a.sin(),
                1.0 + 0.6 * a.sin(),
            );
            let op = if stroke % 2 == 0 {
                BrushOp::Subtract
            } else {
                BrushOp::Add
            };
            let brush = Brush::sphere(at, 0.1 + 0.04 * (i % 4) as f32, op);
            match i % 4 {
                0 => ApplyEdit::new(volume, brush),
                _ => ApplyEdit::continuing(volume, brush),
            }
        })
        .collect()
}

/// A chunk's shown positions and indices.
type Shown = Option<(Vec<[f32; 3]>, Vec<u32>)>;

/// Every shown chunk's mesh, by chunk.
fn meshes(app: &App, volume: Entity) -> Vec<(ChunkKey, Shown)> {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let mut out: Vec<_> = state
        .shown_chunks()
        .into_iter()
        .map(|(k, e)| (k, shown(app, e)))
        .collect();
    out.sort_by_key(|(k, _)| k.order());
    out
}

/// Asks the app to exit and runs the update that saves; one more lets the
/// test's collectors (also in `Last`) see what it wrote.
fn exit(app: &mut App) {
    app.world_mut().write_message(AppExit::Success);
    app.update();
    app.update();
}

#[test]
fn edits_saved_on_exit_load_at_start_and_give_the_same_meshes() {
    let dir = scratch("restart");
    let path = dir.join("ball.kdsave");
    let (mut app, volume) = ball_app(&path, None);
    settle(&mut app, volume);
    for e in strokes(volume, 24) {
        app.world_mut().write_message(e);
        app.update();
    }
    settle(&mut app, volume);
    let before = meshes(&app, volume);
    assert!(seen::<EditsSaved>(&app).is_empty(), "no autosave was asked");
    exit(&mut app);
    let saves = seen::<EditsSaved>(&app);
    assert_eq!(saves.len(), 1, "{saves:?}");
    assert_eq!(saves[0].edits, 24);
    assert!(
        saves[0].written < 24,
        "dabs covered by the next were kept: {saves:?}"
    );
    assert!(!path.with_file_name(".ball.kdsave.tmp").exists());
    eprintln!("saved {} of {} edits", saves[0].written, saves[0].edits);

    let (mut again, volume) = ball_app(&path, None);
    settle(&mut again, volume);
    let loaded = seen::<EditsLoaded>(&again);
    assert_eq!(loaded.len(), 1);
    assert_eq!(loaded[0].edits, saves[0].written);
    assert!(seen::<PersistFailed>(&again).is_empty());
    let after = meshes(&again, volume);
    assert_eq!(before.len(), after.len());
    for ((k, a), (l, b)) in before.iter().zip(&after) {
        assert_eq!(k, l);
        assert_eq!(a, b, "chunk {k:?} differs after the reload");
    }
    // Nothing new: exiting does not write again.
    exit(&mut again);
    assert!(seen::<EditsSaved>(&again).is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn autosave_waits_until_the_edits_stop() {
    let dir = scratch("debounce");
    let path = dir.join("ball.kdsave");
    let (mut app, volume) = ball_app(&path, Some(Duration::from_millis(300)));
    settle(&mut app, volume);
    // A stroke of 12 dabs, 20 ms apart: the log never stays still for 300 ms.
    for e in strokes(volume, 12) {
        app.world_mut().write_message(e);
        app.update();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(seen::<EditsSaved>(&app).is_empty());
    assert!(!path.exists());
    // Still for longer than the delay: one save of all 12.
    let start = std::time::Instant::now();
    while seen::<EditsSaved>(&app).is_empty() && start.elapsed() < Duration::from_secs(10) {
        app.update();
        std::thread::sleep(Duration::from_millis(5));
    }
    let saves = seen::<EditsSaved>(&app);
    assert_eq!(saves.len(), 1, "{saves:?}");
    assert_eq!(saves[0].edits, 12);
    assert!(start.elapsed() >= Duration::from_millis(250));
    let state = app.world().get::<SaveState>(volume).unwrap();
    assert_eq!(state.saved(), 12);
    assert!(!state.saving());
    let data = file::read(&path, file::MAX_FILE_BYTES).unwrap().unwrap();
    assert_eq!(data.edits.len(), saves[0].written);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_save_for_another_seed_is_refused_and_never_overwritten() {
    let dir = scratch("seed");
    let path = dir.join("terrain.kdsave");
    let spawn = |app: &mut App, seed: u32| {
        let params = DensityParams::demo(seed);
        app.world_mut()
            .spawn((
                KdVolume::new(
                    Arc::new(Density::new(params.clone())),
                    UVec3::new(2, 1, 2),
                    16,
                    1.0,
                ),
                Transform::from_xyz(-16.0, -8.0, -16.0),
                KdSave::new(&path, KdSave::fingerprint_of(&params)).with_autosave(None),
            ))
            .id()
    };
    let mut first = app_with(LodSettings::default());
    let volume = spawn(&mut first, 7);
    settle(&mut first, volume);
    first.world_mut().write_message(ApplyEdit::new(
        volume,
        Brush::sphere(Vec3::new(16.0, 8.0, 16.0), 5.0, BrushOp::Subtract),
    ));
    first.update();
    exit(&mut first);
    let saved = std::fs::read(&path).unwrap();

    let mut other = app_with(LodSettings::default());
    collect::<PersistFailed>(&mut other);
    let volume = spawn(&mut other, 8);
    settle(&mut other, volume);
    let failed = seen::<PersistFailed>(&other);
    assert_eq!(failed.len(), 1);
    let msg = &failed[0].error;
    assert!(
        msg.contains("made for another field")
            && msg.contains("\"seed\":7")
            && msg.contains("\"seed\":8")
            && msg.contains("move it away"),
        "{msg}"
    );
    assert_eq!(
        other
            .world()
            .get::<VolumeState>(volume)
            .unwrap()
            .field()
            .edit_count(),
        0
    );
    assert!(other.world().get::<SaveState>(volume).unwrap().refused());
    // Edits made on the other field are not written over the save.
    other.world_mut().write_message(ApplyEdit::new(
        volume,
        Brush::sphere(Vec3::new(4.0, 8.0, 4.0), 3.0, BrushOp::Add),
    ));
    other.update();
    exit(&mut other);
    assert_eq!(std::fs::read(&path).unwrap(), saved);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_damaged_save_is_refused_with_what_to_do_and_left_whole() {
    let dir = scratch("damaged");
    let path = dir.join("ball.kdsave");
    let good = file::encode(&SaveData {
        fingerprint: KdSave::fingerprint_of(&ball()),
        edits: strokes(Entity::PLACEHOLDER, 8)
            .into_iter()
            .map(|e| e.brush)
            .collect(),
        undo: Default::default(),
    });
    // Undo steps that do not fit the log (they go back down): refused whole,
    // though every brush decodes.
    let steps = file::encode(&SaveData {
        fingerprint: KdSave::fingerprint_of(&ball()),
        edits: strokes(Entity::PLACEHOLDER, 8)
            .into_iter()
            .map(|e| e.brush)
            .collect(),
        undo: kdcontour::edit::UndoSteps {
            floor: 0,
            ends: vec![4, 2, 8],
            applied: 3,
            open: false,
        },
    });
    let truncated = good[..good.len() - 5].to_vec();
    let mut nan = good.clone();
    // A brush with a NaN radius: decodes, but the core refuses it.
    let bad_brush = SaveData {
        fingerprint: KdSave::fingerprint_of(&ball()),
        edits: vec![Brush::sphere(Vec3::ONE, f32::NAN, BrushOp::Add)],
        undo: Default::default(),
    };
    nan.clear();
    nan.extend(file::encode(&bad_brush));
    let cases: [(&[u8], &str); 5] = [
        (b"not a save at all", "is not a bevy_kdcontour save"),
        (&steps, "its undo steps do not fit its edits: invalid setting `undo steps`: step ends must rise"),
        (&truncated, "the header promises"),
        (&nan, "a saved edit does not apply"),
        (&good[..10], "shorter than the 24-byte header"),
    ];
    for (bytes, expect) in cases {
        std::fs::write(&path, bytes).unwrap();
        let (mut app, volume) = ball_app(&path, Some(Duration::ZERO));
        settle(&mut app, volume);
        app.world_mut().write_message(ApplyEdit::new(
            volume,
            Brush::sphere(Vec3::ONE, 0.3, BrushOp::Subtract),
        ));
        for _ in 0..5 {
            app.update();
        }
        exit(&mut app);
        let failed = seen::<PersistFailed>(&app);
        assert_eq!(failed.len(), 1, "{failed:?}");
        assert!(failed[0].error.contains(expect), "{}", failed[0].error);
        assert!(failed[0].error.contains("left as it is"));
        assert!(seen::<EditsSaved>(&app).is_empty());
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "{expect}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// 10,000 brushes over the ball (none covering another): saved through the
/// plugin on exit, loaded by a new app, the same log.
#[test]
fn ten_thousand_edits_save_and_load() {
    let dir = scratch("many");
    let path = dir.join("ball.kdsave");
    let (mut app, volume) = ball_app(&path, None);
    settle(&mut app, volume);
    let brushes: Vec<Brush> = (0..10_000)
        .map(|i| {
            let t = i as f32 * 0.01;
            let at = Vec3::new(
                1.0 + 0.7 * t.cos(),
                1.0 + 0.5 * (t * 0.37).sin(),
                1.0 + 0.7 * t.sin(),
            );
            let op = if i % 3 == 0 {
                BrushOp::Add
            } else {
                BrushOp::Subtract
            };
            Brush::sphere(at, 0.02, op)
        })
        .collect();
    for b in &brushes {
        app.world_mut()
            .write_message(ApplyEdit::new(volume, b.clone()));
    }
    app.update();
    exit(&mut app);
    let saves = seen::<EditsSaved>(&app);
    assert_eq!((saves[0].edits, saves[0].written), (10_000, 10_000));
    let (mut again, volume) = ball_app(&path, None);
    again.update();
    again.update();
    assert_eq!(seen::<EditsLoaded>(&again)[0].edits, 10_000);
    let log = again.world().get::<VolumeState>(volume).unwrap().edit_log();
    assert_eq!(log, brushes);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Edit `i` of [`autosaving_child`]: small digs along a circle, none covering
/// another, so a save of the first `n` is exactly those `n`.
fn dab(i: usize) -> Brush {
    let t = i as f32 * 0.05;
    let at = Vec3::new(1.0 + 0.7 * t.cos(), 1.0, 1.0 + 0.7 * t.sin());
    Brush::sphere(at, 0.01, BrushOp::Subtract)
}

/// The child of [`a_process_killed_while_it_autosaves_leaves_a_whole_save`]:
/// loads the save, then edits and autosaves after every edit until it is
/// killed. Does nothing unless that test starts it.
#[test]
#[ignore = "run by a_process_killed_while_it_autosaves_leaves_a_whole_save"]
fn autosaving_child() {
    let Ok(path) = std::env::var("KDSAVE_CHILD_PATH") else {
        return;
    };
    let (mut app, volume) = ball_app(Path::new(&path), Some(Duration::ZERO));
    app.update();
    app.update();
    let loaded = app
        .world()
        .get::<VolumeState>(volume)
        .unwrap()
        .field()
        .edit_count();
    for i in loaded.. {
        app.world_mut()
            .write_message(ApplyEdit::new(volume, dab(i)));
        app.update();
    }
}

#[test]
fn a_process_killed_while_it_autosaves_leaves_a_whole_save() {
    let dir = scratch("killed");
    let path = dir.join("ball.kdsave");
    let exe = std::env::current_exe().unwrap();
    let mut counts = Vec::new();
    for (round, wait_ms) in [300u64, 600, 900, 1200, 1500].into_iter().enumerate() {
        let before = std::fs::metadata(&path).ok().map(|m| m.modified().unwrap());
        let mut child = std::process::Command::new(&exe)
            .args([
                "--exact",
                "persist::autosaving_child",
                "--ignored",
                "--nocapture",
            ])
            .env("KDSAVE_CHILD_PATH", &path)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Wait until the child has saved, let it go on saving, and kill it.
        let start = std::time::Instant::now();
        while std::fs::metadata(&path).ok().map(|m| m.modified().unwrap()) == before
            && start.elapsed() < Duration::from_secs(120)
        {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(wait_ms));
        child.kill().unwrap();
        child.wait().unwrap();
        // The last whole save: every edit up to some point, in order, whatever
        // the write was doing when the process died.
        let data = file::read(&path, file::MAX_FILE_BYTES)
            .unwrap_or_else(|e| panic!("round {round}: {e}"))
            .unwrap_or_else(|| panic!("round {round}: no save after {wait_ms} ms"));
        assert_eq!(data.fingerprint, KdSave::fingerprint_of(&ball()));
        for (i, b) in data.edits.iter().enumerate() {
            assert_eq!(*b, dab(i), "round {round}, edit {i}");
        }
        counts.push(data.edits.len());
    }
    eprintln!("edits in the save after each kill: {counts:?}");
    assert!(
        counts.windows(2).all(|w| w[0] < w[1]) && counts[0] > 0,
        "each round goes on from the last save: {counts:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
