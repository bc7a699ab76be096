//! Upload: [`UploadPlugin`] turns finished extractions into Bevy meshes on the
//! chunk entities, nearest the camera first and at most
//! [`KdContourSettings::max_uploads_per_frame`] a frame (in
//! [`KdContourSystems::Apply`](crate::KdContourSystems::Apply)), and sends [`ChunkMeshed`].

use crate::material::TerrainMaterial;
use crate::messages::ChunkMeshed;
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::{ChunkStatus, KdChunk, KdVolume, VolumeMaterial};
use crate::workers::drop_elsewhere;
use crate::KdContourStep;
use bevy::prelude::*;
use kdcontour::world::ChunkKey;

/// Uploads chunk meshes.
pub struct UploadPlugin;

impl Plugin for UploadPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(PostUpdate, apply_meshes.in_set(KdContourStep::Upload));
    }
}

pub(crate) fn apply_meshes(
    mut commands: Commands,
    (settings, time): (Res<KdContourSettings>, Res<Time<Real>>),
    clock: Res<MainThreadClock>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut volumes: Query<(Entity, &KdVolume, &mut VolumeState)>,
    mut chunks: ChunkQuery,
    mut meshed: MessageWriter<ChunkMeshed>,
) {
    let _time = clock.measure();
    let mut budget = settings.max_uploads_per_frame;
    for (entity, vol, mut state) in &mut volumes {
        let state = &mut *state;
        let mut up = Upload {
            commands: &mut commands,
            meshes: &mut meshes,
            chunks: &mut chunks,
            meshed: &mut meshed,
            volume: entity,
            material: &vol.material,
        };
        // A level change whose meshes are all ready shows them in one frame,
        // whatever the budget (see `crate::horizon`).
        if crate::horizon::transition_ready(state) {
            for k in crate::horizon::finish_transition(state, up.commands, time.elapsed_secs_f64())
            {
                up.show(state, k);
            }
        }
        let mut keys: Vec<ChunkKey> = state
            .slots
            .iter()
            .filter(|(_, s)| s.work.has_ready() && !s.held())
            .map(|(c, _)| *c)
            .collect();
        state.nearest_first(&mut keys);
        for k in keys {
            if budget == 0 {
                return;
            }
            budget -= 1;
            up.show(state, k);
        }
    }
}

/// The chunk entities' info and meshes.
type ChunkQuery<'w, 's> = Query<'w, 's, (&'static mut KdChunk, Option<&'static Mesh3d>)>;

/// What showing a chunk's mesh needs.
struct Upload<'a, 'w, 's, 'qw, 'qs, 'mw> {
    commands: &'a mut Commands<'w, 's>,
    meshes: &'a mut Assets<Mesh>,
    chunks: &'a mut ChunkQuery<'qw, 'qs>,
    meshed: &'a mut MessageWriter<'mw, ChunkMeshed>,
    volume: Entity,
    material: &'a VolumeMaterial,
}

impl Upload<'_, '_, '_, '_, '_, '_> {
    /// Shows chunk `k`'s waiting mesh on its entity.
    fn show(&mut self, state: &mut VolumeState, k: ChunkKey) {
        let Some(slot) = state.slots.get_mut(&k) else {
            return;
        };
        let Some(ready) = slot.take_mesh_to_show() else {
            return;
        };
        let chunk = slot.entity();
        let Ok((mut info, existing)) = self.chunks.get_mut(chunk) else {
            return;
        };
        let failed = matches!(info.status, ChunkStatus::Failed(_));
        info.threshold = ready.threshold;
        info.triangles = ready.triangles;
        for put in ready.extra {
            put(&mut self.commands.entity(chunk));
        }
        match ready.mesh {
            None => {
                self.commands.entity(chunk).remove::<(
                    Mesh3d,
                    MeshMaterial3d<StandardMaterial>,
                    MeshMaterial3d<TerrainMaterial>,
                )>();
                if !failed {
                    info.status = ChunkStatus::Empty;
                }
            }
            Some(bevy_mesh) => {
                match existing {
                    Some(Mesh3d(handle)) if self.meshes.get(handle.id()).is_some() => {
                        if let Some(mut mesh) = self.meshes.get_mut(handle.id()) {
                            drop_elsewhere(std::mem::replace(&mut *mesh, bevy_mesh));
                        }
                    }
                    _ => {
                        let handle = self.meshes.add(bevy_mesh);
                        let mut entity = self.commands.entity(chunk);
                        entity.insert(Mesh3d(handle));
                        match self.material {
                            VolumeMaterial::Standard(m) => {
                                entity.insert(MeshMaterial3d(m.clone()));
                            }
                            VolumeMaterial::Terrain(m) => {
                                entity.insert(MeshMaterial3d(m.clone()));
                            }
                        }
                    }
                }
                if !failed {
                    info.status = ChunkStatus::Meshed;
                }
            }
        }
        self.meshed.write(ChunkMeshed {
            volume: self.volume,
            chunk,
            coord: k.coord,
            level: k.level,
            triangles: ready.triangles,
        });
    }
}
