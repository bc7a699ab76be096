//! What crisp material borders cost (issue 16): triangles and time per mesh with
//! and without material-aware clustering ([`Settings::material_borders`]) on a
//! plane split into two materials, `csg_mix` (each part its own material) and a
//! chunk of the demo terrain ([`DensityParams::demo`], 32³ cells of 1, grass,
//! rock, dirt and snow), each at threshold 1 and 0.01. Also the time one mesh
//! takes with and without materials at all (the terrain's material evaluated at
//! every crossing and component).
//!
//! Then what drawing borders along their creases does
//! ([`kdcontour::material::split_borders`], issue 13's teeth): on the
//! csg_editor's opening scene at its resolution, `csg_mix`, `caves` and the
//! demo terrain chunk, the faces of one pure material with a corner of another (drawn as a
//! sawtooth) before and after, the vertices added, and the split's time against
//! the extraction's (`KdTree::mesh`).
//!
//! Run with `cargo run --release -p kdcontour --example material_borders`.
//! Times are the best of five runs on one thread.

use glam::Vec3;
use kdcontour::field::layers;
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::material::{split_borders, MaterialBlend};
use kdcontour::{scenes, validate, Field, Grid, IndexedMesh, KdTree, Settings};
use std::time::Instant;

/// A plane split at x = 0.113 into materials 1 and 0.
struct TwoMaterials;

impl Field for TwoMaterials {
    fn value(&self, p: Vec3) -> f32 {
        p.y - 0.37 / 32.0
    }
    fn material(&self, p: Vec3) -> MaterialBlend {
        MaterialBlend::single(if p.x < 0.113 { 1 } else { 0 })
    }
    fn has_materials(&self) -> bool {
        true
    }
}

/// Triangles at `threshold` and the best build + contour time of five (ms),
/// with crisp `borders` or not (`None`: no materials at all).
fn measure(field: &dyn Field, grid: &Grid, threshold: f32, borders: Option<bool>) -> (usize, f64) {
    let settings = Settings {
        threads: 1,
        materials: borders.is_some(),
        material_borders: borders.unwrap_or(false),
        ..Default::default()
    };
    let mut best = f64::INFINITY;
    let mut tris = 0;
    for _ in 0..5 {
        let t = Instant::now();
        let tree = KdTree::build(field, grid, &settings).expect("builds");
        let mesh = tree.mesh(threshold);
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
        tris = mesh.triangle_count();
    }
    (tris, best)
}

/// Faces drawn with a tooth ([`kdcontour::validate::Materials::toothed_triangles`]).
fn teeth(mesh: &IndexedMesh, field: &dyn Field, cell: f32) -> usize {
    validate(mesh, Some((field, cell)))
        .materials
        .and_then(|m| m.toothed_triangles)
        .expect("a field with materials")
}

/// One row of the split table: `field` on `grid` at `threshold`.
fn split_row(name: &str, field: &dyn Field, grid: &Grid, threshold: f32, borders: bool) {
    let settings = Settings {
        threads: 1,
        material_borders: borders,
        ..Default::default()
    };
    let tree = KdTree::build(field, grid, &settings).expect("builds");
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool");
    let (mut extract_ms, mut split_ms) = (f64::INFINITY, f64::INFINITY);
    let (mut before, mut split, mut report) = (IndexedMesh::default(), None, None);
    for _ in 0..5 {
        one.install(|| {
            let t = Instant::now();
            let mesh = tree.mesh(threshold);
            extract_ms = extract_ms.min(t.elapsed().as_secs_f64() * 1e3);
            let mut drawn = mesh.clone();
            let t = Instant::now();
            let r = split_borders(&mut drawn, field, grid.cell_size);
            split_ms = split_ms.min(t.elapsed().as_secs_f64() * 1e3);
            (before, split, report) = (mesh, Some(drawn), Some(r));
        });
    }
    let (split, report) = (split.expect("ran"), report.expect("ran"));
    println!(
        "| {name} | {threshold} | {} | {} | {} | {} | {split_ms:.2} | {extract_ms:.2} |",
        before.triangle_count(),
        teeth(&before, field, grid.cell_size),
        teeth(&split, field, grid.cell_size),
        report.vertices_added,
    );
}

fn main() {
    let csg = scenes::scene("csg_mix").expect("built in");
    let terrain = Density::new(DensityParams::demo(7));
    let chunk = Grid {
        origin: Vec3::new(0.0, -16.0, 0.0),
        cell_size: 1.0,
        cells: glam::UVec3::splat(32),
        offset: glam::IVec3::ZERO,
    };
    let cases: [(&str, &dyn Field, Grid); 3] = [
        (
            "two-material plane, 64³",
            &TwoMaterials,
            Grid::cube(1.0, 64),
        ),
        ("csg_mix, 64³", &*csg.field, Grid::cube(1.0, 64)),
        ("demo terrain chunk, 32³", &terrain, chunk),
    ];
    println!(
        "| field | threshold | triangles crisp | triangles merged | cost | ms crisp | ms merged |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (name, field, grid) in cases {
        for threshold in [1.0, 0.01] {
            let (on, t_on) = measure(field, &grid, threshold, Some(true));
            let (off, t_off) = measure(field, &grid, threshold, Some(false));
            println!(
                "| {name} | {threshold} | {on} | {off} | {:+.1}% | {t_on:.2} | {t_off:.2} |",
                (on as f64 / off.max(1) as f64 - 1.0) * 1e2
            );
        }
    }
    let (_, with) = measure(&terrain, &chunk, 1.0, Some(false));
    let (_, without) = measure(&terrain, &chunk, 1.0, None);
    println!(
        "demo terrain chunk: {with:.2} ms with materials (merged), {without:.2} ms without materials"
    );

    println!();
    println!("| field | threshold | triangles | teeth before | teeth after | vertices added | split ms | extraction ms |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    let starter = layers::scene_node(&layers::starter())
        .compile()
        .expect("the editor's scene compiles");
    let editor = Grid::cube(1.5, 96);
    split_row(
        "csg_editor's opening scene, 96³",
        &starter,
        &editor,
        0.005,
        true,
    );
    for res in [64, 128] {
        for threshold in [-1.0, 0.01, 1.0] {
            let name = format!("csg_mix, {res}³");
            split_row(&name, &*csg.field, &Grid::cube(1.0, res), threshold, true);
        }
    }
    let caves = scenes::scene("caves").expect("built in");
    for threshold in [0.01, 1.0] {
        split_row(
            "caves, 64³",
            &*caves.field,
            &Grid::cube(1.0, 64),
            threshold,
            true,
        );
    }
    for threshold in [0.01, 1.0] {
        // As the terrain demo builds it: borders merged, weights blend.
        split_row(
            "demo terrain chunk, 32³",
            &terrain,
            &chunk,
            threshold,
            false,
        );
    }
}
