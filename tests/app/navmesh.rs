//! Navmesh (feature `navmesh`), headless: tiles are built in the meshing
//! tasks (never on the main thread) for the chunks near anchors; a path goes
//! around a pit dug across it once the pit's chunks re-mesh, and only their
//! tiles are rebuilt; a goal in rock has no path; tiles past a frame's
//! linking budget are linked in later frames, to the same navmesh; new agent
//! settings rebuild every tile, and turning tiles off takes them all away.

use crate::common::{app_with, settle};
use bevy::prelude::*;
use bevy_kdcontour::navmesh::PathError;
use bevy_kdcontour::prelude::*;
use bevy_kdcontour::{NavAnchor, NavStats, NavmeshSettings, VolumeNavMesh};
use kdcontour::edit::{Brush, BrushOp};
use kdcontour::world::ChunkKey;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Rolling ground around y = 16, the boundary between the two chunk layers.
fn height(x: f32, z: f32) -> f32 {
    16.0 + 2.5 * (x / 6.0).sin() + 1.5 * (z / 8.0).cos()
}

fn on_ground(x: f32, z: f32) -> Vec3 {
    Vec3::new(x, height(x, z) + 0.5, z)
}

/// 6 x 2 x 6 chunks of 16 cells of 1 unit (96 x 32 x 96), anchors at `points`,
/// the LOD camera far above (beyond the tile distance), settled.
fn world(points: &[Vec3]) -> (App, Entity) {
    let (mut app, volume) = unsettled_world(points, NavmeshSettings::default());
    settle(&mut app, volume);
    (app, volume)
}

/// [`world`] with `settings`, before its first update.
fn unsettled_world(points: &[Vec3], settings: NavmeshSettings) -> (App, Entity) {
    let mut app = app_with(LodSettings::default());
    app.insert_resource(settings);
    let field: Arc<dyn kdcontour::Field> =
        Arc::new(kdcontour::field::FnField(|p: Vec3| p.y - height(p.x, p.z)));
    let volume = app
        .world_mut()
        .spawn(KdVolume::new(field, UVec3::new(6, 2, 6), 16, 1.0))
        .id();
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(48.0, 400.0, 48.0)));
    for p in points {
        app.world_mut()
            .spawn((NavAnchor, Transform::from_translation(*p)));
    }
    (app, volume)
}

fn navmesh(app: &App, volume: Entity) -> &VolumeNavMesh {
    app.world().get::<VolumeNavMesh>(volume).expect("a navmesh")
}

fn stats(app: &App) -> NavStats {
    app.world().resource::<NavStats>().clone()
}

/// Each tile, by chunk.
fn tiles(app: &App, volume: Entity) -> BTreeMap<(i32, i32, i32, u32), Arc<kdcontour_nav::NavTile>> {
    let nav = navmesh(app, volume).navmesh();
    nav.keys()
        .map(|k| (k.order(), nav.tile(k).unwrap().clone()))
        .collect()
}

fn closest_approach(points: &[Vec3], c: Vec3) -> f32 {
    let mut best = f32::INFINITY;
    for s in points.windows(2) {
        for i in 0..=20 {
            let p = s[0].lerp(s[1], i as f32 / 20.0);
            best = best.min(Vec2::new(p.x - c.x, p.z - c.z).length());
        }
    }
    best
}

