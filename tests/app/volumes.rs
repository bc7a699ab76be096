//! The plugin in a headless app (`HeadlessPlugins`: MinimalPlugins, AssetPlugin,
//! MeshPlugin, TransformPlugin): volumes mesh, edits rebuild exactly what they touch, nothing is
//! lost under a stream of edits and camera moves, LOD never re-samples, and a
//! panicking field is reported without taking the app down.

use crate::common::{app_with, applied_edits, settle, shown};
use bevy::prelude::*;
use bevy_kdcontour::headless::HeadlessPlugins;
use bevy_kdcontour::prelude::*;
use kdcontour::edit::EditedField;
use kdcontour::{CsgNode, Field, IndexedMesh, World};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

fn app(lod: bool) -> App {
    app_with(LodSettings {
        enabled: lod,
        base: 0.001,
        near: 0.3,
        ..Default::default()
    })
}

fn torus() -> Arc<dyn Field> {
    Arc::new(
        CsgNode::from_json(r#"{"type":"torus","major_radius":0.55,"minor_radius":0.2}"#)
            .unwrap()
            .compile()
            .unwrap(),
    )
}

/// 3x3x3 chunks of 8^3 cells over [-1, 1]^3.
fn spawn(app: &mut App, field: Arc<dyn Field>) -> Entity {
    app.world_mut()
        .spawn((
            KdVolume::new(field, UVec3::splat(3), 8, 2.0 / 24.0),
            Transform::from_xyz(-1.0, -1.0, -1.0),
        ))
        .id()
}

/// A from-scratch world of `field` at the thresholds `state` uses.
fn fresh(field: &dyn Field, state: &VolumeState) -> World {
    let w = state.world();
    // The lowest threshold the volume's trees were built for (one for all).
    let lowest = w
        .chunks()
        .iter()
        .filter_map(|k| w.tree(k).map(|t| t.min_threshold()))
        .fold(w.settings.min_threshold, f32::min);
    let mut f = World::unbounded(
        Vec3::ZERO,
        w.cell_size,
        w.chunk_res,
        0.01,
        // A volume with a plain material builds without the field's materials;
        // a streaming volume's trees are cut no lower than the lowest threshold
        // it asks (below it the fold guard checks nothing, so the meshes at and
        // above it are those of trees built for it, not of unlimited ones).
        kdcontour::Settings {
            materials: false,
            min_threshold: lowest,
            ..Default::default()
        },
    )
    .unwrap();
    for c in w.chunks() {
        f.add_chunk(c.coord).unwrap();
    }
    f.build_all(field).unwrap();
    for c in w.chunks() {
        f.set_threshold(&c, w.threshold(&c));
    }
    f
}

/// The lowest thresholds the volume's built trees serve, each once.
fn tree_floors(app: &App, volume: Entity) -> Vec<f32> {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let w = state.world();
    let mut m: Vec<f32> = w
        .chunks()
        .iter()
        .filter_map(|k| w.tree(k).map(|t| t.min_threshold()))
        .collect();
    m.sort_by(f32::total_cmp);
    m.dedup();
    m
}

fn assert_matches_fresh(app: &App, volume: Entity, field: &dyn Field) {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let f = fresh(field, state);
    let mut want = IndexedMesh::default();
    let mut total = 0;
    for c in f.chunks() {
        f.snapshot(&c).unwrap().extract(&mut want);
        let entity = state.chunk_entity(&c).unwrap();
        match shown(app, entity) {
            None => assert!(
                want.is_empty(),
                "chunk {c} shows nothing but should show {} triangles",
                want.triangle_count()
            ),
            Some((p, i)) => {
                let wp: Vec<[f32; 3]> = want.positions.iter().map(|v| v.to_array()).collect();
                assert_eq!(
                    p, wp,
                    "chunk {c}: positions differ from a from-scratch build"
                );
                assert_eq!(
                    i, want.indices,
                    "chunk {c}: indices differ from a from-scratch build"
                );
            }
        }
        total += want.triangle_count();
    }
    assert!(total > 0);
}

#[test]
fn a_volume_meshes_every_chunk_with_surface_and_no_empty_one() {
    let mut app = app(false);
    let v = spawn(&mut app, torus());
    settle(&mut app, v);
    // The trees are built for no cut below the one threshold the settings ask.
    assert_eq!(tree_floors(&app, v), vec![0.01]);
    assert_matches_fresh(&app, v, &*torus());
    // The torus misses some chunks entirely (corners of the cube).
    let mut q = app.world_mut().query::<(&KdChunk, Option<&Mesh3d>)>();
    let (mut meshed, mut empty) = (0, 0);
    for (chunk, mesh) in q.iter(app.world()) {
        match chunk.status {
            ChunkStatus::Meshed => {
                assert!(mesh.is_some() && chunk.triangles > 0);
                meshed += 1
            }
            ChunkStatus::Empty => {
                assert!(mesh.is_none());
                empty += 1
            }
            ref s => panic!("chunk {} is {s:?}", chunk.coord),
        }
    }
    assert_eq!(meshed + empty, 27);
    assert!(meshed > 0 && empty > 0, "{meshed} meshed, {empty} empty");
}

#[test]
fn one_edit_rebuilds_exactly_the_chunks_it_meets() {
    let mut app = app(false);
    let v = spawn(&mut app, torus());
    settle(&mut app, v);
    let before: Vec<(IVec3, usize)> = {
        let s = app.world().get::<VolumeState>(v).unwrap();
        s.world()
            .chunks()
            .into_iter()
            .map(|c| (c.coord, s.world().tree(&c).unwrap() as *const _ as usize))
            .collect()
    };
    // A ball around the chunk corner at (1/3, 1/3, 1/3) of the cube, local space.
    let center = Vec3::splat(2.0 / 3.0) + Vec3::new(0.02, 0.03, 0.01);
    app.world_mut()
        .write_message(ApplyEdit::new(v, Brush::sphere(center, 0.1, BrushOp::Add)));
    app.update();
    let applied = applied_edits(&mut app);
    assert_eq!(applied.len(), 1);
    assert!(applied[0].rebuilt.iter().all(|k| k.level == 0));
    let mut rebuilt: Vec<IVec3> = applied[0].rebuilt.iter().map(|k| k.coord).collect();
    rebuilt.sort_by_key(|c| (c.z, c.y, c.x));
    // The eight chunks around that corner.
    let mut want: Vec<IVec3> = (0..8)
        .map(|i| IVec3::new(i & 1, (i >> 1) & 1, (i >> 2) & 1))
        .collect();
    want.sort_by_key(|c| (c.z, c.y, c.x));
    assert_eq!(rebuilt, want);
    settle(&mut app, v);
    let s = app.world().get::<VolumeState>(v).unwrap();
    for (c, ptr) in before {
        let now = s.world().tree(&ChunkKey::new(0, c)).unwrap() as *const _ as usize;
        assert_eq!(
            now != ptr,
            want.contains(&c),
            "chunk {c}: rebuilt {}",
            now != ptr
        );
    }
    let field = s.field().clone();
    assert_matches_fresh(&app, v, &field);
}

#[test]
fn a_hundred_edits_and_camera_moves_lose_nothing() {
    let mut app = app(true);
    let v = spawn(&mut app, torus());
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 0.0, 2.0)))
        .id();
    settle(&mut app, v);
    let mut seed = 5u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as f32 / (1u64 << 31) as f32
    };
    for i in 0..100 {
        let center = Vec3::new(next(), next(), next()) * 2.0;
        let op = if next() < 0.5 {
            BrushOp::Add
        } else {
            BrushOp::Subtract
        };
        app.world_mut().write_message(ApplyEdit::new(
            v,
            Brush::sphere(center, 0.05 + 0.15 * next(), op),
        ));
        if i % 7 == 0 {
            let p = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 4.0 + Vec3::ONE;
            app.world_mut()
                .get_mut::<Transform>(cam)
                .unwrap()
                .translation = p;
        }
        for _ in 0..(next() * 3.0) as usize {
            app.update();
        }
    }
    settle(&mut app, v);
    let s = app.world().get::<VolumeState>(v).unwrap();
    assert_eq!(s.edit_log().len(), 100, "every edit is in the log");
    let replayed = EditedField::replay(torus(), &s.edit_log()).unwrap();
    assert_matches_fresh(&app, v, &replayed);
}

