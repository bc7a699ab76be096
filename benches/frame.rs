//! Main-thread time of one frame while the LOD camera moves: the plugin's
//! systems (LOD, streaming, scheduling, polling, uploads), meshing tasks aside.
//!
//! - `frame_1000_chunks`: a bounded volume of 1,000 chunks around a sphere.
//! - `frame_1000_chunks_colliders`: the same volume with avian physics on, every
//!   chunk within reach of the camera carrying a trimesh collider, and a
//!   collider anchor (a falling body's) moving through the volume, so chunks gain
//!   and lose colliders every frame; it prints the plugin's main-thread time per
//!   frame (mean, p99, max), the chunks with colliders, and the main thread's
//!   processor time of whole app updates with and without a physics step.
//! - `horizon_4096`: the terrain demo's field seen 4,096 cells out through chunk
//!   levels (32-cell chunks, meshing on 2 task threads), the camera flying at
//!   10, 25, 50 and 100 cells a second in turn, at 60 frames a second. Before
//!   measuring it prints the chunk count, retained bytes and the time the
//!   plugin took to build the whole view from scratch; after each speed, the
//!   plugin's own main-thread time per frame (mean, 99th percentile, max) over
//!   every measured frame, how far the camera was from where the shown
//!   levels were made for it (the lag: the plugin lays levels out for where
//!   a moving camera will be), and how long the level changes took.
//!
//! - `frame_navmesh`: the terrain demo's field seen 1,024 cells out, navmesh
//!   on: four agents (navigation anchors) walking circles at 5 units a second,
//!   one of them digging a pit where it stands every two seconds, the camera
//!   flying at 10 cells a second, at 60 frames a second. It prints the
//!   plugin's main-thread time per frame (mean, p99, max; linking tiles in
//!   counts) by the clock and as processor time, the whole update's
//!   main-thread processor time, the tiles built (and any on the main thread:
//!   none), and the time of a path query between two agents; then the same
//!   with tiles off. `frame_navmesh_spare_core` repeats it with one chunk
//!   worker fewer than the cores, so the frame's threads never wait for one.
//!
//! Every group but `frame_navmesh` runs with navmesh tiles off (the bench
//! builds with the tests' features, `navmesh` among them).
//!
//! `cargo bench -p bevy_kdcontour --bench frame`

use bevy::app::{TaskPoolOptions, TaskPoolPlugin, TaskPoolThreadAssignmentPolicy};
use bevy::prelude::*;
use bevy_kdcontour::headless::{run_until_settled, HeadlessPlugins};
use bevy_kdcontour::kdcontour::field::terrain::{Density, DensityParams};
use bevy_kdcontour::prelude::*;
use criterion::{criterion_group, criterion_main, Criterion};
use std::sync::Arc;
use std::time::Duration;

fn frame(c: &mut Criterion) {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        KdContourPlugins {
            settings: KdContourSettings {
                lod: LodSettings {
                    near: 0.2,
                    ..Default::default()
                },
                ..Default::default()
            },
        },
    ))
    // The bench builds with features `avian` and `navmesh` (the tests'
    // dev-dependency turns them on), which would give every chunk here a
    // collider and a tile: those are measured by `frame_colliders` and
    // `frame_navmesh`, so this one is the plugin without them.
    .insert_resource(bevy_kdcontour::ColliderSettings {
        enabled: false,
        ..Default::default()
    })
    .insert_resource(no_navmesh());
    let volume = spawn_sphere_volume(&mut app);
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(1.0, 1.0, -1.0)))
        .id();
    assert!(
        run_until_settled(&mut app, volume, 20_000, Duration::ZERO),
        "the volume did not settle"
    );
    let mut t = 0.0f32;
    let mut g = c.benchmark_group("frame_1000_chunks");
    g.sample_size(50).measurement_time(Duration::from_secs(5));
    g.bench_function("camera_moving", |b| {
        b.iter(|| {
            t += 0.05;
            app.world_mut()
                .get_mut::<Transform>(cam)
                .unwrap()
                .translation = Vec3::new(1.0 + 1.5 * t.cos(), 1.0, 1.0 + 1.5 * t.sin());
            app.update();
        })
    });
    g.bench_function("camera_still", |b| b.iter(|| app.update()));
    g.finish();
}

