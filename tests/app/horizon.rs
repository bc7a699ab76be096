//! A horizon volume (chunk levels around the camera) in a headless app: while the
//! camera flies a scripted path, with edits near and far, the shown chunks cover
//! the loaded region exactly once at every frame (no gap, no chunk shown beside
//! its replacement); after the camera stops, every shown mesh equals a
//! from-scratch build of its level world, and no edit is lost.

use crate::common::{app_with, applied_edits, assert_shown_match_fresh, settle};
use bevy::prelude::*;
use bevy_kdcontour::prelude::*;
use kdcontour::field::FnField;
use kdcontour::Field;
use std::collections::HashMap;
use std::sync::Arc;

/// Cells per chunk side.
const RES: u32 = 8;
/// The view reaches 64 cells: top level 3 (chunks of 8 level-0 chunks).
const VIEW: u32 = 64;
/// Level-0 chunk rows kept.
const ROWS: (i32, i32) = (-2, 1);

fn app() -> App {
    app_with(LodSettings {
        base: 0.01,
        near: 8.0,
        ..Default::default()
    })
}

/// Rolling hills about 4 cells high, with a hollow under (40, 0, 20).
fn hills() -> Arc<dyn Field> {
    Arc::new(FnField(|p: Vec3| {
        let ground = p.y - 4.0 * (p.x * 0.09).sin() * (p.z * 0.07).cos();
        let hollow = 5.0 - p.distance(Vec3::new(40.0, -3.0, 20.0));
        ground.max(hollow)
    }))
}

fn spawn(app: &mut App, field: Arc<dyn Field>) -> Entity {
    app.world_mut()
        .spawn(KdVolume::horizon(field, RES, 1.0, VIEW).with_level0(2 * RES))
        .id()
}

/// Spawns the camera at (40, 6, 4) and a horizon volume of the hills, and
/// waits for its first view: (camera, volume).
fn fly_from_hills(app: &mut App) -> (Entity, Entity) {
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(40.0, 6.0, 4.0)))
        .id();
    let v = spawn(app, hills());
    settle(app, v);
    (cam, v)
}

/// Checks that the shown chunks are exactly the kept chunks of the layout the
/// volume shows (so no two overlap), that they cover every level-0 chunk of the
/// rows within the view of that layout's camera exactly once, and that every
/// shown chunk's entity is that chunk. Returns how many are shown.
fn check_cover(app: &App, volume: Entity) -> Result<usize, String> {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let (layout, keep) = state.horizon_shown().ok_or("nothing shown yet")?;
    let shown = state.shown_chunks();
    let mut have: Vec<ChunkKey> = shown.iter().map(|(k, _)| *k).collect();
    let mut want: Vec<ChunkKey> = layout
        .chunks()
        .into_iter()
        .filter(|k| keep.keeps(k))
        .collect();
    have.sort_by_key(|k| k.order());
    want.sort_by_key(|k| k.order());
    if have != want {
        let extra: Vec<_> = have.iter().filter(|k| !want.contains(k)).collect();
        let missing: Vec<_> = want.iter().filter(|k| !have.contains(k)).collect();
        return Err(format!(
            "shown but not kept {extra:?}; kept but not shown {missing:?}"
        ));
    }
    for (k, e) in &shown {
        match app.world().get::<KdChunk>(*e) {
            Some(c) if c.coord == k.coord && c.level == k.level => {}
            other => return Err(format!("chunk {k:?} shows on {e}: {other:?}")),
        }
    }
    // Count, per level-0 chunk of the rows, the shown chunks that hold it.
    let lo = layout.lo().with_y(ROWS.0);
    let hi = layout.hi().with_y(ROWS.1 + 1);
    let size = hi - lo;
    let mut count = vec![0u8; (size.x * size.y * size.z) as usize];
    for (k, _) in &shown {
        let (a, b) = (k.lo().max(lo), k.hi().min(hi));
        for z in a.z..b.z {
            for y in a.y..b.y {
                for x in a.x..b.x {
                    let i = ((z - lo.z) * size.y + (y - lo.y)) * size.x + (x - lo.x);
                    count[i as usize] += 1;
                }
            }
        }
    }
    for (i, &n) in count.iter().enumerate() {
        let i = i as i32;
        let at = lo + IVec3::new(i % size.x, (i / size.x) % size.y, i / (size.x * size.y));
        let center = at.as_vec3().xz() + 0.5;
        let inside = center.distance(keep.camera.xz()) <= keep.reach;
        if n > 1 || (inside && n != 1) {
            return Err(format!("level-0 chunk {at} is shown {n} times"));
        }
    }
    Ok(shown.len())
}

