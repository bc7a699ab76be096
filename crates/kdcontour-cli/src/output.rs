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
    let mut line = serde_json::json!({
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
    });
    with_geometry(&mut line, r);
    line.to_string()
}

/// Adds the geometric checks' keys ([`geometry_json`]) to a JSON object.
pub fn with_geometry(line: &mut serde_json::Value, r: &MeshReport) {
    let (obj, geo) = (line.as_object_mut().expect("an object"), geometry_json(r));
    obj.extend(geo.as_object().expect("an object").clone());
}

/// The geometric checks' keys (`null` where a check did not run).
pub fn geometry_json(r: &MeshReport) -> serde_json::Value {
    let i = r.intersections.as_ref();
    let d = r.distance.as_ref();
    let f = r.folds.as_ref();
    serde_json::json!({
        "fold_bucket_degrees": kdcontour::validate::FOLD_BUCKET_DEGREES,
        "fold_histogram": f.map(|f| f.histogram),
        "fold_max_degrees": f.map(|f| f.max_degrees),
        "fold_mean_degrees": f.map(|f| f.mean_degrees),
        "folded_triangles": f.map(|f| f.folded),
        "folded_share": f.map(|f| f.folded_share),
        "folds_near_creases": f.map(|f| f.near_crease),
        "fold_no_gradient": f.map(|f| f.no_gradient),
        "zero_area_triangles": r.zero_area_triangles,
        "coincident_vertices": r.coincident_vertices,
        "sliver_triangles": r.sliver_triangles,
        "flipped_triangles": r.flipped_triangles,
        "crossing_pairs": i.map(|i| i.crossing_pairs),
        "crossing_triangles": i.map(|i| i.crossing_triangles),
        "crossing_depth": i.map(|i| i.max_depth),
        "overlapping_pairs": i.map(|i| i.overlapping_pairs),
        "overlapping_triangles": i.map(|i| i.overlapping_triangles),
        "mesh_to_surface_max": d.map(|d| d.mesh_to_surface_max),
        "mesh_to_surface_mean": d.map(|d| d.mesh_to_surface_mean),
        "surface_to_mesh_max": d.map(|d| d.surface_to_mesh_max),
        "surface_to_mesh_mean": d.map(|d| d.surface_to_mesh_mean),
        "surface_points": d.map(|d| d.surface_points),
        "lost_surface": d.map(|d| d.lost_surface),
        "surface_refined": d.map(|d| d.refined),
    })
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
    if let Some(m) = &r.materials {
        let off = m.mismatched_vertices.map_or("-".into(), |n| n.to_string());
        let teeth = m.toothed_triangles.map_or("-".into(), |n| n.to_string());
        say!(
            "materials  {} border triangles ({teeth} drawn with a tooth), {off} vertices off the field's material, {} bad blends",
            m.border_triangles,
            m.bad_blends
        );
    }
    let flipped = r.flipped_triangles.map_or("-".into(), |n| n.to_string());
    println!(
        "faces      {} zero-area, {} coincident vertices, {} slivers (< {} deg), {flipped} flipped",
        r.zero_area_triangles,
        r.coincident_vertices,
        r.sliver_triangles,
        kdcontour::validate::SLIVER_DEGREES
    );
    if let Some(f) = &r.folds {
        use kdcontour::validate::{FOLD_BUCKET_DEGREES, FOLD_DEGREES};
        let buckets: Vec<String> = FOLD_BUCKET_DEGREES
            .iter()
            .zip(f.histogram)
            .map(|(edge, n)| format!("<{edge}:{n}"))
            .collect();
        println!(
            "folds      normal vs gradient (deg) {}; max {:.1}, mean {:.2}; {} folded > {FOLD_DEGREES} deg off creases ({:.3}%), {} near creases",
            buckets.join(" "),
            f.max_degrees,
            f.mean_degrees,
            f.folded,
            100.0 * f.folded_share,
            f.near_crease
        );
    }
    if let Some(i) = &r.intersections {
        println!(
            "crossings  {} pairs ({} triangles, depth {:.3} cells), {} coplanar overlapping pairs ({} triangles)",
            i.crossing_pairs,
            i.crossing_triangles,
            i.max_depth,
            i.overlapping_pairs,
            i.overlapping_triangles
        );
    }
    if let Some(d) = &r.distance {
        let on = if d.refined {
            "the grid, the shifted grid and finer lattices"
        } else {
            "the grid and the shifted grid; --checks full adds finer lattices"
        };
        println!(
            "distance   mesh->surface max {:.4} mean {:.4}, surface->mesh max {:.4} mean {:.4} cells (surface sampled on {on})",
            d.mesh_to_surface_max,
            d.mesh_to_surface_mean,
            d.surface_to_mesh_max,
            d.surface_to_mesh_mean
        );
        println!(
            "lost       {:.2}% of {} surface points farther than {} cells from the mesh",
            100.0 * d.lost_surface,
            d.surface_points,
            kdcontour::validate::LOST_CELLS
        );
    }
}
