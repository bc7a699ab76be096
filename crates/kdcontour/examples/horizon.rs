//! How chunk count, retained memory and build time grow with view distance when
//! chunk levels double their cells with distance (issue 12, "Speed and memory").
//!
//! The field is the terrain demo's (`examples/terrain.rs` of the plugin,
//! [`DensityParams::demo`]: seed 7, amplitude 22, frequency 0.011, 5 octaves,
//! caves of frequency 0.018 and radius 0.11 down to 24 cells below the surface);
//! cells of 1, chunks of 32 cells. For a view distance `D` the region is
//! `2 x 1 x 2` chunks of the top level `T`, whose chunks are `D` cells wide
//! (`32 * 2^T = D`): `D` cells out from the camera along x and z, and a slab one
//! top chunk (`D` cells) tall with the mean surface (y = 0) in its middle. Levels
//! come from [`Layout::around`] with the camera 40 cells above the mean surface;
//! every chunk is cut at one threshold in its own cells. The whole view is built
//! from scratch on `THREADS` threads and welded. The terrain runs off the region's
//! sides, so that mesh is open there; to check that it is closed everywhere else,
//! the view is built a second time with the terrain capped half a cell inside the
//! region (intersected with a box), and that mesh must be watertight, manifold and
//! oriented.
//!
//! Chunks the field's bound ([`Field::bound`]) proves to be all sky or all rock
//! are not sampled (their trees are the ones sampling would build: no surface);
//! per level the table counts them, and gives the build's time per remaining
//! chunk and thread. The build's processor time is printed too: on a machine
//! shared with other work the wall time grows with the load, and processor time
//! divided by the threads is what the build takes on idle cores.
//!
//! Measured on 2 cores shared with other builds (load average about 7), ring 1:
//!
//! | distance | chunks (skipped) | retained | build (wall) | build (processor) | triangles |
//! |---:|---:|---:|---:|---:|---:|
//! | 256 | 298 (120) | 22.6 MB | 6.64 s | 3.04 s | 154,577 |
//! | 1,024 | 634 (360) | 37.7 MB | 13.63 s | 6.46 s | 342,728 |
//! | 4,096 | 970 (600) | 51.6 MB | 18.46 s | 9.22 s | 519,595 |
//! | 16,384 | 1,306 (840) | 66.0 MB | 27.86 s | 12.46 s | 715,028 |
//!
//! Chunks grow by about 340 per quadrupling of the distance, memory by 15 MB
//! (the log of the distance, not its square); every capped view is watertight,
//! manifold and oriented.
//!
//! Each view prints a fingerprint of its welded mesh (`mesh ...`): a speed-up
//! that must not change the meshes keeps it. Before the views, the field's
//! batched sampling ([`Field::sample_grid`]) is compared with [`Field::value`]
//! bit for bit on a few chunks of every level.
//!
//! Trees are built with the largest threshold the plugin gives a horizon
//! volume's trees with its default LOD curve ([`Lod::around_limit`], 0.29 at
//! ring 1; `Settings::max_threshold`), as the plugin builds them.
//!
//! `cargo run --release -p kdcontour --example horizon [-- DISTANCE... [--ring R]
//! [--max-threshold T] [--no-materials]]` (default distances 256 1024 4096 16384,
//! ring 1; `T` `inf` builds trees for every threshold; `--no-materials` builds
//! them as for a plain material, as the plugin's frame bench does). A distance
//! stops, and says
//! so, when its retained trees pass `MAX_BYTES` or its build passes `MAX_SECS`.