struct Counted {
    inner: Arc<dyn Field>,
    samples: Arc<AtomicUsize>,
}

impl Field for Counted {
    fn value(&self, p: Vec3) -> f32 {
        self.samples.fetch_add(1, Ordering::Relaxed);
        self.inner.value(p)
    }
    fn lipschitz(&self) -> Option<f32> {
        self.inner.lipschitz()
    }
}

#[test]
fn moving_the_camera_re_extracts_without_sampling() {
    let mut app = app(true);
    let samples = Arc::new(AtomicUsize::new(0));
    let v = spawn(
        &mut app,
        Arc::new(Counted {
            inner: torus(),
            samples: samples.clone(),
        }),
    );
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 0.0, 1.5)))
        .id();
    settle(&mut app, v);
    // With the camera driving thresholds, the trees serve the curve's lowest.
    assert_eq!(tree_floors(&app, v), vec![0.001]);
    let before = samples.load(Ordering::Relaxed);
    let thresholds = |app: &App| {
        let s = app.world().get::<VolumeState>(v).unwrap();
        s.world()
            .chunks()
            .into_iter()
            .map(|c| s.world().threshold(&c))
            .collect::<Vec<_>>()
    };
    let t0 = thresholds(&app);
    app.world_mut()
        .resource_mut::<Messages<LodChanged>>()
        .clear();
    app.world_mut()
        .get_mut::<Transform>(cam)
        .unwrap()
        .translation = Vec3::new(2.0, 2.0, -0.5);
    settle(&mut app, v);
    let t1 = thresholds(&app);
    assert_ne!(t0, t1, "thresholds follow the camera");
    assert_eq!(
        samples.load(Ordering::Relaxed),
        before,
        "a threshold change sampled the field"
    );
    assert!(!app.world().resource::<Messages<LodChanged>>().is_empty());
}

