//! A chunk's trimesh collider, built in its extraction task from the mesh it
//! shows.

use avian3d::prelude::{Collider, CollisionLayers, TrimeshFlags};
use bevy::prelude::*;
use kdcontour::IndexedMesh;

/// A chunk's collider, built in its extraction task, and its layers.
pub(crate) type ChunkCollider = (Collider, CollisionLayers);

/// The trimesh collider of `mesh` (in the volume's local space, as the chunk
/// entity's), or `None` for an empty mesh or one avian refuses.
pub(crate) fn build(mesh: &IndexedMesh, layers: CollisionLayers) -> Option<ChunkCollider> {
    if mesh.is_empty() {
        return None;
    }
    let vertices = mesh.positions.clone();
    let indices: Vec<[u32; 3]> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    // Internal edges fixed so bodies slide over triangle edges without bumps.
    match Collider::try_trimesh_with_config(vertices, indices, TrimeshFlags::FIX_INTERNAL_EDGES) {
        Ok(c) => Some((c, layers)),
        Err(e) => {
            warn!("a chunk's trimesh collider failed: {e:?}");
            None
        }
    }
}
