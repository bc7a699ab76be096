//! Adaptive Skeleton Climbing (`skeleton-climbing`): what holds on every built-in
//! scene, checked through `kdcontour::validate`.
//!
//! Block 1 (every box a cell) is Marching Cubes' topology. Coarser blocks are
//! closed and oriented on every scene (both boxes at a face cut it alike, the
//! paper's point against adaptive Marching Cubes), and keep Marching Cubes'
//! topology where every feature is wider than a box; `caves` is where they do not
//! (see `caves_is_the_scene_whose_topology_coarse_boxes_change`).

use glam::Vec3;
use kdcontour::field::FnField;
use kdcontour::meshers::{self, Mesher, Sampled};
use kdcontour::skeleton_climbing::{block_for_threshold, skeleton_climbing};
use kdcontour::{scenes, validate, Error, Grid, IndexedMesh, MeshReport, Settings};

fn sampled(scene: &scenes::Scene, res: u32) -> Sampled<'_> {
    meshers::sample(&*scene.field, &Grid::cube(1.0, res), &Settings::default()).unwrap()
}

fn scene(name: &str) -> scenes::Scene {
    scenes::scene(name).unwrap()
}

fn mc(s: &Sampled) -> MeshReport {
    let (m, _) = meshers::run(Mesher::MarchingCubes, s, -1.0, &Settings::default()).unwrap();
    validate(&m, None)
}

fn climb(s: &Sampled, block: u32) -> (IndexedMesh, MeshReport) {
    let m = skeleton_climbing(&s.hermite, block).unwrap();
    let r = validate(&m, None);
    (m, r)
}

#[test]
fn block_1_is_marching_cubes_topology_on_every_scene() {
    for name in scenes::SCENES {
        for res in [32, 48] {
            let scene = scene(name);
            let s = sampled(&scene, res);
            let (m, r) = (mc(&s), climb(&s, 1).1);
            assert!(r.triangles > 0, "{name} res {res}: empty");
            assert!(r.is_closed_manifold(), "{name} res {res}: {r:?}");
            // Same loops, each cut into (length - 2) triangles.
            assert_eq!(r.triangles, m.triangles, "{name} res {res}");
            assert_eq!(r.euler, m.euler, "{name} res {res}");
            assert_eq!(r.components, m.components, "{name} res {res}");
        }
    }
}

#[test]
fn coarse_blocks_are_closed_oriented_and_smaller_on_every_scene() {
    for name in scenes::SCENES {
        for res in [32, 48] {
            let scene = scene(name);
            let s = sampled(&scene, res);
            let m = mc(&s);
            for block in [2, 4, 8, 16] {
                let r = climb(&s, block).1;
                let at = format!("{name} res {res} block {block}");
                assert!(r.triangles > 0, "{at}: empty");
                assert!(r.watertight && r.oriented, "{at}: {r:?}");
                assert!(
                    r.triangles < m.triangles,
                    "{at}: {} >= MC {}",
                    r.triangles,
                    m.triangles
                );
                assert_eq!(r.degenerate_triangles, 0, "{at}");
                if *name != "caves" {
                    assert!(r.manifold, "{at}: {r:?}");
                    assert_eq!((r.euler, r.components), (m.euler, m.components), "{at}");
                }
            }
        }
    }
}

#[test]
fn caves_is_the_scene_whose_topology_coarse_boxes_change() {
    // The caves' thin walls and tunnels fit inside simple boxes: a box only asks
    // that each line of samples through it cross the surface once, so a tunnel
    // whose every sample line is crossed once closes, and two boxes can draw the
    // same edge in a face they share. Recorded, not hidden: if this starts to
    // hold, move caves into the test above.
    let scene = scene("caves");
    let s = sampled(&scene, 48);
    let m = mc(&s);
    let changed = [2, 4, 8, 16].iter().any(|&b| {
        let r = climb(&s, b).1;
        !r.manifold || (r.euler, r.components) != (m.euler, m.components)
    });
    assert!(changed);
}

#[test]
fn vertices_are_marching_cubes_crossings() {
    // Every vertex is a Hermite crossing, so none stands further from the surface
    // than Marching Cubes' furthest vertex.
    for name in ["sphere", "csg_mix", "gyroid"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 32);
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        let field = Some((&*scene.field, grid.cell_size));
        let (mc, _) = meshers::run(Mesher::MarchingCubes, &s, -1.0, &Settings::default()).unwrap();
        let limit = validate(&mc, field).max_vertex_error;
        for block in [1, 4, 16] {
            let m = skeleton_climbing(&s.hermite, block).unwrap();
            let r = validate(&m, field);
            assert!(r.vertices <= mc.vertex_count(), "{name} block {block}");
            assert!(r.max_vertex_error <= limit + 1e-6, "{name} block {block}");
        }
    }
}

