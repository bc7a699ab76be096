//! The far horizon: chunk levels around the camera for
//! [`VolumeExtent::Horizon`](crate::VolumeExtent::Horizon) volumes (run by the
//! streaming subsystem).
//!
//! ## The layout
//! The core's [`World`] holds an octree of chunks over a region of top-level
//! chunks (level `T`, the smallest whose chunks are at least `view_cells` wide):
//! along x and z the 3 x 3 top chunks around the one that holds the camera, so
//! the terrain reaches at least `view_cells` out; along y the top chunks that
//! cover the volume's rows. [`Layout::around`] splits a chunk while the camera
//! is within `level0_cells / (2 * chunk_res)` of its own side, so level-0 chunks
//! reach about `level0_cells` from the camera and every level about twice as far
//! as the one below it, balanced 2:1. Chunks wholly outside the rows get no
//! entity and are not built, and so are chunks farther than `view_cells` from
//! the camera along x and z ([`HorizonKeep`]). The layout is recomputed when the
//! camera enters another level-0 chunk, on a task thread (with every chunk's
//! neighbourhood, [`PreparedLayout`]), so the main thread only does the
//! bookkeeping.
//!
//! A moving camera is laid out for where it will be ([`motion`]): its
//! position ahead by its velocity times one and a half level changes (at most
//! the reach of level 2), so a level change lands with the camera near the
//! point it was made for instead of a change's flight behind it. "The camera"
//! above is that point; a still camera's is the camera itself.
//!
//! ## Changing levels without a hole or an overlap
//! A new layout adds chunks, drops chunks, and changes the neighbourhood (so the
//! samples, see [`kdcontour::world`]) or the seams of chunks it keeps. A
//! level change is a transition: it waits for a new mesh of every added
//! chunk, every kept chunk whose neighbourhood changed, and every chunk that
//! owns a seam touching one of them or a dropped chunk. Those meshes are held
//! back, and the dropped chunks stay shown, until all of them are ready; then
//! the held meshes are shown and the dropped chunks despawned in one frame. So
//! the shown chunks always cover the loaded region exactly once, and never show
//! two levels in the same place. While a transition runs, the next layout waits
//! (the camera's latest position is used when it ends), builds are scheduled
//! before extractions (a landing build re-queues its neighbours' extractions),
//! and a threshold change that would re-extract a held chunk waits for the end
//! (so camera moves cannot starve it). Edits go on as usual: an edit that
//! reaches a waiting chunk makes the transition wait for its rebuild too, so no
//! edit is lost.
//!
//! The first layout of a volume replaces nothing: its chunks show as they land.
//!
//! ## Trees for the thresholds the curve gives
//! A chunk of a horizon layout takes the LOD curve at its distance in its own
//! level's cells, and the layout keeps every chunk within a few of its own
//! widths of the camera ([`Layout::around_reach`]). So the volume's trees are
//! built for thresholds up to the curve's there, two more widths out for a
//! camera ahead of its layout ([`max_threshold`], as
//! [`kdcontour::Settings::max_threshold`]): the fold guard checks no merge
//! above it. A chunk asked for more (a camera far from its layout, or a
//! setting raised at run time until the chunk is rebuilt) is cut at it, finer
//! than asked and never folded.

pub(crate) mod layout;
pub(crate) mod motion;

pub use layout::{horizon_layout, HorizonKeep};
use layout::{top_level, NextLayout, Rows};

use crate::state::VolumeState;
use crate::volume::KdVolume;
use crate::workers::drop_elsewhere;
use bevy::prelude::*;
use bevy::tasks::{futures::check_ready, AsyncComputeTaskPool};
use kdcontour::world::layout::MAX_LEVEL;
use kdcontour::world::{ChunkKey, ChunkSet, Layout};
use kdcontour::{Settings, World};
use layout::Transition;

/// Chunk widths a camera may be from where its layout was made for, in
/// [`max_threshold`]: a still or slow camera is within one.
const MOTION_SLACK: f32 = 2.0;

/// The largest threshold a horizon volume of `chunk_res`-cell chunks of
/// `cell_size` with level-0 chunks out to `level0_cells` asks of a chunk (see
/// the module docs): the LOD curve's at [`Layout::around_reach`] plus
/// [`MOTION_SLACK`] chunk widths, or the default threshold when that is
/// higher or the camera does not drive thresholds.
pub(crate) fn max_threshold(
    settings: &crate::KdContourSettings,
    chunk_res: u32,
    cell_size: f32,
    level0_cells: u32,
) -> f32 {
    let ring = layout::ring(chunk_res, level0_cells);
    let curve = if settings.lod.enabled {
        settings
            .lod
            .curve()
            .around_limit(ring, chunk_res, cell_size, MOTION_SLACK)
    } else {
        f32::NEG_INFINITY
    };
    curve.max(settings.default_threshold)
}