/// The 1,000-chunk volume of [`frame`] and [`frame_colliders`]: 10 x 10 x 10
/// chunks of 8^3 cells around a sphere.
fn spawn_sphere_volume(app: &mut App) -> Entity {
    let field: Arc<dyn kdcontour::Field> = Arc::new(kdcontour::field::FnField(|p: Vec3| {
        (p - Vec3::splat(1.0)).length() - 0.8
    }));
    app.world_mut()
        .spawn(KdVolume::new(field, UVec3::splat(10), 8, 2.0 / 80.0))
        .id()
}

/// Two async compute threads (Bevy gives it a quarter of the cores, one on this
/// 2-core machine) for the level changes' layouts; the meshing itself runs on the
/// plugin's chunk workers, one per core.
fn two_task_threads() -> TaskPoolPlugin {
    TaskPoolPlugin {
        task_pool_options: TaskPoolOptions {
            async_compute: TaskPoolThreadAssignmentPolicy {
                min_threads: 2,
                max_threads: 2,
                percent: 1.0,
                on_thread_spawn: None,
                on_thread_destroy: None,
            },
            ..default()
        },
    }
}

/// Navmesh tiles off (for the groups that do not measure them).
fn no_navmesh() -> bevy_kdcontour::NavmeshSettings {
    bevy_kdcontour::NavmeshSettings {
        enabled: false,
        ..Default::default()
    }
}

/// A headless app with the terrain demo's settings (camera LOD, 16 tasks in
/// flight) on 2 task threads, for `horizon_4096` and `frame_navmesh`.
fn demo_app(chunk_threads: usize) -> App {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins.set(two_task_threads()),
        KdContourPlugins {
            settings: KdContourSettings {
                max_tasks_in_flight: 16,
                chunk_threads,
                lod: LodSettings {
                    base: 0.02,
                    near: 40.0,
                    growth: 2.0,
                    max: 4.0,
                    ..Default::default()
                },
                ..Default::default()
            },
        },
    ));
    app
}

