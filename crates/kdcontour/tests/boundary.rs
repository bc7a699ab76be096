//! Surfaces that leave the grid: open meshes cover what the uniform mesh covers
//! (within 1%) at every threshold, curved ones too, and capped meshes are closed,
//! on both partitions.

use kdcontour::boundary::CappedField;
mod common;
use common::area;
use kdcontour::{
    validate_with, Boundary, Checks, CsgNode, Field, Grid, KdTree, MeshReport, Partition, Settings,
};

/// Surfaces that cross the faces of `[-1, 1]^3`: curved ones (a sphere far
/// larger than the grid, a torus larger than it, a sphere whose cap crosses
/// three faces, noise terrain running off every side) and planes, slabs,
/// cylinders and boxes, axis aligned and tilted.
const OPEN_SCENES: [(&str, &str); 12] = [
    (
        "big sphere",
        r#"{"type":"sphere","radius":3.0,"center":[0.3,-2.6,0.2]}"#,
    ),
    (
        "big torus",
        r#"{"type":"torus","major_radius":1.6,"minor_radius":0.5,"center":[0,0.1,0]}"#,
    ),
    (
        "cap",
        r#"{"type":"sphere","radius":1.3,"center":[0.9,0.2,-0.1]}"#,
    ),
    (
        "terrain",
        r#"{"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}"#,
    ),
    ("plane", r#"{"type":"plane","normal":[0,1,0],"offset":0.1}"#),
    (
        "tilted plane",
        r#"{"type":"plane","normal":[0.3,1,0.2],"offset":0.05}"#,
    ),
    (
        "slab",
        r#"{"type":"intersection","children":[
            {"type":"plane","normal":[0,1,0],"offset":0.3},
            {"type":"plane","normal":[0,-1,0],"offset":0.2}]}"#,
    ),
    (
        "tilted slab",
        r#"{"type":"transform","rotate_axis":[1,0,1],"rotate_degrees":20,"child":
            {"type":"intersection","children":[
                {"type":"plane","normal":[0,1,0],"offset":0.3},
                {"type":"plane","normal":[0,-1,0],"offset":0.2}]}}"#,
    ),
    (
        "cylinder",
        r#"{"type":"cylinder","radius":0.4,"half_height":2.0}"#,
    ),
    (
        "tilted cylinder",
        r#"{"type":"transform","rotate_axis":[1,0,0.3],"rotate_degrees":30,"child":
            {"type":"cylinder","radius":0.4,"half_height":2.0}}"#,
    ),
    (
        "box",
        r#"{"type":"box","half_extents":[1.5,0.45,0.45],"center":[0.2,0,0]}"#,
    ),
    (
        "tilted box",
        r#"{"type":"transform","rotate_axis":[0,1,1],"rotate_degrees":25,"child":
            {"type":"box","half_extents":[1.5,0.45,0.45]}}"#,
    ),
];

/// The curved scenes of [`OPEN_SCENES`].
const CURVED: [&str; 4] = ["big sphere", "big torus", "cap", "terrain"];

/// Meshes every scene at res 32 and 64 on both partitions with `boundary`, and
/// checks each mesh with `check(report, covered area / uniform's, raw area /
/// uniform's)`; prints a table.
fn each_mesh(boundary: Boundary, check: impl Fn(&str, &MeshReport, f64, f64)) {
    println!("{boundary:?}: scene, res, partition, threshold: triangles, covered and raw area / uniform's, flipped");
    for (name, json) in OPEN_SCENES {
        let field = CsgNode::from_json(json).unwrap().compile().unwrap();
        for res in [32, 64] {
            let grid = Grid::cube(1.0, res);
            let cut = CappedField::new(&field, &grid);
            let checked: &dyn Field = match boundary {
                Boundary::Open => &field,
                Boundary::Capped => &cut,
            };
            for partition in [Partition::KdTree, Partition::Octree] {
                let s = Settings {
                    partition,
                    boundary,
                    ..Default::default()
                };
                let tree = KdTree::build(&field, &grid, &s).unwrap();
                let uniform = tree.mesh(-1.0);
                let (full, _) = area(&uniform, checked);
                assert!(full > 0.5, "{name} res {res}: {full}");
                for e in [-1.0, 0.001, 0.01, 0.1, 1.0] {
                    let m = tree.mesh(e);
                    let r = validate_with(
                        &m,
                        &Checks {
                            field: Some((checked, grid.cell_size)),
                            intersections: true,
                            surface: None,
                            refine_surface: false,
                        },
                    );
                    let (covered, raw) = area(&m, checked);
                    let at = format!("{name} res {res} {partition:?} e {e}");
                    let i = r.intersections.as_ref().unwrap();
                    println!(
                        "{at}: {} {:.4} {:.4} {} {} {} {}",
                        m.triangle_count(),
                        covered / full,
                        raw / full,
                        r.flipped_triangles.unwrap(),
                        r.zero_area_triangles,
                        i.crossing_triangles,
                        i.overlapping_triangles
                    );
                    check(&at, &r, covered / full, raw / full);
                }
            }
        }
    }
}

#[test]
fn open_meshes_cover_what_the_uniform_mesh_covers() {
    each_mesh(Boundary::Open, |at, r, covered, _| {
        assert!((covered - 1.0).abs() < 0.01, "{at}: {covered}");
        assert!(r.triangles > 0 && !r.watertight, "{at}: {r:?}");
        assert!(r.manifold && r.oriented, "{at}: {r:?}");
    });
}

#[test]
fn capped_meshes_are_closed() {
    each_mesh(Boundary::Capped, |at, r, covered, _| {
        assert!(r.is_closed_manifold(), "{at}: {r:?}");
        // Caps meet a curved surface at creases, which the coarsest threshold
        // cuts by up to 1.3% of the area (the torus at res 32, threshold 1);
        // every other mesh keeps it within 1%.
        let curved_at_1 = CURVED.iter().any(|c| at.starts_with(c)) && at.ends_with("e 1");
        let tolerance = if curved_at_1 { 0.02 } else { 0.01 };
        assert!((covered - 1.0).abs() < tolerance, "{at}: {covered}");
        // Caps lie in the grid's faces, so the error is measured against the
        // field cut by the grid's box.
        assert!(r.max_vertex_error < 1.0, "{at}: {r:?}");
    });
}

#[test]
fn a_surface_inside_the_grid_meshes_the_same_either_way() {
    let field = kdcontour::scenes::scene("torus").unwrap().field;
    let grid = Grid::cube(1.0, 32);
    for partition in [Partition::KdTree, Partition::Octree] {
        let s = |boundary| Settings {
            partition,
            boundary,
            ..Default::default()
        };
        let open = KdTree::build(&*field, &grid, &s(Boundary::Open)).unwrap();
        let capped = KdTree::build(&*field, &grid, &s(Boundary::Capped)).unwrap();
        assert_eq!(*capped.grid(), grid);
        for e in [-1.0, 0.01, 0.1] {
            assert_eq!(open.mesh(e), capped.mesh(e));
        }
    }
}
