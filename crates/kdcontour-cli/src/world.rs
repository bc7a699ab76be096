//! `kdcontour world`: a scene as a grid of chunks, each at its own threshold,
//! written as one welded mesh so the seams can be checked; with `--levels`, chunks
//! at several levels of detail ([`levels`] makes the layout). Either way it is one
//! [`kdcontour::World`], built, cut and welded the same way.

mod levels;

use crate::args::{settings, Memory, SceneInput};
use crate::output::print_checks;
use glam::{UVec3, Vec3};
use kdcontour::io::input::{parse_uvec3, parse_vec3};
use kdcontour::world::ChunkKey;
use kdcontour::{validate, IndexedMesh, Lod};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct World {
    #[command(flatten)]
    input: SceneInput,
    /// Chunks along x, y, z; the world spans [-1, 1] along its longest side
    /// [default: 3,3,3; 16,16,16 with --levels]. With --levels this is the level-0
    /// grid: see --levels.
    #[arg(long, value_parser = parse_uvec3)]
    chunks: Option<glam::UVec3>,
    /// Cells per chunk along each axis (at every level; even with --levels).
    #[arg(long, default_value_t = 16)]
    chunk_res: u32,
    /// Per-chunk thresholds: `random:SEED` (each chunk picks one of -1, 0.001,
    /// 0.01, 0.1, 1, 10).
    #[arg(long, conflicts_with = "camera")]
    thresholds: Option<String>,
    /// Per-chunk thresholds from the distance to a camera at X,Y,Z (0.001 within
    /// 0.25, growing with the square of the distance). Negative values may
    /// follow the flag (`--camera -1,0,0`).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    camera: Option<glam::Vec3>,
    /// Chunk levels of detail: `random:SEED` (random balanced levels) or
    /// `camera:X,Y,Z` (finest at a camera in the world's [-1, 1] coordinates,
    /// coarser with distance). A level-k chunk has cells 2^k times as wide and
    /// covers 2^k level-0 chunks per axis. The top level is the highest of 1 and 2
    /// that divides every --chunks count (16,16,16 or 8,4,8: levels 0 to 2; 6,6,6:
    /// levels 0 and 1); an odd count is an error. --thresholds or --camera set
    /// the thresholds within the levels (in each chunk's own cells); without
    /// them every chunk is at 0.01.
    #[arg(long)]
    levels: Option<String>,
    /// Write the welded mesh to this .obj or .ply file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Print one JSON line instead of a summary.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    memory: Memory,
}

/// How chunks get their thresholds.
#[derive(Clone, Copy)]
enum Thresholds {
    /// Each chunk one of [`THRESHOLDS`], seeded ([`random_thresholds`]).
    Random(u64),
    /// From the distance to a camera ([`Lod::default`]).
    Camera(glam::Vec3),
    /// Every chunk at the world's default (0.01).
    Default,
}

impl Thresholds {
    /// `--thresholds` or `--camera`; neither is [`Thresholds::Default`].
    fn parse(spec: Option<&str>, camera: Option<glam::Vec3>) -> Result<Self, String> {
        match (spec, camera) {
            (Some(spec), None) => spec
                .strip_prefix("random:")
                .and_then(|s| s.parse().ok())
                .map(Thresholds::Random)
                .ok_or(format!("--thresholds must be random:SEED, got `{spec}`")),
            (None, Some(cam)) => Ok(Thresholds::Camera(cam)),
            _ => Ok(Thresholds::Default),
        }
    }
}

/// The thresholds `--thresholds random:SEED` picks from.
const THRESHOLDS: [f32; 6] = [-1.0, 0.001, 0.01, 0.1, 1.0, 10.0];

/// `n` thresholds from [`THRESHOLDS`], picked by a seeded generator (a PCG step
/// per chunk, in the world's chunk order).
fn random_thresholds(n: usize, seed: u64) -> Vec<f32> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1);
    (0..n)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            THRESHOLDS[(state >> 33) as usize % THRESHOLDS.len()]
        })
        .collect()
}

/// The world's cell size: `chunks * chunk_res` cells span [-1, 1] along the
/// longest side.
fn cell_size(chunks: UVec3, chunk_res: u32) -> f32 {
    2.0 / (chunks.max_element().max(1) * chunk_res.max(1)) as f32
}

/// What one level's chunks hold and cost.
#[derive(Default)]
struct LevelStats {
    level: u32,
    chunks: usize,
    retained_bytes: usize,
    build_ms: f64,
    /// Triangles of the level's chunk meshes (interiors and owned seams).
    triangles: usize,
}

impl LevelStats {
    fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "level": self.level, "chunks": self.chunks, "retained_bytes": self.retained_bytes,
            "build_ms": self.build_ms, "triangles": self.triangles,
        })
    }
}