fn horizon(c: &mut Criterion) {
    let mut app = demo_app(0);
    app.insert_resource(no_navmesh());
    let field: Arc<dyn kdcontour::Field> = Arc::new(Density::new(DensityParams::demo(7)));
    let volume = app
        .world_mut()
        .spawn(KdVolume::horizon(field, 32, 1.0, 4096).with_rows(-3, 1))
        .id();
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 40.0, 0.0)))
        .id();
    let t0 = std::time::Instant::now();
    let cpu0 = process_cpu_s();
    assert!(
        run_until_settled(&mut app, volume, 1_000_000, Duration::from_millis(1)),
        "the view did not settle"
    );
    let built = t0.elapsed();
    let built_cpu = process_cpu_s() - cpu0;
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let mut levels = std::collections::BTreeMap::<u32, usize>::new();
    for (k, _) in state.shown_chunks() {
        *levels.entry(k.level).or_default() += 1;
    }
    let stats = app.world().resource::<KdContourStats>();
    println!(
        "horizon_4096: {} chunks {:?} (by level), {:.1} MB retained, whole view built in {:.1} s \
         using {:.1} s of processor time ({} builds of {:.1} ms and {} extractions of {:.1} ms, \
         recent means)",
        state.shown_chunks().len(),
        levels,
        state.world().retained_bytes() as f64 / 1e6,
        built.as_secs_f64(),
        built_cpu,
        stats.builds,
        stats.build_ms,
        stats.extractions,
        stats.extract_ms,
    );
    // The camera flies along x and a little z at 60 frames a second, at each
    // speed in turn, from where the last flight left it.
    let mut g = c.benchmark_group("horizon_4096");
    g.sample_size(10).measurement_time(Duration::from_secs(15));
    for speed in HORIZON_SPEEDS {
        let step = Vec3::new(50.0, 0.0, 10.0).normalize() * (speed / 60.0);
        let mut frames: Vec<f64> = Vec::new();
        let mut cpu: Vec<f64> = Vec::new();
        // How far (cells) the camera is from where the shown layout was made
        // for it, and how many level changes landed.
        let mut lag: Vec<f32> = Vec::new();
        let mut changes = 0usize;
        // How long each of them took, from its layout's request to shown.
        let mut took: Vec<f64> = Vec::new();
        let mut shown_for = Vec3::NAN;
        g.bench_function(format!("camera_flying_{speed}_cells_per_s"), |b| {
            b.iter_custom(|n| {
                let mut total = Duration::ZERO;
                for _ in 0..n {
                    app.world_mut()
                        .get_mut::<Transform>(cam)
                        .unwrap()
                        .translation += step;
                    let t = std::time::Instant::now();
                    let c0 = thread_cpu_ms();
                    app.update();
                    cpu.push(thread_cpu_ms() - c0);
                    total += t.elapsed();
                    let state = app.world().get::<VolumeState>(volume).unwrap();
                    if let Some((_, keep)) = state.horizon_shown() {
                        let at = app.world().get::<Transform>(cam).unwrap().translation;
                        // Level-0 chunks of 32 cells of 1.
                        let made_for = keep.camera * 32.0;
                        if made_for != shown_for {
                            shown_for = made_for;
                            changes += 1;
                            took.push(state.level_change_seconds());
                        }
                        lag.push(at.xz().distance(made_for.xz()));
                    }
                    frames.push(app.world().resource::<KdContourStats>().main_thread_ms);
                    // The rest of a 60 Hz frame, so the task threads mesh as
                    // they would in a game.
                    std::thread::sleep(Duration::from_micros(16_667).saturating_sub(t.elapsed()));
                }
                total
            })
        });
        // A filter that leaves this speed out measures nothing.
        let (Some((mean, p99, max)), Some((cpu_mean, cpu_p99, cpu_max))) =
            (spread(&mut frames), spread(&mut cpu))
        else {
            continue;
        };
        println!(
            "horizon_4096 at {speed} cells/s: plugin main thread per frame over {} frames: \
             mean {mean:.3} ms, p99 {p99:.3} ms, max {max:.3} ms",
            frames.len(),
        );
        lag.sort_by(f32::total_cmp);
        println!(
            "horizon_4096 at {speed} cells/s: {changes} level changes shown; the camera is \
             {:.0} cells (mean), {:.0} (max) along x and z from where the shown layout was \
             made for it",
            lag.iter().sum::<f32>() / lag.len().max(1) as f32,
            lag.last().copied().unwrap_or(0.0)
        );
        if let Some((took_mean, _, took_max)) = spread(&mut took) {
            println!(
                "horizon_4096 at {speed} cells/s: a level change takes {took_mean:.2} s \
                 (mean), {took_max:.2} s (max) from its layout's request to shown",
            );
        }
        println!(
            "horizon_4096 at {speed} cells/s: whole app update, main thread processor time \
             per frame: mean {cpu_mean:.3} ms, p99 {cpu_p99:.3} ms, max {cpu_max:.3} ms",
        );
    }
    g.finish();
}

/// The camera speeds of `horizon_4096` (cells a second), flown in this order.
const HORIZON_SPEEDS: [f32; 4] = [10.0, 25.0, 50.0, 100.0];

/// Mean, 99th percentile and max of `v` (sorting it); `None` when it is empty.
fn spread(v: &mut [f64]) -> Option<(f64, f64, f64)> {
    let last = v.len().checked_sub(1)?;
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    Some((mean, v[(v.len() * 99 / 100).min(last)], v[last]))
}

