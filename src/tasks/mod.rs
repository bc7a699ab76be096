//! Meshing tasks: [`TasksPlugin`] starts chunk builds (sample, Hermite data,
//! retained tree) and extractions (interior plus owned seams at the chunk's
//! threshold) on the [`ChunkWorkers`], nearest the camera first and at most
//! [`KdContourSettings::max_tasks_in_flight`] at once (in
//! [`KdContourSystems::Schedule`]), and collects them with `check_ready` (in
//! [`KdContourSystems::Poll`]): a result from an older field or threshold is
//! dropped, and a panic inside a build or an extraction is reported as
//! [`ChunkFailed`] (a failed extraction leaves the chunk's mesh as it was; a
//! panic in one of its extras, a collider or a navmesh tile, is reported and
//! the mesh lands without that extra).

use crate::mesh::{build_extras, ReadyMesh};
use crate::messages::ChunkFailed;
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::{KdContourStats, MainThreadClock};
use crate::volume::{ChunkStatus, KdChunk};
use crate::workers::ChunkWorkers;
use crate::KdContourSystems;
use bevy::prelude::*;
use bevy::tasks::futures::check_ready;
use kdcontour::world::ChunkKey;
use kdcontour::IndexedMesh;
use work::{BuildOut, ExtractOut};

pub(crate) mod work;

/// Starts and collects meshing tasks.
pub struct TasksPlugin;

impl Plugin for TasksPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourStats>()
            .init_resource::<KdContourSettings>()
            .add_systems(
                PostUpdate,
                (
                    schedule_tasks.in_set(KdContourSystems::Schedule),
                    poll_tasks.in_set(KdContourSystems::Poll),
                ),
            );
    }
}

/// The two kinds of chunk work, in the order they are scheduled.
#[derive(Clone, Copy)]
enum Work {
    /// Cheap (well under a millisecond) and shows built chunks at once; seams to
    /// neighbours not built yet are re-cut when those land.
    Extract,
    Build,
}

/// Chunks waiting for `work` that can start now, nearest the camera first
/// (ties in a fixed order, so runs are reproducible).
fn waiting(state: &VolumeState, work: Work) -> Vec<ChunkKey> {
    let mut v: Vec<ChunkKey> = state
        .slots
        .iter()
        .filter(|(_, s)| match work {
            // Not while a build of the chunk is queued or running: its tree
            // is about to change.
            Work::Extract => s.work.need_extract && s.work.building.is_none() && !s.work.need_build,
            Work::Build => s.work.need_build && s.work.building.is_none(),
        })
        .map(|(c, _)| *c)
        // An extraction reads the trees of its seams' chunks: one whose
        // partner is about to change would be done again when it lands
        // (a horizon's first load did each 2.5 times).
        .filter(|c| matches!(work, Work::Build) || !partner_pending(state, c))
        .collect();
    state.nearest_first(&mut v);
    v
}

/// Whether a chunk of a seam `c` owns waits for a build: its tree is about
/// to change, and a seam cut against the old one may not fit the new (an
/// edit reached both).
fn partner_pending(state: &VolumeState, c: &ChunkKey) -> bool {
    let pending =
        |p: &ChunkKey| p != c && state.slots.get(p).is_some_and(|s| s.work.build_pending());
    match state.horizon.seam_partners(c) {
        Some(ps) => ps.iter().any(pending),
        None => state
            .world()
            .owned_seams(c)
            .iter()
            .any(|s| s.chunks().iter().any(pending)),
    }
}

/// Starts `work` on chunk `c`; false when no task was needed.
fn start(state: &mut VolumeState, workers: &ChunkWorkers, work: Work, c: ChunkKey) -> bool {
    match work {
        Work::Extract => {
            let threshold = state.world().threshold(&c);
            let snapshot = state.world().snapshot(&c);
            let field = state.field().clone();
            // Creases are looked for at the finest level's scale at every
            // level: a far chunk's coarse faces bend at their own scale
            // everywhere, and splitting there would draw whole faces in
            // one material (angular patches on distant hills).
            let cell = state.world().cell_size;
            let extras = state.extras_for(&state.slots[&c]);
            let slot = state.slots.get_mut(&c).expect("listed");
            slot.work.need_extract = false;
            let Some(snapshot) = snapshot else {
                // No tree (no surface yet, or its build failed): show nothing.
                slot.work.extracting = None;
                slot.work.ready = Some(ReadyMesh::new(threshold, &IndexedMesh::default()));
                return false;
            };
            let stamp = slot.work.extract_stamp;
            // A newer extraction replaces a running one: dropping its task
            // cancels it (its stamp would be stale anyway).
            slot.work.extracting = Some(workers.run(move || {
                let t = std::time::Instant::now();
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    let mut mesh = IndexedMesh::default();
                    // Vertex materials come from the tree, when the volume's
                    // world carries them (a terrain material).
                    snapshot.extract(&mut mesh);
                    // The extras (a collider, a navmesh tile) take the welded
                    // mesh; the drawn one has its vertices split along hard
                    // material borders, so a border is drawn along the crease,
                    // not as a sawtooth across it.
                    let (extra, failures) = build_extras(extras, &mesh);
                    kdcontour::material::split_borders(&mut mesh, &field, cell);
                    let mut ready = ReadyMesh::new(threshold, &mesh);
                    ready.extra = extra;
                    ready.extra_failures = failures;
                    ready
                }))
                .map_err(|p| format!("the extraction panicked: {}", panic_message(&*p)));
                ExtractOut {
                    stamp,
                    mesh: result,
                    ms: t.elapsed().as_secs_f64() * 1e3,
                }
            }));
        }
        Work::Build => {
            let job = state.world().chunk_build(&c);
            let field = state.field().clone();
            let slot = state.slots.get_mut(&c).expect("listed");
            slot.work.need_build = false;
            let generation = slot.work.build_gen;
            slot.work.building = Some(workers.run(move || {
                let t = std::time::Instant::now();
                let result =
                    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job.build(&field)))
                        .map_err(|p| format!("the field panicked: {}", panic_message(&*p)))
                        .and_then(|r| r.map_err(|e| e.to_string()));
                BuildOut {
                    generation,
                    job,
                    result,
                    ms: t.elapsed().as_secs_f64() * 1e3,
                }
            }));
        }
    }
    true
}

