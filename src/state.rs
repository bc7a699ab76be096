//! The meshing state of one volume ([`VolumeState`], added by the volume
//! subsystem): its chunk world, its edited field, and one `ChunkSlot` per
//! loaded chunk holding everything the plugin tracks for that chunk, so loading
//! and unloading a chunk is one insert and one remove. Chunks are addressed by
//! [`ChunkKey`] (level 0 in a one-level world).

use crate::horizon::layout::{HorizonKeep, HorizonState};
use crate::mesh::{ChunkExtra, ExtraKind, MeshExtra, EXTRA_KINDS};
use crate::tasks::work::ChunkWork;
use crate::volume::{ChunkStatus, KdChunk};
use bevy::prelude::*;
use kdcontour::edit::{Brush, EditHistory, EditedField};
use kdcontour::world::{ChunkKey, ChunkMap, Layout};
use kdcontour::{Field, World};
use std::sync::Arc;

/// Everything the plugin tracks for one loaded chunk. Its meshing work is the
/// task subsystem's ([`ChunkWork`]); the rest changes through the methods here.
pub(crate) struct ChunkSlot {
    /// The chunk's entity (a child of the volume).
    entity: Entity,
    /// Builds and extractions wanted, running and finished.
    pub(crate) work: ChunkWork,
    /// Its mesh waits for the rest of a level change, to be shown in the same
    /// frame as the chunks it replaces are dropped (see `horizon`).
    held: bool,
    /// Which extras its meshes carry (by [`ExtraKind`]): a collider or a
    /// navmesh tile, for a chunk near the camera or an anchor.
    carries: [bool; EXTRA_KINDS],
    /// Which extras a subsystem found this frame it should carry (its scratch
    /// mark while it reconciles `carries`).
    wants: [bool; EXTRA_KINDS],
    /// It has shown a mesh (or its lack of surface) at least once.
    shown: bool,
}

impl ChunkSlot {
    /// The chunk's entity.
    pub(crate) fn entity(&self) -> Entity {
        self.entity
    }

    /// Whether its mesh is held for a level change.
    pub(crate) fn held(&self) -> bool {
        self.held
    }

    /// Holds its next mesh for a level change (or not, for a first load), drops a
    /// finished one and asks for a new extraction.
    pub(crate) fn hold_for_change(&mut self, hold: bool) {
        self.held = hold;
        self.work.discard_ready();
        self.work.request_extract();
    }

    /// Ends its hold; returns whether a mesh is ready to show.
    pub(crate) fn release(&mut self) -> bool {
        let was = std::mem::take(&mut self.held);
        was && self.work.has_ready()
    }

    /// Whether it has shown a mesh (or its lack of surface).
    pub(crate) fn shown(&self) -> bool {
        self.shown
    }