/// Processor time the whole process has run, in s (Linux: `/proc/self/stat`,
/// user plus system, in 10 ms ticks; 0 elsewhere).
fn process_cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            // Fields after the command name (which may hold spaces): utime and
            // stime are the 12th and 13th.
            let mut f = s.rsplit_once(')')?.1.split_whitespace().skip(11);
            let user: u64 = f.next()?.parse().ok()?;
            let system: u64 = f.next()?.parse().ok()?;
            Some((user + system) as f64 / 100.0)
        })
        .unwrap_or(0.0)
}

/// Processor time this thread has run, in ms (Linux: `/proc/thread-self/schedstat`;
/// 0 elsewhere): unlike a clock, it leaves out the time the thread waited for a
/// core, so it shows the work a frame put on the main thread.
fn thread_cpu_ms() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .map_or(0.0, |ns| ns as f64 * 1e-6)
}

/// [`frame`] with colliders: the plugin's main thread per frame while chunks gain
/// and lose colliders around a moving anchor. The same volume with physics on
/// and colliders off is measured after it (as many updates, no criterion), so
/// avian's own step shows apart from what the colliders add.
fn frame_colliders(c: &mut Criterion) {
    let mut on = ColliderRun::new(true);
    let mut g = c.benchmark_group("frame_1000_chunks_colliders");
    g.sample_size(50).measurement_time(Duration::from_secs(5));
    g.bench_function("anchor_moving", |b| b.iter(|| on.update()));
    g.finish();
    on.report("colliders on");
    let mut off = ColliderRun::new(false);
    for _ in 0..on.frames.len() {
        off.update();
    }
    off.report("colliders off (baseline)");
}

/// One app of [`frame_colliders`] and what its updates measured.
struct ColliderRun {
    app: App,
    anchor: Entity,
    t: f32,
    /// The plugin's main-thread time per update (its clock).
    frames: Vec<f64>,
    /// Main-thread processor time of whole app updates, apart by whether avian
    /// stepped in them (a fixed 64 Hz step: about one update in 15 here, where
    /// updates follow each other with no frame pacing).
    cpu: Vec<f64>,
    cpu_step: Vec<f64>,
}

impl ColliderRun {
    /// The settled 1,000-chunk volume, avian on, chunk colliders on or off.
    fn new(enabled: bool) -> Self {
        use bevy_kdcontour::avian3d::prelude::*;
        use bevy_kdcontour::{ColliderAnchor, ColliderSettings};
        let mut app = App::new();
        app.add_plugins((
            HeadlessPlugins,
            KdContourPlugins::default(),
            PhysicsPlugins::default(),
        ))
        .insert_resource(ColliderSettings {
            enabled,
            // Chunks are 0.2 units: about 250 chunks around the camera and anchor.
            distance: 0.5,
            ..Default::default()
        })
        .insert_resource(no_navmesh());
        // `App::run` does this; avian sets up its diagnostics resources in `finish`.
        app.finish();
        app.cleanup();
        let volume = spawn_sphere_volume(&mut app);
        app.world_mut()
            .spawn((LodCamera, Transform::from_xyz(1.0, 1.9, 1.0)));
        let anchor = app
            .world_mut()
            .spawn((ColliderAnchor, Transform::from_xyz(1.0, 1.0, 0.1)))
            .id();
        assert!(
            run_until_settled(&mut app, volume, 20_000, Duration::ZERO),
            "the volume did not settle"
        );
        Self {
            app,
            anchor,
            t: 0.0,
            frames: Vec::new(),
            cpu: Vec::new(),
            cpu_step: Vec::new(),
        }
    }