/// The level world of a new horizon volume (its layout comes from the camera
/// when streaming first runs). Checks the extent's settings.
pub(crate) fn new_world(
    vol: &KdVolume,
    (view_cells, level0_cells): (u32, u32),
    (min_y, max_y): Rows,
    threshold: f32,
    settings: Settings,
) -> kdcontour::Result<World> {
    let bad = |reason: String| {
        Err(kdcontour::Error::InvalidSetting {
            name: "extent",
            reason,
        })
    };
    if min_y > max_y {
        return bad(format!("min_y {min_y} must be <= max_y {max_y}"));
    }
    if !vol.chunk_res.is_multiple_of(2) {
        return bad(format!(
            "chunk_res {} must be even: a chunk one level coarser halves it",
            vol.chunk_res
        ));
    }
    if view_cells < vol.chunk_res || level0_cells > view_cells {
        return bad(format!(
            "view_cells {view_cells} must be at least chunk_res {} and at least \
             level0_cells {level0_cells}",
            vol.chunk_res
        ));
    }
    if top_level(vol.chunk_res, view_cells) > MAX_LEVEL {
        return bad(format!(
            "view_cells {view_cells} needs more than {MAX_LEVEL} levels of {}-cell chunks",
            vol.chunk_res
        ));
    }
    let placeholder = Layout::uniform(IVec3::ZERO, IVec3::ONE, 0)?;
    World::new(
        Vec3::ZERO,
        vol.cell_size,
        vol.chunk_res,
        placeholder,
        threshold,
        settings,
    )
}

/// Follows the camera (`now`: real seconds): when the point it will be at
/// (see [`motion`]) enters another level-0 chunk, and no level change is
/// running, lays the volume out around that point on a task thread, then
/// starts the level change when that is ready.
pub(crate) fn stream(
    commands: &mut Commands,
    volume: Entity,
    state: &mut VolumeState,
    (camera, now): (Vec3, f64),
    cells: (u32, u32),
    rows: Rows,
    threshold: f32,
) {
    let res = state.world().chunk_res;
    // Level 2 reaches four times as far as level 0 (chunks).
    let reach2 = 4.0 * cells.1 as f32 / res as f32;
    let here = state.world().to_chunk_units(camera);
    state.horizon.motion.observe(now, here, reach2);
    if state.horizon.transition.is_some() {
        return;
    }
    if let Some(task) = state.horizon.pending_layout.as_mut() {
        let Some(result) = check_ready(task) else {
            return;
        };
        state.horizon.pending_layout = None;
        let started = result.and_then(|next| relayout(state, commands, volume, next, threshold));
        if let Err(e) = started {
            error!("KdVolume {volume}: {e}");
        }
        if state.horizon.transition.is_none() {
            // Nothing changed, or it failed: no level change to time.
            state.horizon.requested_at = None;
        }
        return;
    }
    let cam = state.horizon.motion.ahead(here, reach2);
    let key = (
        cam.floor().as_ivec3(),
        ((cells.0 as u64) << 32) | cells.1 as u64,
        rows.0,
        rows.1,
    );
    if !state.stream_to(key) {
        return;
    }
    state.horizon.requested_at = Some(now);
    let keep = HorizonKeep {
        camera: cam,
        reach: cells.0 as f32 / res as f32,
        rows,
    };
    // Laying out and finding every chunk's neighbourhood and seams costs
    // milliseconds at a long view: off the main thread.
    state.horizon.pending_layout = Some(
        AsyncComputeTaskPool::get()
            .spawn(async move { NextLayout::new(horizon_layout(res, cam, cells, rows)?, keep) }),
    );
}