#[test]
fn a_path_goes_around_a_pit_dug_across_it_and_only_the_pits_tiles_are_rebuilt() {
    let (s, g) = (on_ground(20.0, 50.0), on_ground(76.0, 50.0));
    let (mut app, volume) = world(&[s, g, on_ground(48.0, 50.0)]);
    let before_stats = stats(&app);
    println!("{before_stats:?}");
    assert!(before_stats.tiles >= 12 && before_stats.links > 0);
    assert_eq!(
        before_stats.built_on_main_thread, 0,
        "a tile was built on the main thread"
    );
    assert_eq!(before_stats.failures, 0);
    let before = navmesh(&app, volume).find_path(s, g).unwrap();
    let c = Vec3::new(48.0, height(48.0, 50.0), 50.0);
    assert!(closest_approach(&before.points, c) < 3.0);
    let placed = GlobalTransform::IDENTITY;
    assert_eq!(
        navmesh(&app, volume).is_open_between_world(&placed, s, g),
        Ok(true)
    );
    let old = tiles(&app, volume);

    // A pit of radius 7 across the path.
    app.world_mut().write_message(ApplyEdit::new(
        volume,
        Brush::sphere(c, 7.0, BrushOp::Subtract),
    ));
    app.update();
    settle(&mut app, volume);
    let after_stats = stats(&app);
    let new = tiles(&app, volume);
    // Rebuilt: the tiles that are not the same tile as before.
    let rebuilt: Vec<_> = new
        .iter()
        .filter(|(k, t)| old.get(*k).is_none_or(|o| !Arc::ptr_eq(o, t)))
        .map(|(k, _)| *k)
        .collect();
    println!(
        "the pit rebuilt {} of {} tiles ({} built by the counter)",
        rebuilt.len(),
        new.len(),
        after_stats.tiles_built - before_stats.tiles_built
    );
    assert!(!rebuilt.is_empty() && rebuilt.len() * 2 < new.len());
    // Every tile rebuilt is counted, and is of a chunk the pit reaches or of
    // the owner of a seam of one (a chunk owns the seams with its neighbours
    // above it on each axis, so an owner is at most one chunk below on each).
    assert_eq!(
        after_stats.tiles_built - before_stats.tiles_built,
        rebuilt.len() as u64
    );
    let reached: Vec<IVec3> = (0..6)
        .flat_map(|x| (0..2).flat_map(move |y| (0..6).map(move |z| IVec3::new(x, y, z))))
        .filter(|k| {
            let lo = k.as_vec3() * 16.0;
            c.clamp(lo, lo + 16.0).distance(c) <= 7.0
        })
        .collect();
    for (x, y, z, level) in &rebuilt {
        let key = ChunkKey::new(*level, IVec3::new(*x, *y, *z));
        assert!(
            reached.iter().any(|r| {
                let d = *r - key.coord;
                d.min_element() >= 0 && d.max_element() <= 1
            }),
            "{key:?} rebuilt; the pit reaches {reached:?}"
        );
    }
    assert_eq!(after_stats.built_on_main_thread, 0);
    let after = navmesh(&app, volume).find_path(s, g).unwrap();
    println!(
        "before: {:.1} over {} polygons; after: {:.1} over {} polygons",
        before.length(),
        before.polygons,
        after.length(),
        after.polygons
    );
    assert!(after.length() > before.length() + 2.0);
    let clear = closest_approach(&after.points, c);
    assert!(clear > 5.0, "the path passes {clear} from the pit's centre");
    // The pit stands in the straight line's way now.
    assert_eq!(
        navmesh(&app, volume).is_open_between_world(&placed, s, g),
        Ok(false)
    );

    // A goal in the rock under the ground has no path, and says so.
    let rock = Vec3::new(60.0, height(60.0, 40.0) - 6.0, 40.0);
    match navmesh(&app, volume).find_path(s, rock) {
        Err(e @ PathError::OffMesh { .. }) => println!("{e}"),
        other => panic!("{other:?}"),
    }
    // In world space, for a moved volume, the same path moved.
    app.world_mut()
        .entity_mut(volume)
        .insert(Transform::from_xyz(100.0, 0.0, 0.0));
    app.update();
    let tf = *app.world().get::<GlobalTransform>(volume).unwrap();
    let moved = navmesh(&app, volume)
        .find_path_world(&tf, s + Vec3::X * 100.0, g + Vec3::X * 100.0)
        .unwrap();
    assert_eq!(moved.len(), after.points.len());
    assert!(moved
        .iter()
        .zip(&after.points)
        .all(|(m, p)| m.distance(*p + Vec3::X * 100.0) < 1e-3));
}

