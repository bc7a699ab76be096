//! The volume subsystem's systems: it orders [`KdContourSystems`] and their
//! steps, gives new volumes their meshing state, and swaps a volume's field when
//! its field or iso changes.

use super::*;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::{KdContourStep, KdContourSystems};
use bevy::transform::TransformSystems;
use kdcontour::edit::EditedField;

/// Orders [`KdContourSystems`], registers the volume and chunk types, gives new
/// volumes a [`VolumeState`] (in [`KdContourSystems::Edits`], first) and
/// rebuilds a volume whose field or iso changed.
pub struct VolumePlugin;

impl Plugin for VolumePlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<KdContourSettings>()
            .init_resource::<MainThreadClock>()
            .register_type::<KdVolume>()
            .register_type::<VolumeExtent>()
            .register_type::<KdChunk>()
            .register_type::<ChunkStatus>()
            .register_type::<LodCamera>()
            .configure_sets(
                PostUpdate,
                (
                    KdContourSystems::Edits,
                    KdContourSystems::Lod,
                    KdContourSystems::Schedule,
                    KdContourSystems::Poll,
                    KdContourSystems::Apply,
                    KdContourSystems::Stats,
                )
                    .chain()
                    .before(TransformSystems::Propagate),
            )
            .configure_sets(
                PostUpdate,
                (
                    (
                        KdContourStep::CreateVolumes,
                        KdContourStep::LoadEdits,
                        KdContourStep::SyncVolumes,
                        KdContourStep::ReceiveEdits,
                        KdContourStep::ApplyEdits,
                        KdContourStep::SendEdits,
                    )
                        .chain()
                        .in_set(KdContourSystems::Edits),
                    (KdContourStep::ChooseChunks, KdContourStep::Thresholds)
                        .chain()
                        .in_set(KdContourSystems::Lod),
                    (KdContourStep::Upload, KdContourStep::AfterUpload)
                        .chain()
                        .in_set(KdContourSystems::Apply),
                ),
            )
            .add_systems(
                PostUpdate,
                (
                    init_volumes.in_set(KdContourStep::CreateVolumes),
                    sync_volumes.in_set(KdContourStep::SyncVolumes),
                ),
            );
    }
}

pub(crate) fn init_volumes(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    volumes: Query<(Entity, &KdVolume), Without<VolumeState>>,
) {
    let _time = clock.measure();
    for (entity, vol) in &volumes {
        if !vol.iso.is_finite() {
            error!("KdVolume {entity}: iso {} must be finite", vol.iso);
            commands.entity(entity).remove::<KdVolume>();
            continue;
        }
        // Materials only for the terrain material: a plain one shows none, so
        // the trees keep none (no time, memory or border triangles spent).
        let core = kdcontour::Settings {
            threads: 1,
            materials: vol.material.wants_layers(),
            material_borders: vol.material_borders,
            ..Default::default()
        };
        let world = match vol.extent {
            VolumeExtent::Bounded { chunks } => World::bounded(
                Vec3::ZERO,
                vol.cell_size,
                vol.chunk_res,
                chunks,
                settings.default_threshold,
                core,
            ),
            VolumeExtent::Streaming {
                view_distance,
                min_y,
                max_y,
            } => {
                if !(view_distance.is_finite() && view_distance >= 0.0) || min_y > max_y {
                    Err(kdcontour::Error::InvalidSetting {
                        name: "extent",
                        reason: format!(
                            "view_distance {view_distance} must be finite and >= 0, \
                             and min_y {min_y} <= max_y {max_y}"
                        ),
                    })
                } else if let Err(e) =
                    streaming_budget(vol, view_distance, max_y - min_y + 1, &core)
                {
                    Err(e)
                } else {
                    World::unbounded(
                        Vec3::ZERO,
                        vol.cell_size,
                        vol.chunk_res,
                        settings.default_threshold,
                        core,
                    )
                }
            }
            VolumeExtent::Horizon {
                view_cells,
                level0_cells,
                min_y,
                max_y,
            } => crate::horizon::new_world(
                vol,
                (view_cells, level0_cells),
                (min_y, max_y),
                settings.default_threshold,
                core,
            ),
        };
        let world = match world {
            Ok(w) => w,
            Err(e) => {
                error!("KdVolume {entity}: {e}");
                commands.entity(entity).remove::<KdVolume>();
                continue;
            }
        };
        let field = EditedField::new(KdVolume::shifted(&vol.field.0, vol.iso));
        let mut state = VolumeState::new(world, field, (&vol.field.0, vol.iso));
        // A bounded world already lists its chunks; give each an entity. (A
        // streaming or horizon world is empty until streaming runs.)
        if let VolumeExtent::Bounded { .. } = vol.extent {
            for c in state.world().chunks() {
                state.add_slot(&mut commands, entity, c, settings.default_threshold);
            }
        }
        commands.entity(entity).insert(state);
    }
}

/// Bytes a chunk retains per cell of one face, measured on the terrain demo
/// (a 32-cell chunk keeps about 130 KB): the budget's estimate of a loaded chunk.
const RETAINED_PER_FACE_CELL: u64 = 128;

/// Checks that every chunk a streaming volume loads within `view_distance`
/// (over `rows` chunk rows) fits the memory budget, before any is loaded.
fn streaming_budget(
    vol: &KdVolume,
    view_distance: f32,
    rows: i32,
    core: &kdcontour::Settings,
) -> kdcontour::Result<()> {
    let side = vol.chunk_res as f64 * vol.cell_size as f64;
    let across = view_distance as f64 / side + 2.0;
    let chunks = (std::f64::consts::PI * across * across * rows.max(1) as f64).min(1e18) as u64;
    let res = vol.chunk_res as u64;
    let needed = chunks.saturating_mul(res * res * RETAINED_PER_FACE_CELL);
    kdcontour::settings::check_budget(
        format!(
            "streaming about {chunks} chunks of {res}^3 cells within view_distance \
             {view_distance} (for a far view use KdVolume::horizon, whose chunks grow \
             with the log of the distance)"
        ),
        needed,
        core.memory_budget,
    )
}

/// A volume whose field or iso changed: replay its edits on the new field and
/// rebuild every chunk.
pub(crate) fn sync_volumes(
    clock: Res<MainThreadClock>,
    mut volumes: Query<(Entity, &KdVolume, &mut VolumeState), Changed<KdVolume>>,
) {
    let _time = clock.measure();
    for (entity, vol, mut state) in &mut volumes {
        if state.has_base(&vol.field.0, vol.iso) {
            continue;
        }
        if !vol.iso.is_finite() {
            warn!(
                "KdVolume {entity}: iso {} must be finite; kept {}",
                vol.iso,
                state.base_iso()
            );
            continue;
        }
        state.swap_base(vol.field.0.clone(), vol.iso);
        state.rebuild_all();
    }
}
