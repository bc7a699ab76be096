//! The messages the plugin reads ([`ApplyEdit`], [`UndoEdit`], [`RedoEdit`],
//! [`ReplaceField`]) and writes
//! ([`EditApplied`], [`ChunkMeshed`], [`LodChanged`], [`ChunkFailed`]), and
//! [`MessagesPlugin`], which registers them all, so any subsystem can be left
//! out without the others losing a message type.

use crate::volume::SharedField;
use bevy::prelude::*;
use kdcontour::edit::{Brush, EditOp};
use kdcontour::world::ChunkKey;

/// Apply a brush to a volume.
#[derive(Message, Clone, Debug)]
pub struct ApplyEdit {
    /// The volume entity.
    pub volume: Entity,
    /// The brush, in the volume's local space.
    pub brush: Brush,
    /// This dab continues the stroke of the edit before it: one [`UndoEdit`]
    /// takes back the whole stroke. A stroke ends at any undo or redo, and at
    /// the next edit that does not continue it.
    pub continues_stroke: bool,
}

impl ApplyEdit {
    /// A brush that is its own undo step.
    pub fn new(volume: Entity, brush: Brush) -> Self {
        ApplyEdit {
            volume,
            brush,
            continues_stroke: false,
        }
    }

    /// A dab that continues the stroke before it (see
    /// [`ApplyEdit::continues_stroke`]).
    pub fn continuing(volume: Entity, brush: Brush) -> Self {
        ApplyEdit {
            continues_stroke: true,
            ..ApplyEdit::new(volume, brush)
        }
    }
}

/// Take back a volume's last edit (a stroke counts as one), re-meshing only
/// the chunks it reached. Within one frame a volume's messages run in this
/// order: its [`ApplyEdit`]s, then its undos, then its redos. At most
/// [`KdContourSettings::undo_steps`](crate::KdContourSettings::undo_steps) edits
/// can be taken back.
#[derive(Message, Clone, Copy, Debug)]
pub struct UndoEdit {
    /// The volume entity.
    pub volume: Entity,
}

/// Put back the edit last taken back by [`UndoEdit`] (a new edit after an undo
/// drops what could be put back).
#[derive(Message, Clone, Copy, Debug)]
pub struct RedoEdit {
    /// The volume entity.
    pub volume: Entity,
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

/// An edit, an undo, a redo or a [`ReplaceField`] was applied; these chunks
/// are being rebuilt (none for an undo or redo with nothing to take back: it
/// still ends the open stroke).
#[derive(Message, Clone, Debug)]
pub struct EditApplied {
    /// The volume entity.
    pub volume: Entity,
    /// Chunks whose samples the brush reaches, at every level that covers it
    /// (level 0 in a one-level volume).
    pub rebuilt: Vec<ChunkKey>,
    /// What was applied to the volume's edit history, in the order applied
    /// (`None`: a [`ReplaceField`]).
    pub op: Option<EditOp>,
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

/// A chunk's build or extraction failed (a field error or a panic inside the
/// task), or one of its extras (a collider, a navmesh tile) could not be built
/// and the chunk is shown without it.
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
            .add_message::<UndoEdit>()
            .add_message::<RedoEdit>()
            .add_message::<EditApplied>()
            .add_message::<ReplaceField>()
            .add_message::<ChunkMeshed>()
            .add_message::<LodChanged>()
            .add_message::<ChunkFailed>();
    }
}