    /// Its finished mesh, to show now (it counts as shown from then on).
    pub(crate) fn take_mesh_to_show(&mut self) -> Option<crate::mesh::ReadyMesh> {
        let ready = self.work.take_ready()?;
        self.shown = true;
        Some(ready)
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
    pub(crate) world: World,
    /// The edited field, with its undo and redo steps.
    history: EditHistory,
    /// Which of the volume's fields and isos the edits are layered on: the
    /// field's address (the field itself is the volume's, and the edited
    /// field's, which keeps it alive) and the iso; compared to notice a swap.
    base: (usize, f32),
    /// One slot per loaded chunk.
    pub(crate) slots: ChunkMap<ChunkSlot>,
    /// The camera in the volume's local space: work is scheduled nearest first.
    focus: Vec3,
    /// The camera chunk and settings streaming last ran for.
    stream_key: Option<(IVec3, u64, i32, i32)>,
    /// A horizon volume's level changes and layouts (the horizon subsystem's).
    pub(crate) horizon: HorizonState,
    /// What chunks near the camera or an anchor add to their meshes, by
    /// [`ExtraKind`] (set by the collider and navmesh subsystems; `None`
    /// without them).
    extras: [Option<ChunkExtra>; EXTRA_KINDS],
    /// What [`VolumeState::want_near`] last marked from, per kind: with the
    /// same anchors (to a unit), settings and chunks, nothing changes.
    wanted_for: [Option<WantedFor>; EXTRA_KINDS],
    /// The owners of the seams touching each chunk asked about, for the
    /// chunks (fingerprint) they were found among: looking them up is most of
    /// [`VolumeState::want_near`]'s time, and anchors move every frame.
    owners_touching: (Option<(usize, u64)>, ChunkMap<Vec<ChunkKey>>),
}

/// The inputs of one [`VolumeState::want_near`]: anchors to the unit, the
/// distance, whether it is on, and a fingerprint of the loaded chunks.
#[derive(Clone, PartialEq)]
struct WantedFor {
    points: Vec<IVec3>,
    distance: u32,
    enabled: bool,
    chunks: (usize, u64),
}

impl VolumeState {
    /// A state with no chunk loaded.
    pub(crate) fn new(world: World, field: EditedField, base: (&Arc<dyn Field>, f32)) -> Self {
        let base = (field_id(base.0), base.1);
        VolumeState {
            world,
            history: EditHistory::new(field),
            base,
            slots: ChunkMap::default(),
            focus: Vec3::ZERO,
            stream_key: None,
            horizon: HorizonState::default(),
            extras: Default::default(),
            wanted_for: Default::default(),
            owners_touching: Default::default(),
        }
    }

    /// Chunks loaded (with an entity, built or being built). A horizon volume's
    /// world also lists the chunks of its layout that its view leaves out.
    pub fn loaded_chunks(&self) -> usize {
        self.slots.len()
    }

    /// The chunk world (trees and thresholds).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The chunk world, to change.
    pub(crate) fn world_mut(&mut self) -> &mut World {
        &mut self.world
    }

    /// The field with every edit applied so far (undone ones left out).
    pub fn field(&self) -> &EditedField {
        self.history.field()
    }

    /// The edits with their undo and redo steps.
    pub fn history(&self) -> &EditHistory {
        &self.history
    }

    /// The edits, to change (the caller marks what to rebuild).
    pub(crate) fn history_mut(&mut self) -> &mut EditHistory {
        &mut self.history
    }

    /// Puts the edit log back on a new base field and iso (the volume's field
    /// was swapped): the edits, applied and undone, are put on `field` shifted
    /// by `iso`, and the caller marks what to rebuild.
    pub(crate) fn swap_base(&mut self, field: Arc<dyn Field>, iso: f32) {
        self.history
            .rebase(crate::volume::KdVolume::shifted(&field, iso));
        self.base = (field_id(&field), iso);
    }

    /// Whether `field` and `iso` are the ones the edits are layered on.
    pub(crate) fn has_base(&self, field: &Arc<dyn Field>, iso: f32) -> bool {
        self.base == (field_id(field), iso)
    }

    /// The iso the edits are layered on.
    pub(crate) fn base_iso(&self) -> f32 {
        self.base.1
    }

    /// Points scheduling at `focus` (the camera, in the volume's local space).
    pub(crate) fn follow(&mut self, focus: Vec3) {
        self.focus = focus;
    }

    /// Records that streaming runs for `key` (the camera's chunk and the
    /// settings); false when it ran for the same key last time (nothing to do).
    pub(crate) fn stream_to(&mut self, key: (IVec3, u64, i32, i32)) -> bool {
        self.stream_key.replace(key) != Some(key)
    }

    /// The edit log applied, oldest first (serialisable with serde).
    pub fn edit_log(&self) -> Vec<Brush> {
        self.history.field().log()
    }

    /// No work queued, running or waiting for upload, and no level change in
    /// progress.
    pub fn is_settled(&self) -> bool {
        self.horizon.is_settled() && self.slots.values().all(|s| s.work.is_settled())
    }

    /// Whether a level change (a horizon volume's new layout) is waiting for
    /// its meshes; the chunks it replaces are shown until it ends.
    pub fn level_change_in_progress(&self) -> bool {
        self.horizon.level_change_in_progress()
    }

