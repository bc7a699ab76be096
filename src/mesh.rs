//! Chunk meshes as Bevy shows them: a core mesh converted ([`to_bevy_mesh`]), a
//! chunk's finished extraction waiting for upload ([`ReadyMesh`]), and what a
//! subsystem adds to it ([`MeshExtra`]: colliders, navmesh tiles).

use bevy::asset::RenderAssetUsages;
use bevy::ecs::system::EntityCommands;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use kdcontour::IndexedMesh;
use std::sync::Arc;

/// What a subsystem adds to a chunk's mesh (a collider, a navmesh tile): built
/// from the welded mesh in the chunk's extraction task, put on the chunk entity
/// in the frame its mesh is shown, so the two never disagree.
pub(crate) trait MeshExtra: Send + Sync + 'static {
    /// Builds it from `mesh`, or, with `None`, what takes an old one away (the
    /// chunk should have none now).
    fn build(&self, mesh: Option<&IndexedMesh>) -> ExtraPayload;
}

/// Which subsystem's extra (an index into a chunk's extras).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ExtraKind {
    /// A trimesh collider (feature `avian`).
    #[cfg_attr(not(feature = "avian"), allow(dead_code))]
    Collider = 0,
    /// A navmesh tile (feature `navmesh`).
    #[cfg_attr(not(feature = "navmesh"), allow(dead_code))]
    NavTile = 1,
}

/// How many kinds of extra there are.
pub(crate) const EXTRA_KINDS: usize = 2;

/// A built extra: puts itself on the chunk entity.
pub(crate) type ExtraPayload = Box<dyn FnOnce(&mut EntityCommands) + Send + Sync>;

/// A volume's mesh extra and the threshold its chunks are capped at.
#[derive(Clone)]
pub(crate) struct ChunkExtra {
    /// What builds it.
    pub builder: Arc<dyn MeshExtra>,
    /// `Some(threshold)` while it is on: the chunks that carry it are cut no
    /// coarser; `None` while it is off (every chunk's old one is taken away).
    pub on: Option<f32>,
}

/// A chunk mesh ready to show: made into a Bevy mesh on the task thread, so
/// showing it on the main thread is a move, however many show in one frame.
pub(crate) struct ReadyMesh {
    /// The threshold it was cut at.
    pub threshold: f32,
    /// Its triangles.
    pub triangles: usize,
    /// The Bevy mesh; `None` when the chunk has no surface.
    pub mesh: Option<Mesh>,
    /// What the subsystems add to it (a collider of the same triangles, a
    /// navmesh tile of its floor).
    pub extra: Vec<ExtraPayload>,
}

impl ReadyMesh {
    /// `mesh` (from the core) at `threshold`, as Bevy will show it.
    pub fn new(threshold: f32, mesh: &IndexedMesh) -> Self {
        ReadyMesh {
            threshold,
            triangles: mesh.triangle_count(),
            mesh: (!mesh.is_empty()).then(|| to_bevy_mesh(mesh)),
            extra: Vec::new(),
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
