//! The meshing state of one volume ([`VolumeState`], added by the volume
//! subsystem): its chunk world, its edited field, and one `ChunkSlot` per
//! loaded chunk holding everything the plugin tracks for that chunk, so loading
//! and unloading a chunk is one insert and one remove.

use crate::tasks::{BuildOut, ExtractOut};
use crate::volume::{ChunkStatus, KdChunk};
use bevy::prelude::*;
use bevy::tasks::Task;
use kdcontour::edit::{Brush, EditedField};
use kdcontour::{ChunkWorld, Field, IndexedMesh};
use std::collections::HashMap;
use std::sync::Arc;

/// Everything the plugin tracks for one loaded chunk.
pub(crate) struct ChunkSlot {
    /// The chunk's entity (a child of the volume).
    pub entity: Entity,
    /// Bumped by every build request; a build result from an older generation
    /// is dropped.
    pub build_gen: u64,
    /// Bumped by every extraction request; an older extraction is dropped.
    pub extract_stamp: u64,
    /// A build is wanted.
    pub need_build: bool,
    /// An extraction (interior and owned seams) is wanted.
    pub need_extract: bool,
    /// The running build (dropping it cancels it).
    pub building: Option<Task<BuildOut>>,
    /// The running extraction (dropping it cancels it).
    pub extracting: Option<Task<ExtractOut>>,
    /// A finished extraction waiting for upload: its threshold and mesh.
    pub ready: Option<(f32, IndexedMesh)>,
}

impl ChunkSlot {
    /// No work queued, running or waiting for upload.
    fn is_settled(&self) -> bool {
        !self.need_build
            && !self.need_extract
            && self.building.is_none()
            && self.extracting.is_none()
            && self.ready.is_none()
    }
}

/// Tasks running and waiting, for [`crate::KdContourStats`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkCounts {
    /// Builds and extractions running.
    pub running: usize,
    /// Builds and extractions waiting for a slot.
    pub queued: usize,
}

/// The meshing state of one volume (added by the plugin).
#[derive(Component)]
pub struct VolumeState {
    world: ChunkWorld,
    field: EditedField,
    /// The volume's field and iso the edits are layered on.
    pub(crate) base: (Arc<dyn Field>, f32),
    /// One slot per loaded chunk.
    pub(crate) slots: HashMap<IVec3, ChunkSlot>,
    /// The camera in the volume's local space: work is scheduled nearest first.
    pub(crate) focus: Vec3,
    /// The camera chunk and settings streaming last ran for.
    pub(crate) stream_key: Option<(IVec3, u32, i32, i32)>,
}

impl VolumeState {
    /// A state with no chunk loaded.
    pub(crate) fn new(world: ChunkWorld, field: EditedField, base: (Arc<dyn Field>, f32)) -> Self {
        VolumeState {
            world,
            field,
            base,
            slots: HashMap::new(),
            focus: Vec3::ZERO,
            stream_key: None,
        }
    }

    /// The chunk world (trees and thresholds).
    pub fn world(&self) -> &ChunkWorld {
        &self.world
    }

    /// The chunk world, to change.
    pub(crate) fn world_mut(&mut self) -> &mut ChunkWorld {
        &mut self.world
    }

    /// The field with every edit applied so far.
    pub fn field(&self) -> &EditedField {
        &self.field
    }

    /// Replaces the field (the caller marks what to rebuild).
    pub(crate) fn set_field(&mut self, field: EditedField) {
        self.field = field;
    }

    /// The edit log, oldest first (serialisable with serde).
    pub fn edit_log(&self) -> Vec<Brush> {
        self.field.log()
    }

    /// No work queued, running or waiting for upload.
    pub fn is_settled(&self) -> bool {
        self.slots.values().all(ChunkSlot::is_settled)
    }