    /// Moves the anchor a step and runs one measured update.
    fn update(&mut self) {
        self.t += 0.02;
        let t = self.t;
        let app = &mut self.app;
        app.world_mut()
            .get_mut::<Transform>(self.anchor)
            .unwrap()
            .translation = Vec3::new(1.0 + 0.9 * t.cos(), 1.0, 1.0 + 0.9 * t.sin());
        let step0 = app.world().resource::<Time<Fixed>>().elapsed();
        let c0 = thread_cpu_ms();
        app.update();
        let ms = thread_cpu_ms() - c0;
        if app.world().resource::<Time<Fixed>>().elapsed() == step0 {
            self.cpu.push(ms);
        } else {
            self.cpu_step.push(ms);
        }
        self.frames
            .push(app.world().resource::<KdContourStats>().main_thread_ms);
    }

    /// Prints the figures.
    fn report(&mut self, what: &str) {
        use bevy_kdcontour::avian3d::prelude::Collider;
        let with = self
            .app
            .world_mut()
            .query::<(&KdChunk, &Collider)>()
            .iter(self.app.world())
            .count();
        let (n, steps) = (self.frames.len(), self.cpu_step.len());
        let (
            Some((mean, p99, max)),
            Some((cpu_mean, cpu_p99, cpu_max)),
            Some((st_mean, st_p99, st_max)),
        ) = (
            spread(&mut self.frames),
            spread(&mut self.cpu),
            spread(&mut self.cpu_step),
        )
        else {
            return;
        };
        println!(
            "frame_1000_chunks_colliders, {what}: {with} chunks with colliders at the end; \
             plugin main thread per frame (clock) over {n} frames: mean {mean:.3} ms, p99 \
             {p99:.3} ms, max {max:.3} ms; whole app update, main thread processor time: \
             without a physics step mean {cpu_mean:.3} ms, p99 {cpu_p99:.3} ms, max \
             {cpu_max:.3} ms; with avian's step ({steps} updates) mean {st_mean:.3} ms, p99 \
             {st_p99:.3} ms, max {st_max:.3} ms"
        );
    }
}

/// The terrain's ground height at `(x, z)` (a ray down the field).
fn ground(field: &dyn kdcontour::Field, x: f32, z: f32) -> Vec3 {
    let top = Vec3::new(x, 120.0, z);
    let t = kdcontour::field::raycast(field, top, Vec3::NEG_Y, 400.0, 0.5).unwrap_or(120.0);
    top - Vec3::Y * t
}

fn frame_navmesh(c: &mut Criterion) {
    navmesh_walk(c, "frame_navmesh", 0);
    // The same with one core left to the frame's threads: 1 chunk worker on
    // this 2-core machine.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    navmesh_walk(
        c,
        "frame_navmesh_spare_core",
        cores.saturating_sub(1).max(1),
    );
}

/// Wall-clock and processor-time spreads of the plugin's main-thread time over
/// some frames, printed as one line.
#[derive(Default)]
struct PluginTimes {
    wall: Vec<f64>,
    cpu: Vec<f64>,
}

impl PluginTimes {
    fn push(&mut self, wall: f64, cpu: f64) {
        self.wall.push(wall);
        self.cpu.push(cpu);
    }

    fn line(&mut self) -> String {
        let show = |v: &mut Vec<f64>| match spread(v) {
            Some((mean, p99, max)) => {
                format!("mean {mean:.3} ms, p99 {p99:.3} ms, max {max:.3} ms")
            }
            None => "no frames".into(),
        };
        format!(
            "by the clock {}; processor time {}",
            show(&mut self.wall),
            show(&mut self.cpu)
        )
    }
}

