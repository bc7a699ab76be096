//! Camera-driven level of detail: [`LodPlugin`] sets each chunk's threshold
//! from its distance to the [`LodCamera`] on the curve of
//! [`crate::LodSettings`], with hysteresis, and queues a re-cut of the retained
//! tree (never a re-sample) where it changed (in [`KdContourSystems::Lod`](crate::KdContourSystems::Lod));
//! and has every volume's trees built for cuts no lower than the lowest threshold
//! the settings and the chunks' extras can ask (a tree then skips the work only
//! finer cuts need; lowering it rebuilds the volume's trees).

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
            .add_systems(
                PostUpdate,
                (floor_trees, update_lod).in_set(KdContourStep::Thresholds),
            );
    }
}

/// Builds every volume's trees from now on for cuts no lower than the lowest
/// threshold its chunks can be given ([`VolumeState::lowest_threshold`]),
/// rounded down to a power of ten, nor higher than the highest they serve (a
/// streaming volume's, set while its chunks are chosen). The rounding keeps a
/// threshold slider dragged down from rebuilding every tree on each frame: the
/// trees are built again once per decade crossed.
fn floor_trees(
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    mut volumes: Query<&mut VolumeState>,
) {
    let _time = clock.measure();
    for mut state in &mut volumes {
        let floor = decade_at_or_below(state.lowest_threshold(&settings));
        state.cut_no_lower_than(floor);
    }
}

/// The largest power of ten at or below `x` (`x` itself when it is not a
/// positive finite number, or is a power of ten to rounding).
fn decade_at_or_below(x: f32) -> f32 {
    if !(x > 0.0 && x.is_finite()) {
        return x;
    }
    // A power of ten in f32 may sit a hair below its true value: round its
    // logarithm up by a millionth of a decade, then never pass `x`.
    let decade = 10f64.powi(((x as f64).log10() + 1e-6).floor() as i32) as f32;
    decade.min(x)
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

#[cfg(test)]
mod tests {
    use super::decade_at_or_below;

    #[test]
    fn floors_round_down_to_a_power_of_ten() {
        for (x, want) in [
            (0.01f32, 0.01f32),
            (0.001, 0.001),
            (0.0099, 0.001),
            (0.02, 0.01),
            (0.0002, 0.0001),
            (1.0, 1.0),
            (7.5, 1.0),
            (12.0, 10.0),
            (1e-5, 1e-5),
        ] {
            assert_eq!(decade_at_or_below(x), want, "{x}");
        }
        assert_eq!(decade_at_or_below(0.0), 0.0);
        assert_eq!(decade_at_or_below(-1.0), -1.0);
        assert_eq!(decade_at_or_below(f32::INFINITY), f32::INFINITY);
        assert!(decade_at_or_below(f32::NAN).is_nan());
        // Never above what it is given, whatever the rounding.
        let mut x = 1e-7f32;
        while x < 1e4 {
            assert!(decade_at_or_below(x) <= x, "{x}");
            assert!(decade_at_or_below(x) * 10.0 > x * 0.999_999, "{x}");
            x *= 1.37;
        }
    }
}
