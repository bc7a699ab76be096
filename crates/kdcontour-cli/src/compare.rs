//! `kdcontour compare`: Marching Cubes, uniform DMC, the octree, the k-d tree and
//! the discrete-planes octree on the same samples.

use crate::args::{Input, RunArgs};
use crate::output::json_line;
use kdcontour::meshers::{self, Mesher};
use kdcontour::validate::validate_with;

#[derive(clap::Args)]
pub struct Compare {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    run: RunArgs,
}

pub fn run(mut args: Compare) -> Result<(), String> {
    let (loaded, grid, settings) = args.run.prepare(&args.input)?;
    let (scene, field) = (&loaded.name, &*loaded.field);
    let capped = crate::args::capped(field, &grid, &settings);
    let checked = capped
        .as_ref()
        .map_or(field, |c| c as &dyn kdcontour::Field);
    let checks = args.run.checks(checked, &grid);
    let RunArgs {
        res,
        threshold,
        json,
        ..
    } = args.run;
    let progress = crate::progress::Progress::new(json);
    progress.stage(format!("sampling {} cells", grid.cell_count()));
    let sampled = meshers::sample(field, &grid, &settings)
        .map_err(|e| crate::args::build_error(&loaded, e))?;
    if !json {
        progress.suspend(|| say!("{scene} at res {res}, threshold {threshold} (errors in cells)"));
        progress.suspend(|| {
            say!(
                "{:<17} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6} {:>6}",
                "mesher",
                "triangles",
                "vertices",
                "max err",
                "mean err",
                "sample",
                "build",
                "contour",
                "closed",
                "manif",
                "euler"
            )
        });
    }
    let mut octree_tris = None;
    let mut reports = Vec::new();
    for (i, mesher) in Mesher::ALL.into_iter().enumerate() {
        let of = format!("{} of {}", i + 1, Mesher::ALL.len());
        progress.stage(format!("meshing with {} ({of})", mesher.name()));
        let (mesh, t) =
            meshers::run(mesher, &sampled, threshold, &settings).map_err(|e| e.to_string())?;
        progress.stage(format!("checking {}'s mesh ({of})", mesher.name()));
        let r = validate_with(&mesh, &checks);
        if json {
            say!(
                "{}",
                json_line(mesher.name(), scene, res, threshold, &r, &t)
            );
        } else {
            progress.suspend(|| say!(
                "{:<17} {:>10} {:>9} {:>9.4} {:>9.4} {:>7.1}ms {:>7.1}ms {:>7.1}ms {:>6} {:>6} {:>6}",
                mesher.name(),
                r.triangles,
                r.vertices,
                r.max_error,
                r.mean_error,
                t.sample_ms,
                t.build_ms,
                t.contour_ms,
                r.watertight,
                r.manifold,
                r.euler
            ));
        }
        match mesher {
            Mesher::Octree => octree_tris = Some(r.triangles),
            Mesher::KdTree if !json => {
                if let Some(o) = octree_tris.filter(|&o| o > 0) {
                    let ratio = r.triangles as f64 / o as f64;
                    progress.suspend(|| say!("k-d / octree triangles: {ratio:.3}"));
                }
            }
            _ => {}
        }
        reports.push((mesher.name(), r));
    }
    progress.finish();
    if !json {
        print_geometry(&reports);
    }
    Ok(())
}

/// The geometric checks of every mesher, one row each (`-` where a check did not
/// run).
fn print_geometry(reports: &[(&str, kdcontour::MeshReport)]) {
    println!(
        "{:<17} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>7}",
        "mesher",
        "zero-area",
        "slivers",
        "flipped",
        "folded",
        "crossing",
        "overlap",
        "depth",
        "mesh->srf",
        "srf->mesh",
        "lost %"
    );
    let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    for (name, r) in reports {
        let (i, d) = (r.intersections.as_ref(), r.distance.as_ref());
        println!(
            "{:<17} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>7}",
            name,
            r.zero_area_triangles,
            r.sliver_triangles,
            opt(r.flipped_triangles.map(|n| n.to_string())),
            opt(r.folds.as_ref().map(|f| f.folded.to_string())),
            opt(i.map(|i| i.crossing_pairs.to_string())),
            opt(i.map(|i| i.overlapping_pairs.to_string())),
            opt(i.map(|i| format!("{:.3}", i.max_depth))),
            opt(d.map(|d| format!("{:.4}", d.mesh_to_surface_max))),
            opt(d.map(|d| format!("{:.4}", d.surface_to_mesh_max))),
            opt(d.map(|d| format!("{:.2}", 100.0 * d.lost_surface))),
        );
    }
}