    /// How long a horizon volume's last level change took, from its layout's
    /// request to its meshes shown (seconds; zero before the first, and for
    /// other volumes).
    pub fn level_change_seconds(&self) -> f64 {
        self.horizon.change_seconds()
    }

    /// A horizon volume's layout whose chunks are shown now (while a level
    /// change runs, the one it replaces), and which of its chunks are kept;
    /// `None` until the first layout has loaded. The shown chunks are exactly
    /// the layout's kept chunks.
    pub fn horizon_shown(&self) -> Option<(&Layout, &HorizonKeep)> {
        self.horizon.shown()
    }

    /// The chunks that show something now, with their entities: every loaded
    /// chunk that has shown a mesh (or its lack of surface), and the chunks a
    /// level change in progress is replacing. Together they cover the loaded
    /// region once when the volume has finished its first load.
    pub fn shown_chunks(&self) -> Vec<(ChunkKey, Entity)> {
        let mut v: Vec<(ChunkKey, Entity)> = self
            .slots
            .iter()
            .filter(|(_, s)| s.shown)
            .map(|(k, s)| (*k, s.entity))
            .collect();
        v.extend(self.horizon.retired().iter().copied());
        v.sort_by_key(|(k, _)| k.order());
        v
    }

    /// Tasks running and waiting.
    pub fn work_counts(&self) -> WorkCounts {
        let mut w = WorkCounts::default();
        for s in self.slots.values() {
            w.running += s.work.running();
            w.queued += s.work.queued();
        }
        w
    }

    /// The entity of chunk `c`.
    pub fn chunk_entity(&self, c: &ChunkKey) -> Option<Entity> {
        self.slots.get(c).map(|s| s.entity)
    }

    /// Queues a new extraction of every loaded chunk whose mesh shows part of
    /// `c`: `c` and the neighbours that own seams touching it.
    pub(crate) fn mark_extract(&mut self, c: &ChunkKey) {
        for o in self.world.seam_owners_touching(c) {
            if let Some(slot) = self.slots.get_mut(&o) {
                slot.work.request_extract();
            }
        }
    }

    /// The threshold a chunk (its slot) may not be cut coarser than because it
    /// carries an extra (a collider or a navmesh tile), if any: the finest of
    /// theirs.
    pub(crate) fn extra_cap(&self, slot: &ChunkSlot) -> Option<f32> {
        self.extras
            .iter()
            .zip(slot.carries)
            .filter(|(_, on)| *on)
            .filter_map(|(e, _)| e.as_ref().and_then(|e| e.on))
            .reduce(f32::min)
    }

    /// The lowest threshold this volume's chunks can be cut at with
    /// `settings`: the settings' ([`crate::KdContourSettings::lowest_threshold`]) or
    /// an extra's cap, if finer.
    pub(crate) fn lowest_threshold(&self, settings: &crate::KdContourSettings) -> f32 {
        self.extras
            .iter()
            .filter_map(|e| e.as_ref().and_then(|e| e.on))
            .fold(settings.lowest_threshold(), f32::min)
    }

    /// Builds trees from now on for cuts no lower than `floor`
    /// ([`kdcontour::Settings::min_threshold`]: a lower cut is the cut at it),
    /// or than the highest cut they serve ([`kdcontour::Settings::max_threshold`])
    /// if that is lower. When it went down, every loaded chunk's tree, built for
    /// a higher one, is built again, so no chunk is cut coarser than it asks.
    pub(crate) fn cut_no_lower_than(&mut self, floor: f32) {
        // Settings with no number for it (NaN) limit nothing: the thresholds
        // themselves are refused where they are used.
        let floor = if floor.is_nan() {
            f32::NEG_INFINITY
        } else {
            floor.min(self.world.settings.max_threshold)
        };
        let old = self.world.settings.min_threshold;
        if old.to_bits() == floor.to_bits() {
            return;
        }
        self.world.settings.min_threshold = floor;
        if floor < old {
            self.mark_build_all();
        }
    }

