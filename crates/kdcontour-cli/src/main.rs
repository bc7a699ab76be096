//! `kdcontour`: mesh built-in scenes, scene files, volumes and triangle meshes from
//! the command line, and compare the meshers side by side.

use clap::{Parser, Subcommand};
use kdcontour::field::mesh_sdf::MeshSdf;
use kdcontour::field::volume::Inside;
use kdcontour::io::volume::{self, VoxelType};
use kdcontour::meshers::{self, Mesher};
use kdcontour::{
    scenes, validate, ChunkWorld, CsgNode, Field, Grid, IndexedMesh, KdTree, Lod, MeshReport,
    Settings,
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
struct Input {
    #[command(flatten)]
    source: Source,
    /// Raw volumes: voxels along x, y, z (e.g. 256,256,128).
    #[arg(long, value_parser = parse_uvec3)]
    dims: Option<glam::UVec3>,
    /// Raw volumes: voxel type, u8 | u16 | i16 | f32 (little endian).
    #[arg(long = "type")]
    voxel_type: Option<String>,
    /// Raw volumes: voxel spacing along x, y, z (world units).
    #[arg(long, value_parser = parse_vec3, default_value = "1,1,1")]
    spacing: glam::Vec3,
    /// Volumes: the iso value of the surface.
    #[arg(long, allow_negative_numbers = true)]
    iso: Option<f32>,
    /// Volumes: values `above` (CT: bone) or `below` the iso value are inside.
    #[arg(long, default_value = "above")]
    inside: String,
}

#[derive(clap::Args)]
#[group(required = true, multiple = false)]
struct Source {
    /// A built-in scene (see `kdcontour scenes`).
    #[arg(long)]
    scene: Option<String>,
    /// A JSON CSG scene file (format: scenes/README.md).
    #[arg(long)]
    scene_file: Option<PathBuf>,
    /// A volume: NIfTI-1 (.nii, .nii.gz) or raw voxels (with --dims and --type).
    #[arg(long)]
    volume: Option<PathBuf>,
    /// A triangle mesh (.obj, .ply) meshed as a signed distance field.
    #[arg(long)]
    mesh: Option<PathBuf>,
}

fn parse_triple(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .map_err(|_| format!("`{t}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    <[f32; 3]>::try_from(v).map_err(|_| format!("`{s}`: expected three comma-separated numbers"))
}

fn parse_vec3(s: &str) -> Result<glam::Vec3, String> {
    parse_triple(s).map(glam::Vec3::from)
}

fn parse_uvec3(s: &str) -> Result<glam::UVec3, String> {
    let t = parse_triple(s)?;
    if t.iter().any(|v| *v < 0.0 || v.fract() != 0.0) {
        return Err(format!("`{s}`: dims must be whole numbers"));
    }
    Ok(glam::UVec3::new(t[0] as u32, t[1] as u32, t[2] as u32))
}

/// Options `mesh` and `compare` share.
#[derive(clap::Args)]
struct RunArgs {
    /// Cells per axis (along the longest side for volumes and meshes).
    #[arg(long, default_value_t = 64)]
    res: u32,
    /// Error threshold in squared cells (negative = uniform Dual Marching Cubes).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    threshold: f32,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Print JSON lines instead of a summary (one line for `mesh`, one per mesher
    /// for `compare`).
    #[arg(long)]
    json: bool,
}

impl RunArgs {
    /// Checks the threshold, loads the input and fits its grid: the set-up `mesh`
    /// and `compare` share.
    fn prepare(
        input: &Input,
        res: u32,
        threshold: f32,
        threads: usize,
    ) -> Result<(String, Box<dyn Field>, Grid, Settings), String> {
        check_threshold(threshold)?;
        let loaded = load(input)?;
        let grid = grid_for(&loaded, res);
        let settings = Settings {
            threads,
            ..Default::default()
        };
        Ok((loaded.name, loaded.field, grid, settings))
    }
}

#[derive(Subcommand)]
enum Command {
    /// Mesh a scene in [-1, 1]^3 and report size, times and mesh checks.
    Mesh {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        run: RunArgs,
        /// Write the mesh to this .obj or .ply file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Mesh one input with Marching Cubes, uniform DMC, the octree and the k-d tree
    /// side by side (same samples, same threshold).
    Compare {
        #[command(flatten)]
        input: Input,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Mesh a scene as a grid of chunks, each at its own threshold, and write the
    /// union of every chunk's mesh and seams as one welded mesh (so the seams can be
    /// checked).
    World {
        #[command(flatten)]
        input: Input,
        /// Chunks along x, y, z; the world spans [-1, 1] along its longest side.
        #[arg(long, value_parser = parse_uvec3, default_value = "3,3,3")]
        chunks: glam::UVec3,
        /// Cells per chunk along each axis.
        #[arg(long, default_value_t = 16)]
        chunk_res: u32,
        /// Per-chunk thresholds: `random:SEED` (each chunk picks one of -1, 0.001,
        /// 0.01, 0.1, 1, 10).
        #[arg(long, conflicts_with = "camera")]
        thresholds: Option<String>,
        /// Per-chunk thresholds from the distance to a camera at X,Y,Z (0.001 within
        /// 0.25, growing with the square of the distance).
        #[arg(long, value_parser = parse_vec3)]
        camera: Option<glam::Vec3>,
        /// Write the welded mesh to this .obj or .ply file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (0 = all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Print one JSON line instead of a summary.
        #[arg(long)]
        json: bool,
    },
    /// List the built-in scenes.
    Scenes,
    /// Write a synthetic CT scan (the 3-D Shepp-Logan head phantom) as NIfTI.
    Phantom {
        /// Voxels per axis.
        #[arg(long, default_value_t = 128)]
        res: u32,
        /// The .nii or .nii.gz file to write.
        #[arg(long)]
        out: PathBuf,
    },
}

/// The loaded input: its name, its field, and the world box to mesh.
struct Loaded {
    name: String,
    field: Box<dyn Field>,
    bounds: Option<(glam::Vec3, glam::Vec3)>,
}

fn load(input: &Input) -> Result<Loaded, String> {
    let src = &input.source;
    if let Some(name) = &src.scene {
        let s = scenes::scene(name).map_err(|e| e.to_string())?;
        return Ok(Loaded {
            name: s.name.to_string(),
            field: s.field,
            bounds: None,
        });
    }
    if let Some(path) = &src.scene_file {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let node = CsgNode::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        let field = node
            .compile()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        return Ok(Loaded {
            name: path.display().to_string(),
            field: Box::new(field),
            bounds: None,
        });
    }
    if let Some(path) = &src.volume {
        let inside = match input.inside.as_str() {
            "above" => Inside::Above,
            "below" => Inside::Below,
            other => {
                return Err(format!(
                    "--inside must be `above` or `below`, got `{other}`"
                ))
            }
        };
        let iso = input
            .iso
            .ok_or("--iso is required with --volume (the value the surface is drawn at)")?;
        let name = path.display().to_string();
        let vol = if name.ends_with(".nii") || name.ends_with(".nii.gz") {
            volume::load_nifti(path, iso, inside)
        } else {
            let dims = input
                .dims
                .ok_or("a raw volume needs --dims X,Y,Z (or use a .nii / .nii.gz file)")?;
            let ty = input
                .voxel_type
                .as_deref()
                .ok_or("a raw volume needs --type u8|u16|i16|f32")?;
            let ty = VoxelType::parse(ty)
                .ok_or(format!("--type must be u8, u16, i16 or f32, got `{ty}`"))?;
            volume::load_raw(path, dims, ty, input.spacing, iso, inside)
        }
        .map_err(|e| e.to_string())?;
        let (lo, hi) = vol.range();
        if !(lo..=hi).contains(&iso) {
            eprintln!("warning: iso {iso} is outside the volume's values [{lo}, {hi}]: the mesh will be empty");
        }
        let bounds = vol.bounds();
        return Ok(Loaded {
            name,
            field: Box::new(vol),
            bounds: Some(bounds),
        });
    }
    let path = src.mesh.as_ref().expect("clap requires one input");
    let mesh = kdcontour::io::mesh::load_mesh(path).map_err(|e| e.to_string())?;
    let sdf = MeshSdf::new(&mesh);
    let bounds = sdf.bounds();
    Ok(Loaded {
        name: path.display().to_string(),
        field: Box::new(sdf),
        bounds: Some(bounds),
    })
}

/// The grid for an input: `[-1, 1]^3` for scenes; for volumes and meshes the input's
/// box with `res` cells along its longest side and one cell of margin all round, so
/// the surface closes inside the grid.
fn grid_for(loaded: &Loaded, res: u32) -> Grid {
    match loaded.bounds {
        None => Grid::cube(1.0, res),
        Some((lo, hi)) => {
            let ext = hi - lo;
            let cell = if res == 0 {
                0.0
            } else {
                ext.max_element() / res as f32
            };
            let cells = if cell > 0.0 {
                (ext / cell).ceil().as_uvec3().max(glam::UVec3::ONE) + glam::UVec3::splat(2)
            } else {
                glam::UVec3::ZERO
            };
            Grid {
                origin: lo - glam::Vec3::splat(cell),
                cell_size: cell,
                cells,
                offset: glam::IVec3::ZERO,
            }
        }
    }
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
            run:
                RunArgs {
                    res,
                    threshold,
                    threads,
                    json,
                },
        } => {
            let (scene, field, grid, settings) = RunArgs::prepare(&input, res, threshold, threads)?;
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
        Command::World {
            input,
            chunks,
            chunk_res,
            thresholds,
            camera,
            out,
            threads,
            json,
        } => {
            let loaded = load(&input)?;
            if loaded.bounds.is_some() {
                return Err("world meshes [-1, 1]^3: use --scene or --scene-file".into());
            }
            let settings = Settings {
                threads,
                ..Default::default()
            };
            let cell = 2.0 / (chunks.max_element().max(1) * chunk_res.max(1)) as f32;
            let mut world = ChunkWorld::new(
                glam::Vec3::splat(-1.0),
                cell,
                chunk_res,
                chunks,
                0.01,
                settings,
            )
            .map_err(|e| e.to_string())?;
            let t0 = Instant::now();
            world.build_all(&*loaded.field).map_err(|e| e.to_string())?;
            let build_ms = t0.elapsed().as_secs_f64() * 1e3;
            match (thresholds.as_deref(), camera) {
                (Some(spec), None) => {
                    let seed: u64 = spec
                        .strip_prefix("random:")
                        .and_then(|s| s.parse().ok())
                        .ok_or(format!("--thresholds must be random:SEED, got `{spec}`"))?;
                    let levels = [-1.0, 0.001, 0.01, 0.1, 1.0, 10.0];
                    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1);
                    let coords = world.coords();
                    for c in coords {
                        state = state
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        world.set_threshold(c, levels[(state >> 33) as usize % levels.len()]);
                    }
                }
                (None, Some(cam)) => {
                    world.apply_lod(cam, &Lod::default());
                }
                _ => return Err("give --thresholds random:SEED or --camera X,Y,Z".into()),
            }
            let t1 = Instant::now();
            let mesh = world.extract_all();
            let contour_ms = t1.elapsed().as_secs_f64() * 1e3;
            let r = validate(&mesh, Some((&*loaded.field, cell)));
            let mut seam_triangles = 0;
            let mut m = IndexedMesh::default();
            for c in world.coords() {
                world.extract_seams(c, &mut m);
                seam_triangles += m.triangle_count();
            }
            if let Some(p) = &out {
                mesh.save(p).map_err(|e| e.to_string())?;
            }
            let ts: Vec<f32> = world
                .coords()
                .into_iter()
                .map(|c| world.threshold(c))
                .collect();
            if json {
                println!(
                    "{}",
                    serde_json::json!({
                        "scene": loaded.name, "chunks": chunks.to_array(), "chunk_res": chunk_res,
                        "triangles": r.triangles, "vertices": r.vertices, "seam_triangles": seam_triangles,
                        "watertight": r.watertight, "manifold": r.manifold, "oriented": r.oriented,
                        "euler": r.euler, "max_error": r.max_error, "mean_error": r.mean_error,
                        "build_ms": build_ms, "contour_ms": contour_ms,
                        "retained_bytes": world.retained_bytes(), "thresholds": ts,
                    })
                );
            } else {
                println!(
                    "world      {} in {}x{}x{} chunks of {chunk_res}^3 cells",
                    loaded.name, chunks.x, chunks.y, chunks.z
                );
                println!(
                    "mesh       {} triangles ({seam_triangles} in seams), {} vertices, Euler {}",
                    r.triangles, r.vertices, r.euler
                );
                println!(
                    "checks     watertight {}, manifold {}, oriented {}",
                    r.watertight, r.manifold, r.oriented
                );
                println!(
                    "error      max {:.4} cells, mean {:.4} cells",
                    r.max_error, r.mean_error
                );
                println!("time       build {build_ms:.1} ms, contour {contour_ms:.1} ms; {} bytes retained", world.retained_bytes());
                if let Some(p) = out {
                    println!("wrote      {}", p.display());
                }
            }
            Ok(())
        }
        Command::Phantom { res, out } => {
            if !(8..=1024).contains(&res) {
                return Err(format!("--res must be 8 to 1024, got {res}"));
            }
            volume::write_nifti(&out, &volume::phantom(res)).map_err(|e| e.to_string())?;
            println!(
                "wrote {} ({res}^3 voxels; the skull is at --iso 1.5)",
                out.display()
            );
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
            run:
                RunArgs {
                    res,
                    threshold,
                    threads,
                    json,
                },
            out,
        } => {
            let (scene, field, grid, settings) = RunArgs::prepare(&input, res, threshold, threads)?;
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