#[test]
fn one_thread_and_many_give_the_same_mesh() {
    for name in ["sphere", "gyroid", "caves", "csg_mix"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 40);
        for threshold in [-1.0, 0.01, 0.1, 1.0] {
            let meshes: Vec<IndexedMesh> = [1, 4]
                .map(|threads| {
                    let settings = Settings {
                        threads,
                        ..Default::default()
                    };
                    let s = meshers::sample(&*scene.field, &grid, &settings).unwrap();
                    meshers::run(Mesher::SkeletonClimbing, &s, threshold, &settings)
                        .unwrap()
                        .0
                })
                .into();
            assert_eq!(meshes[0].indices, meshes[1].indices, "{name} {threshold}");
            assert_eq!(
                meshes[0].positions, meshes[1].positions,
                "{name} {threshold}"
            );
            assert_eq!(meshes[0].normals, meshes[1].normals, "{name} {threshold}");
        }
    }
}

#[test]
fn the_threshold_picks_the_box_size_limit() {
    assert_eq!(block_for_threshold(-1.0), 1);
    assert_eq!(block_for_threshold(0.0), 1);
    assert_eq!(block_for_threshold(0.005), 1);
    assert_eq!(block_for_threshold(0.01), 2);
    assert_eq!(block_for_threshold(0.05), 2);
    assert_eq!(block_for_threshold(0.1), 4);
    assert_eq!(block_for_threshold(1.0), 8);
    assert_eq!(block_for_threshold(1e9), 64);
    assert_eq!(block_for_threshold(f32::NAN), 1);
    // Larger thresholds never give more triangles.
    let scene = scene("torus");
    let s = sampled(&scene, 48);
    let mut last = usize::MAX;
    for t in [-1.0, 0.01, 0.1] {
        let (m, _) = meshers::run(Mesher::SkeletonClimbing, &s, t, &Settings::default()).unwrap();
        assert!(m.triangle_count() < last, "threshold {t}");
        last = m.triangle_count();
    }
}

#[test]
fn a_block_size_that_is_no_power_of_two_or_too_large_is_refused() {
    let scene = scene("sphere");
    let s = sampled(&scene, 16);
    for block in [0, 3, 12, 128] {
        let e = skeleton_climbing(&s.hermite, block).err();
        assert!(
            matches!(e, Some(Error::InvalidSetting { name: "block", .. })),
            "{block}: {e:?}"
        );
    }
}

#[test]
fn nan_samples_are_an_error_and_an_empty_field_an_empty_mesh() {
    let grid = Grid::cube(1.0, 16);
    let nan = FnField(|p: Vec3| {
        if p.x > 0.3 {
            f32::NAN
        } else {
            p.length() - 0.5
        }
    });
    let e = meshers::sample(&nan, &grid, &Settings::default()).err();
    assert!(matches!(e, Some(Error::NonFiniteSample { .. })), "{e:?}");
    for value in [1.0f32, -1.0] {
        let field = FnField(move |_| value);
        let s = meshers::sample(&field, &grid, &Settings::default()).unwrap();
        for threshold in [-1.0, 0.01, 1.0] {
            let (m, _) = meshers::run(
                Mesher::SkeletonClimbing,
                &s,
                threshold,
                &Settings::default(),
            )
            .unwrap();
            assert!(
                m.is_empty() && m.positions.is_empty(),
                "{value} {threshold}"
            );
        }
    }
}

#[test]
fn grids_that_are_no_multiple_of_the_block_are_closed_too() {
    // Partial blocks at the grid's high end, and a flat box.
    let scene = scenes::scene("torus").unwrap();
    for cells in [glam::UVec3::new(37, 29, 45), glam::UVec3::new(50, 50, 13)] {
        let grid = Grid {
            cells,
            cell_size: 2.0 / 50.0,
            ..Grid::cube(1.0, 50)
        };
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        let m = mc(&s);
        for block in [4, 16] {
            let r = climb(&s, block).1;
            assert!(r.triangles > 0, "{cells} {block}");
            // Cut by the grid, so open where MC is open, and nowhere else.
            assert_eq!(r.watertight, m.watertight, "{cells} {block}: {r:?}");
            assert!(r.manifold && r.oriented, "{cells} {block}: {r:?}");
        }
    }
}
