//! The mesher's invariants on every built-in scene: watertight, 2-manifold,
//! consistently oriented, Euler characteristic kept across thresholds, triangle
//! count never growing with the threshold, re-extraction equal to a fresh build,
//! threshold < 0 equal to uniform DMC, one thread equal to many.

use kdcontour::{dmc, hermite, pipeline, scenes, validate, Grid, IndexedMesh, KdTree, Settings};

const THRESHOLDS: [f32; 5] = [-1.0, 0.001, 0.01, 0.1, 1.0];

/// Triangles as sorted tuples of vertex positions (bit patterns), rotation-invariant.
fn canonical(m: &IndexedMesh) -> Vec<[[u32; 3]; 3]> {
    let key = |i: u32| m.positions[i as usize].to_array().map(f32::to_bits);
    let mut tris: Vec<[[u32; 3]; 3]> = m
        .indices
        .chunks_exact(3)
        .map(|t| {
            let k = [key(t[0]), key(t[1]), key(t[2])];
            let r = (0..3).min_by_key(|&i| k[i]).unwrap();
            [k[r], k[(r + 1) % 3], k[(r + 2) % 3]]
        })
        .collect();
    tris.sort();
    tris
}

fn check_scene(name: &str, res: u32) {
    let scene = scenes::scene(name).unwrap();
    let grid = Grid::cube(1.0, res);
    let tree = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
    let mut prev_tris = usize::MAX;
    let mut euler = None;
    let mut mesh = IndexedMesh::default();
    for &e in &THRESHOLDS {
        tree.extract(e, &mut mesh);
        let r = validate(&mesh, None);
        assert!(r.triangles > 0, "{name} res {res} e {e}: empty mesh");
        assert!(
            r.is_closed_manifold(),
            "{name} res {res} threshold {e}: {r:?}"
        );
        let eu = *euler.get_or_insert(r.euler);
        assert_eq!(r.euler, eu, "{name} res {res} threshold {e}: Euler changed");
        assert!(
            r.triangles <= prev_tris,
            "{name} res {res} threshold {e}: more triangles"
        );
        prev_tris = r.triangles;
    }
}

macro_rules! scene_tests {
    ($($test:ident => $name:literal),*) => { $(
        #[test]
        fn $test() {
            check_scene($name, 32);
            check_scene($name, 64);
        }
    )* };
}

scene_tests!(
    sphere => "sphere", box_ => "box", torus => "torus", disk_pole => "disk_pole",
    thin_plates => "thin_plates", anisotropic => "anisotropic", gyroid => "gyroid",
    terrain => "terrain", caves => "caves", csg_mix => "csg_mix"
);

#[test]
fn every_builtin_scene_is_covered() {
    assert_eq!(scenes::SCENES.len(), 10);
}

#[test]
fn negative_threshold_is_uniform_dmc() {
    for name in ["torus", "csg_mix", "gyroid", "caves"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 40);
        let s = Settings::default();
        let h = hermite::Hermite::from_field(&*scene.field, &grid, &s).unwrap();
        let oracle = dmc::uniform_dmc(&h);
        let tree = KdTree::build(&*scene.field, &grid, &s).unwrap();
        let m = tree.mesh(-1.0);
        assert_eq!(m.triangle_count(), oracle.triangle_count(), "{name}");
        assert!(canonical(&m) == canonical(&oracle), "{name}: meshes differ");
    }
}

/// Every used vertex's position, normal and material (bits), sorted (two
/// patches may share a position).
fn vertex_table(m: &IndexedMesh) -> Vec<([u32; 3], Vec<u32>, Vec<u32>)> {
    let mut used = vec![false; m.positions.len()];
    for &i in &m.indices {
        used[i as usize] = true;
    }
    let mut table: Vec<_> = (0..m.positions.len())
        .filter(|&i| used[i])
        .map(|i| {
            let n = m.normals[i].to_array().map(f32::to_bits).to_vec();
            let mat = m.materials.get(i).map_or(Vec::new(), |b| {
                b.ids
                    .iter()
                    .map(|&x| x as u32)
                    .chain(b.weights.iter().map(|w| w.to_bits()))
                    .collect()
            });
            (m.positions[i].to_array().map(f32::to_bits), n, mat)
        })
        .collect();
    table.sort();
    table
}

#[test]
fn full_resolution_is_the_trees_mesh_below_zero_without_a_tree() {
    // Materials (terrain, caves, csg_mix's parts), a capped grid's padded one
    // (the terrain reaches the grid's faces), and a grid large enough for
    // parallel work; one thread and four give the same mesh index for index.
    for (name, res) in [
        ("terrain", 40),
        ("caves", 48),
        ("csg_mix", 40),
        ("sphere", 72),
    ] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, res);
        for boundary in [kdcontour::Boundary::Open, kdcontour::Boundary::Capped] {
            let one = Settings {
                threads: 1,
                boundary,
                ..Default::default()
            };
            let many = Settings {
                threads: 4,
                ..one.clone()
            };
            let full = pipeline::full(&*scene.field, &grid, &one).unwrap();
            let tree = KdTree::build(&*scene.field, &grid, &one)
                .unwrap()
                .mesh(-1.0);
            let what = format!("{name} res {res} {boundary:?}");
            assert_eq!(full.triangle_count(), tree.triangle_count(), "{what}");
            assert!(
                canonical(&full) == canonical(&tree),
                "{what}: triangles differ"
            );
            assert!(
                vertex_table(&full) == vertex_table(&tree),
                "{what}: normals or materials differ"
            );
            assert_eq!(
                full.materials.is_empty(),
                !scene.field.has_materials(),
                "{what}"
            );
            let r = validate(&full, Some((&*scene.field, grid.cell_size)));
            assert!(
                r.is_closed_manifold() || boundary == kdcontour::Boundary::Open,
                "{what}: {r:?}"
            );
            let again = pipeline::full(&*scene.field, &grid, &many).unwrap();
            assert_eq!(full.positions, again.positions, "{what}: threads differ");
            assert_eq!(full.indices, again.indices, "{what}: threads differ");
        }
    }
}

#[test]
fn reextraction_equals_fresh_build_and_threads_agree() {
    // Large enough (res 72) that the build splits into parallel subtrees.
    let mut parallel_walks = 0;
    for name in ["thin_plates", "gyroid", "caves", "csg_mix"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 72);
        let one = Settings {
            threads: 1,
            ..Default::default()
        };
        let many = Settings {
            threads: 4,
            ..Default::default()
        };
        let tree = KdTree::build(&*scene.field, &grid, &one).unwrap();
        let tree_many = KdTree::build(&*scene.field, &grid, &many).unwrap();
        assert!(
            tree == tree_many,
            "{name}: trees differ across thread counts"
        );
        let mut reused = IndexedMesh::default();
        for &e in THRESHOLDS.iter().rev() {
            tree.extract(e, &mut reused);
            let fresh = kdcontour::mesh(&*scene.field, &grid, e, &one).unwrap();
            assert_eq!(
                reused, fresh,
                "{name} threshold {e}: re-extraction differs from a fresh build"
            );
            // Extraction itself on 4 threads: trees of 16,384 components or more
            // are walked in parallel pieces and merged.
            assert_eq!(
                many.run(|| tree_many.mesh(e)).unwrap(),
                fresh,
                "{name} threshold {e}: 4 threads differ from 1"
            );
        }
        parallel_walks += (tree.component_count() >= 16_384) as usize;
    }
    assert!(
        parallel_walks >= 2,
        "the parallel extraction was not exercised"
    );
}