    /// Tasks running and waiting.
    pub fn work_counts(&self) -> WorkCounts {
        let mut w = WorkCounts::default();
        for s in self.slots.values() {
            w.running += s.building.is_some() as usize + s.extracting.is_some() as usize;
            w.queued += s.need_build as usize + s.need_extract as usize;
        }
        w
    }

    /// The entity of chunk `c`.
    pub fn chunk_entity(&self, c: IVec3) -> Option<Entity> {
        self.slots.get(&c).map(|s| s.entity)
    }

    /// Queues a new extraction of every loaded chunk whose mesh shows part of
    /// `c`: `c` and the lower neighbours that own seams touching it.
    pub(crate) fn mark_extract(&mut self, c: IVec3) {
        for o in self.world.seam_owners_touching(c) {
            if let Some(slot) = self.slots.get_mut(&o) {
                slot.extract_stamp += 1;
                slot.need_extract = true;
            }
        }
    }

    /// Queues a new build of chunk `c`.
    pub(crate) fn mark_build(&mut self, c: IVec3) {
        if let Some(slot) = self.slots.get_mut(&c) {
            slot.build_gen += 1;
            slot.need_build = true;
        }
    }

    /// Makes `c` a member chunk with an entity, queued for its first build.
    pub(crate) fn load(
        &mut self,
        commands: &mut Commands,
        volume: Entity,
        c: IVec3,
        threshold: f32,
    ) {
        match self.world.add_chunk(c) {
            Ok(true) => {}
            Ok(false) => return,
            Err(e) => {
                error!("KdVolume {volume}: {e}");
                return;
            }
        }
        let entity = commands
            .spawn((
                KdChunk {
                    volume,
                    coord: c,
                    threshold,
                    triangles: 0,
                    status: ChunkStatus::Pending,
                },
                Transform::default(),
                Visibility::default(),
                ChildOf(volume),
            ))
            .id();
        self.slots.insert(
            c,
            ChunkSlot {
                entity,
                build_gen: 0,
                extract_stamp: 0,
                need_build: false,
                need_extract: false,
                building: None,
                extracting: None,
                ready: None,
            },
        );
        self.mark_build(c);
    }

    /// Drops chunk `c`: its tree, its tasks (dropping a task cancels it), its
    /// entity; the seams its lower neighbours own are re-extracted without it.
    pub(crate) fn unload(&mut self, commands: &mut Commands, c: IVec3) {
        let owners = self.world.seam_owners_touching(c);
        self.world.remove_chunk(c);
        if let Some(slot) = self.slots.remove(&c) {
            commands.entity(slot.entity).despawn();
        }
        for o in owners.into_iter().filter(|&o| o != c) {
            if let Some(slot) = self.slots.get_mut(&o) {
                slot.extract_stamp += 1;
                slot.need_extract = true;
            }
        }
    }

    /// Marks every chunk whose samples (its box grown by the one-cell halo) come
    /// within `reach` of `centre`; returns them.
    pub(crate) fn rebuild_near(&mut self, centre: Vec3, reach: f32) -> Vec<IVec3> {
        let grow = self.world.cell_size;
        let mut rebuilt = Vec::new();
        for c in self.world.coords() {
            let (lo, hi) = self.world.chunk_bounds(c);
            if centre.clamp(lo - grow, hi + grow).distance(centre) <= reach {
                self.mark_build(c);
                rebuilt.push(c);
            }
        }
        rebuilt
    }

    /// Distance from `p` to chunk `c`'s box.
    pub(crate) fn distance(&self, p: Vec3, c: IVec3) -> f32 {
        let (lo, hi) = self.world.chunk_bounds(c);
        p.clamp(lo, hi).distance(p)
    }

    /// Sorts chunks nearest the focus first (ties in z, y, x order).
    pub(crate) fn nearest_first(&self, v: &mut [IVec3]) {
        v.sort_by(|a, b| {
            self.distance(self.focus, *a)
                .total_cmp(&self.distance(self.focus, *b))
                .then((a.z, a.y, a.x).cmp(&(b.z, b.y, b.x)))
        });
    }
}
