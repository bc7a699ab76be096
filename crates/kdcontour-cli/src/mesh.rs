//! `kdcontour mesh`: one input through the k-d tree, with size, times and checks.

use crate::args::{Input, RunArgs};
use crate::output::{json_line, print_checks};
use kdcontour::meshers::Timings;
use kdcontour::validate::validate_with;
use kdcontour::{IndexedMesh, KdTree};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Mesh {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    run: RunArgs,
    /// Write the mesh to this .obj or .ply file.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Mesh) -> Result<(), String> {
    let Mesh { input, run, out } = args;
    crate::args::check_out(out.as_deref())?;
    let (loaded, grid, settings) = run.prepare(&input)?;
    let (scene, field) = (&loaded.name, &*loaded.field);
    let capped = crate::args::capped(field, &grid, &settings);
    let checked = capped
        .as_ref()
        .map_or(field, |c| c as &dyn kdcontour::Field);
    let checks = run.checks(checked, &grid);
    let RunArgs {
        res,
        threshold,
        json,
        ..
    } = run;
    let t0 = Instant::now();
    let tree = KdTree::build(field, &grid, &settings).map_err(|e| format!("{scene}: {e}"))?;
    let t1 = Instant::now();
    let mut mesh = IndexedMesh::default();
    settings
        .run(|| tree.extract(threshold, &mut mesh))
        .map_err(|e| e.to_string())?;
    let t2 = Instant::now();
    let report = validate_with(&mesh, &checks);
    let t3 = Instant::now();
    if let Some(path) = &out {
        mesh.save(path).map_err(|e| e.to_string())?;
    }
    let contour_ms = (t2 - t1).as_secs_f64() * 1e3;
    let total_ms = (t2 - t0).as_secs_f64() * 1e3;
    if json {
        let times = Timings {
            sample_ms: tree.stats.sample_ms,
            build_ms: tree.stats.build_ms,
            contour_ms,
        };
        let line = json_line("kdtree", scene, res, threshold, &report, &times);
        say!("{line}");
    } else {
        say!("scene      {scene} at res {res}, threshold {threshold}");
        say!(
            "mesh       {} triangles, {} vertices, {} components, Euler {}",
            report.triangles,
            report.vertices,
            report.components,
            report.euler
        );
        print_checks(&report);
        say!(
            "time       sample {:.2} ms, build {:.2} ms, contour {:.2} ms, total {:.2} ms (checks {:.2} ms)",
            tree.stats.sample_ms,
            tree.stats.build_ms,
            contour_ms,
            total_ms,
            (t3 - t2).as_secs_f64() * 1e3
        );
        say!(
            "tree       {} nodes, {} components, {} bytes retained ({:.1} per node)",
            tree.nodes.len(),
            tree.comps.len(),
            tree.retained_bytes(),
            tree.retained_bytes() as f64 / tree.nodes.len().max(1) as f64
        );
        if let Some(p) = out {
            say!("wrote      {}", p.display());
        }
    }
    Ok(())
}