pub fn run(args: World) -> Result<(), String> {
    crate::args::check_out(args.out.as_deref())?;
    let thresholds = Thresholds::parse(args.thresholds.as_deref(), args.camera)?;
    let levels = args
        .levels
        .as_deref()
        .map(levels::Levels::parse)
        .transpose()?;
    if levels.is_none() && matches!(thresholds, Thresholds::Default) {
        return Err("give --thresholds random:SEED or --camera X,Y,Z".into());
    }
    let default_chunks = if levels.is_some() { 16 } else { 3 };
    let chunks = args.chunks.unwrap_or(UVec3::splat(default_chunks));
    if chunks.min_element() == 0 {
        return Err(format!(
            "--chunks must be at least 1 along every axis, got {},{},{}",
            chunks.x, chunks.y, chunks.z
        ));
    }
    if levels.is_some() && !args.chunk_res.is_multiple_of(2) {
        return Err(format!(
            "--chunk-res must be even with --levels (a level-1 cell is two level-0 \
             cells), got {}",
            args.chunk_res
        ));
    }
    let top = match levels {
        Some(_) => levels::top_level(chunks)?,
        None => 0,
    };
    let loaded = args.input.load()?;
    if levels.is_some() && loaded.bounds.is_some() {
        return Err("world meshes [-1, 1]^3: use --scene or --scene-file".into());
    }
    let settings = settings(args.threads, args.memory.budget);
    let progress = crate::progress::Progress::new(args.json);
    let threads = match args.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let cell = cell_size(chunks, args.chunk_res);
    let origin = Vec3::splat(-1.0);
    let mut world = match levels {
        None => kdcontour::World::bounded(origin, cell, args.chunk_res, chunks, 0.01, settings),
        Some(l) => levels::world(l, origin, cell, args.chunk_res, chunks, top, settings),
    }
    .map_err(|e| e.to_string())?;

    // Build level by level to time each.
    let keys = world.chunks();
    let mut stats: Vec<LevelStats> = (0..=top)
        .map(|level| LevelStats {
            level,
            ..Default::default()
        })
        .collect();
    for s in &mut stats {
        let mine: Vec<ChunkKey> = keys
            .iter()
            .filter(|k| k.level == s.level)
            .copied()
            .collect();
        let t = Instant::now();
        progress.chunks(format!("building level {}", s.level), mine.len() as u64);
        // In parts as large as the world's own batches (16 a thread), so the
        // line moves as chunks are done and the builds are the same.
        for part in mine.chunks(16 * threads) {
            world
                .build(part, &*loaded.field)
                .map_err(|e| format!("{}: {e}", loaded.name))?;
            progress.done(part.len() as u64);
        }
        s.build_ms = t.elapsed().as_secs_f64() * 1e3;
        s.chunks = mine.len();
        s.retained_bytes = mine
            .iter()
            .filter_map(|k| world.tree(k))
            .map(|t| t.retained_bytes())
            .sum();
    }
    let build_ms: f64 = stats.iter().map(|s| s.build_ms).sum();

    match thresholds {
        Thresholds::Random(seed) => {
            for (k, e) in keys.iter().zip(random_thresholds(keys.len(), seed)) {
                world.set_threshold(k, e);
            }
        }
        Thresholds::Camera(cam) => {
            world.apply_lod(cam, &Lod::default());
        }
        Thresholds::Default => {}
    }
    let t = Instant::now();
    progress.stage(format!("cutting and welding {} chunks", keys.len()));
    let mesh = world.extract_all();
    let contour_ms = t.elapsed().as_secs_f64() * 1e3;
    progress.stage(format!("checking {} triangles", mesh.triangle_count()));
    let r = validate(&mesh, Some((&*loaded.field, cell)));
    let mut seam_triangles = 0;
    let mut m = IndexedMesh::default();
    for k in &keys {
        world.extract_seams(k, &mut m);
        seam_triangles += m.triangle_count();
        stats[k.level as usize].triangles += m.triangle_count();
        world.extract_interior(k, &mut m);
        stats[k.level as usize].triangles += m.triangle_count();
    }
    if let Some(p) = &args.out {
        progress.stage(format!("writing {}", p.display()));
        mesh.save(p).map_err(|e| e.to_string())?;
    }
    progress.finish();
    let retained = world.retained_bytes();
    let ts: Vec<f32> = keys.iter().map(|k| world.threshold(k)).collect();
    if args.json {
        say!("{}", {
            let mut line = serde_json::json!({
                "scene": loaded.name, "chunks": chunks.to_array(), "chunk_res": args.chunk_res,
                "top_level": top, "chunk_count": keys.len(),
                "per_level": stats.iter().map(LevelStats::json).collect::<Vec<_>>(),
                "triangles": r.triangles, "vertices": r.vertices, "seam_triangles": seam_triangles,
                "watertight": r.watertight, "manifold": r.manifold, "oriented": r.oriented,
                "euler": r.euler, "max_error": r.max_error, "mean_error": r.mean_error,
                "build_ms": build_ms, "contour_ms": contour_ms,
                "retained_bytes": retained, "thresholds": ts,
            });
            if let Some(spec) = &args.levels {
                line["levels"] = spec.as_str().into();
            }
            crate::output::with_geometry(&mut line, &r);
            line
        });
        return Ok(());
    }
    match &args.levels {
        None => say!(
            "world      {} in {}x{}x{} chunks of {}^3 cells",
            loaded.name,
            chunks.x,
            chunks.y,
            chunks.z,
            args.chunk_res
        ),
        Some(spec) => {
            say!(
                "world      {} in {}x{}x{} level-0 chunks of {}^3 cells, levels {spec}: {} chunks",
                loaded.name,
                chunks.x,
                chunks.y,
                chunks.z,
                args.chunk_res,
                keys.len()
            );
            for s in &stats {
                say!(
                    "level {}    {} chunks, {} triangles, build {:.1} ms, {} bytes retained",
                    s.level,
                    s.chunks,
                    s.triangles,
                    s.build_ms,
                    s.retained_bytes
                );
            }
        }
    }
    say!(
        "mesh       {} triangles ({seam_triangles} in seams), {} vertices, Euler {}",
        r.triangles,
        r.vertices,
        r.euler
    );
    print_checks(&r);
    say!(
        "time       build {build_ms:.1} ms, contour {contour_ms:.1} ms; {retained} bytes retained"
    );
    if let Some(p) = &args.out {
        say!("wrote      {}", p.display());
    }
    Ok(())
}
