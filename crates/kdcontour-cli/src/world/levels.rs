//! `kdcontour world --levels`: the layout of chunks at several levels of detail
//! (random balanced levels, or rings around a camera).

use glam::{IVec3, UVec3, Vec3};
use kdcontour::io::input::parse_vec3;
use kdcontour::world::Layout;
use kdcontour::{Settings, World};

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
/// `camera:X,Y,Z` farther out than this along an axis is taken at this
/// distance: the world spans [-1, 1], so both split no chunk.
const FAR: f32 = 1e6;

/// A `--levels` value.
#[derive(Clone, Copy)]
pub enum Levels {
    /// Random balanced levels, seeded.
    Random(u64),
    /// Rings of levels around a camera (world coordinates).
    Camera(Vec3),
}

impl Levels {
    /// Parses `random:SEED` or `camera:X,Y,Z`.
    pub fn parse(spec: &str) -> Result<Self, String> {
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
pub fn top_level(chunks: UVec3) -> Result<u32, String> {
    (1..=TOP)
        .rev()
        .find(|&l| (chunks % (1 << l)) == UVec3::ZERO)
        .ok_or(format!(
            "--levels needs --chunks divisible by 2 along every axis (a level-1 chunk \
             covers 2 level-0 chunks per axis), got {},{},{}",
            chunks.x, chunks.y, chunks.z
        ))
}

/// The world of `chunks` level-0 chunks laid out by `levels` up to level `top`,
/// none built. A layout may split down to level 0 everywhere: the most chunks it
/// can have are checked against the budget before any layout is made.
pub fn world(
    levels: Levels,
    origin: Vec3,
    cell: f32,
    chunk_res: u32,
    chunks: UVec3,
    top: u32,
    settings: Settings,
) -> kdcontour::Result<World> {
    World::check_chunk_count(chunks.as_u64vec3().element_product(), chunk_res, &settings)?;
    let (lo, hi) = (IVec3::ZERO, chunks.as_ivec3());
    let mut world = World::new(
        origin,
        cell,
        chunk_res,
        Layout::uniform(lo, hi, top)?,
        0.01,
        settings,
    )?;
    // Built once: no level change will need the samples again.
    world.keep_samples = false;
    let layout = match levels {
        Levels::Random(seed) => Layout::random(lo, hi, top, SPLIT, seed),
        // The world spans [-1, 1]: a camera a million units out splits nothing,
        // as one farther does, and stays finite in chunk units.
        Levels::Camera(cam) => {
            let cam = cam.clamp(Vec3::splat(-FAR), Vec3::splat(FAR));
            Layout::around(lo, hi, top, world.to_chunk_units(cam), RING)
        }
    }?;
    world.set_layout(layout)?;
    Ok(world)
}