/// Replaces the layout and starts the level change (see the module docs).
pub(crate) fn relayout(
    state: &mut VolumeState,
    commands: &mut Commands,
    volume: Entity,
    next: NextLayout,
    threshold: f32,
) -> kdcontour::Result<()> {
    let NextLayout {
        prepared,
        keep,
        kept: members,
        owners,
        partners,
    } = next;
    let layout = prepared.layout();
    let first = !state.slots.values().any(|s| s.shown());
    let dropped: Vec<ChunkKey> = state
        .slots
        .keys()
        .filter(|k| !layout.contains(k) || !keep.keeps(k))
        .copied()
        .collect();
    // The kept chunks that own seams with dropped ones (in the old layout).
    let mut touched: Vec<ChunkKey> = Vec::new();
    for k in &dropped {
        match state.horizon.seam_owners.get(k) {
            Some(o) => touched.extend(o),
            None => touched.extend(state.world().seam_owners_touching(k)),
        }
    }
    let world = state.world_mut();
    let stale = world.set_prepared(prepared)?;
    // A chunk the layout keeps but the view no longer does loses its tree,
    // so no seam is cut against it.
    for k in &dropped {
        if world.layout().contains(k) {
            world.remove_tree(k);
        }
    }
    let mut retired = Vec::new();
    let mut garbage = Vec::with_capacity(dropped.len());
    for k in &dropped {
        let slot = state.slots.remove(k).expect("listed");
        if slot.shown() && !first {
            retired.push((*k, slot.entity()));
        } else {
            commands.entity(slot.entity()).despawn();
        }
        garbage.push(slot);
    }
    for k in members {
        if !state.slots.contains_key(&k) {
            state.add_slot(commands, volume, k, threshold);
        }
    }
    // (Chunks the view leaves out are never built: no seam is cut against
    // them, so only the kept ones count.)
    let stale: Vec<ChunkKey> = stale
        .into_iter()
        .filter(|k| state.slots.contains_key(k))
        .collect();
    for k in &stale {
        state.mark_build(k);
        touched.extend(owners.get(k).into_iter().flatten());
    }
    touched.retain(|k| state.slots.contains_key(k));
    touched.sort_by_key(|k| k.order());
    touched.dedup();
    if touched.is_empty() && dropped.is_empty() {
        // Nothing changed (the camera moved within the same rings).
        return Ok(());
    }
    let mut blocked = ChunkSet::default();
    if !first {
        for k in &touched {
            blocked.insert(*k);
            blocked.extend(partners.get(k).into_iter().flatten());
        }
    }
    drop_elsewhere((
        garbage,
        std::mem::replace(&mut state.horizon.seam_owners, owners),
        std::mem::replace(&mut state.horizon.seam_partners, partners),
    ));
    for k in &touched {
        let slot = state.slots.get_mut(k).expect("kept");
        slot.hold_for_change(!first);
    }
    state.horizon.transition = Some(Transition {
        waiting: touched,
        hold: !first,
        keep,
        blocked,
        retired,
    });
    Ok(())
}

/// Whether the level change in progress has every mesh it waits for.
pub(crate) fn transition_ready(state: &VolumeState) -> bool {
    let Some(t) = &state.horizon.transition else {
        return false;
    };
    t.waiting.iter().all(|k| {
        state.slots.get(k).is_none_or(|s| {
            s.work.idle()
                && if t.hold {
                    s.work.has_ready()
                } else {
                    s.shown() && !s.work.has_ready()
                }
        })
    })
}

/// Ends the level change (at `now`, real seconds): despawns the chunks it
/// replaced and returns the chunks whose held meshes must be shown in this
/// same frame.
pub(crate) fn finish_transition(
    state: &mut VolumeState,
    commands: &mut Commands,
    now: f64,
) -> Vec<ChunkKey> {
    let Some(t) = state.horizon.transition.take() else {
        return Vec::new();
    };
    state.horizon.shown = Some((state.world().layout().clone(), t.keep));
    if let Some(at) = state.horizon.requested_at.take() {
        state.horizon.motion.change_took(now - at);
    }
    for (_, e) in t.retired {
        commands.entity(e).despawn();
    }
    let mut show = Vec::new();
    for k in t.waiting {
        if let Some(slot) = state.slots.get_mut(&k) {
            if slot.release() {
                show.push(k);
            }
        }
    }
    show
}

#[cfg(test)]
mod tests {
    use super::layout::in_rows;
    use super::*;

    #[test]
    fn the_top_level_is_the_first_at_least_as_wide_as_the_view() {
        assert_eq!(top_level(32, 32), 0);
        assert_eq!(top_level(32, 33), 1);
        assert_eq!(top_level(32, 4096), 7);
        assert_eq!(top_level(32, 5000), 8);
    }

    #[test]
    fn rows_keep_the_chunks_that_reach_into_them() {
        assert!(in_rows(&ChunkKey::new(0, IVec3::new(0, -2, 0)), (-2, 1)));
        assert!(!in_rows(&ChunkKey::new(0, IVec3::new(0, 2, 0)), (-2, 1)));
        // A level-3 chunk from row -8 to row -1 reaches into -2..=1.
        assert!(in_rows(&ChunkKey::new(3, IVec3::new(0, -1, 0)), (-2, 1)));
        assert!(!in_rows(&ChunkKey::new(3, IVec3::new(0, -2, 0)), (-2, 1)));
    }
}
