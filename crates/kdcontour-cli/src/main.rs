//! `kdcontour`: mesh built-in scenes or JSON scene files from the command line.

use clap::{Parser, Subcommand};
use kdcontour::{scenes, validate, CsgNode, Field, Grid, IndexedMesh, KdTree, Settings};
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

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
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
                let line = serde_json::json!({
                    "mesher": "kdtree",
                    "scene": scene,
                    "res": res,
                    "threshold": threshold,
                    "triangles": report.triangles,
                    "vertices": report.vertices,
                    "sample_ms": tree.stats.sample_ms,
                    "build_ms": tree.stats.build_ms,
                    "contour_ms": contour_ms,
                    "total_ms": total_ms,
                    "watertight": report.watertight,
                    "manifold": report.manifold,
                    "euler": report.euler,
                    "max_error": report.max_error,
                    "mean_error": report.mean_error,
                });
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
