//! Geometric defects per built-in scene, resolution and threshold, with every
//! check of `validate` (issue 13): triangles, zero-area, flipped, crossing and
//! overlapping faces, the deepest crossing and the k-d build and extraction time.
//!
//! `cargo run --release -p kdcontour --example defects -- [scenes,..] [res,..]`
//! (default: every scene at 32 and 64; thresholds -1, 0.001, 0.01, 0.1, 1).

use kdcontour::{scenes, validate_with, Checks, Grid, KdTree, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let names: Vec<String> = args
        .next()
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_else(|| scenes::SCENES.iter().map(|s| s.to_string()).collect());
    let res: Vec<u32> = args
        .next()
        .map(|s| {
            s.split(',')
                .map(|r| r.parse().expect("res is a number"))
                .collect()
        })
        .unwrap_or_else(|| vec![32, 64]);
    println!("scene        res  e         tris  zero flip cross ovlp  depth  build_ms  extract_ms");
    let mut totals = [0usize; 4];
    for name in &names {
        let scene = scenes::scene(name).unwrap_or_else(|e| panic!("{e}"));
        for &r in &res {
            let grid = Grid::cube(1.0, r);
            let t0 = Instant::now();
            let tree = KdTree::build(&*scene.field, &grid, &Settings::default())
                .unwrap_or_else(|e| panic!("{e}"));
            let build_ms = t0.elapsed().as_secs_f64() * 1e3;
            for e in [-1.0f32, 0.001, 0.01, 0.1, 1.0] {
                let t1 = Instant::now();
                let mesh = tree.mesh(e);
                let extract_ms = t1.elapsed().as_secs_f64() * 1e3;
                let rep = validate_with(
                    &mesh,
                    &Checks {
                        field: Some((&*scene.field, grid.cell_size)),
                        intersections: true,
                        surface: None,
                        refine_surface: false,
                    },
                );
                let i = rep.intersections.clone().unwrap_or_default();
                let flip = rep.flipped_triangles.unwrap_or(0);
                totals[0] += rep.zero_area_triangles;
                totals[1] += flip;
                totals[2] += i.crossing_triangles;
                totals[3] += i.overlapping_triangles;
                println!(
                    "{name:<12} {r:>3}  {e:<6} {:>7} {:>5} {:>4} {:>5} {:>4} {:>6.3} {build_ms:>9.1} {extract_ms:>11.2}{}",
                    rep.triangles,
                    rep.zero_area_triangles,
                    flip,
                    i.crossing_triangles,
                    i.overlapping_triangles,
                    i.max_depth,
                    if rep.is_closed_manifold() { "" } else { "  NOT CLOSED MANIFOLD" },
                );
            }
        }
    }
    println!(
        "total: zero-area {}, flipped {}, crossing triangles {}, overlapping triangles {}",
        totals[0], totals[1], totals[2], totals[3]
    );
}