/// [`frame_navmesh`] with `chunk_threads` chunk workers (0: one per core).
fn navmesh_walk(c: &mut Criterion, name: &str, chunk_threads: usize) {
    use bevy_kdcontour::{NavAnchor, NavStats, VolumeNavMesh};
    let mut app = demo_app(chunk_threads);
    app.insert_resource(bevy_kdcontour::ColliderSettings {
        enabled: false,
        ..Default::default()
    });
    let field: Arc<dyn kdcontour::Field> = Arc::new(Density::new(DensityParams::demo(7)));
    let volume = app
        .world_mut()
        .spawn(KdVolume::horizon(field.clone(), 32, 1.0, 1024).with_rows(-3, 1))
        .id();
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(0.0, 40.0, 0.0)))
        .id();
    let circles: Vec<(f32, f32)> = (0..4)
        .map(|i| (12.0 + 8.0 * i as f32, i as f32 * 1.6))
        .collect();
    let agents: Vec<Entity> = circles
        .iter()
        .map(|(r, a)| {
            let at = ground(&*field, r * a.cos(), r * a.sin());
            app.world_mut()
                .spawn((NavAnchor, Transform::from_translation(at)))
                .id()
        })
        .collect();
    assert!(
        run_until_settled(&mut app, volume, 1_000_000, Duration::from_millis(1)),
        "the view did not settle"
    );
    let settled = app.world().resource::<NavStats>().clone();
    println!(
        "{name}: {} chunk workers; {} tiles, {} polygons, {} links after the first view; {} \
         tile builds of {:.1} ms mean, {:.1} ms max, {} on the main thread",
        match chunk_threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        },
        settled.tiles,
        settled.polygons,
        settled.links,
        settled.tiles_built,
        settled.build_ms / settled.tiles_built.max(1) as f64,
        settled.build_ms_max,
        settled.built_on_main_thread,
    );
    let mut plugin = PluginTimes::default();
    let mut own = PluginTimes::default();
    let mut cpu: Vec<f64> = Vec::new();
    let mut queries: Vec<f64> = Vec::new();
    let (mut found, mut missed) = (0, 0);
    let mut walk = NavWalk {
        frame: 0,
        cam,
        agents: agents.clone(),
        circles,
        field: field.clone(),
        volume,
    };
    let mut g = c.benchmark_group(name);
    g.sample_size(10).measurement_time(Duration::from_secs(15));
    g.bench_function("agents_walking_and_digging", |b| {
        b.iter_custom(|n| {
            let mut total = Duration::ZERO;
            for _ in 0..n {
                walk.advance(&mut app);
                let t0 = std::time::Instant::now();
                let c0 = thread_cpu_ms();
                app.update();
                cpu.push(thread_cpu_ms() - c0);
                total += t0.elapsed();
                let stats = app.world().resource::<KdContourStats>();
                plugin.push(stats.main_thread_ms, stats.main_thread_cpu_ms);
                let nav = app.world().resource::<NavStats>();
                own.push(nav.main_thread_ms, nav.main_thread_cpu_ms);
                if walk.frame.is_multiple_of(30) {
                    let at = |e: Entity| app.world().get::<Transform>(e).unwrap().translation;
                    // Two agents that do not dig (the first digs itself into
                    // its pits).
                    let (a, b) = (at(agents[1]), at(agents[3]));
                    let nav = app.world().get::<VolumeNavMesh>(volume).unwrap();
                    let q = std::time::Instant::now();
                    match nav.find_path(a + Vec3::Y, b + Vec3::Y) {
                        Ok(_) => found += 1,
                        Err(e) => {
                            missed += 1;
                            if missed <= 3 {
                                println!("{name}: no path from {a} to {b}: {e}");
                            }
                        }
                    }
                    queries.push(q.elapsed().as_secs_f64() * 1e3);
                }
                std::thread::sleep(Duration::from_micros(16_667).saturating_sub(t0.elapsed()));
            }
            total
        })
    });
    g.finish();
    let end = app.world().resource::<NavStats>().clone();
    // The same walk and digging with tiles off, as many frames: the baseline.
    app.world_mut()
        .resource_mut::<bevy_kdcontour::NavmeshSettings>()
        .enabled = false;
    let mut off = PluginTimes::default();
    let mut off_cpu: Vec<f64> = Vec::new();
    for _ in 0..plugin.wall.len() {
        walk.advance(&mut app);
        let t0 = std::time::Instant::now();
        let c0 = thread_cpu_ms();
        app.update();
        off_cpu.push(thread_cpu_ms() - c0);
        let stats = app.world().resource::<KdContourStats>();
        off.push(stats.main_thread_ms, stats.main_thread_cpu_ms);
        std::thread::sleep(Duration::from_micros(16_667).saturating_sub(t0.elapsed()));
    }
    let frames = plugin.wall.len();
    if let Some((c_mean, c_p99, c_max)) = spread(&mut off_cpu) {
        println!(
            "{name}, tiles off (baseline): plugin main thread per frame over {frames} frames: \
             {}; whole app update, main thread processor time: mean {c_mean:.3} ms, p99 \
             {c_p99:.3} ms, max {c_max:.3} ms",
            off.line()
        );
    }
    let (Some((c_mean, c_p99, c_max)), Some((q_mean, q_p99, q_max))) =
        (spread(&mut cpu), spread(&mut queries))
    else {
        return;
    };
    println!(
        "{name}: plugin main thread per frame over {frames} frames: {}; whole app update, main \
         thread processor time: mean {c_mean:.3} ms, p99 {c_p99:.3} ms, max {c_max:.3} ms",
        plugin.line()
    );
    println!(
        "{name}: the navmesh subsystem's own main-thread time per frame (its systems and \
         linking tiles in): {}",
        own.line()
    );
    let built = end.tiles_built - settled.tiles_built;
    println!(
        "{name}: {built} tiles built while walking ({} on the main thread, {} failed; {:.1} ms \
         each in the tasks), {} tiles at the end; linking on the main thread (processor time): \
         {:.3} ms a tile, {:.3} ms the slowest; path between two agents: {found} found, \
         {missed} not, query mean {q_mean:.3} ms, p99 {q_p99:.3} ms, max {q_max:.3} ms",
        end.built_on_main_thread,
        end.failures,
        (end.build_ms - settled.build_ms) / built.max(1) as f64,
        end.tiles,
        (end.link_ms - settled.link_ms) / built.max(1) as f64,
        end.link_ms_max,
    );
}

