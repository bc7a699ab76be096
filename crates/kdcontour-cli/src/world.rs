//! `kdcontour world`: a scene as a grid of chunks, each at its own threshold,
//! written as one welded mesh so the seams can be checked; with `--levels`, chunks
//! at several levels of detail ([`levels`]).

mod levels;

use crate::args::{settings, Memory, SceneInput};
use crate::output::print_checks;
use kdcontour::io::input::{parse_uvec3, parse_vec3};
use kdcontour::{validate, ChunkWorld, Field, IndexedMesh, Lod, MeshReport};
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
    /// 0.25, growing with the square of the distance).
    #[arg(long, value_parser = parse_vec3)]
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
fn cell_size(chunks: glam::UVec3, chunk_res: u32) -> f32 {
    2.0 / (chunks.max_element().max(1) * chunk_res.max(1)) as f32
}

/// Welds the world with `extract`, timed (ms), and checks the mesh against
/// `field` (errors in cells of `cell`).
fn weld(
    extract: impl FnOnce() -> IndexedMesh,
    field: &dyn Field,
    cell: f32,
) -> (IndexedMesh, f64, MeshReport) {
    let t = Instant::now();
    let mesh = extract();
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let r = validate(&mesh, Some((field, cell)));
    (mesh, ms, r)
}

pub fn run(args: World) -> Result<(), String> {
    crate::args::check_out(args.out.as_deref())?;
    let thresholds = Thresholds::parse(args.thresholds.as_deref(), args.camera)?;
    if let Some(spec) = &args.levels {
        return levels::run(&args, spec, thresholds);
    }
    if let Thresholds::Default = thresholds {
        return Err("give --thresholds random:SEED or --camera X,Y,Z".into());
    }
    let World {
        input,
        chunks,
        chunk_res,
        out,
        threads: n_threads,
        json,
        memory,
        ..
    } = args;
    let chunks = chunks.unwrap_or(glam::UVec3::splat(3));
    let loaded = input.load()?;
    let cell = cell_size(chunks, chunk_res);
    let mut world = ChunkWorld::new(
        glam::Vec3::splat(-1.0),
        cell,
        chunk_res,
        chunks,
        0.01,
        settings(n_threads, memory.budget),
    )
    .map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    world
        .build_all(&*loaded.field)
        .map_err(|e| format!("{}: {e}", loaded.name))?;
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    match thresholds {
        Thresholds::Random(seed) => {
            let coords = world.coords();
            for (c, e) in coords.iter().zip(random_thresholds(coords.len(), seed)) {
                world.set_threshold(*c, e);
            }
        }
        Thresholds::Camera(cam) => {
            world.apply_lod(cam, &Lod::default());
        }
        Thresholds::Default => unreachable!("checked above"),
    }
    let (mesh, contour_ms, r) = weld(|| world.extract_all(), &*loaded.field, cell);
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
        say!("{}", {
            let mut line = serde_json::json!({
                "scene": loaded.name, "chunks": chunks.to_array(), "chunk_res": chunk_res,
                "triangles": r.triangles, "vertices": r.vertices, "seam_triangles": seam_triangles,
                "watertight": r.watertight, "manifold": r.manifold, "oriented": r.oriented,
                "euler": r.euler, "max_error": r.max_error, "mean_error": r.mean_error,
                "build_ms": build_ms, "contour_ms": contour_ms,
                "retained_bytes": world.retained_bytes(), "thresholds": ts,
            });
            crate::output::with_geometry(&mut line, &r);
            line
        });
    } else {
        say!(
            "world      {} in {}x{}x{} chunks of {chunk_res}^3 cells",
            loaded.name,
            chunks.x,
            chunks.y,
            chunks.z
        );
        say!(
            "mesh       {} triangles ({seam_triangles} in seams), {} vertices, Euler {}",
            r.triangles,
            r.vertices,
            r.euler
        );
        print_checks(&r);
        say!(
            "time       build {build_ms:.1} ms, contour {contour_ms:.1} ms; {} bytes retained",
            world.retained_bytes()
        );
        if let Some(p) = out {
            say!("wrote      {}", p.display());
        }
    }
    Ok(())
}