use glam::{IVec3, Vec3};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::world::{ChunkKey, Layout, Lod, World};
use kdcontour::{hermite, validate, Field, IndexedMesh, MeshReport, Settings};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Cells per chunk side (the terrain demo's default).
const CHUNK_RES: u32 = 32;
/// Worker threads for the build.
const THREADS: usize = 2;
/// Threshold of every chunk, in squared cells of its own level (the terrain
/// demo's LOD base).
const THRESHOLD: f32 = 0.02;
/// The plugin's default LOD curve (`LodSettings::default`): its horizon volumes'
/// trees are built for the largest threshold it gives their chunks.
const PLUGIN_LOD: Lod = Lod {
    base: 0.001,
    near: 16.0,
    growth: 2.0,
    max: 10.0,
};
/// Chunk widths a camera may be from where its layout was made for, in the
/// plugin's rule for that threshold.
const MOTION_SLACK: f32 = 2.0;
/// Whether trees keep the field's materials (`--no-materials`: as a volume with
/// a plain material builds them, the plugin's frame bench).
static MATERIALS: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(true);
/// Camera height above the mean surface (cells).
const CAMERA_HEIGHT: f32 = 40.0;
/// Stop a distance whose retained trees pass this many bytes.
const MAX_BYTES: usize = 8 << 30;
/// Stop a distance whose build passes this many seconds.
const MAX_SECS: f64 = 300.0;
/// Chunks built between two checks of the limits.
const BATCH: usize = 128;

fn terrain() -> Density {
    Density::new(DensityParams::demo(7))
}

/// One level's share of a view.
#[derive(Default)]
struct Level {
    chunks: usize,
    /// Chunks the field's bound proved one-signed (no sampling).
    skipped: usize,
    retained: usize,
    build_s: f64,
}

/// What building one view cost.
struct View {
    top: u32,
    levels: Vec<Level>,
    build_s: f64,
    /// Processor time of the build, all threads (Linux only).
    build_cpu_s: Option<f64>,
    contour_s: f64,
    report: MeshReport,
    /// [`fingerprint`] of the welded mesh.
    hash: u64,
    /// The region's world box (min, max).
    region: (Vec3, Vec3),
}

/// The world for view distance `distance` (cells), laid out around the camera.
fn layout(distance: u32, ring: f32, max_threshold: f32) -> Result<World, String> {
    if !(distance.is_power_of_two() && distance >= 2 * CHUNK_RES) {
        return Err(format!(
            "view distance {distance} must be a power of two, at least {}",
            2 * CHUNK_RES
        ));
    }
    let top = (distance / CHUNK_RES).trailing_zeros();
    let side = 1 << top;
    let (lo, hi) = (IVec3::new(-side, 0, -side), IVec3::new(side, side, side));
    // Lattice y = 0 at world y = -distance / 2: the mean surface sits mid-slab.
    let origin = Vec3::new(0.0, -(distance as f32) / 2.0, 0.0);
    let settings = Settings {
        threads: THREADS,
        max_threshold,
        materials: MATERIALS.load(Ordering::Relaxed),
        ..Default::default()
    };
    let uniform = Layout::uniform(lo, hi, top).map_err(|e| e.to_string())?;
    let mut world = World::new(origin, 1.0, CHUNK_RES, uniform, THRESHOLD, settings)
        .map_err(|e| e.to_string())?;
    let camera = Vec3::new(16.0, CAMERA_HEIGHT, 16.0);
    let around = Layout::around(lo, hi, top, world.to_chunk_units(camera), ring)
        .map_err(|e| e.to_string())?;
    world.set_layout(around).map_err(|e| e.to_string())?;
    Ok(world)
}

/// Builds, welds and checks the view at `distance`; `Err` says why it stopped.
fn view(distance: u32, ring: f32, max_threshold: f32, field: &dyn Field) -> Result<View, String> {
    let mut world = layout(distance, ring, max_threshold)?;
    let top = (distance / CHUNK_RES).trailing_zeros();
    let keys = world.chunks();
    let mut levels: Vec<Level> = (0..=top).map(|_| Level::default()).collect();
    let cpu0 = cpu_seconds().unwrap_or(0.0);
    let start = Instant::now();
    for (l, level) in levels.iter_mut().enumerate() {
        let mine: Vec<ChunkKey> = keys
            .iter()
            .filter(|k| k.level == l as u32)
            .copied()
            .collect();
        level.chunks = mine.len();
        level.skipped = mine
            .iter()
            .filter(|k| {
                let b = world.chunk_build(k);
                matches!(
                    hermite::one_sign(field, &b.grid, 3, &b.settings),
                    Ok(Some(_))
                )
            })
            .count();
        let t = Instant::now();
        for batch in mine.chunks(BATCH) {
            world.build(batch, field).map_err(|e| e.to_string())?;
            let (bytes, secs) = (world.retained_bytes(), start.elapsed().as_secs_f64());
            if bytes > MAX_BYTES || secs > MAX_SECS {
                return Err(format!(
                    "stopped in level {l} after {secs:.0} s with {} MB retained \
                     ({} of {} chunks built)",
                    bytes >> 20,
                    keys.len() - world.stale().len(),
                    keys.len()
                ));
            }
        }
        level.build_s = t.elapsed().as_secs_f64();
        level.retained = mine
            .iter()
            .filter_map(|k| world.tree(k))
            .map(|t| t.retained_bytes())
            .sum();
    }
    let build_s = start.elapsed().as_secs_f64();
    let build_cpu_s = cpu_seconds().map(|c| c - cpu0);
    let t = Instant::now();
    let mesh = world.extract_all();
    let contour_s = t.elapsed().as_secs_f64();
    Ok(View {
        top,
        levels,
        build_s,
        build_cpu_s,
        contour_s,
        hash: fingerprint(&mesh),
        report: validate(&mesh, None),
        region: region(&world),
    })
}

/// FNV-1a over the bits of the mesh's positions and normals and its indices:
/// equal for two builds exactly when (but for collisions) their meshes are the
/// same bit for bit, to check that a speed-up changed no mesh.
fn fingerprint(mesh: &IndexedMesh) -> u64 {
    let floats = mesh
        .positions
        .iter()
        .chain(&mesh.normals)
        .flat_map(|v| v.to_array());
    let words = floats.map(f32::to_bits).chain(mesh.indices.iter().copied());
    words.fold(0xcbf2_9ce4_8422_2325, |h, w| {
        w.to_le_bytes()
            .iter()
            .fold(h, |h, b| (h ^ *b as u64).wrapping_mul(0x100_0000_01b3))
    })
}

/// The world box of the world's region (min, max).
fn region(world: &World) -> (Vec3, Vec3) {
    let side = CHUNK_RES as f32 * world.cell_size;
    let l = world.layout();
    (
        world.origin + l.lo().as_vec3() * side,
        world.origin + l.hi().as_vec3() * side,
    )
}

/// A field intersected with a box: outside the box is air, so the surface closes
/// on the box's faces.
struct Capped<'a> {
    field: &'a dyn Field,
    lo: Vec3,
    hi: Vec3,
}