struct Panics;
impl Field for Panics {
    fn value(&self, p: Vec3) -> f32 {
        if p.x > 1.4 {
            panic!("this field has no values beyond x = 1.4");
        }
        p.distance(Vec3::splat(1.0)) - 0.6
    }
}

#[test]
fn a_panicking_field_is_reported_and_the_app_keeps_running() {
    let mut app = app(false);
    // Every failure as it is sent: a message lives two frames, and the volume
    // may take more than that to settle after its last failure.
    #[derive(Resource, Default)]
    struct Failed(Vec<ChunkFailed>);
    app.init_resource::<Failed>().add_systems(
        Last,
        |mut seen: MessageReader<ChunkFailed>, mut all: ResMut<Failed>| {
            all.0.extend(seen.read().cloned())
        },
    );
    let v = spawn(&mut app, Arc::new(Panics));
    settle(&mut app, v);
    let failed = std::mem::take(&mut app.world_mut().resource_mut::<Failed>().0);
    assert!(!failed.is_empty());
    assert!(
        failed.iter().all(|f| f.error.contains("no values beyond")),
        "{failed:?}"
    );
    let mut q = app.world_mut().query::<&KdChunk>();
    let statuses: Vec<ChunkStatus> = q.iter(app.world()).map(|c| c.status.clone()).collect();
    assert!(statuses.iter().any(|s| matches!(s, ChunkStatus::Failed(_))));
    assert!(
        statuses.contains(&ChunkStatus::Meshed),
        "chunks away from the panic still mesh"
    );
    for _ in 0..10 {
        app.update();
    }
}

