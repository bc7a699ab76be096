//! Debug drawing (crate feature `debug`): [`DebugPlugin`] colours each chunk by
//! its threshold band (by its level in a horizon volume: blue finest, red
//! coarsest) when [`KdContourSettings::color_by_lod`] is on, to see the LOD
//! rings and the seams between them, and gives chunks back their volume's
//! material when it is turned off.

use crate::settings::{KdContourSettings, LodSettings};
use crate::stats::MainThreadClock;
use crate::upload::apply_meshes;
use crate::volume::{KdChunk, KdVolume, VolumeExtent};
use crate::KdContourSystems;
use bevy::prelude::*;

/// Colours chunks by LOD band on request.
pub struct DebugPlugin;

impl Plugin for DebugPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(
                PostUpdate,
                color_chunks
                    .in_set(KdContourSystems::Apply)
                    .after(apply_meshes),
            );
    }
}

/// One material per threshold band, for [`KdContourSettings::color_by_lod`].
#[derive(Resource)]
struct LodPalette(Vec<Handle<StandardMaterial>>);

/// Bands of the LOD palette.
const LOD_BANDS: usize = 8;

/// The band of `threshold` on the LOD curve: 0 at `base`, the last at `max`.
fn lod_band(threshold: f32, lod: &LodSettings) -> usize {
    let (lo, hi) = (
        lod.base.max(1e-9).ln(),
        lod.max.max(lod.base).max(1e-9).ln(),
    );
    let t = if hi > lo {
        (threshold.max(1e-9).ln() - lo) / (hi - lo)
    } else {
        0.0
    };
    ((t.clamp(0.0, 1.0) * (LOD_BANDS - 1) as f32).round() as usize).min(LOD_BANDS - 1)
}

/// Gives each meshed chunk its volume's material, or its LOD band's colour.
fn color_chunks(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    palette: Option<Res<LodPalette>>,
    materials: Option<ResMut<Assets<StandardMaterial>>>,
    volumes: Query<&KdVolume>,
    chunks: Query<(Entity, Ref<KdChunk>, &MeshMaterial3d<StandardMaterial>)>,
) {
    let _time = clock.measure();
    let palette = match palette {
        Some(p) => p.0.clone(),
        None if settings.color_by_lod && materials.is_some() => {
            let mut materials = materials.expect("checked");
            let p: Vec<_> = (0..LOD_BANDS)
                .map(|i| {
                    let t = i as f32 / (LOD_BANDS - 1) as f32;
                    materials.add(StandardMaterial {
                        base_color: Color::hsl(240.0 * (1.0 - t), 0.75, 0.55),
                        perceptual_roughness: 0.8,
                        ..default()
                    })
                })
                .collect();
            commands.insert_resource(LodPalette(p.clone()));
            p
        }
        None => Vec::new(),
    };
    let all = settings.is_changed();
    for (entity, chunk, material) in &chunks {
        if !(all || chunk.is_changed()) {
            continue;
        }
        let want = if settings.color_by_lod && !palette.is_empty() {
            // A horizon volume is coloured by chunk level, others by threshold.
            let band = match volumes.get(chunk.volume).map(|v| &v.extent) {
                Ok(VolumeExtent::Horizon { .. }) => (chunk.level as usize).min(LOD_BANDS - 1),
                _ => lod_band(chunk.threshold, &settings.lod),
            };
            palette[band].clone()
        } else if let Ok(vol) = volumes.get(chunk.volume) {
            vol.material.clone()
        } else {
            continue;
        };
        if material.0 != want {
            commands.entity(entity).insert(MeshMaterial3d(want));
        }
    }
}