impl Capped<'_> {
    /// The box's term: the largest distance outside a face (negative inside).
    fn wall(&self, p: Vec3) -> f32 {
        (self.lo - p).max(p - self.hi).max_element()
    }
}

impl Field for Capped<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.field.value(p).max(self.wall(p))
    }

    /// The larger of the field's bound and the wall's (distance-like, slope at
    /// most 1: its value at the box's center plus or minus the half-diagonal).
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (a, b) = self.field.bound(lo, hi)?;
        let w = self.wall((lo + hi) * 0.5);
        let r = (hi - lo).length() * 0.5 * 1.001;
        Some((a.max(w - r), b.max(w + r)))
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let w = self.wall(p);
        if self.field.value(p) >= w {
            return self.field.gradient(p);
        }
        let out = (self.lo - p)
            .to_array()
            .into_iter()
            .chain((p - self.hi).to_array());
        let face = out.enumerate().find(|&(_, d)| d == w).map_or(0, |(i, _)| i);
        let mut n = Vec3::ZERO;
        n[face % 3] = if face < 3 { -1.0 } else { 1.0 };
        n
    }
}

fn main() {
    let mut distances: Vec<u32> = Vec::new();
    let mut ring = 1.0f32;
    let mut max_threshold = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--ring" {
            ring = args
                .next()
                .and_then(|s| s.parse().ok())
                .expect("--ring takes a number");
        } else if a == "--no-materials" {
            MATERIALS.store(false, Ordering::Relaxed);
        } else if a == "--max-threshold" {
            max_threshold = Some(
                args.next()
                    .and_then(|s| s.parse::<f32>().ok())
                    .expect("--max-threshold takes a number (inf: none)"),
            );
        } else {
            distances.push(a.parse().expect("a view distance in cells"));
        }
    }
    let max_threshold = max_threshold
        .unwrap_or_else(|| PLUGIN_LOD.around_limit(ring, CHUNK_RES, 1.0, MOTION_SLACK));
    if distances.is_empty() {
        distances = vec![256, 1024, 4096, 16384];
    }
    let field = terrain();
    print_stage_times(&field, max_threshold);
    match check_batched(&field, 1024, 2) {
        Ok(n) => println!(
            "batched sampling equals the value bit for bit at {n} corners (2 surface \
             chunks per level of the 1,024 view)"
        ),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
    println!(
        "terrain seed 7, {CHUNK_RES}-cell chunks of 1-cell cells, ring {ring}, threshold \
         {THRESHOLD} (own cells), trees for thresholds up to {max_threshold}, {THREADS} \
         threads; limits {} GB, {MAX_SECS} s",
        MAX_BYTES >> 30
    );
    for d in distances {
        println!("\nview distance {d} cells");
        let v = match view(d, ring, max_threshold, &field) {
            Err(e) => {
                println!("  {e}");
                continue;
            }
            Ok(v) => v,
        };
        print_view(&v);
        let capped = Capped {
            field: &field,
            lo: v.region.0 + 0.5,
            hi: v.region.1 - 0.5,
        };
        match view(d, ring, max_threshold, &capped) {
            Err(e) => println!("  capped: {e}"),
            Ok(c) => {
                let r = &c.report;
                println!(
                    "  capped at the region: {} triangles, watertight {}, manifold {}, \
                     oriented {} (build {:.2} s)",
                    r.triangles, r.watertight, r.manifold, r.oriented, c.build_s
                );
            }
        }
    }
}

