//! Chunk meshes as Bevy shows them: a core mesh converted ([`to_bevy_mesh`]), and
//! a chunk's finished extraction waiting for upload ([`ReadyMesh`]).

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use kdcontour::IndexedMesh;

/// A chunk mesh ready to show: made into a Bevy mesh on the task thread, so
/// showing it on the main thread is a move, however many show in one frame.
pub(crate) struct ReadyMesh {
    /// The threshold it was cut at.
    pub threshold: f32,
    /// Its triangles.
    pub triangles: usize,
    /// The Bevy mesh; `None` when the chunk has no surface.
    pub mesh: Option<Mesh>,
    /// The collider of the same triangles, when the chunk wants one.
    #[cfg(feature = "avian")]
    pub collider: Option<crate::colliders::trimesh::ChunkCollider>,
}

impl ReadyMesh {
    /// `mesh` (from the core) at `threshold`, as Bevy will show it.
    pub fn new(threshold: f32, mesh: &IndexedMesh) -> Self {
        ReadyMesh {
            threshold,
            triangles: mesh.triangle_count(),
            mesh: (!mesh.is_empty()).then(|| to_bevy_mesh(mesh)),
            #[cfg(feature = "avian")]
            collider: None,
        }
    }
}

/// A core mesh as a Bevy triangle-list mesh (positions, normals, u32 indices), as
/// the plugin uploads it. A mesh that carries materials also gets the terrain
/// material's layer weights ([`crate::material::layer_weights`]): layers 0-3 as
/// vertex colours, 4-5 as the UV set (`ATTRIBUTE_UV_0`: chunk meshes have no texture
/// coordinates, and Bevy 0.19 does not build a second UV set without a first).
pub fn to_bevy_mesh(m: &IndexedMesh) -> Mesh {
    let mesh = Mesh::new(
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
    .with_inserted_indices(Indices::U32(m.indices.clone()));
    if m.materials.len() != m.positions.len() {
        return mesh;
    }
    let (lo, hi) = crate::material::layer_weights(&m.materials);
    mesh.with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, lo)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, hi)
}