/// The text of a caught panic.
pub(crate) fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

fn schedule_tasks(
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    mut volumes: Query<&mut VolumeState>,
    mut chunks: Query<&mut KdChunk>,
    mut workers: Local<Option<ChunkWorkers>>,
) {
    let _time = clock.measure();
    // Started on first use, and again when the thread count changes (the old
    // workers finish what they have queued).
    if workers
        .as_ref()
        .is_none_or(|w| w.wanted() != settings.chunk_threads)
    {
        *workers = Some(ChunkWorkers::new(settings.chunk_threads));
    }
    let workers = workers.as_ref().expect("just started");
    let mut in_flight: usize = volumes.iter().map(|s| s.work_counts().running).sum();
    for mut state in &mut volumes {
        // During a level change nothing it waits for shows before every build
        // has landed, and a build re-queues its neighbours' extractions: build
        // first, so no extraction is done twice. (A first load shows chunks as
        // they land, so it extracts first, as a one-level volume does.)
        let order = if state.horizon.holds() {
            [Work::Build, Work::Extract]
        } else {
            [Work::Extract, Work::Build]
        };
        for work in order {
            // Finding and sorting the waiting chunks costs more than anything
            // else here with many chunks: not when no task can start.
            if in_flight >= settings.max_tasks_in_flight {
                return;
            }
            for c in waiting(&state, work) {
                if in_flight >= settings.max_tasks_in_flight {
                    return;
                }
                if !start(&mut state, workers, work, c) {
                    continue;
                }
                in_flight += 1;
                if let (Work::Build, Some(mut ch)) = (
                    work,
                    state.chunk_entity(&c).and_then(|e| chunks.get_mut(e).ok()),
                ) {
                    ch.status = ChunkStatus::Busy;
                }
            }
        }
    }
}

/// A chunk's build or extraction failed: logged, shown on its `KdChunk`, and
/// reported as [`ChunkFailed`].
fn report_failure(
    volume: Entity,
    c: ChunkKey,
    chunk: Option<Entity>,
    error: String,
    chunks: &mut Query<&mut KdChunk>,
    failed: &mut MessageWriter<ChunkFailed>,
) {
    error!(
        "chunk {} (level {}) of volume {volume}: {error}",
        c.coord, c.level
    );
    if let Some(mut ch) = chunk.and_then(|e| chunks.get_mut(e).ok()) {
        ch.status = ChunkStatus::Failed(error.clone());
    }
    failed.write(ChunkFailed {
        volume,
        coord: c.coord,
        level: c.level,
        error,
    });
}

fn poll_tasks(
    clock: Res<MainThreadClock>,
    mut stats: ResMut<KdContourStats>,
    mut volumes: Query<(Entity, &mut VolumeState)>,
    mut chunks: Query<&mut KdChunk>,
    mut failed: MessageWriter<ChunkFailed>,
) {
    let _time = clock.measure();
    for (entity, mut state) in &mut volumes {
        let state = &mut *state;
        // Builds first: a new tree queues new extractions, so an extraction
        // of the old tree that lands in the same frame is dropped below.
        let mut built = Vec::new();
        for (&c, slot) in state.slots.iter_mut() {
            if let Some(out) = slot.work.building.as_mut().and_then(check_ready) {
                slot.work.building = None;
                stats.record_build(out.ms);
                // An edit that came after this build started queued a newer one.
                if out.generation == slot.work.build_gen {
                    built.push((c, out.job, out.result));
                }
            }
        }
        built.sort_by_key(|(c, _, _)| c.order());
        for (c, job, result) in built {
            match result {
                Ok(built) => state.world_mut().insert_built(&job, built),
                Err(error) => {
                    state.world_mut().remove_tree(&c);
                    let chunk = state.chunk_entity(&c);
                    report_failure(entity, c, chunk, error, &mut chunks, &mut failed);
                }
            }
            state.mark_extract(&c);
        }
        for (c, slot) in state.slots.iter_mut() {
            if let Some(out) = slot.work.extracting.as_mut().and_then(check_ready) {
                slot.work.extracting = None;
                stats.record_extraction(out.ms);
                if out.stamp != slot.work.extract_stamp {
                    continue;
                }
                match out.mesh {
                    Ok(mut mesh) => {
                        // The mesh lands without the extras that panicked.
                        for error in std::mem::take(&mut mesh.extra_failures) {
                            let chunk = Some(slot.entity());
                            report_failure(entity, *c, chunk, error, &mut chunks, &mut failed);
                        }
                        slot.work.ready = Some(mesh);
                    }
                    // The chunk keeps the mesh it shows.
                    Err(error) => {
                        let chunk = Some(slot.entity());
                        report_failure(entity, *c, chunk, error, &mut chunks, &mut failed);
                    }
                }
            }
        }
    }
}
