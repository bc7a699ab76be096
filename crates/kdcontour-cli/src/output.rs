//! What reports print: the JSON line of `mesh --json` and `compare --json`, and
//! the check and error lines of the `mesh` and `world` summaries.

use kdcontour::meshers::Timings;
use kdcontour::MeshReport;
use std::io::Write;

/// Prints one line to stdout. When the reader has gone (`kdcontour scenes | head
/// -1`) the command stops quietly with status 0, as a command killed by SIGPIPE
/// would, instead of panicking; any other write error is exit status 2.
pub fn line(args: std::fmt::Arguments) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush())
    {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to stdout: {e}");
        std::process::exit(2);
    }
}

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
    say!(
        "checks     watertight {}, manifold {}, oriented {}",
        r.watertight,
        r.manifold,
        r.oriented
    );
    say!(
        "error      max {:.4} cells, mean {:.4} cells",
        r.max_error,
        r.mean_error
    );
}
