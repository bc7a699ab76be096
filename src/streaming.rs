//! Streaming: [`StreamingPlugin`] loads the chunks of unbounded volumes
//! ([`crate::KdVolume::streaming`]) around the [`LodCamera`], nearest first, and
//! drops those left behind (their trees built for the thresholds the LOD asks
//! within the view distance, [`max_threshold`]; the lowest they serve is the
//! [`crate::LodPlugin`]'s to set); lays horizon volumes ([`crate::KdVolume::horizon`])
//! out in chunk levels around the camera ([`crate::horizon`]); and for every
//! volume points scheduling at the camera (in [`KdContourSystems::Lod`](crate::KdContourSystems::Lod), before
//! thresholds are set).

use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::{lod_camera, to_volume, KdVolume, LodCamera, VolumeExtent};
use crate::KdContourStep;
use bevy::prelude::*;

/// Streams chunks around the camera.
pub struct StreamingPlugin;

impl Plugin for StreamingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(
                PostUpdate,
                stream_chunks.in_set(KdContourStep::ChooseChunks),
            );
    }
}

/// Loads and drops the chunks of streaming volumes around the camera (around the
/// volume's origin when there is no [`LodCamera`]), and points every volume's
/// scheduling at the camera.
fn stream_chunks(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    time: Res<Time<Real>>,
    camera: Query<&GlobalTransform, With<LodCamera>>,
    mut volumes: Query<(Entity, &KdVolume, &GlobalTransform, &mut VolumeState)>,
) {
    let _time = clock.measure();
    let cam = lod_camera(&camera);
    for (entity, vol, vol_tf, mut state) in &mut volumes {
        let state = &mut *state;
        let local = cam.map(to_volume(vol_tf)).unwrap_or(Vec3::ZERO);
        state.follow(local);
        let (view_distance, min_y, max_y) = match vol.extent {
            VolumeExtent::Streaming {
                view_distance,
                min_y,
                max_y,
            } => (view_distance, min_y, max_y),
            VolumeExtent::Horizon {
                view_cells,
                level0_cells,
                min_y,
                max_y,
            } => {
                // Trees built from now on serve the thresholds the settings
                // can ask (they may change at run time).
                let limit = crate::horizon::max_threshold(
                    &settings,
                    vol.chunk_res,
                    vol.cell_size,
                    level0_cells,
                );
                if state.world().settings.max_threshold.to_bits() != limit.to_bits() {
                    state.world_mut().settings.max_threshold = limit;
                }
                crate::horizon::stream(
                    &mut commands,
                    entity,
                    state,
                    (local, time.elapsed_secs_f64()),
                    (view_cells, level0_cells),
                    (min_y, max_y),
                    settings.default_threshold,
                );
                continue;
            }
            VolumeExtent::Bounded { .. } => continue,
        };
        // Trees built from now on serve the thresholds the LOD can ask of a
        // loaded chunk (they may change at run time).
        let limit = max_threshold(&settings, view_distance, state.world().chunk_side());
        if state.world().settings.max_threshold.to_bits() != limit.to_bits() {
            state.world_mut().settings.max_threshold = limit;
        }
        let key = (
            state.world().chunk_at(local),
            view_distance.to_bits() as u64,
            min_y,
            max_y,
        );
        if !state.stream_to(key) {
            continue; // the camera is in the same chunk as last time
        }
        let world = state.world();
        let side = world.chunk_side();
        let near = world.chunks_near(local, view_distance);
        let rows = min_y..=max_y;
        // Drop what is out of range (with one chunk side of slack) first.
        for k in state.world().chunks() {
            if !rows.contains(&k.coord.y) || state.distance(local, &k) > view_distance + side {
                state.unload(&mut commands, k);
            }
        }
        for c in near {
            if rows.contains(&c.y) {
                state.load(&mut commands, entity, c, settings.default_threshold);
            }
        }
    }
}

/// Chunk widths past the view distance a streaming volume's chunk can be from
/// the camera while loaded: one of unloading slack, and up to the diagonal of
/// the chunk the camera is in, which it may cross before the chunks are
/// streamed again (it re-streams when it enters another chunk).
const LOADED_SLACK: f32 = 3.0;

/// The largest threshold a streaming volume with `view_distance` and chunks of
/// side `chunk_side` asks of a loaded chunk: the LOD curve at the view distance
/// plus [`LOADED_SLACK`] chunk widths, or the default threshold when that is
/// higher or the camera does not drive thresholds. Its trees are built with it
/// as [`kdcontour::Settings::max_threshold`]: the fold guard checks no merge a
/// cut never reaches (a chunk asked for more is cut at it, finer).
pub(crate) fn max_threshold(
    settings: &KdContourSettings,
    view_distance: f32,
    chunk_side: f32,
) -> f32 {
    let curve = if settings.lod.enabled {
        settings
            .lod
            .curve()
            .threshold(view_distance + LOADED_SLACK * chunk_side)
    } else {
        f32::NEG_INFINITY
    };
    curve.max(settings.default_threshold)
}
