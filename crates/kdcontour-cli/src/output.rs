//! What reports print: the JSON line of `mesh --json` and `compare --json`, and
//! the check and error lines of the `mesh` and `world` summaries.

use kdcontour::meshers::Timings;
use kdcontour::MeshReport;

/// The JSON line every report prints (the keys `mesh --json` promises).
pub fn json_line(
    mesher: &str,
    scene: &str,
    res: u32,
    threshold: f32,
    r: &MeshReport,
    t: &Timings,
) -> String {
    serde_json::json!({
        "mesher": mesher,
        "scene": scene,
        "res": res,
        "threshold": threshold,
        "triangles": r.triangles,
        "vertices": r.vertices,
        "sample_ms": t.sample_ms,
        "build_ms": t.build_ms,
        "contour_ms": t.contour_ms,
        "total_ms": t.total_ms(),
        "watertight": r.watertight,
        "manifold": r.manifold,
        "euler": r.euler,
        "max_error": r.max_error,
        "mean_error": r.mean_error,
    })
    .to_string()
}

/// The summary's `checks` and `error` lines.
pub fn print_checks(r: &MeshReport) {
    println!(
        "checks     watertight {}, manifold {}, oriented {}",
        r.watertight, r.manifold, r.oriented
    );
    println!(
        "error      max {:.4} cells, mean {:.4} cells",
        r.max_error, r.mean_error
    );
}
