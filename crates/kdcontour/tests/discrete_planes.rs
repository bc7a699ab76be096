//! Boada and Navazo's discrete-planes octree: on every built-in scene a closed
//! 2-manifold with Marching Cubes' topology, fewer polygons than Marching Cubes,
//! vertices within half a cell of the surface, the same mesh on one thread and
//! many, and the other meshers' behaviour on bad input.

use glam::Vec3;
use kdcontour::discrete_planes::{self, Class};
use kdcontour::field::FnField;
use kdcontour::meshers::{self, Mesher};
use kdcontour::{scenes, validate, Error, Grid, Settings};

#[test]
fn every_scene_is_closed_with_the_topology_of_marching_cubes() {
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        for res in [32, 48] {
            let grid = Grid::cube(1.0, res);
            let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
            let (mc, _) =
                meshers::run(Mesher::MarchingCubes, &s, -1.0, &Settings::default()).unwrap();
            let (dp, _) =
                meshers::run(Mesher::DiscretePlanes, &s, -1.0, &Settings::default()).unwrap();
            let (rm, rd) = (validate(&mc, None), validate(&dp, None));
            assert!(rd.triangles > 0, "{name} res {res}: empty");
            assert!(rd.is_closed_manifold(), "{name} res {res}: {rd:?}");
            assert_eq!(rd.euler, rm.euler, "{name} res {res}: Euler characteristic");
            assert_eq!(rd.components, rm.components, "{name} res {res}");
            // Midpoint vertices are never coincident and no triangle is flat.
            assert_eq!(rd.coincident_vertices, 0, "{name} res {res}");
            assert_eq!(rd.zero_area_triangles, 0, "{name} res {res}");
        }
    }
}

#[test]
fn merging_coplanar_cells_leaves_fewer_polygons_than_the_cells_had() {
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 64);
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        let dp = discrete_planes::extract(&s.hermite);
        let st = &dp.stats;
        assert!(
            st.polygons < st.cell_polygons,
            "{name}: {} polygons after merging, {} before",
            st.polygons,
            st.cell_polygons
        );
        // Every terminal node is counted once, at one level.
        let terminals: usize = st.terminals.iter().sum();
        assert_eq!(terminals, st.per_level.iter().sum::<usize>(), "{name}");
        // Nodes above the cells exist: something merged.
        assert!(
            st.per_level[1..].iter().sum::<usize>() > 0,
            "{name}: {st:?}"
        );
    }
}

#[test]
fn a_plane_merges_to_the_top_of_the_octree() {
    // z = 0.3: one Face per node, and the whole grid is one node.
    let field = FnField(|p: Vec3| p.z - 0.3);
    let grid = Grid::cube(1.0, 16);
    let s = meshers::sample(&field, &grid, &Settings::default()).unwrap();
    let dp = discrete_planes::extract(&s.hermite);
    assert_eq!(dp.stats.polygons, 1, "{:?}", dp.stats);
    assert_eq!(dp.stats.terminals[Class::Face.slot()], 1);
    assert_eq!(dp.stats.per_level.last(), Some(&1));
    // The open square spans the grid's crossings: 2 triangles, 4 corners.
    let r = validate(&dp.mesh, None);
    assert_eq!((r.triangles, r.vertices), (2, 4));
    assert_eq!(r.euler, 1);
}

#[test]
fn vertices_stay_within_half_a_cell_of_the_surface() {
    // The paper's error: Discretized Marching Cubes moves a vertex at most half
    // an edge, and merging adds nothing. Exact distance fields only.
    for name in ["sphere", "box", "torus"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 48);
        let s = meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        let (dp, _) = meshers::run(Mesher::DiscretePlanes, &s, -1.0, &Settings::default()).unwrap();
        let r = validate(&dp, Some((&*scene.field, grid.cell_size)));
        assert!(
            r.max_vertex_error <= 0.5 + 1e-3,
            "{name}: vertex error {} cells",
            r.max_vertex_error
        );
    }
}

#[test]
fn one_thread_and_many_give_the_same_mesh() {
    for name in ["gyroid", "csg_mix", "caves"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 40);
        let mut meshes = Vec::new();
        for threads in [1, 4] {
            let settings = Settings {
                threads,
                ..Default::default()
            };
            let s = meshers::sample(&*scene.field, &grid, &settings).unwrap();
            let (m, _) = meshers::run(Mesher::DiscretePlanes, &s, -1.0, &settings).unwrap();
            meshes.push(m);
        }
        assert!(!meshes[0].is_empty(), "{name}");
        assert_eq!(meshes[0].indices, meshes[1].indices, "{name}");
        assert_eq!(meshes[0].positions, meshes[1].positions, "{name}");
        assert_eq!(meshes[0].normals, meshes[1].normals, "{name}");
    }
}

#[test]
fn bad_input_is_refused_and_empty_fields_mesh_to_nothing() {
    let nan = FnField(|p: Vec3| {
        if p.x > 0.2 {
            f32::NAN
        } else {
            p.length() - 0.5
        }
    });
    let err = meshers::sample(&nan, &Grid::cube(1.0, 16), &Settings::default());
    assert!(matches!(err, Err(Error::NonFiniteSample { .. })));
    for f in [
        (|_p: Vec3| 1.0) as fn(Vec3) -> f32,
        |_p| -1.0,
        |p| (p - Vec3::splat(3.0)).length() - 0.5,
    ] {
        let field = FnField(f);
        let s = meshers::sample(&field, &Grid::cube(1.0, 16), &Settings::default()).unwrap();
        let (m, _) = meshers::run(Mesher::DiscretePlanes, &s, -1.0, &Settings::default()).unwrap();
        assert!(m.is_empty() && m.positions.is_empty());
    }
    let bad = Settings {
        threads: 5000,
        ..Default::default()
    };
    let s = meshers::sample(
        &FnField(|p: Vec3| p.length() - 0.5),
        &Grid::cube(1.0, 8),
        &Settings::default(),
    )
    .unwrap();
    assert!(meshers::run(Mesher::DiscretePlanes, &s, -1.0, &bad).is_err());
}
