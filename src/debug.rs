//! Debug drawing (crate feature `debug`): [`DebugPlugin`] colours each chunk by
//! its threshold band (by its level in a horizon volume: blue finest, red
//! coarsest) when [`KdContourSettings::color_by_lod`] is on, to see the LOD
//! rings and the seams between them, and gives chunks back their volume's
//! material when it is turned off.

use crate::material::{TerrainMaterial, LAYERS};
use crate::settings::{KdContourSettings, LodSettings};
use crate::stats::MainThreadClock;
use crate::volume::{KdChunk, KdVolume, VolumeExtent, VolumeMaterial};
use crate::KdContourStep;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

/// Colours chunks by LOD band on request.
pub struct DebugPlugin;

impl Plugin for DebugPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(PostUpdate, color_chunks.in_set(KdContourStep::AfterUpload));
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

/// The LOD colours: one `StandardMaterial` per band, and per terrain material
/// one copy per band with every layer tinted the band's colour (a terrain
/// chunk's vertex colours are layer weights, which would tint a plain material).
#[derive(Resource, Default)]
struct TerrainLodPalette(HashMap<AssetId<TerrainMaterial>, Vec<Handle<TerrainMaterial>>>);

/// The colour of LOD band `i`: blue finest, red coarsest.
fn band_color(i: usize) -> Color {
    let t = i as f32 / (LOD_BANDS - 1) as f32;
    Color::hsl(240.0 * (1.0 - t), 0.75, 0.55)
}

/// The band palette of terrain material `of`, made on first use.
fn terrain_palette(
    cache: &mut TerrainLodPalette,
    materials: &mut Assets<TerrainMaterial>,
    of: &Handle<TerrainMaterial>,
) -> Option<Vec<Handle<TerrainMaterial>>> {
    if let Some(p) = cache.0.get(&of.id()) {
        return Some(p.clone());
    }
    let base = materials.get(of.id())?.clone();
    let p: Vec<_> = (0..LOD_BANDS)
        .map(|i| {
            let mut m = base.clone();
            m.extension.tints = [band_color(i).to_linear(); LAYERS];
            m.extension.texture_mix = 0.0;
            materials.add(m)
        })
        .collect();
    cache.0.insert(of.id(), p.clone());
    Some(p)
}

/// Meshed chunk entities and the material they show.
type MeshedChunks<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        Ref<'static, KdChunk>,
        Option<&'static MeshMaterial3d<StandardMaterial>>,
        Option<&'static MeshMaterial3d<TerrainMaterial>>,
    ),
    With<Mesh3d>,
>;

/// Gives each meshed chunk its volume's material, or its LOD band's colour.
#[allow(clippy::too_many_arguments)]
fn color_chunks(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    palette: Option<Res<LodPalette>>,
    mut terrain_palettes: Local<TerrainLodPalette>,
    materials: Option<ResMut<Assets<StandardMaterial>>>,
    mut terrain_materials: Option<ResMut<Assets<TerrainMaterial>>>,
    volumes: Query<&KdVolume>,
    chunks: MeshedChunks,
) {
    let _time = clock.measure();
    let palette = match palette {
        Some(p) => p.0.clone(),
        None if settings.color_by_lod && materials.is_some() => {
            let mut materials = materials.expect("checked");
            let p: Vec<_> = (0..LOD_BANDS)
                .map(|i| {
                    materials.add(StandardMaterial {
                        base_color: band_color(i),
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
    for (entity, chunk, standard, terrain) in &chunks {
        if !(all || chunk.is_changed()) {
            continue;
        }
        let Ok(vol) = volumes.get(chunk.volume) else {
            continue;
        };
        // A horizon volume is coloured by chunk level, others by threshold.
        let band = match vol.extent {
            VolumeExtent::Horizon { .. } => (chunk.level as usize).min(LOD_BANDS - 1),
            _ => lod_band(chunk.threshold, &settings.lod),
        };
        let by_lod = settings.color_by_lod;
        match &vol.material {
            VolumeMaterial::Standard(own) => {
                let want = if by_lod && !palette.is_empty() {
                    palette[band].clone()
                } else {
                    own.clone()
                };
                if standard.map(|m| &m.0) != Some(&want) {
                    commands.entity(entity).insert(MeshMaterial3d(want));
                }
            }
            VolumeMaterial::Terrain(own) => {
                let tinted = match (by_lod, terrain_materials.as_deref_mut()) {
                    (true, Some(assets)) => terrain_palette(&mut terrain_palettes, assets, own),
                    _ => None,
                };
                let want = tinted.map_or_else(|| own.clone(), |p| p[band].clone());
                if terrain.map(|m| &m.0) != Some(&want) {
                    commands.entity(entity).insert(MeshMaterial3d(want));
                }
            }
        }
    }
}
