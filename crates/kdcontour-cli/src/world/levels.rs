//! `kdcontour world --levels`: the world's chunks at several levels of detail
//! (a [`LevelWorld`]), welded into one mesh across level seams, with chunk counts,
//! retained bytes, build time and triangles per level.

use super::{cell_size, random_thresholds, weld, Thresholds, World};
use crate::args::settings;
use crate::output::print_checks;
use glam::{IVec3, UVec3, Vec3};
use kdcontour::io::input::parse_vec3;
use kdcontour::world::{ChunkKey, Layout, LevelWorld};
use kdcontour::{IndexedMesh, Lod};
use std::time::Instant;

/// Deepest level `--levels` uses ("random balanced levels 0..2").
const TOP: u32 = 2;
/// Chance that a chunk above level 0 splits in a `random:SEED` layout. Balancing
/// splits more: over 16,16,16 level-0 chunks, seeds 0 to 7 kept 8 to 49 level-2
/// chunks at 0.15 (and 117 to 348 level-1, 24 to 128 level-0), 2 to 7 at 0.3,
/// none at 0.5; over 8,8,8 (eight level-2 chunks, all touching) any split
/// cascades, so the default grid is 16,16,16.
const SPLIT: f64 = 0.15;
/// `camera:X,Y,Z`: a chunk splits while the camera is within this many of its own
/// sides of it, so level 0 reaches out about 2 level-0 chunks and level `k` about
/// `2^(k + 1)` ([`Layout::around`]).
const RING: f32 = 1.0;

/// A `--levels` value.
#[derive(Clone, Copy)]
enum Levels {
    /// Random balanced levels, seeded.
    Random(u64),
    /// Rings of levels around a camera (world coordinates).
    Camera(Vec3),
}

impl Levels {
    fn parse(spec: &str) -> Result<Self, String> {
        let bad = || format!("--levels must be random:SEED or camera:X,Y,Z, got `{spec}`");
        if let Some(seed) = spec.strip_prefix("random:") {
            seed.parse().map(Levels::Random).map_err(|_| bad())
        } else if let Some(cam) = spec.strip_prefix("camera:") {
            parse_vec3(cam)
                .map(Levels::Camera)
                .map_err(|e| format!("{}: {e}", bad()))
        } else {
            Err(bad())
        }
    }
}

/// The highest level up to [`TOP`] whose chunks tile `chunks` level-0 chunks.
fn top_level(chunks: UVec3) -> Result<u32, String> {
    (1..=TOP)
        .rev()
        .find(|&l| (chunks % (1 << l)) == UVec3::ZERO)
        .ok_or(format!(
            "--levels needs --chunks divisible by 2 along every axis (a level-1 chunk \
             covers 2 level-0 chunks per axis), got {},{},{}",
            chunks.x, chunks.y, chunks.z
        ))
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

pub fn run(args: &World, spec: &str, thresholds: Thresholds) -> Result<(), String> {
    let levels = Levels::parse(spec)?;
    let chunks = args.chunks.unwrap_or(UVec3::splat(16));
    let top = top_level(chunks)?;
    let loaded = args.input.load()?;
    if loaded.bounds.is_some() {
        return Err("world meshes [-1, 1]^3: use --scene or --scene-file".into());
    }
    // A layout may split down to level 0 everywhere: check the most chunks it can
    // have before building any.
    let settings = settings(args.threads, args.memory.budget);
    LevelWorld::check_budget(
        chunks.as_u64vec3().element_product(),
        args.chunk_res,
        &settings,
    )
    .map_err(|e| e.to_string())?;
    let (lo, hi) = (IVec3::ZERO, chunks.as_ivec3());
    let cell = cell_size(chunks, args.chunk_res);
    let mut world = LevelWorld::new(
        Vec3::splat(-1.0),
        cell,
        args.chunk_res,
        Layout::uniform(lo, hi, top).map_err(|e| e.to_string())?,
        0.01,
        settings,
    )
    .map_err(|e| e.to_string())?;
    // Built once: no level change will need the samples again.
    world.keep_samples = false;
    let layout = match levels {
        Levels::Random(seed) => Layout::random(lo, hi, top, SPLIT, seed),
        Levels::Camera(cam) => Layout::around(lo, hi, top, world.to_chunk_units(cam), RING),
    }
    .map_err(|e| e.to_string())?;
    world.set_layout(layout).map_err(|e| e.to_string())?;

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
        world
            .build(&mine, &*loaded.field)
            .map_err(|e| e.to_string())?;
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
            let lod = Lod::default();
            for k in &keys {
                let (lo, hi) = world.chunk_bounds(k);
                world.set_threshold(k, lod.threshold(cam.clamp(lo, hi).distance(cam)));
            }
        }
        Thresholds::Default => {}
    }
    let (mesh, contour_ms, r) = weld(|| world.extract_all(), &*loaded.field, cell);
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
        mesh.save(p).map_err(|e| e.to_string())?;
    }
    let retained = world.retained_bytes();
    if args.json {
        let ts: Vec<f32> = keys.iter().map(|k| world.threshold(k)).collect();
        say!("{}", {
            let mut line = serde_json::json!({
                "scene": loaded.name, "chunks": chunks.to_array(), "chunk_res": args.chunk_res,
                "levels": spec, "top_level": top, "chunk_count": keys.len(),
                "per_level": stats.iter().map(LevelStats::json).collect::<Vec<_>>(),
                "triangles": r.triangles, "vertices": r.vertices, "seam_triangles": seam_triangles,
                "watertight": r.watertight, "manifold": r.manifold, "oriented": r.oriented,
                "euler": r.euler, "max_error": r.max_error, "mean_error": r.mean_error,
                "build_ms": build_ms, "contour_ms": contour_ms,
                "retained_bytes": retained, "thresholds": ts,
            });
            crate::output::with_geometry(&mut line, &r);
            line
        });
        return Ok(());
    }
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
