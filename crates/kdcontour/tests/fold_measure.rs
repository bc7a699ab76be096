//! The fold measure of `validate` (issue 13, deliver 2): angles between face
//! normals and the field's gradient, and folds away from creases.

use glam::Vec3;
use kdcontour::field::FnField;
use kdcontour::validate::{Folds, FOLD_BUCKET_DEGREES};
use kdcontour::{scenes, validate, Field, Grid, IndexedMesh, KdTree, Settings};

fn folds(mesh: &IndexedMesh, field: &dyn Field, grid: &Grid) -> Folds {
    let r = validate(mesh, Some((field, grid.cell_size)));
    let f = r.folds.expect("a field was given");
    assert_eq!(
        f.histogram.iter().sum::<usize>(),
        f.measured,
        "every measured face in one bucket"
    );
    assert_eq!(
        f.measured + f.no_gradient + r.zero_area_triangles + r.degenerate_triangles,
        r.triangles
    );
    assert!(f.max_degrees.is_finite() && f.mean_degrees.is_finite());
    f
}

#[test]
fn a_smooth_surface_has_no_fold_and_a_reversed_face_is_one() {
    let field = FnField(|p: Vec3| p.length() - 0.7);
    let grid = Grid::cube(1.0, 32);
    let tree = KdTree::build(&field, &grid, &Settings::default()).unwrap();
    for e in [-1.0, 0.1] {
        let mut mesh = tree.mesh(e);
        let f = folds(&mesh, &field, &grid);
        assert_eq!((f.folded, f.near_crease, f.no_gradient), (0, 0, 0), "{f:?}");
        assert!(f.max_degrees < 30.0, "e {e}: {f:?}");
        // Reverse one face: it points 180 degrees from the gradient, on a sphere
        // with no crease.
        mesh.indices.swap(0, 1);
        let f = folds(&mesh, &field, &grid);
        assert_eq!(f.folded, 1, "{f:?}");
        assert_eq!(f.histogram[FOLD_BUCKET_DEGREES.len() - 1], 1, "{f:?}");
        assert!(f.max_degrees > 170.0 && f.folded_share > 0.0, "{f:?}");
    }
}

#[test]
fn a_face_across_a_crease_is_not_a_fold() {
    // An axis-aligned cube of half side 0.5; cells of 1/16.
    let field = FnField(|p: Vec3| {
        let q = p.abs() - Vec3::splat(0.5);
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    });
    let grid = Grid::cube(1.0, 32);
    // A small face on the +x side whose normal is +y, 90 degrees off the
    // gradient: within a cell of the edge at y = 0.5 it is near a crease, in the
    // middle of the side it is a fold.
    let face = |c: Vec3| IndexedMesh {
        positions: vec![c, c + Vec3::Z * 0.01, c + Vec3::X * 0.01],
        normals: vec![Vec3::Y; 3],
        indices: vec![0, 1, 2],
        materials: Vec::new(),
    };
    let f = folds(&face(Vec3::new(0.495, 0.47, 0.0)), &field, &grid);
    assert_eq!((f.near_crease, f.folded), (1, 0), "{f:?}");
    let f = folds(&face(Vec3::new(0.495, 0.0, 0.0)), &field, &grid);
    assert_eq!((f.near_crease, f.folded), (0, 1), "{f:?}");
    assert!((f.max_degrees - 90.0).abs() < 1.0, "{f:?}");
    // 90 degrees, on the edge between the 60-90 and 90-120 buckets.
    assert_eq!(f.histogram[5] + f.histogram[6], 1, "{f:?}");
    // Uniform meshes of scenes with sharp edges: no fold.
    for name in ["box", "csg_mix"] {
        let scene = scenes::scene(name).unwrap();
        let tree = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
        let f = folds(&tree.mesh(-1.0), &*scene.field, &grid);
        assert_eq!(f.folded, 0, "{name}: {f:?}");
    }
}

#[test]
fn a_flat_gradient_is_left_out_not_divided_by() {
    // A step: -1 below z = 0, +1 above, and its central-difference gradient is
    // exactly zero away from the step.
    let field = FnField(|p: Vec3| if p.z < 0.0 { -1.0 } else { 1.0 });
    let grid = Grid::cube(1.0, 8);
    let c = Vec3::new(0.0, 0.0, 0.5);
    let mesh = IndexedMesh {
        positions: vec![c, c + Vec3::X * 0.1, c + Vec3::Y * 0.1],
        normals: vec![Vec3::Z; 3],
        indices: vec![0, 1, 2],
        materials: Vec::new(),
    };
    let f = folds(&mesh, &field, &grid);
    assert_eq!((f.no_gradient, f.measured, f.folded), (1, 0, 0), "{f:?}");
    assert_eq!(f.folded_share, 0.0);
}
