//! Geometric defects per built-in scene, resolution and threshold, with every
//! check of `validate` (issue 13): triangles, zero-area, flipped, crossing and
//! overlapping faces, the deepest crossing and the k-d build and extraction time.
//! Then the same for level worlds: 8 x 8 x 8 level-0 chunks of 16 cells over
//! `[-1, 1]^3` (128 cells at level 0, 32 at level 2), laid out at levels 0 to 2
//! at random (two seeds) and in rings around a camera in a corner, every chunk
//! at each threshold in turn and then at random ones. Their flipped faces are
//! split into those of the seams ([`World::extract_seam`]; by kind, per row
//! faces between levels and faces within one level, in the totals chunk edges
//! too) and those inside the chunks.
//!
//! `cargo run --release -p kdcontour --example defects -- [scenes,..] [res,..]`
//! (default: every scene at 32 and 64; thresholds -1, 0.001, 0.01, 0.1, 1).

use glam::{IVec3, Vec3};
use kdcontour::world::{Layout, Seam, World};
use kdcontour::{scenes, validate_with, Checks, Field, Grid, IndexedMesh, KdTree, Settings};
use std::time::Instant;

/// The thresholds every mesh is cut at.
const THRESHOLDS: [f32; 5] = [-1.0, 0.001, 0.01, 0.1, 1.0];

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
            for e in THRESHOLDS {
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
    level_worlds(&names);
}

/// Flipped and zero-area faces of `mesh` against `field` (cells of `cell`).
fn faces(mesh: &IndexedMesh, field: &dyn Field, cell: f32) -> (usize, usize) {
    let r = validate_with(
        mesh,
        &Checks {
            field: Some((field, cell)),
            intersections: false,
            surface: None,
            refine_surface: false,
        },
    );
    (r.flipped_triangles.unwrap_or(0), r.zero_area_triangles)
}

/// The level worlds' table (see the module docs).
fn level_worlds(names: &[String]) {
    const REGION: i32 = 8;
    const RES: u32 = 16;
    let cell = 2.0 / (REGION as u32 * RES) as f32;
    let (lo, hi) = (IVec3::ZERO, IVec3::splat(REGION));
    println!("\nlevel worlds: {REGION}^3 level-0 chunks of {RES} cells, levels 0 to 2");
    println!(
        "scene        layout   e       tris  zero flip (seams inside) [between-levels same-level] cross ovlp"
    );
    let mut totals = [0usize; 6];
    // Seam flips by kind: faces between levels, faces within one, chunk edges.
    let mut by_kind = [0usize; 3];
    let kind = |s: &Seam| match *s {
        Seam::Face { low, high, .. } if low.level != high.level => 0,
        Seam::Face { .. } => 1,
        Seam::Edge { .. } => 2,
    };
    for name in names {
        let scene = scenes::scene(name).unwrap_or_else(|e| panic!("{e}"));
        let layouts = [
            ("random:3", Layout::random(lo, hi, 2, 0.3, 3)),
            ("random:7", Layout::random(lo, hi, 2, 0.5, 7)),
            ("camera", Layout::around(lo, hi, 2, Vec3::splat(7.6), 0.9)),
        ];
        for (layout_name, layout) in layouts {
            let layout = layout.expect("a valid layout");
            let mut w = World::new(
                Vec3::splat(-1.0),
                cell,
                RES,
                layout,
                0.01,
                Settings::default(),
            )
            .expect("a valid world");
            w.build_all(&*scene.field).unwrap_or_else(|e| panic!("{e}"));
            // Each threshold everywhere, then a random one per chunk.
            let mut rng = 0x9e37_79b9_7f4a_7c15u64;
            for round in 0..=THRESHOLDS.len() {
                for k in w.chunks() {
                    rng = rng
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let e = THRESHOLDS
                        .get(round)
                        .copied()
                        .unwrap_or(THRESHOLDS[(rng >> 33) as usize % THRESHOLDS.len()]);
                    w.set_threshold(&k, e);
                }
                let mesh = w.extract_all();
                let r = validate_with(
                    &mesh,
                    &Checks {
                        field: Some((&*scene.field, cell)),
                        intersections: true,
                        surface: None,
                        refine_surface: false,
                    },
                );
                let i = r.intersections.clone().unwrap_or_default();
                let (mut seams, mut inside) = (0, 0);
                // This row's seam flips by kind.
                let mut row_kind = [0usize; 3];
                let mut one = IndexedMesh::default();
                for k in w.chunks() {
                    for s in w.owned_seams(&k) {
                        w.extract_seam(&s, &mut one);
                        let flipped = faces(&one, &*scene.field, cell).0;
                        seams += flipped;
                        by_kind[kind(&s)] += flipped;
                        row_kind[kind(&s)] += flipped;
                    }
                    w.extract_interior(&k, &mut one);
                    inside += faces(&one, &*scene.field, cell).0;
                }
                let flip = r.flipped_triangles.unwrap_or(0);
                for (t, n) in totals.iter_mut().zip([
                    r.zero_area_triangles,
                    flip,
                    seams,
                    inside,
                    i.crossing_triangles,
                    i.overlapping_triangles,
                ]) {
                    *t += n;
                }
                let e = THRESHOLDS
                    .get(round)
                    .map_or("random".to_string(), |e| e.to_string());
                println!(
                    "{name:<12} {layout_name:<8} {e:<6} {:>6} {:>5} {:>4} ({seams:>5} {inside:>6}) [{:>4} {:>4}] {:>5} {:>4}{}",
                    r.triangles,
                    r.zero_area_triangles,
                    flip,
                    row_kind[0],
                    row_kind[1],
                    i.crossing_triangles,
                    i.overlapping_triangles,
                    if r.is_closed_manifold() { "" } else { "  NOT CLOSED MANIFOLD" },
                );
            }
        }
    }
    println!(
        "level worlds total: zero-area {}, flipped {} ({} in seams, {} inside chunks), \
         crossing triangles {}, overlapping triangles {}",
        totals[0], totals[1], totals[2], totals[3], totals[4], totals[5]
    );
    println!(
        "seams' flipped faces: {} on faces between levels, {} on faces within one, {} on chunk edges",
        by_kind[0], by_kind[1], by_kind[2]
    );
}