#[test]
fn a_flight_with_edits_keeps_the_horizon_whole_and_loses_nothing() {
    let mut app = app();
    let (cam, v) = fly_from_hills(&mut app);
    check_cover(&app, v).unwrap();
    let levels = |app: &App| -> HashMap<u32, usize> {
        let s = app.world().get::<VolumeState>(v).unwrap();
        let mut n = HashMap::new();
        for (k, _) in s.shown_chunks() {
            *n.entry(k.level).or_default() += 1;
        }
        n
    };
    let first = levels(&app);
    let region0 = app
        .world()
        .get::<VolumeState>(v)
        .unwrap()
        .world()
        .layout()
        .lo();
    assert!(
        (0..=2).all(|l| first.get(&l).copied().unwrap_or(0) > 0),
        "levels 0 to 2 all shown: {first:?}"
    );

    // Fly 0.6 cells a frame along x (and 0.25 along z) for 240 frames, a frame
    // about every 10 ms (about 60 cells a second): across many level-0 chunks
    // and two top-level chunk borders (x = 64 and 128), so the region moves.
    let mut edits = 0;
    let mut far_rebuilt = Vec::new();
    let mut changing = 0;
    let mut regions = vec![region0];
    for frame in 0..240 {
        let p = Vec3::new(40.0 + 0.6 * frame as f32, 6.0, 4.0 + 0.25 * frame as f32);
        app.world_mut()
            .get_mut::<Transform>(cam)
            .unwrap()
            .translation = p;
        let brush = match frame {
            30 | 90 | 150 => Some(Brush::sphere(p.with_y(0.0), 3.0, BrushOp::Subtract)),
            // A crater far out, where only coarse chunks are.
            60 => Some(Brush::sphere(
                p + Vec3::new(52.0, -6.0, 0.0),
                6.0,
                BrushOp::Subtract,
            )),
            _ => None,
        };
        if let Some(brush) = brush {
            app.world_mut().write_message(ApplyEdit::new(v, brush));
            edits += 1;
        }
        app.update();
        if frame == 60 {
            let applied = applied_edits(&mut app);
            far_rebuilt = applied.last().unwrap().rebuilt.clone();
        }
        let state = app.world().get::<VolumeState>(v).unwrap();
        if state.level_change_in_progress() {
            changing += 1;
        }
        let lo = state.world().layout().lo();
        if regions.last() != Some(&lo) {
            regions.push(lo);
        }
        if let Err(e) = check_cover(&app, v) {
            panic!("frame {frame}, camera {p}: {e}");
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(
        far_rebuilt.iter().any(|k| k.level >= 2),
        "the far crater rebuilds coarse chunks: {far_rebuilt:?}"
    );
    settle(&mut app, v);
    check_cover(&app, v).unwrap();
    let state = app.world().get::<VolumeState>(v).unwrap();
    // The last layout may land after the flight when the cores are busy (the
    // other tests of this binary run beside this one).
    let lo = state.world().layout().lo();
    if regions.last() != Some(&lo) {
        regions.push(lo);
    }
    assert_eq!(state.edit_log().len(), edits, "an edit was lost");
    // The trees are built for the thresholds the camera asks of the view: up
    // to the LOD curve's a few chunk widths out, in each chunk's own cells.
    let world = state.world();
    let limit = world.settings.max_threshold;
    let lod = LodSettings {
        base: 0.01,
        near: 8.0,
        ..Default::default()
    };
    let ring = 1.0; // level-0 chunks out to 2 * RES cells
    let widths = kdcontour::world::Layout::around_reach(ring) + 2.0;
    assert_eq!(limit, lod.curve().threshold(widths * RES as f32));
    // ... and no lower than the lowest it asks: the curve's base here.
    assert_eq!(world.settings.min_threshold, lod.base);
    for (k, _) in state.shown_chunks() {
        if let Some(tree) = world.tree(&k) {
            assert_eq!(tree.max_threshold(), limit, "{k:?}");
            assert_eq!(tree.min_threshold(), lod.base, "{k:?}");
            assert!(world.threshold(&k) >= lod.base, "{k:?}");
        }
    }
    let field = app.world().get::<VolumeState>(v).unwrap().field().clone();
    assert_shown_match_fresh(&app, v, &field);
    assert!(changing > 20, "levels changed in only {changing} frames");
    assert!(regions.len() >= 3, "the region moved twice: {regions:?}");
}

#[test]
fn bad_horizon_settings_are_reported_and_skipped() {
    for vol in [
        KdVolume::horizon(hills(), 7, 1.0, 64), // odd chunk_res
        KdVolume::horizon(hills(), 8, 1.0, 4),  // view under one chunk
        KdVolume::horizon(hills(), 8, 1.0, 64).with_level0(128),
        KdVolume::horizon(hills(), 8, 1.0, 64).with_rows(2, 1),
    ] {
        let mut app = app();
        let v = app.world_mut().spawn(vol).id();
        app.update();
        app.update();
        assert!(app.world().get::<VolumeState>(v).is_none());
        assert!(app.world().get::<KdVolume>(v).is_none(), "removed");
    }
}

#[test]
fn a_flying_camera_is_laid_out_ahead_of_itself_and_a_still_one_where_it_is() {
    use bevy::time::TimeUpdateStrategy;
    use std::time::Duration;
    let mut app = app();
    // The app's clock moves 20 ms a frame, whatever the machine does.
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(
        20,
    )));
    let (cam, v) = fly_from_hills(&mut app);
    fn state(app: &App, v: Entity) -> &VolumeState {
        app.world().get::<VolumeState>(v).unwrap()
    }
    assert!(
        state(&app, v).level_change_seconds() > 0.0,
        "the first load is timed"
    );
    let shown_for = |app: &App| state(app, v).horizon_shown().unwrap().1.camera;
    // Still: laid out where it is (level-0 chunks of RES cells).
    assert_eq!(shown_for(&app), Vec3::new(40.0, 6.0, 4.0) / RES as f32);

    // Fly along x at a quarter of a cell a frame (12.5 cells a second by the
    // app's clock), slow enough that the look-ahead stays under its cap in a
    // debug build.
    let mut x = 40.0;
    let mut ahead = 0;
    let mut changes = 0;
    let mut last = shown_for(&app);
    // Until four level changes have shown (a busy machine takes more frames).
    for _ in 0..1600 {
        if changes == 4 {
            break;
        }
        x += 0.25;
        app.world_mut()
            .get_mut::<Transform>(cam)
            .unwrap()
            .translation = Vec3::new(x, 6.0, 4.0);
        app.update();
        let made_for = shown_for(&app);
        if made_for != last {
            last = made_for;
            changes += 1;
            let lead = made_for.x - x / RES as f32;
            // Never past the reach of level 2 (4 x the level-0 reach of 2
            // chunks) ahead.
            assert!(lead <= 8.0 + 1e-3, "laid out {lead} chunks ahead");
            assert!(made_for.z == 0.5 && made_for.y == 0.75, "{made_for}");
            ahead += (lead > 0.0) as usize;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(changes >= 3, "only {changes} level changes in the flight");
    // A layout made for where the camera was would always be behind it.
    assert!(
        ahead > 0,
        "no level change of {changes} was laid out ahead of the camera"
    );

    // Stopped: after a moment it is laid out where it is again.
    for _ in 0..30 {
        app.update();
    }
    settle(&mut app, v);
    assert_eq!(shown_for(&app), Vec3::new(x, 6.0, 4.0) / RES as f32);
    check_cover(&app, v).unwrap();
}
