//! `kdcontour`: mesh built-in scenes or JSON scene files from the command line.

use clap::{Parser, Subcommand};
use kdcontour::meshers::{self, Mesher};
use kdcontour::{
    scenes, validate, CsgNode, Field, Grid, IndexedMesh, KdTree, MeshReport, Settings,
};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "kdcontour",
    version,
    about = "Adaptive isosurface meshing through a discrete k-d tree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args)]
#[group(required = true, multiple = false)]
struct Input {
    /// A built-in scene (see `kdcontour scenes`).
    #[arg(long)]
    scene: Option<String>,
    /// A JSON CSG scene file (format: crates/kdcontour/src/field/csg.rs, scenes/*.json).
    #[arg(long)]
    scene_file: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Mesh a scene in [-1, 1]^3 and report size, times and mesh checks.
    Mesh {
        #[command(flatten)]
        input: Input,
        /// Cells per axis.
        #[arg(long, default_value_t = 64)]
        res: u32,
        /// Error threshold in squared cells (negative = uniform Dual Marching Cubes).
        #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
        threshold: f32,
        /// Worker threads (0 = all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Write the mesh to this .obj or .ply file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print exactly one JSON line instead of a summary.
        #[arg(long)]
        json: bool,
    },
    /// Mesh one input with Marching Cubes, uniform DMC, the octree and the k-d tree
    /// side by side (same samples, same threshold).
    Compare {
        #[command(flatten)]
        input: Input,
        /// Cells per axis.
        #[arg(long, default_value_t = 64)]
        res: u32,
        /// Error threshold in squared cells for the adaptive meshers.
        #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
        threshold: f32,
        /// Worker threads (0 = all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Print one JSON line per mesher instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// List the built-in scenes.
    Scenes,
}

fn load(input: &Input) -> Result<(String, Box<dyn Field>), String> {
    if let Some(name) = &input.scene {
        let s = scenes::scene(name).map_err(|e| e.to_string())?;
        return Ok((s.name.to_string(), s.field));
    }
    let path = input.scene_file.as_ref().expect("clap requires one input");
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let node = CsgNode::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let field = node
        .compile()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((path.display().to_string(), Box::new(field)))
}

/// The JSON line every report prints (the keys `mesh --json` promises).
#[allow(clippy::too_many_arguments)]
fn json_line(
    mesher: &str,
    scene: &str,
    res: u32,
    threshold: f32,
    r: &MeshReport,
    sample_ms: f64,
    build_ms: f64,
    contour_ms: f64,
) -> String {
    serde_json::json!({
        "mesher": mesher,
        "scene": scene,
        "res": res,
        "threshold": threshold,
        "triangles": r.triangles,
        "vertices": r.vertices,
        "sample_ms": sample_ms,
        "build_ms": build_ms,
        "contour_ms": contour_ms,
        "total_ms": sample_ms + build_ms + contour_ms,
        "watertight": r.watertight,
        "manifold": r.manifold,
        "euler": r.euler,
        "max_error": r.max_error,
        "mean_error": r.mean_error,
    })
    .to_string()
}

fn check_threshold(threshold: f32) -> Result<(), String> {
    if threshold.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "--threshold must be a finite number, got {threshold}"
        ))
    }
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Compare {
            input,
            res,
            threshold,
            threads,
            json,
        } => {
            check_threshold(threshold)?;
            let (scene, field) = load(&input)?;
            let grid = Grid::cube(1.0, res);
            let settings = Settings {
                threads,
                ..Default::default()
            };
            let sampled = meshers::sample(&*field, &grid, &settings).map_err(|e| e.to_string())?;
            if !json {
                println!("{scene} at res {res}, threshold {threshold} (errors in cells)");
                println!(
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
                let (mesh, t) = meshers::run(mesher, &sampled, threshold, &settings)
                    .map_err(|e| e.to_string())?;
                let r = validate(&mesh, Some((&*field, grid.cell_size)));
                if json {
                    println!(
                        "{}",
                        json_line(
                            mesher.name(),
                            &scene,
                            res,
                            threshold,
                            &r,
                            t.sample_ms,
                            t.build_ms,
                            t.contour_ms
                        )
                    );
                } else {
                    println!(
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
                            println!(
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
        Command::Scenes => {
            for name in scenes::SCENES {
                let s = scenes::scene(name).map_err(|e| e.to_string())?;
                println!("{:<12} {}", s.name, s.description);
            }
            Ok(())
        }
        Command::Mesh {
            input,
            res,
            threshold,
            threads,
            out,
            json,
        } => {
            if !threshold.is_finite() {
                return Err(format!(
                    "--threshold must be a finite number, got {threshold}"
                ));
            }
            let (scene, field) = load(&input)?;
            let grid = Grid::cube(1.0, res);
            let settings = Settings {
                threads,
                ..Default::default()
            };
            let t0 = Instant::now();
            let tree = KdTree::build(&*field, &grid, &settings).map_err(|e| e.to_string())?;
            let t1 = Instant::now();
            let mut mesh = IndexedMesh::default();
            settings
                .run(|| tree.extract(threshold, &mut mesh))
                .map_err(|e| e.to_string())?;
            let t2 = Instant::now();
            let report = validate(&mesh, Some((&*field, grid.cell_size)));
            if let Some(path) = &out {
                mesh.save(path).map_err(|e| e.to_string())?;
            }
            let contour_ms = (t2 - t1).as_secs_f64() * 1e3;
            let total_ms = (t2 - t0).as_secs_f64() * 1e3;
            if json {
                let line = json_line(
                    "kdtree",
                    &scene,
                    res,
                    threshold,
                    &report,
                    tree.stats.sample_ms,
                    tree.stats.build_ms,
                    contour_ms,
                );
                println!("{line}");
            } else {
                println!("scene      {scene} at res {res}, threshold {threshold}");
                println!(
                    "mesh       {} triangles, {} vertices, {} components, Euler {}",
                    report.triangles, report.vertices, report.components, report.euler
                );
                println!(
                    "checks     watertight {}, manifold {}, oriented {}",
                    report.watertight, report.manifold, report.oriented
                );
                println!(
                    "error      max {:.4} cells, mean {:.4} cells",
                    report.max_error, report.mean_error
                );
                println!(
                    "time       sample {:.2} ms, build {:.2} ms, contour {:.2} ms, total {:.2} ms",
                    tree.stats.sample_ms, tree.stats.build_ms, contour_ms, total_ms
                );
                println!(
                    "tree       {} nodes, {} components, {} bytes retained ({:.1} per node)",
                    tree.nodes.len(),
                    tree.comps.len(),
                    tree.retained_bytes(),
                    tree.retained_bytes() as f64 / tree.nodes.len().max(1) as f64
                );
                if let Some(p) = out {
                    println!("wrote      {}", p.display());
                }
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
