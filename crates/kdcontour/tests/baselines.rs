//! The baselines: Marching Cubes and the octree are closed manifolds on closed
//! input, and the k-d tree needs fewer triangles than the octree at equal threshold.

use kdcontour::meshers::{self, Mesher};
use kdcontour::{scenes, validate, Grid, Settings};

#[test]
fn marching_cubes_is_closed_and_matches_dmc_topology() {
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        for res in [32, 48] {
            let grid = Grid::cube(1.0, res);
            let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
            let (mc, _) =
                meshers::run(Mesher::MarchingCubes, &s, -1.0, &Settings::default()).unwrap();
            let (dmc, _) =
                meshers::run(Mesher::UniformDmc, &s, -1.0, &Settings::default()).unwrap();
            let (rm, rd) = (validate(&mc, None), validate(&dmc, None));
            assert!(rm.is_closed_manifold(), "{name} res {res}: {rm:?}");
            assert_eq!(
                rm.euler, rd.euler,
                "{name} res {res}: MC and DMC topology differ"
            );
            assert_eq!(rm.components, rd.components, "{name} res {res}");
        }
    }
}

#[test]
fn octree_is_closed_and_keeps_topology() {
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 64);
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        let mut euler = None;
        for e in [-1.0, 0.001, 0.01, 0.1, 1.0] {
            let (m, _) = meshers::run(Mesher::Octree, &s, e, &Settings::default()).unwrap();
            let r = validate(&m, None);
            assert!(r.is_closed_manifold(), "{name} e {e}: {r:?}");
            assert_eq!(r.euler, *euler.get_or_insert(r.euler), "{name} e {e}");
        }
    }
}

#[test]
fn kdtree_needs_fewer_triangles_than_the_octree() {
    // Equal threshold, equal Hermite data: the partition is the only difference.
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 64);
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        for e in [0.01, 0.1] {
            let (oct, _) = meshers::run(Mesher::Octree, &s, e, &Settings::default()).unwrap();
            let (kd, _) = meshers::run(Mesher::KdTree, &s, e, &Settings::default()).unwrap();
            let ratio = kd.triangle_count() as f64 / oct.triangle_count() as f64;
            assert!(
                ratio < 1.0,
                "{name} e {e}: k-d {} vs octree {} triangles",
                kd.triangle_count(),
                oct.triangle_count()
            );
        }
    }
}
