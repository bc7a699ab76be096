//! `kdcontour compare`: Marching Cubes, uniform DMC, the octree and the k-d tree on
//! the same samples.

use crate::args::{Input, RunArgs};
use crate::output::json_line;
use kdcontour::meshers::{self, Mesher};
use kdcontour::validate;

#[derive(clap::Args)]
pub struct Compare {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    run: RunArgs,
}

pub fn run(args: Compare) -> Result<(), String> {
    let (loaded, grid, settings) = args.run.prepare(&args.input)?;
    let (scene, field) = (&loaded.name, &*loaded.field);
    let RunArgs {
        res,
        threshold,
        json,
        ..
    } = args.run;
    let sampled = meshers::sample(field, &grid, &settings).map_err(|e| format!("{scene}: {e}"))?;
    if !json {
        say!("{scene} at res {res}, threshold {threshold} (errors in cells)");
        say!(
            "{:<15} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6} {:>6} {:>6}",
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
        );
    }
    let mut octree_tris = None;
    for mesher in Mesher::ALL {
        let (mesh, t) =
            meshers::run(mesher, &sampled, threshold, &settings).map_err(|e| e.to_string())?;
        let r = validate(&mesh, Some((field, grid.cell_size)));
        if json {
            say!(
                "{}",
                json_line(mesher.name(), scene, res, threshold, &r, &t)
            );
        } else {
            say!(
                "{:<15} {:>10} {:>9} {:>9.4} {:>9.4} {:>7.1}ms {:>7.1}ms {:>7.1}ms {:>6} {:>6} {:>6}",
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
            );
        }
        match mesher {
            Mesher::Octree => octree_tris = Some(r.triangles),
            Mesher::KdTree if !json => {
                if let Some(o) = octree_tris.filter(|&o| o > 0) {
                    say!(
                        "k-d / octree triangles: {:.3}",
                        r.triangles as f64 / o as f64
                    );
                }
            }
            _ => {}
        }
    }
    Ok(())
}
