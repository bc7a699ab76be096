//! What the plugin did, for panels and profiling: the [`KdContourStats`] resource,
//! the [`MainThreadClock`] every system of the plugin times itself with, and
//! [`StatsPlugin`], which totals both once a frame.

use crate::state::VolumeState;
use crate::volume::KdChunk;
use crate::KdContourSystems;
use bevy::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What the plugin did, for panels and profiling (updated every frame).
#[derive(Resource, Clone, Debug, Default, Reflect)]
#[reflect(Resource)]
pub struct KdContourStats {
    /// Chunks of all volumes.
    pub chunks: usize,
    /// Chunks showing a mesh.
    pub meshed_chunks: usize,
    /// Triangles shown.
    pub triangles: usize,
    /// Builds and extractions running.
    pub tasks_in_flight: usize,
    /// Builds and extractions waiting for a slot.
    pub queued: usize,
    /// Chunk builds finished since start.
    pub builds: u64,
    /// Extractions finished since start.
    pub extractions: u64,
    /// Mean time of one chunk build (sample + tree), ms, over recent builds.
    pub build_ms: f64,
    /// Mean time of one chunk extraction (interior + owned seams), ms.
    pub extract_ms: f64,
    /// Main-thread time of the plugin's systems in the last frame, ms (mesh
    /// upload included), by the clock on the wall: what the frame waited for
    /// them, including any time their threads waited for a core.
    pub main_thread_ms: f64,
    /// The processor time those systems used in the last frame, ms: their
    /// own work, without the waits for a core that
    /// [`KdContourStats::main_thread_ms`] includes (Linux; elsewhere the
    /// same as it).
    pub main_thread_cpu_ms: f64,
    /// Smallest and largest chunk threshold in use.
    pub threshold_range: (f32, f32),
}

impl KdContourStats {
    /// Folds one build's time into [`KdContourStats::build_ms`].
    pub(crate) fn record_build(&mut self, ms: f64) {
        self.builds += 1;
        ema(&mut self.build_ms, ms, self.builds);
    }

    /// Folds one extraction's time into [`KdContourStats::extract_ms`].
    pub(crate) fn record_extraction(&mut self, ms: f64) {
        self.extractions += 1;
        ema(&mut self.extract_ms, ms, self.extractions);
    }
}

/// Moving average over about the last 32 samples.
fn ema(avg: &mut f64, x: f64, n: u64) {
    let k = 1.0 / (n.min(32) as f64);
    *avg += (x - *avg) * k;
}

/// The main-thread time the plugin's systems spent this frame. Every system
/// starts with `let _time = clock.measure();`: the guard adds the system's
/// time when it drops, early returns included, and systems that only read the
/// clock can still run in parallel. [`StatsPlugin`] publishes the sums as
/// [`KdContourStats::main_thread_ms`] (wall clock) and
/// [`KdContourStats::main_thread_cpu_ms`] (the threads' processor time) at the
/// end of the frame and starts over.
///
/// The two differ when a system's thread waits for a core: with every core
/// busy meshing, the kernel may give a chunk worker the rest of its time
/// slice before a frame thread it has just preempted (up to a scheduler tick,
/// 4 ms at 250 Hz, in spite of the workers' lower priority).
#[derive(Resource, Default, Debug)]
pub struct MainThreadClock {
    nanos: AtomicU64,
    cpu_nanos: AtomicU64,
}

/// The calling thread's processor time so far, ns (Linux; `None` elsewhere).
pub(crate) fn thread_cpu_ns() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `clock_gettime` writes the timespec it is given and reads
        // nothing else.
        let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) } == 0;
        ok.then(|| t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64)
    }
    #[cfg(not(target_os = "linux"))]
    None
}

