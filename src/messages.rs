//! The messages the plugin reads ([`ApplyEdit`], [`ReplaceField`]) and writes
//! ([`EditApplied`], [`ChunkMeshed`], [`LodChanged`], [`ChunkFailed`]), and
//! [`MessagesPlugin`], which registers them all, so any subsystem can be left
//! out without the others losing a message type.

use crate::volume::SharedField;
use bevy::prelude::*;
use kdcontour::edit::Brush;
use kdcontour::world::ChunkKey;

/// Apply a brush to a volume.
#[derive(Message, Clone, Debug)]
pub struct ApplyEdit {
    /// The volume entity.
    pub volume: Entity,
    /// The brush, in the volume's local space.
    pub brush: Brush,
}

/// Replace a volume's field (the edit log is replayed on top of it). With
/// `regions`, only chunks within those spheres `(center, radius)`, in the volume's
/// local space, are rebuilt: the caller promises the new field equals the old one
/// outside them (a CSG editor passes the old and new bounds of the shape it
/// changed). With `None` every chunk is rebuilt.
#[derive(Message, Clone)]
pub struct ReplaceField {
    /// The volume entity.
    pub volume: Entity,
    /// The new field.
    pub field: SharedField,
    /// Where the new field differs from the old, or `None` for everywhere.
    pub regions: Option<Vec<(Vec3, f32)>>,
}

/// An edit (or a [`ReplaceField`]) was applied; these chunks are being rebuilt.
#[derive(Message, Clone, Debug)]
pub struct EditApplied {
    /// The volume entity.
    pub volume: Entity,
    /// Chunks whose samples the brush reaches, at every level that covers it
    /// (level 0 in a one-level volume).
    pub rebuilt: Vec<ChunkKey>,
}

/// A chunk now shows a new mesh.
#[derive(Message, Clone, Debug)]
pub struct ChunkMeshed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk entity.
    pub chunk: Entity,
    /// Its coordinates (in chunks of its level).
    pub coord: IVec3,
    /// Its level (0 in a one-level volume).
    pub level: u32,
    /// Triangles in the mesh (0: the chunk is empty).
    pub triangles: usize,
}

/// The camera moved a chunk to a new threshold.
#[derive(Message, Clone, Debug)]
pub struct LodChanged {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk (in chunks of its level).
    pub coord: IVec3,
    /// Its level (0 in a one-level volume).
    pub level: u32,
    /// Its new threshold.
    pub threshold: f32,
}

/// A chunk's build failed (a field error or a panic inside the task).
#[derive(Message, Clone, Debug)]
pub struct ChunkFailed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk (in chunks of its level).
    pub coord: IVec3,
    /// Its level (0 in a one-level volume).
    pub level: u32,
    /// What went wrong.
    pub error: String,
}

/// Registers every message of the plugin.
pub struct MessagesPlugin;

impl Plugin for MessagesPlugin {
    fn build(&self, app: &mut App) {
        app.add_message::<ApplyEdit>()
            .add_message::<EditApplied>()
            .add_message::<ReplaceField>()
            .add_message::<ChunkMeshed>()
            .add_message::<LodChanged>()
            .add_message::<ChunkFailed>();
    }
}
