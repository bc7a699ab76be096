//! Upload: [`UploadPlugin`] turns finished extractions into Bevy meshes on the
//! chunk entities, nearest the camera first and at most
//! [`KdContourSettings::max_uploads_per_frame`] a frame (in
//! [`KdContourSystems::Apply`]), and sends [`ChunkMeshed`].

use crate::messages::ChunkMeshed;
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::{ChunkStatus, KdChunk, KdVolume};
use crate::KdContourSystems;
use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use kdcontour::IndexedMesh;

/// Uploads chunk meshes.
pub struct UploadPlugin;

impl Plugin for UploadPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<KdContourSettings>()
            .add_systems(PostUpdate, apply_meshes.in_set(KdContourSystems::Apply));
    }
}

/// A core mesh as a Bevy triangle-list mesh (positions, normals, u32 indices), as
/// the plugin uploads it.
pub fn to_bevy_mesh(m: &IndexedMesh) -> Mesh {
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        m.positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_NORMAL,
        m.normals.iter().map(|n| n.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_indices(Indices::U32(m.indices.clone()))
}

pub(crate) fn apply_meshes(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut volumes: Query<(Entity, &KdVolume, &mut VolumeState)>,
    mut chunks: Query<(&mut KdChunk, Option<&Mesh3d>)>,
    mut meshed: MessageWriter<ChunkMeshed>,
) {
    let _time = clock.measure();
    let mut budget = settings.max_uploads_per_frame;
    for (entity, vol, mut state) in &mut volumes {
        let mut coords: Vec<IVec3> = state
            .slots
            .iter()
            .filter(|(_, s)| s.ready.is_some())
            .map(|(c, _)| *c)
            .collect();
        state.nearest_first(&mut coords);
        for c in coords {
            if budget == 0 {
                return;
            }
            budget -= 1;
            let slot = state.slots.get_mut(&c).expect("listed");
            let (threshold, mesh) = slot.ready.take().expect("listed");
            let chunk = slot.entity;
            let Ok((mut info, existing)) = chunks.get_mut(chunk) else {
                continue;
            };
            let failed = matches!(info.status, ChunkStatus::Failed(_));
            info.threshold = threshold;
            info.triangles = mesh.triangle_count();
            if mesh.is_empty() {
                commands
                    .entity(chunk)
                    .remove::<(Mesh3d, MeshMaterial3d<StandardMaterial>)>();
                if !failed {
                    info.status = ChunkStatus::Empty;
                }
            } else {
                let bevy_mesh = to_bevy_mesh(&mesh);
                match existing {
                    Some(Mesh3d(handle)) if meshes.get(handle.id()).is_some() => {
                        let _ = meshes.insert(handle.id(), bevy_mesh);
                    }
                    _ => {
                        let handle = meshes.add(bevy_mesh);
                        commands
                            .entity(chunk)
                            .insert((Mesh3d(handle), MeshMaterial3d(vol.material.clone())));
                    }
                }
                if !failed {
                    info.status = ChunkStatus::Meshed;
                }
            }
            meshed.write(ChunkMeshed {
                volume: entity,
                chunk,
                coord: c,
                triangles: mesh.triangle_count(),
            });
        }
    }
}