/// Times sampling against the whole build for one chunk near the camera (level
/// 0) and one farther out (level 4), on one thread: the first of each level that
/// the field's bound cannot skip.
fn print_stage_times(field: &dyn Field, max_threshold: f32) {
    let world = layout(1024, 1.0, max_threshold).expect("a valid layout");
    for level in [0, 4] {
        let surface = |k: &ChunkKey| {
            let b = world.chunk_build(k);
            matches!(hermite::one_sign(field, &b.grid, 3, &b.settings), Ok(None))
        };
        let Some(k) = world
            .chunks()
            .into_iter()
            .find(|k| k.level == level && surface(k))
        else {
            continue;
        };
        let mut build = world.chunk_build(&k);
        build.settings.threads = 1;
        // Counted on a wrapper (which samples point by point), timed on the
        // field itself (with its own batched sampling).
        let counted = Counting::new(field);
        build.samples(&counted).expect("the chunk samples");
        let sampled = counted.take();
        build.run(&counted).expect("the chunk builds");
        let (values, gradients) = counted.take();
        let t = Instant::now();
        let samples = build.samples(field).expect("the chunk samples");
        let sample_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let tree = build.run(field).expect("the chunk builds");
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        println!(
            "one level-{level} chunk{} on one thread: sampling {} corners ({} evaluations) \
             {sample_ms:.1} ms of a {build_ms:.1} ms build ({} evaluations, {} gradients), \
             {} KB retained",
            if build.neighbourhood.coarser.is_empty() {
                ""
            } else {
                " (conforming)"
            },
            samples.len(),
            sampled.0,
            values,
            gradients,
            tree.retained_bytes() >> 10
        );
    }
}