/// What moves in [`frame_navmesh`]: the camera flying at 10 cells a second,
/// the agents walking circles at 5 units a second on the ground, the first
/// digging a pit where it stands every 120 frames.
struct NavWalk {
    frame: u64,
    cam: Entity,
    agents: Vec<Entity>,
    /// Each agent's circle: radius and starting angle.
    circles: Vec<(f32, f32)>,
    field: Arc<dyn kdcontour::Field>,
    volume: Entity,
}

impl NavWalk {
    /// Moves everything one 60 Hz frame on (the update is the caller's).
    fn advance(&mut self, app: &mut App) {
        use bevy_kdcontour::kdcontour::edit::{Brush, BrushOp};
        self.frame += 1;
        let t = self.frame as f32 / 60.0;
        let step = Vec3::new(50.0, 0.0, 10.0).normalize() * (10.0 / 60.0);
        app.world_mut()
            .get_mut::<Transform>(self.cam)
            .unwrap()
            .translation += step;
        for (i, (&agent, (r, a))) in self.agents.iter().zip(&self.circles).enumerate() {
            let angle = a + t * 5.0 / r * if i % 2 == 0 { 1.0 } else { -1.0 };
            let at = ground(&*self.field, r * angle.cos(), r * angle.sin());
            app.world_mut()
                .get_mut::<Transform>(agent)
                .unwrap()
                .translation = at;
            if i == 0 && self.frame.is_multiple_of(120) {
                app.world_mut().write_message(ApplyEdit::new(
                    self.volume,
                    Brush::sphere(at, 3.0, BrushOp::SmoothSubtract { radius: 1.0 }),
                ));
            }
        }
    }
}

criterion_group!(benches, frame, frame_colliders, horizon, frame_navmesh);
criterion_main!(benches);
