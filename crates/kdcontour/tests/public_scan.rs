//! A real public scan (issue 17): the MNI ICBM152 2009a T1 average brain that
//! `scripts/fetch-scan.sh` fetches into `data/scans/` (git-ignored; licence in the
//! script). Absent, each test says so on stderr (past the test harness's
//! capture) and passes without checking it; present, it is meshed at one cell per
//! voxel by the k-d tree and the octree and both meshes are checked.

use glam::UVec3;
use kdcontour::field::volume::Inside;
use kdcontour::io::input::Input;
use kdcontour::io::volume::load_nifti;
use kdcontour::{validate_with, Checks, KdTree, Partition, Settings};
use std::io::Write;
use std::path::PathBuf;

/// The iso value of the brain's outer (grey matter to background and fluid)
/// surface: tissue is 30 to 240, the background 0 and fluid 60 to 120.
const ISO: f32 = 100.0;

/// The scan's path, or `None` (said on stderr) when it has not been fetched.
fn scan(test: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scans/mni152_t1.nii.gz");
    if path.exists() {
        return Some(path);
    }
    writeln!(
        std::io::stderr(),
        "{test}: SKIPPED, the public scan {} is absent; run scripts/fetch-scan.sh to fetch it",
        path.display()
    )
    .ok();
    None
}

#[test]
fn the_public_brain_scan_meshes_closed_at_native_resolution() {
    let Some(path) = scan("the_public_brain_scan_meshes_closed_at_native_resolution") else {
        return;
    };
    let vol = load_nifti(&path, ISO, Inside::Above).unwrap();
    assert_eq!(vol.dims, UVec3::new(197, 233, 189));
    vol.check_iso(ISO).unwrap();
    let input = Input::volume(&path, vol);
    // 233 voxels of 1 mm along y: 232 cells, plus one of margin on each side.
    assert_eq!(input.native_res, Some(232));
    let grid = input.grid(232).unwrap();
    assert_eq!(grid.cells, UVec3::new(198, 234, 190));
    let field = &*input.field;
    let build = |partition| {
        let settings = Settings {
            partition,
            ..Settings::default()
        };
        KdTree::build(field, &grid, &settings).unwrap()
    };
    let (kd, oct) = (build(Partition::KdTree), build(Partition::Octree));
    for e in [0.01, 0.1] {
        let (mk, mo) = (kd.mesh(e), oct.mesh(e));
        // The cheap checks only (as `--quick-checks`): the costly ones take
        // minutes on 300,000 triangles outside a release build.
        let checks = Checks {
            field: Some((field, grid.cell_size)),
            ..Default::default()
        };
        let (rk, ro) = (validate_with(&mk, &checks), validate_with(&mo, &checks));
        println!(
            "threshold {e}: k-d {} triangles, octree {}, ratio {:.3}; mean error {:.3} / {:.3} cells",
            rk.triangles,
            ro.triangles,
            rk.triangles as f64 / ro.triangles as f64,
            rk.mean_error,
            ro.mean_error
        );
        for (name, r) in [("k-d tree", &rk), ("octree", &ro)] {
            assert!(r.triangles > 100_000, "{name} at {e}: {r:?}");
            assert!(
                r.watertight && r.manifold && r.oriented,
                "{name} at {e}: {r:?}"
            );
            // The largest error is not checked: on this scan it reaches the
            // distance search's cap (8 cells) for every mesher, Marching Cubes too,
            // with either gradient.
            assert!(r.mean_error < 0.2, "{name} at {e}: {r:?}");
        }
        assert!(
            rk.triangles < ro.triangles,
            "threshold {e}: {rk:?} vs {ro:?}"
        );
    }
}
