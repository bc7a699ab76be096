//! Boada and Navazo's claim checked: polygons of the discrete-planes octree
//! against Marching Cubes on the same samples, with time, error and whether each
//! mesh is closed and manifold. One row per input: the CT phantom at its native
//! resolution, the public brain MRI of `scripts/fetch-scan.sh` at its native
//! resolution (iso 100, when it has been fetched) and every built-in scene.
//!
//! `cargo run --release -p kdcontour --example discrete_planes -- [res] [phantom voxels] [reps]`
//! (defaults 64, 128, 3; one thread; times are the best of `reps`).
//!
//! Columns: Marching Cubes triangles; Discretized Marching Cubes polygons (the
//! cells' planar facets before merging); polygons and triangles after merging;
//! the paper's ratio (polygons over Marching Cubes' triangles) and ours
//! (triangles over triangles); contour times; the largest vertex error and the
//! two-sided distance (in cells) of both meshes; closed and manifold.

use kdcontour::discrete_planes;
use kdcontour::field::volume::Inside;
use kdcontour::io::input::Input;
use kdcontour::io::volume::{load_nifti, phantom};
use kdcontour::meshers::{self, Mesher, Sampled};
use kdcontour::validate::{validate_with, Checks};
use kdcontour::{scenes, Field, Grid, IndexedMesh, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let mut num = |default: u32| {
        args.next()
            .map(|s| s.parse().expect("arguments are numbers"))
            .unwrap_or(default)
    };
    let (res, voxels, reps) = (num(64), num(128), num(3).max(1));
    let settings = Settings {
        threads: 1,
        ..Default::default()
    };
    println!(
        "{:<12} {:>4} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6} {:>7} {:>7} {:>6} {:>6} {:>6} {:>6} {:>6}",
        "input",
        "res",
        "MC tris",
        "DiscMC",
        "DP polys",
        "DP tris",
        "poly/",
        "tri/",
        "MC ms",
        "DP ms",
        "MC err",
        "DP err",
        "DP m>s",
        "DP s>m",
        "closed"
    );
    let vol = phantom(voxels).expect("the phantom fits in memory");
    let (lo, hi) = vol.bounds();
    let grid = Grid::fit(lo, hi, voxels - 1);
    row("phantom", &vol, &grid, reps, &settings);
    if let Some((field, grid)) = mni152() {
        row("mni152", &*field, &grid, reps, &settings);
    }
    for name in scenes::SCENES {
        let scene = scenes::scene(name).expect("built-in");
        row(name, &*scene.field, &Grid::cube(1.0, res), reps, &settings);
    }
}

/// The public brain MRI at one cell per voxel, if `scripts/fetch-scan.sh` has
/// fetched it (iso 100: the brain's outer surface, as in `tests/public_scan.rs`).
fn mni152() -> Option<(Box<dyn Field>, Grid)> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scans/mni152_t1.nii.gz");
    if !path.exists() {
        eprintln!(
            "mni152: absent ({}); scripts/fetch-scan.sh fetches it",
            path.display()
        );
        return None;
    }
    let vol = load_nifti(&path, 100.0, Inside::Above).expect("the fetched scan loads");
    let input = Input::volume(&path, vol);
    let res = input.native_res.expect("a volume has a native resolution");
    let grid = input.grid(res).expect("its grid");
    Some((input.field, grid))
}

/// The best time of `reps` runs of `f`, in ms, and its last result.
fn best<T>(reps: u32, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut ms = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps {
        let t = Instant::now();
        out = Some(f());
        ms = ms.min(t.elapsed().as_secs_f64() * 1e3);
    }
    (ms, out.expect("at least one run"))
}

fn row(name: &str, field: &dyn Field, grid: &Grid, reps: u32, settings: &Settings) {
    let s: Sampled = meshers::sample(field, grid, settings).expect("samples");
    let run = |m: Mesher| -> IndexedMesh { meshers::run(m, &s, -1.0, settings).expect("meshes").0 };
    let (mc_ms, mc) = best(reps, || run(Mesher::MarchingCubes));
    let (dp_ms, dp) = best(reps, || {
        settings
            .run(|| discrete_planes::extract(&s.hermite))
            .expect("runs")
    });
    let checks = Checks {
        field: Some((field, grid.cell_size)),
        intersections: false,
        surface: Some(grid),
        refine_surface: true,
    };
    let (rm, rd) = (
        validate_with(&mc, &checks),
        validate_with(&dp.mesh, &checks),
    );
    let d = rd.distance.expect("measured");
    let mc_tris = rm.triangles.max(1) as f64;
    println!(
        "{:<12} {:>4} {:>8} {:>8} {:>8} {:>8} {:>6.3} {:>6.3} {:>7.1} {:>7.1} {:>6.3} {:>6.3} {:>6.3} {:>6.3} {:>6}",
        name,
        grid.cells.max_element(),
        rm.triangles,
        dp.stats.cell_polygons,
        dp.stats.polygons,
        rd.triangles,
        dp.stats.polygons as f64 / mc_tris,
        rd.triangles as f64 / mc_tris,
        mc_ms,
        dp_ms,
        rm.max_vertex_error,
        rd.max_vertex_error,
        d.mesh_to_surface_max,
        d.surface_to_mesh_max,
        format!(
            "{}/{}",
            if rd.watertight { "y" } else { "n" },
            if rd.manifold { "y" } else { "n" }
        ),
    );
}