/// Compares the field's batched sampling ([`Field::sample_grid`]) with
/// [`Field::value`] bit for bit at every corner of the grids of `per_level`
/// chunks of each level of the view at `distance` (chunks the bound cannot skip);
/// returns how many corners it compared, or the first that differs.
fn check_batched(field: &dyn Field, distance: u32, per_level: usize) -> Result<usize, String> {
    let world = layout(distance, 1.0, f32::INFINITY)?;
    let keys = world.chunks();
    let top = (distance / CHUNK_RES).trailing_zeros();
    let mut compared = 0;
    for level in 0..=top {
        let surface = keys.iter().filter(|k| {
            let b = world.chunk_build(k);
            k.level == level
                && matches!(hermite::one_sign(field, &b.grid, 3, &b.settings), Ok(None))
        });
        for k in surface.take(per_level) {
            let grid = world.chunk_build(k).grid;
            let c = grid.corners();
            let mut batched = vec![0f32; grid.corner_count() as usize];
            field.sample_grid(&grid, 0..c.z, &mut batched);
            let corners = (0..c.z).flat_map(|z| {
                (0..c.y).flat_map(move |y| (0..c.x).map(move |x| glam::UVec3::new(x, y, z)))
            });
            for (c, b) in corners.zip(&batched) {
                let p = grid.corner_pos(c);
                let v = field.value(p);
                if v.to_bits() != b.to_bits() {
                    return Err(format!(
                        "batched sampling gives {b} at {p} (chunk {k:?}), the value is {v}"
                    ));
                }
            }
            compared += batched.len();
        }
    }
    Ok(compared)
}

/// A field that counts its evaluations.
struct Counting<'a> {
    field: &'a dyn Field,
    values: AtomicUsize,
    gradients: AtomicUsize,
}

impl<'a> Counting<'a> {
    fn new(field: &'a dyn Field) -> Self {
        Counting {
            field,
            values: AtomicUsize::new(0),
            gradients: AtomicUsize::new(0),
        }
    }

    /// The counts of values and gradients so far; starts counting again.
    fn take(&self) -> (usize, usize) {
        (
            self.values.swap(0, Ordering::Relaxed),
            self.gradients.swap(0, Ordering::Relaxed),
        )
    }
}

impl Field for Counting<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.values.fetch_add(1, Ordering::Relaxed);
        self.field.value(p)
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        self.gradients.fetch_add(1, Ordering::Relaxed);
        self.field.gradient(p)
    }

    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        self.field.bound(lo, hi)
    }
}

/// Processor seconds this process has used (user and system, all threads), from
/// `/proc/self/stat`; `None` off Linux. On a machine shared with other work the
/// wall time of a build grows with the load, its processor time does not: on
/// `THREADS` idle cores the build would take about processor time / `THREADS`.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses): utime, stime are
    // the 12th and 13th of them, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn print_view(v: &View) {
    let mb = |b: usize| b as f64 / (1 << 20) as f64;
    for (l, level) in v.levels.iter().enumerate() {
        let built = level.chunks - level.skipped;
        println!(
            "  level {l}: {:>4} chunks of {:>5} cells ({:>4} skipped), {:>7.1} MB, build \
             {:>6.2} s ({:>5.1} ms per sampled chunk per thread)",
            level.chunks,
            CHUNK_RES << l,
            level.skipped,
            mb(level.retained),
            level.build_s,
            level.build_s * 1e3 * THREADS as f64 / built.max(1) as f64
        );
    }
    let chunks: usize = v.levels.iter().map(|l| l.chunks).sum();
    let skipped: usize = v.levels.iter().map(|l| l.skipped).sum();
    let retained: usize = v.levels.iter().map(|l| l.retained).sum();
    let r = &v.report;
    println!(
        "  total: {chunks} chunks (levels 0 to {}, {skipped} skipped), {:.1} MB retained, \
         build {:.2} s, weld {:.2} s, {} triangles, mesh {:016x}",
        v.top,
        mb(retained),
        v.build_s,
        v.contour_s,
        r.triangles,
        v.hash
    );
    if let Some(cpu) = v.build_cpu_s {
        println!(
            "  build processor time {cpu:.2} s on {THREADS} threads: about {:.2} s on \
             {THREADS} idle cores",
            cpu / THREADS as f64
        );
    }
    println!(
        "  open mesh: {} edges on 3+ triangles, {} misoriented, {} hole edges (the \
         region's sides), {} vertices with 2+ fans",
        r.nonmanifold_edges, r.misoriented_edges, r.boundary_edges, r.nonmanifold_vertices
    );
}
