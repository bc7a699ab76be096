//! What keeps geometry when nodes cluster (issue 13): no adaptive polygon folds
//! back over its neighbours. On the analytic and CSG scenes whose uniform mesh is
//! clean, every threshold gives no flipped, zero-area, crossing or overlapping
//! face, on one grid and inside every chunk of a chunk or level world; elsewhere
//! clustering leaves no face overlapping another in its plane. Chunk seams are
//! checked against the neighbours' finest cells only: their defects are printed.

use glam::Vec3;
use kdcontour::world::{Layout, LevelWorld};
use kdcontour::{
    scenes, validate_with, Checks, Field, Grid, IndexedMesh, KdTree, MeshReport, Settings,
};

mod common;
use common::{chunk_world, Lcg};

const THRESHOLDS: [f32; 5] = [-1.0, 0.001, 0.01, 0.1, 1.0];

/// The scenes and resolutions whose uniform (threshold -1) mesh has no geometric
/// defect. The rest of the analytic and CSG scenes have some already there, which
/// no clustering can remove (see `clustering_overlaps_no_face_in_its_plane`).
/// csg_mix at 64 joined when cells whose QEF vertices folded a quad moved toward
/// their mass points (`hermite::vertex`).
const CLEAN: [(&str, u32); 9] = [
    ("sphere", 32),
    ("sphere", 64),
    ("box", 32),
    ("box", 64),
    ("torus", 32),
    ("torus", 64),
    ("disk_pole", 32),
    ("disk_pole", 64),
    ("csg_mix", 64),
];

/// Topology, per-face geometry against `field` (cell size `cell`) and crossing
/// and overlapping pairs.
fn report(mesh: &IndexedMesh, field: &dyn Field, cell: f32) -> MeshReport {
    validate_with(
        mesh,
        &Checks {
            field: Some((field, cell)),
            intersections: true,
            surface: None,
        },
    )
}

/// Closed, manifold, and no flipped, zero-area, crossing or overlapping face.
fn assert_clean(r: &MeshReport, what: &str) {
    let i = r.intersections.as_ref().expect("requested");
    assert!(r.is_closed_manifold(), "{what}: {r:?}");
    assert_eq!(r.flipped_triangles, Some(0), "{what}: {r:?}");
    assert_eq!(r.zero_area_triangles, 0, "{what}: {r:?}");
    assert_eq!(
        (i.crossing_pairs, i.overlapping_pairs),
        (0, 0),
        "{what}: {i:?}"
    );
}

#[test]
fn clean_scenes_stay_clean_at_every_threshold() {
    for (name, res) in CLEAN {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, res);
        let tree = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
        for e in THRESHOLDS {
            let r = report(&tree.mesh(e), &*scene.field, grid.cell_size);
            assert_clean(&r, &format!("{name} res {res} e {e}"));
        }
    }
}

#[test]
fn clustering_overlaps_no_face_in_its_plane() {
    // The rest of the analytic and CSG scenes: their uniform meshes have flipped
    // faces of their own (the gyroid shell's two-cell-wide cut by its sphere, the
    // comb's fins thinner than a cell standing on its base with touching faces, so
    // the field is zero inside the solid where they meet, three csg_mix surfaces
    // within a third of a cell), but no adaptive fan folds over another. Material
    // borders off: see the ignored test below.
    overlaps_no_face(Settings {
        material_borders: false,
        ..Settings::default()
    });
}

#[test]
#[ignore = "known defect (issue 16): with material borders on, csg_mix (parts of five \
            materials, borders along the cut's crease) at res 32 and threshold 0.001 has \
            one overlapping pair, where bordered cells meet merged nodes"]
fn clustering_with_material_borders_overlaps_no_face_in_its_plane() {
    overlaps_no_face(Settings::default());
}

/// No overlapping fan and no zero-area face on the adaptive meshes of the
/// analytic and CSG scenes built with `settings`, at every threshold.
fn overlaps_no_face(settings: Settings) {
    for (name, res) in [
        ("csg_mix", 32),
        ("thin_plates", 32),
        ("thin_plates", 64),
        ("anisotropic", 32),
        ("anisotropic", 64),
        ("gyroid", 32),
        ("gyroid", 64),
        ("csg_mix", 64),
    ] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, res);
        let tree = KdTree::build(&*scene.field, &grid, &settings).unwrap();
        for e in THRESHOLDS {
            let r = report(&tree.mesh(e), &*scene.field, grid.cell_size);
            let i = r.intersections.as_ref().unwrap();
            assert!(r.is_closed_manifold(), "{name} {res} e {e}: {r:?}");
            assert_eq!(i.overlapping_pairs, 0, "{name} {res} e {e}: {i:?}");
            assert_eq!(r.zero_area_triangles, 0, "{name} {res} e {e}: {r:?}");
        }
    }
}