/// The chunks a streaming volume should hold with the camera at `cam` (local).
fn expected_stream(state: &VolumeState, cam: Vec3, view: f32, rows: (i32, i32)) -> Vec<IVec3> {
    let mut v: Vec<IVec3> = state
        .world()
        .chunks_near(cam, view)
        .into_iter()
        .filter(|c| (rows.0..=rows.1).contains(&c.y))
        .collect();
    v.sort_by_key(|c| (c.z, c.y, c.x));
    v
}

#[test]
fn streaming_terrain_loads_around_the_camera_and_drops_what_it_leaves() {
    use kdcontour::field::terrain::{Heightfield, HeightfieldParams};
    let field: Arc<dyn Field> = Arc::new(Heightfield::new(HeightfieldParams {
        seed: 9,
        base: 0.0,
        amplitude: 6.0,
        frequency: 0.03,
        octaves: 4,
    }));
    let mut app = app(true);
    let (view, rows) = (20.0, (-1, 0));
    let v = app
        .world_mut()
        .spawn(KdVolume::streaming(field.clone(), 8, 1.0, view).with_rows(rows.0, rows.1))
        .id();
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(3.0, 4.0, -2.0)))
        .id();
    settle(&mut app, v);
    let check = |app: &mut App, at: Vec3| {
        let state = app.world().get::<VolumeState>(v).unwrap();
        let want = expected_stream(state, at, view, rows);
        let have: Vec<IVec3> = state.world().chunks().iter().map(|k| k.coord).collect();
        // Everything in range is loaded; anything else is within the slack.
        for c in &want {
            assert!(have.contains(c), "chunk {c} in range but not loaded");
        }
        for c in &have {
            let (lo, hi) = state.world().chunk_bounds(&ChunkKey::new(0, *c));
            assert!(
                at.clamp(lo, hi).distance(at) <= view + 8.0,
                "chunk {c} kept too far"
            );
        }
        let n = app
            .world_mut()
            .query::<&KdChunk>()
            .iter(app.world())
            .count();
        assert_eq!(n, have.len(), "one entity per loaded chunk");
        // Trees are built for the thresholds the LOD asks within the view (and
        // no further, nor lower than its lowest), and show what trees with no
        // largest threshold show.
        let state = app.world().get::<VolumeState>(v).unwrap();
        let limit = state.world().settings.max_threshold;
        assert!(limit.is_finite(), "the trees' limit is {limit}");
        let floor = state.world().settings.min_threshold;
        let settings = app.world().resource::<KdContourSettings>();
        // (rounded down to a power of ten)
        let lowest = settings.lowest_threshold();
        assert!(
            floor <= lowest && floor * 10.0 > lowest,
            "{floor} for {lowest}"
        );
        for k in state.world().chunks() {
            let e = state.world().threshold(&k);
            assert!(e <= limit, "chunk {k:?} is cut at {e}, above {limit}");
            assert!(e >= floor, "chunk {k:?} is cut at {e}, below {floor}");
            if let Some(tree) = state.world().tree(&k) {
                let lowest = tree.min_threshold();
                assert!(lowest <= floor, "chunk {k:?}: a tree for {lowest}");
            }
        }
        assert_matches_fresh(app, v, &*field);
        have
    };
    let first = check(&mut app, Vec3::new(3.0, 4.0, -2.0));
    assert!(first.iter().any(|c| c.x < 0) && first.iter().any(|c| c.z < 0));
    // Fly 60 units along +x: the far side loads, the near side is dropped, and the
    // seams at the old edge are re-cut against what is still loaded.
    for _ in 0..6 {
        app.world_mut()
            .get_mut::<Transform>(cam)
            .unwrap()
            .translation
            .x += 10.0;
        for _ in 0..3 {
            app.update();
        }
    }
    settle(&mut app, v);
    let second = check(&mut app, Vec3::new(63.0, 4.0, -2.0));
    assert!(second.iter().all(|c| c.x >= 4), "{second:?}");
    assert!(second.iter().any(|c| c.x >= 10));
    // Lowering the lowest threshold the settings ask, at run time, builds the
    // loaded trees again for the power of ten below it (no chunk is cut
    // coarser than it asks); lowering it within that decade, or raising it,
    // keeps them (they serve those too).
    assert_eq!(tree_floors(&app, v), vec![0.001]);
    for (base, trees) in [(0.0002, 0.0001), (0.0005, 0.0001), (0.002, 0.0001)] {
        app.world_mut().resource_mut::<KdContourSettings>().lod.base = base;
        for _ in 0..3 {
            app.update();
        }
        settle(&mut app, v);
        check(&mut app, Vec3::new(63.0, 4.0, -2.0));
        assert_eq!(tree_floors(&app, v), vec![trees], "base {base}");
    }
}

