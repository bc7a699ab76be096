//! Camera-driven level of detail: [`LodPlugin`] sets each chunk's threshold
//! from its distance to the [`LodCamera`] on the curve of
//! [`crate::LodSettings`], with hysteresis, and queues a re-cut of the retained
//! tree (never a re-sample) where it changed (in [`KdContourSystems::Lod`](crate::KdContourSystems::Lod)).

use crate::messages::LodChanged;
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::{lod_camera, to_volume, LodCamera};
use crate::KdContourStep;
use bevy::prelude::*;
use kdcontour::world::ChunkKey;

/// Sets chunk thresholds from the camera.
pub struct LodPlugin;

impl Plugin for LodPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(PostUpdate, update_lod.in_set(KdContourStep::Thresholds));
    }
}

pub(crate) fn update_lod(
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    camera: Query<&GlobalTransform, With<LodCamera>>,
    mut volumes: Query<(Entity, &GlobalTransform, &mut VolumeState)>,
    mut changed: MessageWriter<LodChanged>,
) {
    let _time = clock.measure();
    let lod = &settings.lod;
    // With LOD off every chunk follows `default_threshold` (when it changes).
    let cam = if lod.enabled {
        let Some(cam) = lod_camera(&camera) else {
            return;
        };
        Some(cam)
    } else if settings.is_changed() {
        None
    } else {
        return;
    };
    let curve = lod.curve();
    for (entity, vol_tf, mut state) in &mut volumes {
        let local = cam.map(to_volume(vol_tf));
        // Every chunk is weighed each frame, in any order; only those whose
        // threshold changes are sorted (into the world's order, so messages
        // and queued work do not depend on hashing). A chunk whose new
        // threshold would re-extract a chunk held for a level change keeps its
        // threshold until the change ends, so the change is never starved by
        // re-extractions.
        let mut changes: Vec<(ChunkKey, f32)> = state
            .slots
            .iter()
            .filter_map(|(c, slot)| {
                // A chunk's threshold is in squared cells of its own level: it
                // follows the curve at its distance in those cells.
                let mut want = match local {
                    Some(p) => curve.threshold(state.distance(p, c) / (1u32 << c.level) as f32),
                    None => settings.default_threshold,
                };
                if let Some(cap) = state.extra_cap(slot) {
                    want = want.min(cap);
                }
                let have = state.world().threshold(c);
                let differs = if local.is_some() && have > 0.0 && want > 0.0 {
                    // |ln(want / have)| > ln(1 + hysteresis), without the logarithms.
                    let (ratio, band) = (want / have, 1.0 + lod.hysteresis);
                    ratio > band || ratio * band < 1.0
                } else {
                    want != have
                };
                differs.then_some((*c, want))
            })
            .collect();
        changes.sort_unstable_by_key(|(k, _)| k.order()); // keys are unique
        for (c, want) in changes {
            if !state.shows_held(&c) {
                state.world_mut().set_threshold(&c, want);
                state.mark_extract(&c);
                changed.write(LodChanged {
                    volume: entity,
                    coord: c.coord,
                    level: c.level,
                    threshold: want,
                });
            }
        }
    }
}
