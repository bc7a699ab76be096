//! Adaptive Skeleton Climbing against Marching Cubes on the same samples, per box
//! size limit (block): triangles, time, error and whether the mesh is closed and
//! manifold. The paper claims 2-4 times fewer triangles than Marching Cubes in
//! comparable time.
//!
//! `cargo run --release -p kdcontour --example skeleton_climbing -- [scenes] [res] [blocks]`
//! e.g. `-- phantom,csg_mix,gyroid,sphere 128 1,2,4,8,16` (`phantom` is the
//! Shepp-Logan head of `kdcontour phantom` at `res` voxels, iso 1.5; `mni152`
//! is the public brain MRI `scripts/fetch-scan.sh` fetches, at one cell per
//! voxel whatever `res`, iso 100).

use kdcontour::field::volume::Inside;
use kdcontour::io::input::Input;
use kdcontour::io::volume;
use kdcontour::meshers::{self, Mesher};
use kdcontour::skeleton_climbing::skeleton_climbing;
use kdcontour::{scenes, validate_with, Checks, Field, Grid, IndexedMesh, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let list = |s: Option<String>, d: &str| -> Vec<String> {
        s.unwrap_or_else(|| d.into())
            .split(',')
            .map(str::to_owned)
            .collect()
    };
    let names = list(args.next(), "phantom,csg_mix,gyroid,sphere");
    let res: u32 = args.next().map_or(128, |s| s.parse().expect("res"));
    let blocks: Vec<u32> = list(args.next(), "1,2,4,8,16")
        .iter()
        .map(|s| s.parse().expect("block"))
        .collect();
    let settings = Settings::default();
    println!(
        "{:<10} {:<18} {:>9} {:>7} {:>9} {:>8} {:>8} {:>9} {:>6} {:>6} {:>6}",
        "scene",
        "mesher",
        "triangles",
        "MC/x",
        "ms",
        "max err",
        "mean err",
        "hausdorff",
        "closed",
        "manif",
        "euler"
    );
    for name in &names {
        let (field, grid): (Box<dyn Field>, Grid) = if name == "phantom" {
            let v = volume::phantom(res).expect("the phantom fits in memory");
            let (lo, hi) = v.bounds();
            (Box::new(v), Grid::fit(lo, hi, res))
        } else if name == "mni152" {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../data/scans/mni152_t1.nii.gz");
            let v = volume::load_nifti(&path, 100.0, Inside::Above).unwrap_or_else(|e| {
                panic!("{e} (scripts/fetch-scan.sh fetches {})", path.display())
            });
            let input = Input::volume(&path, v);
            let native = input.native_res.expect("a volume has a native resolution");
            let grid = input.grid(native).expect("its grid");
            (input.field, grid)
        } else {
            let scene = scenes::scene(name).unwrap_or_else(|e| panic!("{e}"));
            (scene.field, Grid::cube(1.0, res))
        };
        let s = meshers::sample(&*field, &grid, &settings).expect("samples");
        let checks = Checks::all(&*field, &grid);
        let row = |label: String, mesh: &IndexedMesh, ms: f64, mc: usize| {
            let r = validate_with(mesh, &checks);
            println!(
                "{:<10} {:<18} {:>9} {:>7.2} {:>7.1}ms {:>8.4} {:>8.4} {:>9.4} {:>6} {:>6} {:>6}",
                name,
                label,
                r.triangles,
                mc as f64 / r.triangles.max(1) as f64,
                ms,
                r.max_error,
                r.mean_error,
                r.distance.as_ref().map_or(f32::NAN, |d| d.hausdorff()),
                r.watertight,
                r.manifold,
                r.euler
            );
        };
        // Fastest of three runs each.
        let best = |f: &(dyn Fn() -> IndexedMesh + Sync)| {
            let mut ms = f64::INFINITY;
            let mut mesh = IndexedMesh::default();
            for _ in 0..3 {
                let t = Instant::now();
                mesh = settings.run(f).expect("thread pool");
                ms = ms.min(t.elapsed().as_secs_f64() * 1e3);
            }
            (mesh, ms)
        };
        let (mc, ms) = best(&|| {
            meshers::run(Mesher::MarchingCubes, &s, -1.0, &settings)
                .expect("mc")
                .0
        });
        let n = mc.triangle_count();
        row("marching-cubes".into(), &mc, ms, n);
        for &b in &blocks {
            let (m, ms) = best(&|| skeleton_climbing(&s.hermite, b).expect("block size"));
            row(format!("skeleton-climbing/{b}"), &m, ms, n);
        }
    }
}