#[test]
fn bad_streaming_settings_are_reported_and_skipped() {
    // NaN, and a view whose chunks could not fit the memory budget.
    for view in [f32::NAN, 1e7] {
        let mut app = app(false);
        let v = app
            .world_mut()
            .spawn(KdVolume::streaming(torus(), 8, 1.0, view))
            .id();
        app.update();
        app.update();
        assert!(app.world().get::<VolumeState>(v).is_none(), "{view}");
        assert!(
            app.world().get::<KdVolume>(v).is_none(),
            "the bad volume is removed ({view})"
        );
    }
}

#[test]
fn the_single_plugin_of_before_the_split_still_meshes_the_same() {
    let mut app = App::new();
    app.add_plugins((HeadlessPlugins, KdContourPlugin::default()));
    let v = spawn(&mut app, torus());
    settle(&mut app, v);
    assert_matches_fresh(&app, v, &*torus());
}

#[test]
fn a_subsystem_can_be_left_out() {
    // Without the LOD subsystem a camera right next to the volume changes no
    // threshold: every chunk keeps the default one, and still meshes.
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        KdContourPlugins::default()
            .build()
            .disable::<bevy_kdcontour::LodPlugin>(),
    ));
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 0.0, 0.0)));
    let v = spawn(&mut app, torus());
    settle(&mut app, v);
    let default = KdContourSettings::default().default_threshold;
    let state = app.world().get::<VolumeState>(v).unwrap();
    for c in state.world().chunks() {
        assert_eq!(state.world().threshold(&c), default, "chunk {c}");
    }
    assert_matches_fresh(&app, v, &*torus());
    // With it, the same camera sets other thresholds.
    let mut app = self::app(true);
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 0.0, 0.0)));
    let v = spawn(&mut app, torus());
    settle(&mut app, v);
    let state = app.world().get::<VolumeState>(v).unwrap();
    assert!(state
        .world()
        .chunks()
        .iter()
        .any(|c| state.world().threshold(c) != default));
}

#[test]
fn main_thread_time_and_counts_are_published_every_frame() {
    let mut app = app(false);
    let v = spawn(&mut app, torus());
    app.update();
    let stats = app.world().resource::<KdContourStats>().clone();
    assert_eq!(stats.chunks, 27);
    assert!(stats.main_thread_ms > 0.0, "{stats:?}");
    assert!(stats.tasks_in_flight + stats.queued > 0, "{stats:?}");
    settle(&mut app, v);
    let stats = app.world().resource::<KdContourStats>().clone();
    assert_eq!((stats.tasks_in_flight, stats.queued), (0, 0));
    assert!(stats.builds >= 27 && stats.meshed_chunks > 0, "{stats:?}");
    assert!(stats.main_thread_ms > 0.0 && stats.main_thread_ms < 1000.0);
    // The processor time is part of the clock's (a thread cannot use more
    // than the time that passed), and known on Linux.
    assert!(
        stats.main_thread_cpu_ms <= stats.main_thread_ms + 1e-3,
        "{stats:?}"
    );
    #[cfg(target_os = "linux")]
    assert!(stats.main_thread_cpu_ms > 0.0, "{stats:?}");
}