impl MainThreadClock {
    /// Starts timing; the time counts when the returned guard drops.
    pub fn measure(&self) -> Measure<'_> {
        Measure {
            clock: self,
            watch: Stopwatch::start(),
        }
    }

    /// Adds time measured elsewhere (a command the plugin queued, which runs
    /// after its system's guard has dropped): `wall` on the clock, `cpu` (when
    /// known) as processor time.
    fn add(&self, wall: std::time::Duration, cpu: Option<u64>) {
        let ns = wall.as_nanos().min(u64::MAX as u128) as u64;
        self.nanos.fetch_add(ns, Ordering::Relaxed);
        self.cpu_nanos
            .fetch_add(cpu.unwrap_or(ns), Ordering::Relaxed);
    }

    /// The wall and processor times summed since the last call, in ms, and a
    /// fresh start.
    pub(crate) fn take_ms(&self) -> (f64, f64) {
        (
            self.nanos.swap(0, Ordering::Relaxed) as f64 * 1e-6,
            self.cpu_nanos.swap(0, Ordering::Relaxed) as f64 * 1e-6,
        )
    }
}

/// Adds the time since [`MainThreadClock::measure`] to the clock when dropped.
pub struct Measure<'a> {
    clock: &'a MainThreadClock,
    watch: Stopwatch,
}

impl Drop for Measure<'_> {
    fn drop(&mut self) {
        self.watch.add_to(self.clock);
    }
}

/// Wall and processor time since it started, on the calling thread.
pub(crate) struct Stopwatch {
    start: Instant,
    cpu_start: Option<u64>,
}

impl Stopwatch {
    /// Starts timing.
    pub(crate) fn start() -> Self {
        Stopwatch {
            start: Instant::now(),
            cpu_start: thread_cpu_ns(),
        }
    }

    /// The wall time and (where known) the processor time so far, in ns;
    /// processor first, so it lies inside the wall time.
    fn times(&self) -> (std::time::Duration, Option<u64>) {
        let cpu = self
            .cpu_start
            .zip(thread_cpu_ns())
            .map(|(a, b)| b.saturating_sub(a));
        (self.start.elapsed(), cpu)
    }

    /// The processor time so far in ms where it is known, else the wall time.
    #[cfg_attr(not(feature = "navmesh"), allow(dead_code))]
    pub(crate) fn ms(&self) -> f64 {
        match self.times() {
            (_, Some(ns)) => ns as f64 * 1e-6,
            (wall, None) => wall.as_secs_f64() * 1e3,
        }
    }

    /// Adds the time so far to `clock`, and returns it as [`Stopwatch::ms`].
    pub(crate) fn add_to(&self, clock: &MainThreadClock) -> f64 {
        let (wall, cpu) = self.times();
        clock.add(wall, cpu);
        cpu.map_or(wall.as_secs_f64() * 1e3, |ns| ns as f64 * 1e-6)
    }
}

/// Keeps [`KdContourStats`] up to date (in [`KdContourSystems::Stats`]).
pub struct StatsPlugin;

impl Plugin for StatsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<KdContourStats>()
            .init_resource::<MainThreadClock>()
            .register_type::<KdContourStats>()
            .add_systems(PostUpdate, gather_stats.in_set(KdContourSystems::Stats));
    }
}

/// Totals for [`KdContourStats`], and the frame's main-thread time.
fn gather_stats(
    clock: Res<MainThreadClock>,
    mut stats: ResMut<KdContourStats>,
    volumes: Query<&VolumeState>,
    chunks: Query<&KdChunk>,
) {
    let time = clock.measure();
    let (mut n, mut running, mut queued) = (0, 0, 0);
    for state in &volumes {
        let work = state.work_counts();
        n += state.loaded_chunks();
        running += work.running;
        queued += work.queued;
    }
    let (mut meshed, mut tris) = (0, 0);
    let mut range = (f32::INFINITY, f32::NEG_INFINITY);
    for chunk in &chunks {
        if chunk.triangles > 0 {
            meshed += 1;
            tris += chunk.triangles;
            range = (range.0.min(chunk.threshold), range.1.max(chunk.threshold));
        }
    }
    stats.chunks = n;
    stats.meshed_chunks = meshed;
    stats.triangles = tris;
    stats.tasks_in_flight = running;
    stats.queued = queued;
    stats.threshold_range = if meshed > 0 { range } else { (0.0, 0.0) };
    drop(time);
    (stats.main_thread_ms, stats.main_thread_cpu_ms) = clock.take_ms();
}