    /// Whether the extra `kind` is set.
    #[cfg_attr(not(any(feature = "avian", feature = "navmesh")), allow(dead_code))]
    pub(crate) fn has_extra(&self, kind: ExtraKind) -> bool {
        self.extras[kind as usize].is_some()
    }

    /// Sets what chunks that carry the extra `kind` add to their meshes.
    #[cfg_attr(not(any(feature = "avian", feature = "navmesh")), allow(dead_code))]
    pub(crate) fn set_extra(&mut self, kind: ExtraKind, extra: Option<ChunkExtra>) {
        self.extras[kind as usize] = extra;
    }

    /// For a new extraction of `slot`: each extra's builder and whether the
    /// chunk carries it now.
    pub(crate) fn extras_for(&self, slot: &ChunkSlot) -> Vec<(Arc<dyn MeshExtra>, bool)> {
        self.extras
            .iter()
            .zip(slot.carries)
            .filter_map(|(e, on)| {
                let e = e.as_ref()?;
                Some((e.builder.clone(), e.on.is_some() && on))
            })
            .collect()
    }

    /// Marks the chunks that should carry the extra `kind` (while `enabled`):
    /// those within `distance` of any of `points` (volume-local), and the
    /// owners of seams touching them, so the surface there is whole. A chunk
    /// whose mark changed is extracted again, with or without it; a chunk held
    /// for a level change keeps what it has until the change ends.
    #[cfg_attr(not(any(feature = "avian", feature = "navmesh")), allow(dead_code))]
    pub(crate) fn want_near(
        &mut self,
        kind: ExtraKind,
        enabled: bool,
        distance: f32,
        points: &[Vec3],
    ) {
        let i = kind as usize;
        // The same inputs mark the same chunks: skip the seam lookups (anchors
        // move a little every frame; to the unit is plenty at any distance).
        let inputs = WantedFor {
            points: points.iter().map(|p| p.round().as_ivec3()).collect(),
            distance: distance.to_bits(),
            enabled,
            chunks: self.slots.keys().fold((0, 0), |(n, h), k| {
                let (x, y, z, l) = k.order();
                let mix = (x as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
                    ^ (y as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
                    ^ (z as u64).wrapping_mul(0x1656_67b1_9e37_79f9)
                    ^ (l as u64).rotate_left(17);
                (n + 1, h ^ mix)
            }),
        };
        if self.wanted_for[i].as_ref() == Some(&inputs) {
            return;
        }
        if self.owners_touching.0 != Some(inputs.chunks) {
            self.owners_touching = (Some(inputs.chunks), ChunkMap::default());
        }
        // Marks on the slots rather than a set of keys: the near chunks' seam
        // owners are looked up once each, and nothing is hashed twice.
        for slot in self.slots.values_mut() {
            slot.wants[i] = false;
        }
        if enabled {
            let near: Vec<ChunkKey> = self
                .slots
                .keys()
                .filter(|k| points.iter().any(|p| self.distance(*p, k) <= distance))
                .copied()
                .collect();
            for k in near {
                let owners = self
                    .owners_touching
                    .1
                    .entry(k)
                    .or_insert_with(|| self.world.seam_owners_touching(&k));
                for o in owners.iter() {
                    if let Some(slot) = self.slots.get_mut(o) {
                        slot.wants[i] = true;
                    }
                }
            }
        }
        let mut changed: Vec<ChunkKey> = self
            .slots
            .iter()
            .filter(|(_, s)| s.carries[i] != s.wants[i])
            .map(|(k, _)| *k)
            .collect();
        changed.sort_by_key(|k| k.order());
        let mut waiting = false;
        for k in changed {
            if self.shows_held(&k) {
                waiting = true; // tried again next frame
                continue;
            }
            let slot = self.slots.get_mut(&k).expect("listed");
            slot.carries[i] = !slot.carries[i];
            slot.work.request_extract();
        }
        self.wanted_for[i] = (!waiting).then_some(inputs);
    }

    /// Extracts again every chunk that carries the extra `kind` (its builder
    /// changed).
    #[cfg_attr(not(feature = "navmesh"), allow(dead_code))]
    pub(crate) fn refresh_extra(&mut self, kind: ExtraKind) {
        for slot in self.slots.values_mut() {
            if slot.carries[kind as usize] {
                slot.work.request_extract();
            }
        }
    }

    /// Whether a chunk whose mesh shows part of `c` is held for a level change.
    pub(crate) fn shows_held(&self, c: &ChunkKey) -> bool {
        self.horizon.blocks(c)
    }

    /// Queues a new build of chunk `c`.
    pub(crate) fn mark_build(&mut self, c: &ChunkKey) {
        if let Some(slot) = self.slots.get_mut(c) {
            slot.work.request_build();
        }
    }

    /// Makes level-0 chunk `c` a member of a streaming (open) world with an
    /// entity, queued for its first build.
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
        self.add_slot(commands, volume, ChunkKey::new(0, c), threshold);
    }

    /// Gives chunk `k` (already in the world) an entity and a slot, queued for
    /// its first build.
    pub(crate) fn add_slot(
        &mut self,
        commands: &mut Commands,
        volume: Entity,
        c: ChunkKey,
        threshold: f32,
    ) {
        let entity = commands
            .spawn((
                KdChunk {
                    volume,
                    coord: c.coord,
                    level: c.level,
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
                work: ChunkWork::default(),
                held: false,
                shown: false,
                carries: [false; EXTRA_KINDS],
                wants: [false; EXTRA_KINDS],
            },
        );
        self.mark_build(&c);
    }

    /// Drops chunk `k` of a streaming (open) world: its tree, its tasks
    /// (dropping a task cancels it), its entity; the seams its lower neighbours
    /// own are re-extracted without it.
    pub(crate) fn unload(&mut self, commands: &mut Commands, k: ChunkKey) {
        let owners = self.world.seam_owners_touching(&k);
        if !self.world.remove_chunk(&k) {
            return;
        }
        if let Some(slot) = self.slots.remove(&k) {
            commands.entity(slot.entity).despawn();
        }
        for o in owners.into_iter().filter(|&o| o != k) {
            if let Some(slot) = self.slots.get_mut(&o) {
                slot.work.request_extract();
            }
        }
    }

    /// Marks every loaded chunk whose samples an edit within `reach` of
    /// `center` changes (at every level that covers it); returns them.
    pub(crate) fn rebuild_near(&mut self, center: Vec3, reach: f32) -> Vec<ChunkKey> {
        let mut rebuilt = Vec::new();
        for c in self.world.edited(center, reach) {
            if self.slots.contains_key(&c) {
                self.mark_build(&c);
                rebuilt.push(c);
            }
        }
        rebuilt
    }

    /// Marks every loaded chunk for a rebuild; returns them.
    pub(crate) fn rebuild_all(&mut self) -> Vec<ChunkKey> {
        let every = self.world.chunks();
        self.world.forget_samples(&every);
        self.mark_build_all()
    }

    /// Queues a new build of every loaded chunk (in the world's order);
    /// returns them.
    fn mark_build_all(&mut self) -> Vec<ChunkKey> {
        let mut all: Vec<ChunkKey> = self.slots.keys().copied().collect();
        all.sort_by_key(|c| c.order());
        for c in &all {
            self.mark_build(c);
        }
        all
    }

    /// Distance from `p` to chunk `c`'s box.
    pub(crate) fn distance(&self, p: Vec3, c: &ChunkKey) -> f32 {
        let (lo, hi) = self.world.chunk_bounds(c);
        p.clamp(lo, hi).distance(p)
    }

    /// Sorts chunks nearest the focus first (ties in the world's order).
    pub(crate) fn nearest_first(&self, v: &mut [ChunkKey]) {
        // Each key once (a distance costs a chunk-bounds lookup); a distance is
        // never negative, so its bits sort as the number does.
        v.sort_by_cached_key(|k| (self.distance(self.focus, k).max(0.0).to_bits(), k.order()));
    }
}

/// A field's identity: its address, which stays put while the volume holds it.
fn field_id(field: &Arc<dyn Field>) -> usize {
    Arc::as_ptr(field) as *const () as usize
}