#[test]
fn tiles_past_the_frames_linking_budget_are_linked_in_later_frames_alike() {
    let points = [
        on_ground(20.0, 50.0),
        on_ground(76.0, 50.0),
        on_ground(48.0, 30.0),
    ];
    let (app, volume) = world(&points);
    let all_at_once = stats(&app);
    let path = navmesh(&app, volume)
        .find_path(points[0], points[1])
        .unwrap();
    // No budget: one tile linked a frame, the rest wait.
    let (mut app, volume) = unsettled_world(
        &points,
        NavmeshSettings {
            link_budget_ms: 0.0,
            ..Default::default()
        },
    );
    // Every chunk meshed at once and shown in one frame, so that many tiles
    // land together.
    {
        let mut settings = app.world_mut().resource_mut::<KdContourSettings>();
        settings.max_tasks_in_flight = 1000;
        settings.max_uploads_per_frame = 1000;
    }
    let (mut most_waiting, mut frames) = (0, 0);
    let mut linked = 0;
    while frames < 5000 {
        app.update();
        frames += 1;
        let now = stats(&app);
        assert!(
            now.tiles <= linked + 1,
            "at most one tile linked a frame: {linked} then {}",
            now.tiles
        );
        linked = now.tiles;
        most_waiting = most_waiting.max(navmesh(&app, volume).waiting());
        if now.tiles == all_at_once.tiles && now.waiting == 0 {
            break;
        }
        // The first frames wait for the chunk workers.
        let pause = if frames <= 4 { 300_000 } else { 200 };
        std::thread::sleep(std::time::Duration::from_micros(pause));
    }
    settle(&mut app, volume);
    let one_a_frame = stats(&app);
    assert!(
        most_waiting >= 5,
        "tiles waited: at most {most_waiting} at once"
    );
    assert_eq!(
        (
            one_a_frame.tiles,
            one_a_frame.polygons,
            one_a_frame.links,
            one_a_frame.waiting
        ),
        (
            all_at_once.tiles,
            all_at_once.polygons,
            all_at_once.links,
            0
        )
    );
    let again = navmesh(&app, volume)
        .find_path(points[0], points[1])
        .unwrap();
    assert_eq!(again.points, path.points);
}

#[test]
fn new_agent_settings_rebuild_every_tile_and_off_takes_them_away() {
    let (s, g) = (on_ground(30.0, 30.0), on_ground(66.0, 66.0));
    let (mut app, volume) = world(&[s, g]);
    let first = stats(&app);
    let narrow = navmesh(&app, volume).find_path(s, g).unwrap();
    // A new linking budget is not a new agent: nothing is built again (an
    // endless budget links everything at once, NaN one tile a frame).
    for budget in [1.0, f32::INFINITY, f32::NAN] {
        app.world_mut()
            .resource_mut::<NavmeshSettings>()
            .link_budget_ms = budget;
        app.update();
        settle(&mut app, volume);
        assert_eq!(
            stats(&app).tiles_built,
            first.tiles_built,
            "budget {budget}"
        );
    }
    // A wider agent: every tile built again, the path still there.
    app.world_mut()
        .resource_mut::<NavmeshSettings>()
        .agent_radius = 0.8;
    app.update();
    settle(&mut app, volume);
    let wide = stats(&app);
    assert!(
        wide.tiles_built - first.tiles_built >= first.tiles as u64,
        "{first:?} then {wide:?}"
    );
    assert_eq!(navmesh(&app, volume).navmesh().settings().agent_radius, 0.8);
    assert!(navmesh(&app, volume).find_path(s, g).is_ok());
    assert!(narrow.length() > 0.0);
    // Out of range: refused by name, no tiles, the app keeps running.
    app.world_mut()
        .resource_mut::<NavmeshSettings>()
        .max_slope_degrees = 95.0;
    app.update();
    settle(&mut app, volume);
    let bad = stats(&app);
    assert!(bad
        .last_error
        .as_deref()
        .is_some_and(|e| e.contains("max_slope_degrees")));
    assert_eq!(bad.tiles, 0);
    // Back in range, then off: every tile taken away.
    app.world_mut()
        .resource_mut::<NavmeshSettings>()
        .max_slope_degrees = 40.0;
    app.update();
    settle(&mut app, volume);
    assert!(stats(&app).tiles > 0);
    app.world_mut().resource_mut::<NavmeshSettings>().enabled = false;
    app.update();
    settle(&mut app, volume);
    assert_eq!(stats(&app).tiles, 0);
    assert!(matches!(
        navmesh(&app, volume).find_path(s, g),
        Err(PathError::OffMesh { .. })
    ));
}