/// No flipped, crossing or overlapping face within one chunk's interior mesh;
/// returns its zero-area faces (a chunk's cells can give one where the single
/// grid's do not: it has other cells).
fn assert_interior_clean(mesh: &IndexedMesh, field: &dyn Field, cell: f32, what: &str) -> usize {
    let r = report(mesh, field, cell);
    let i = r.intersections.as_ref().expect("requested");
    assert_eq!(r.flipped_triangles, Some(0), "{what}: {r:?}");
    assert_eq!(
        (i.crossing_pairs, i.overlapping_pairs),
        (0, 0),
        "{what}: {i:?}"
    );
    r.zero_area_triangles
}

/// Prints the welded world's defects (at its seams, which the build checks only
/// against the neighbours' finest cells) and asserts it closed and manifold.
fn print_world(mesh: &IndexedMesh, field: &dyn Field, cell: f32, what: &str) {
    let r = report(mesh, field, cell);
    let i = r.intersections.as_ref().expect("requested");
    println!(
        "{what}: {} triangles, flipped {:?}, zero-area {}, crossing {}, overlapping {}",
        r.triangles,
        r.flipped_triangles,
        r.zero_area_triangles,
        i.crossing_triangles,
        i.overlapping_triangles
    );
    assert!(r.is_closed_manifold(), "{what}: {r:?}");
}

#[test]
fn chunk_interiors_at_random_thresholds_do_not_fold() {
    let mut rng = Lcg(13);
    let mut one = IndexedMesh::default();
    // The scenes clean at both resolutions.
    for name in ["sphere", "box", "torus", "disk_pole"] {
        let scene = scenes::scene(name).unwrap();
        let (chunks, res) = (3u32, 16u32);
        let cell = 2.0 / (chunks * res) as f32;
        let mut w = chunk_world(&*scene.field, chunks, res);
        for round in 0..3 {
            for c in w.coords() {
                w.set_threshold(c, THRESHOLDS[rng.next() % THRESHOLDS.len()]);
            }
            let mut zero_area = 0;
            for c in w.coords() {
                w.extract_interior(c, &mut one);
                zero_area +=
                    assert_interior_clean(&one, &*scene.field, cell, &format!("{name} {c}"));
            }
            println!("{name} round {round}: zero-area faces inside chunks: {zero_area}");
            print_world(
                &w.extract_all(),
                &*scene.field,
                cell,
                &format!("{name} round {round}"),
            );
        }
    }
}

#[test]
fn level_chunk_interiors_at_random_thresholds_do_not_fold() {
    let mut rng = Lcg(29);
    let mut one = IndexedMesh::default();
    let (region, res) = (8, 8u32);
    let cell = 2.0 / (region as u32 * res) as f32;
    for (name, seed) in [("sphere", 3), ("torus", 5), ("disk_pole", 7)] {
        let scene = scenes::scene(name).unwrap();
        let layout =
            Layout::random(glam::IVec3::ZERO, glam::IVec3::splat(region), 2, 0.3, seed).unwrap();
        let mut w = LevelWorld::new(
            Vec3::splat(-1.0),
            cell,
            res,
            layout,
            0.01,
            Settings::default(),
        )
        .unwrap();
        w.build_all(&*scene.field).unwrap();
        for round in 0..2 {
            for k in w.chunks() {
                w.set_threshold(&k, THRESHOLDS[rng.next() % THRESHOLDS.len()]);
            }
            let mut zero_area = 0;
            for k in w.chunks() {
                w.extract_interior(&k, &mut one);
                zero_area +=
                    assert_interior_clean(&one, &*scene.field, cell, &format!("{name} {k:?}"));
            }
            println!(
                "{name} seed {seed} round {round}: zero-area faces inside chunks: {zero_area}"
            );
            print_world(
                &w.extract_all(),
                &*scene.field,
                cell,
                &format!("{name} seed {seed} round {round}"),
            );
        }
    }
}

#[test]
fn a_scan_has_no_zero_area_or_overlapping_face() {
    // The Shepp-Logan phantom at 64 voxels and its skull's iso value: thin shells
    // whose cells' QEF vertices used to fold their quads (at threshold 0.01, 40
    // zero-area, 7 overlapping and 254 crossing faces before the cells stepped
    // toward their mass points, `hermite::vertex`; 0, 0 and 69 after). Its
    // flipped count (about 1,500) stays: Marching Cubes has as many, from the
    // volume's gradient across shells thinner than a voxel.
    let vol = kdcontour::io::volume::phantom(64);
    let (lo, hi) = vol.bounds();
    let grid = Grid::fit(lo, hi, 64);
    let tree = KdTree::build(&vol, &grid, &Settings::default()).unwrap();
    for e in [-1.0, 0.01, 0.1] {
        let r = report(&tree.mesh(e), &vol, grid.cell_size);
        let i = r.intersections.as_ref().unwrap();
        println!("phantom e {e}: {r:?}");
        assert!(r.is_closed_manifold(), "e {e}: {r:?}");
        assert_eq!(r.zero_area_triangles, 0, "e {e}: {r:?}");
        assert_eq!(i.overlapping_pairs, 0, "e {e}: {i:?}");
        assert!(i.crossing_triangles < 100, "e {e}: {i:?}");
    }
}
