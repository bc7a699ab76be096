//! # bevy_kdcontour
//!
//! A Bevy 0.19 plugin that meshes signed-distance, CSG and noise fields through the
//! discrete k-d tree of [`kdcontour`], in chunks: each chunk's tree is built on
//! [`AsyncComputeTaskPool`], kept, and re-cut at a new error threshold when the
//! [`LodCamera`] moves (no re-sampling); edits ([`ApplyEdit`]) rebuild only the
//! chunks they reach; seams between chunks at different thresholds are contoured
//! across the chunk trees, so there are no cracks, skirts or transition cells.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_kdcontour::prelude::*;
//! use std::sync::Arc;
//!
//! fn setup(mut commands: Commands, mut materials: ResMut<Assets<StandardMaterial>>) {
//!     let field = kdcontour::scenes::scene("torus").unwrap().field;
//!     commands.spawn((
//!         KdVolume::new(Arc::from(field), UVec3::splat(4), 16, 2.0 / 64.0)
//!             .with_material(materials.add(Color::srgb(0.8, 0.7, 0.6))),
//!         Transform::from_xyz(-1.0, -1.0, -1.0),
//!     ));
//!     commands.spawn((Camera3d::default(), LodCamera, Transform::from_xyz(0.0, 1.0, 3.0)));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, KdContourPlugin::default()))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! ## Frame by frame
//! [`KdContourSystems`] runs in [`PostUpdate`], chained and before transform
//! propagation: `Edits` (apply brushes, mark chunks to rebuild) → `Lod` (thresholds
//! from the camera, with hysteresis) → `Schedule` (start builds and extractions, at
//! most [`KdContourSettings::max_tasks_in_flight`]) → `Poll` (collect finished tasks
//! with `check_ready`; results from an older field or threshold are dropped) →
//! `Apply` (upload at most [`KdContourSettings::max_uploads_per_frame`] meshes).
//! `Lod` also streams the chunks of unbounded volumes ([`KdVolume::streaming`]) in
//! and out around the camera, nearest first.
//!
//! Each chunk mesh holds the chunk's interior and the seams it owns (see
//! [`kdcontour::world`] for the ownership rule), in the volume's local space.

use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::tasks::{futures::check_ready, AsyncComputeTaskPool, Task};
use bevy::transform::TransformSystems;
use kdcontour::edit::{Brush, EditedField};
use kdcontour::world::ChunkSnapshot;
use kdcontour::{ChunkWorld, Field, IndexedMesh, KdTree, Lod};
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

pub use kdcontour;

#[cfg(feature = "egui")]
pub mod panel;

/// Everything a user of the plugin needs.
pub mod prelude {
    pub use crate::{
        ApplyEdit, ChunkFailed, ChunkMeshed, ChunkStatus, EditApplied, KdChunk, KdContourPlugin,
        KdContourSettings, KdContourStats, KdContourSystems, KdVolume, LodCamera, LodChanged,
        LodSettings, ReplaceField, SharedField, VolumeExtent, VolumeState,
    };
    pub use kdcontour::edit::{Brush, BrushOp};
}

/// How chunk thresholds follow the camera.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct LodSettings {
    /// Whether the camera drives thresholds at all.
    pub enabled: bool,
    /// Threshold of chunks within `near` of the camera (squared cells).
    pub base: f32,
    /// Distance (world units) up to which chunks stay at `base`.
    pub near: f32,
    /// Growth of the threshold with distance (2: with its square).
    pub growth: f32,
    /// Largest threshold.
    pub max: f32,
    /// A chunk changes threshold only when the new one differs by more than this
    /// fraction, so chunks near a boundary do not flicker.
    pub hysteresis: f32,
}

impl Default for LodSettings {
    fn default() -> Self {
        LodSettings {
            enabled: true,
            base: 0.001,
            near: 16.0,
            growth: 2.0,
            max: 10.0,
            hysteresis: 0.25,
        }
    }
}

impl LodSettings {
    fn curve(&self) -> Lod {
        Lod {
            base: self.base,
            near: self.near,
            growth: self.growth,
            max: self.max,
        }
    }
}

/// The plugin's settings, mirrored into a reflected resource so they can change
/// at run time.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct KdContourSettings {
    /// Most chunk builds and extractions running at once.
    pub max_tasks_in_flight: usize,
    /// Most chunk meshes uploaded per frame.
    pub max_uploads_per_frame: usize,
    /// Threshold of chunks before the camera sets one (or with LOD off).
    pub default_threshold: f32,
    /// Camera-driven level of detail.
    pub lod: LodSettings,
    /// Colour each chunk by its threshold (blue: finest, red: coarsest) instead of
    /// its volume's material, to see the LOD rings and seams.
    pub color_by_lod: bool,
}

impl Default for KdContourSettings {
    fn default() -> Self {
        KdContourSettings {
            max_tasks_in_flight: 8,
            max_uploads_per_frame: 16,
            default_threshold: 0.01,
            lod: LodSettings::default(),
            color_by_lod: false,
        }
    }
}

/// Adds chunked, LOD-driven meshing of [`KdVolume`]s.
#[derive(Default)]
pub struct KdContourPlugin {
    /// Initial settings (copied into the [`KdContourSettings`] resource).
    pub settings: KdContourSettings,
}

/// The plugin's systems, in the order they run (chained, in [`PostUpdate`], before
/// transform propagation).
#[derive(SystemSet, Debug, Hash, PartialEq, Eq, Clone)]
pub enum KdContourSystems {
    /// Applies [`ApplyEdit`] messages.
    Edits,
    /// Streams chunks of unbounded volumes around the [`LodCamera`] and sets
    /// thresholds from its distance.
    Lod,
    /// Starts meshing tasks.
    Schedule,
    /// Collects finished tasks.
    Poll,
    /// Uploads meshes.
    Apply,
}

impl Plugin for KdContourPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.settings.clone())
            .init_resource::<KdContourStats>()
            .register_type::<KdContourSettings>()
            .register_type::<KdContourStats>()
            .register_type::<LodSettings>()
            .register_type::<KdVolume>()
            .register_type::<VolumeExtent>()
            .register_type::<KdChunk>()
            .register_type::<ChunkStatus>()
            .register_type::<LodCamera>()
            .add_message::<ApplyEdit>()
            .add_message::<EditApplied>()
            .add_message::<ReplaceField>()
            .add_message::<ChunkMeshed>()
            .add_message::<LodChanged>()
            .add_message::<ChunkFailed>()
            .configure_sets(
                PostUpdate,
                (
                    KdContourSystems::Edits,
                    KdContourSystems::Lod,
                    KdContourSystems::Schedule,
                    KdContourSystems::Poll,
                    KdContourSystems::Apply,
                )
                    .chain()
                    .before(TransformSystems::Propagate),
            )
            .add_systems(
                PostUpdate,
                (
                    (init_volumes, sync_volumes, apply_edits)
                        .chain()
                        .in_set(KdContourSystems::Edits),
                    (stream_chunks, update_lod)
                        .chain()
                        .in_set(KdContourSystems::Lod),
                    schedule_tasks.in_set(KdContourSystems::Schedule),
                    poll_tasks.in_set(KdContourSystems::Poll),
                    (apply_meshes, color_chunks, gather_stats)
                        .chain()
                        .in_set(KdContourSystems::Apply),
                ),
            );
    }
}

/// A field shared with meshing tasks.
#[derive(Clone)]
pub struct SharedField(pub Arc<dyn Field>);

impl Default for SharedField {
    /// Empty space (no surface).
    fn default() -> Self {
        SharedField(Arc::new(kdcontour::field::FnField(|_| 1.0)))
    }
}

/// Which chunks a volume has.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub enum VolumeExtent {
    /// A fixed block of X x Y x Z chunks, from chunk (0, 0, 0).
    Bounded {
        /// Chunks along x, y, z.
        chunks: UVec3,
    },
    /// Unbounded: the chunks whose box comes within `view_distance` of the
    /// [`LodCamera`] are loaded, nearest first; a chunk is dropped once its box is
    /// more than `view_distance` plus one chunk side away (so chunks at the edge do
    /// not load and unload every frame). Chunk rows are limited to
    /// `min_y..=max_y` (terrain has nothing far above or below).
    Streaming {
        /// Load radius around the camera (local units).
        view_distance: f32,
        /// Lowest chunk row.
        min_y: i32,
        /// Highest chunk row.
        max_y: i32,
    },
}

/// A volume of chunks of `chunk_res`³ cells of side `cell_size`, sampled from
/// `field` in the entity's local space (lattice corner (0, 0, 0) at the entity's
/// origin): a bounded block ([`KdVolume::new`]) or unbounded terrain streamed
/// around the camera ([`KdVolume::streaming`]). Its chunks are spawned as children.
#[derive(Component, Clone, Reflect)]
#[reflect(Component)]
#[require(Transform, Visibility)]
pub struct KdVolume {
    /// The field (negative inside).
    #[reflect(ignore)]
    pub field: SharedField,
    /// Which chunks exist.
    pub extent: VolumeExtent,
    /// Cells per chunk along each axis.
    pub chunk_res: u32,
    /// Side of one cell (local units).
    pub cell_size: f32,
    /// The level of the field that is the surface (0 for signed distances; a
    /// density or intensity threshold for scans). Changing it rebuilds every chunk.
    pub iso: f32,
    /// Material of the chunk meshes.
    pub material: Handle<StandardMaterial>,
}

impl KdVolume {
    /// A bounded volume of `chunks` chunks, with the default material.
    pub fn new(field: Arc<dyn Field>, chunks: UVec3, chunk_res: u32, cell_size: f32) -> Self {
        KdVolume {
            field: SharedField(field),
            extent: VolumeExtent::Bounded { chunks },
            chunk_res,
            cell_size,
            iso: 0.0,
            material: Handle::default(),
        }
    }

    /// An unbounded volume streamed within `view_distance` of the camera, chunk
    /// rows -2 to 1 (change them with [`KdVolume::with_rows`]).
    pub fn streaming(
        field: Arc<dyn Field>,
        chunk_res: u32,
        cell_size: f32,
        view_distance: f32,
    ) -> Self {
        KdVolume {
            field: SharedField(field),
            extent: VolumeExtent::Streaming {
                view_distance,
                min_y: -2,
                max_y: 1,
            },
            chunk_res,
            cell_size,
            iso: 0.0,
            material: Handle::default(),
        }
    }

    /// The same volume with its surface at level `iso` of the field.
    pub fn with_iso(mut self, iso: f32) -> Self {
        self.iso = iso;
        self
    }

    /// A streaming volume limited to chunk rows `min_y..=max_y` (no effect on a
    /// bounded one).
    pub fn with_rows(mut self, min_y: i32, max_y: i32) -> Self {
        if let VolumeExtent::Streaming {
            min_y: lo,
            max_y: hi,
            ..
        } = &mut self.extent
        {
            (*lo, *hi) = (min_y, max_y);
        }
        self
    }

    /// The same volume with `material`.
    pub fn with_material(mut self, material: Handle<StandardMaterial>) -> Self {
        self.material = material;
        self
    }
}

/// What a chunk is doing.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub enum ChunkStatus {
    /// Waiting for its first build.
    #[default]
    Pending,
    /// A build or extraction is queued or running.
    Busy,
    /// Shows a mesh.
    Meshed,
    /// Has no surface.
    Empty,
    /// Its last build failed (the message says why); an edit retries it.
    Failed(String),
}

/// One chunk of a [`KdVolume`] (a child entity).
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct KdChunk {
    /// The volume it belongs to.
    pub volume: Entity,
    /// Its chunk coordinates.
    pub coord: IVec3,
    /// The threshold of the mesh it shows.
    pub threshold: f32,
    /// Triangles in the mesh it shows.
    pub triangles: usize,
    /// What it is doing.
    pub status: ChunkStatus,
}

/// Marks the camera whose distance sets chunk thresholds (the first one found).
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct LodCamera;

/// Apply a brush to a volume.
#[derive(Message, Clone, Debug)]
pub struct ApplyEdit {
    /// The volume entity.
    pub volume: Entity,
    /// The brush, in the volume's local space.
    pub brush: Brush,
}

/// Replace a volume's field (the edit log is replayed on top of it). With
/// `regions`, only chunks within those spheres `(centre, radius)`, in the volume's
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
    /// Chunks whose box (grown by a cell) the brush reaches.
    pub rebuilt: Vec<IVec3>,
}

/// A chunk now shows a new mesh.
#[derive(Message, Clone, Debug)]
pub struct ChunkMeshed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk entity.
    pub chunk: Entity,
    /// Its coordinates.
    pub coord: IVec3,
    /// Triangles in the mesh (0: the chunk is empty).
    pub triangles: usize,
}

/// The camera moved a chunk to a new threshold.
#[derive(Message, Clone, Debug)]
pub struct LodChanged {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk.
    pub coord: IVec3,
    /// Its new threshold.
    pub threshold: f32,
}

/// A chunk's build failed (a field error or a panic inside the task).
#[derive(Message, Clone, Debug)]
pub struct ChunkFailed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk.
    pub coord: IVec3,
    /// What went wrong.
    pub error: String,
}

struct BuildOut {
    coord: IVec3,
    generation: u64,
    result: Result<KdTree, String>,
    ms: f64,
}

struct ExtractOut {
    coord: IVec3,
    stamp: u64,
    threshold: f32,
    mesh: IndexedMesh,
    ms: f64,
}

/// What the plugin did, for panels and profiling (updated every frame).
#[derive(Resource, Clone, Debug, Default, Reflect)]
#[reflect(Resource)]
pub struct KdContourStats {
    /// Chunks of all volumes.
    pub chunks: usize,
    /// Chunks showing a mesh.
    pub meshed_chunks: usize,
    /// Triangles shown.
    pub triangles: usize,
    /// Builds and extractions running.
    pub tasks_in_flight: usize,
    /// Builds and extractions waiting for a slot.
    pub queued: usize,
    /// Chunk builds finished since start.
    pub builds: u64,
    /// Extractions finished since start.
    pub extractions: u64,
    /// Mean time of one chunk build (sample + tree), ms, over recent builds.
    pub build_ms: f64,
    /// Mean time of one chunk extraction (interior + owned seams), ms.
    pub extract_ms: f64,
    /// Main-thread time of the plugin's systems in the last frame, ms (mesh
    /// upload included).
    pub main_thread_ms: f64,
    /// Smallest and largest chunk threshold in use.
    pub threshold_range: (f32, f32),
    /// This frame's main-thread time so far (published at the end of the frame).
    frame_ms: f64,
}

impl KdContourStats {
    fn add_time(&mut self, t0: std::time::Instant) {
        self.frame_ms += t0.elapsed().as_secs_f64() * 1e3;
    }
}

/// Moving average over about the last 32 samples.
fn ema(avg: &mut f64, x: f64, n: u64) {
    let k = 1.0 / (n.min(32) as f64);
    *avg += (x - *avg) * k;
}

/// The meshing state of one volume (added by the plugin).
#[derive(Component)]
pub struct VolumeState {
    world: ChunkWorld,
    field: EditedField,
    /// The volume's field and iso the edits are layered on.
    base: (Arc<dyn Field>, f32),
    entities: HashMap<IVec3, Entity>,
    build_gen: HashMap<IVec3, u64>,
    extract_stamp: HashMap<IVec3, u64>,
    need_build: HashSet<IVec3>,
    need_extract: HashSet<IVec3>,
    building: HashMap<IVec3, Task<BuildOut>>,
    extracting: HashMap<IVec3, Task<ExtractOut>>,
    ready: HashMap<IVec3, (f32, IndexedMesh)>,
    /// The camera in the volume's local space: work is scheduled nearest first.
    focus: Vec3,
    /// The camera chunk and settings streaming last ran for.
    stream_key: Option<(IVec3, u32, i32, i32)>,
}

impl VolumeState {
    /// The chunk world (trees and thresholds).
    pub fn world(&self) -> &ChunkWorld {
        &self.world
    }

    /// The field with every edit applied so far.
    pub fn field(&self) -> &EditedField {
        &self.field
    }

    /// The edit log, oldest first (serialisable with serde).
    pub fn edit_log(&self) -> Vec<Brush> {
        self.field.log()
    }

    /// No work queued, running or waiting for upload.
    pub fn is_settled(&self) -> bool {
        self.need_build.is_empty()
            && self.need_extract.is_empty()
            && self.building.is_empty()
            && self.extracting.is_empty()
            && self.ready.is_empty()
    }

    /// The entity of chunk `c`.
    pub fn chunk_entity(&self, c: IVec3) -> Option<Entity> {
        self.entities.get(&c).copied()
    }

    fn mark_extract(&mut self, c: IVec3) {
        for o in self.world.seam_owners_touching(c) {
            *self.extract_stamp.entry(o).or_default() += 1;
            self.need_extract.insert(o);
        }
    }

    fn mark_build(&mut self, c: IVec3) {
        *self.build_gen.entry(c).or_default() += 1;
        self.need_build.insert(c);
    }

    /// Makes `c` a member chunk with an entity, queued for its first build.
    fn load(&mut self, commands: &mut Commands, volume: Entity, c: IVec3, threshold: f32) {
        match self.world.add_chunk(c) {
            Ok(true) => {}
            Ok(false) => return,
            Err(e) => {
                error!("KdVolume {volume}: {e}");
                return;
            }
        }
        let chunk = commands
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
        self.entities.insert(c, chunk);
        self.mark_build(c);
    }

    /// Drops chunk `c`: its tree, its tasks (dropping a task cancels it), its
    /// entity; the seams its lower neighbours own are re-extracted without it.
    fn unload(&mut self, commands: &mut Commands, c: IVec3) {
        let owners = self.world.seam_owners_touching(c);
        self.world.remove_chunk(c);
        for o in owners.into_iter().filter(|&o| o != c) {
            *self.extract_stamp.entry(o).or_default() += 1;
            self.need_extract.insert(o);
        }
        self.need_build.remove(&c);
        self.need_extract.remove(&c);
        self.building.remove(&c);
        self.extracting.remove(&c);
        self.ready.remove(&c);
        self.build_gen.remove(&c);
        self.extract_stamp.remove(&c);
        if let Some(e) = self.entities.remove(&c) {
            commands.entity(e).despawn();
        }
    }

    /// Distance from the focus to chunk `c`'s box, for nearest-first ordering.
    fn focus_distance(&self, c: IVec3) -> f32 {
        let (lo, hi) = self.world.chunk_bounds(c);
        self.focus.clamp(lo, hi).distance(self.focus)
    }

    /// Sorts chunks nearest the focus first (ties in z, y, x order).
    fn nearest_first(&self, v: &mut [IVec3]) {
        v.sort_by(|a, b| {
            self.focus_distance(*a)
                .total_cmp(&self.focus_distance(*b))
                .then((a.z, a.y, a.x).cmp(&(b.z, b.y, b.x)))
        });
    }
}

/// The field a volume meshes: its field at its iso level.
fn shifted(field: &Arc<dyn Field>, iso: f32) -> Arc<dyn Field> {
    if iso == 0.0 {
        field.clone()
    } else {
        Arc::new(kdcontour::field::IsoShift {
            inner: field.clone(),
            iso,
        })
    }
}

fn init_volumes(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    mut stats: ResMut<KdContourStats>,
    volumes: Query<(Entity, &KdVolume), Without<VolumeState>>,
) {
    stats.frame_ms = 0.0;
    let t0 = std::time::Instant::now();
    for (entity, vol) in &volumes {
        if !vol.iso.is_finite() {
            error!("KdVolume {entity}: iso {} must be finite", vol.iso);
            commands.entity(entity).remove::<KdVolume>();
            continue;
        }
        let core = kdcontour::Settings {
            threads: 1,
            ..Default::default()
        };
        let world = match vol.extent {
            VolumeExtent::Bounded { chunks } => ChunkWorld::new(
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
                } else {
                    ChunkWorld::unbounded(
                        Vec3::ZERO,
                        vol.cell_size,
                        vol.chunk_res,
                        settings.default_threshold,
                        core,
                    )
                }
            }
        };
        let world = match world {
            Ok(w) => w,
            Err(e) => {
                error!("KdVolume {entity}: {e}");
                commands.entity(entity).remove::<KdVolume>();
                continue;
            }
        };
        let mut state = VolumeState {
            field: EditedField::new(shifted(&vol.field.0, vol.iso)),
            base: (vol.field.0.clone(), vol.iso),
            world,
            entities: HashMap::new(),
            build_gen: HashMap::new(),
            extract_stamp: HashMap::new(),
            need_build: HashSet::new(),
            need_extract: HashSet::new(),
            building: HashMap::new(),
            extracting: HashMap::new(),
            ready: HashMap::new(),
            focus: Vec3::ZERO,
            stream_key: None,
        };
        // A bounded world already lists its chunks; give each an entity. (A
        // streaming world is empty until `stream_chunks` runs.)
        for c in state.world.coords() {
            state.world.remove_chunk(c);
            state.load(&mut commands, entity, c, settings.default_threshold);
        }
        commands.entity(entity).insert(state);
    }
    stats.add_time(t0);
}

/// A volume whose field or iso changed: replay its edits on the new field and
/// rebuild every chunk.
fn sync_volumes(
    mut stats: ResMut<KdContourStats>,
    mut volumes: Query<(Entity, &KdVolume, &mut VolumeState), Changed<KdVolume>>,
) {
    let t0 = std::time::Instant::now();
    for (entity, vol, mut state) in &mut volumes {
        let (field, iso) = &state.base;
        if Arc::ptr_eq(field, &vol.field.0) && *iso == vol.iso {
            continue;
        }
        if !vol.iso.is_finite() {
            warn!(
                "KdVolume {entity}: iso {} must be finite; kept {iso}",
                vol.iso
            );
            continue;
        }
        let log = state.field.log();
        match EditedField::replay(shifted(&vol.field.0, vol.iso), &log) {
            Ok(f) => {
                state.field = f;
                state.base = (vol.field.0.clone(), vol.iso);
                for c in state.world.coords() {
                    state.mark_build(c);
                }
            }
            Err(e) => warn!("KdVolume {entity}: replaying the edits failed: {e}"),
        }
    }
    stats.add_time(t0);
}

impl VolumeState {
    /// Marks every chunk whose samples (its box grown by the one-cell halo) come
    /// within `reach` of `centre`; returns them.
    fn rebuild_near(&mut self, centre: Vec3, reach: f32) -> Vec<IVec3> {
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
}

fn apply_edits(
    mut edits: MessageReader<ApplyEdit>,
    mut replaced: MessageReader<ReplaceField>,
    mut applied: MessageWriter<EditApplied>,
    mut stats: ResMut<KdContourStats>,
    mut volumes: Query<(&mut VolumeState, &mut KdVolume)>,
) {
    let t0 = std::time::Instant::now();
    for msg in replaced.read() {
        let Ok((mut state, mut vol)) = volumes.get_mut(msg.volume) else {
            warn!("ReplaceField: {} is not a meshed volume", msg.volume);
            continue;
        };
        let log = state.field.log();
        let iso = state.base.1;
        let field = match EditedField::replay(shifted(&msg.field.0, iso), &log) {
            Ok(f) => f,
            Err(e) => {
                warn!(
                    "ReplaceField on {}: replaying the edits failed: {e}",
                    msg.volume
                );
                continue;
            }
        };
        state.field = field;
        state.base.0 = msg.field.0.clone();
        // Keep the component in step (sync_volumes then sees nothing to do).
        vol.field = msg.field.clone();
        let rebuilt = match &msg.regions {
            Some(regions) => {
                let mut all: Vec<IVec3> = Vec::new();
                for &(centre, radius) in regions {
                    all.extend(state.rebuild_near(centre, radius));
                }
                all.sort_by_key(|c| (c.z, c.y, c.x));
                all.dedup();
                all
            }
            None => {
                let all = state.world.coords();
                for &c in &all {
                    state.mark_build(c);
                }
                all
            }
        };
        applied.write(EditApplied {
            volume: msg.volume,
            rebuilt,
        });
    }
    for edit in edits.read() {
        let Ok((mut state, _)) = volumes.get_mut(edit.volume) else {
            warn!("ApplyEdit: {} is not a meshed volume", edit.volume);
            continue;
        };
        let field = match state.field.with_edit(edit.brush.clone()) {
            Ok(f) => f,
            Err(e) => {
                warn!("ApplyEdit on {}: {e}", edit.volume);
                continue;
            }
        };
        let (centre, reach) = field.last_reach().expect("an edit was just added");
        state.field = field;
        let rebuilt = state.rebuild_near(centre, reach);
        applied.write(EditApplied {
            volume: edit.volume,
            rebuilt,
        });
    }
    stats.add_time(t0);
}

/// The camera position, if there is a [`LodCamera`].
fn lod_camera(camera: &Query<&GlobalTransform, With<LodCamera>>) -> Option<Vec3> {
    camera.iter().next().map(|t| t.translation())
}

/// Loads and drops the chunks of streaming volumes around the camera (around the
/// volume's origin when there is no [`LodCamera`]), and points every volume's
/// scheduling at the camera.
fn stream_chunks(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    mut stats: ResMut<KdContourStats>,
    camera: Query<&GlobalTransform, With<LodCamera>>,
    mut volumes: Query<(Entity, &KdVolume, &GlobalTransform, &mut VolumeState)>,
) {
    let t0 = std::time::Instant::now();
    let cam = lod_camera(&camera);
    for (entity, vol, vol_tf, mut state) in &mut volumes {
        let state = &mut *state;
        let local = cam
            .map(|c| vol_tf.affine().inverse().transform_point3(c))
            .unwrap_or(Vec3::ZERO);
        state.focus = local;
        let VolumeExtent::Streaming {
            view_distance,
            min_y,
            max_y,
        } = vol.extent
        else {
            continue;
        };
        let key = (
            state.world.chunk_at(local),
            view_distance.to_bits(),
            min_y,
            max_y,
        );
        if state.stream_key == Some(key) {
            continue; // the camera is in the same chunk as last time
        }
        state.stream_key = Some(key);
        let side = state.world.chunk_res as f32 * state.world.cell_size;
        let rows = min_y..=max_y;
        // Drop what is out of range (with one chunk side of slack) first.
        for c in state.world.coords() {
            if !rows.contains(&c.y) || state_distance(state, local, c) > view_distance + side {
                state.unload(&mut commands, c);
            }
        }
        for c in state.world.chunks_near(local, view_distance) {
            if rows.contains(&c.y) {
                state.load(&mut commands, entity, c, settings.default_threshold);
            }
        }
    }
    stats.add_time(t0);
}

fn state_distance(state: &VolumeState, p: Vec3, c: IVec3) -> f32 {
    let (lo, hi) = state.world.chunk_bounds(c);
    p.clamp(lo, hi).distance(p)
}

fn update_lod(
    settings: Res<KdContourSettings>,
    camera: Query<&GlobalTransform, With<LodCamera>>,
    mut volumes: Query<(Entity, &GlobalTransform, &mut VolumeState)>,
    mut changed: MessageWriter<LodChanged>,
    mut stats: ResMut<KdContourStats>,
) {
    let t0 = std::time::Instant::now();
    #[allow(clippy::redundant_closure_call)]
    (|| {
        let lod = &settings.lod;
        // With LOD off every chunk follows `default_threshold` (when it changes).
        let cam = if lod.enabled {
            let Some(cam) = lod_camera(&camera) else {
                return;
            };
            Some(cam)
        } else if settings.is_changed() {
            None
        } else {
            return;
        };
        let curve = lod.curve();
        for (entity, vol_tf, mut state) in &mut volumes {
            let local = cam.map(|c| vol_tf.affine().inverse().transform_point3(c));
            for c in state.world.coords() {
                let (lo, hi) = state.world.chunk_bounds(c);
                let want = match local {
                    Some(p) => curve.threshold(p.clamp(lo, hi).distance(p)),
                    None => settings.default_threshold,
                };
                let have = state.world.threshold(c);
                let differs = if local.is_some() && have > 0.0 && want > 0.0 {
                    (want / have).ln().abs() > (1.0 + lod.hysteresis).ln()
                } else {
                    want != have
                };
                if differs {
                    state.world.set_threshold(c, want);
                    state.mark_extract(c);
                    changed.write(LodChanged {
                        volume: entity,
                        coord: c,
                        threshold: want,
                    });
                }
            }
        }
    })();
    stats.add_time(t0);
}

fn schedule_tasks(
    settings: Res<KdContourSettings>,
    mut volumes: Query<&mut VolumeState>,
    mut chunks: Query<&mut KdChunk>,
    mut stats: ResMut<KdContourStats>,
) {
    let t0 = std::time::Instant::now();
    #[allow(clippy::redundant_closure_call)]
    (|| {
        let pool = AsyncComputeTaskPool::get();
        let mut in_flight: usize = volumes
            .iter()
            .map(|s| s.building.len() + s.extracting.len())
            .sum();
        for mut state in &mut volumes {
            let state = &mut *state;
            // Extractions first: they are cheap (well under a millisecond) and
            // show built chunks at once; seams to neighbours not built yet are
            // re-cut when those land. Nearest the camera first, ties in a fixed
            // order, so runs are reproducible.
            let mut todo: Vec<IVec3> = state
                .need_extract
                .iter()
                .copied()
                .filter(|c| !state.building.contains_key(c) && !state.need_build.contains(c))
                .collect();
            state.nearest_first(&mut todo);
            for c in todo {
                if in_flight >= settings.max_tasks_in_flight {
                    return;
                }
                state.need_extract.remove(&c);
                // A newer extraction replaces a running one: dropping its task cancels
                // it (its stamp would be stale anyway).
                let stamp = state.extract_stamp[&c];
                let threshold = state.world.threshold(c);
                let Some(snapshot) = state.world.snapshot(c) else {
                    // No tree (no surface yet, or its build failed): show nothing.
                    state.extracting.remove(&c);
                    state.ready.insert(c, (threshold, IndexedMesh::default()));
                    continue;
                };
                let snapshot: ChunkSnapshot = snapshot;
                state.extracting.insert(
                    c,
                    pool.spawn(async move {
                        let t = std::time::Instant::now();
                        let mut mesh = IndexedMesh::default();
                        snapshot.extract(&mut mesh);
                        ExtractOut {
                            coord: c,
                            stamp,
                            threshold,
                            mesh,
                            ms: t.elapsed().as_secs_f64() * 1e3,
                        }
                    }),
                );
                in_flight += 1;
            }
            // Then builds, nearest the camera first.
            let mut todo: Vec<IVec3> = state
                .need_build
                .iter()
                .copied()
                .filter(|c| !state.building.contains_key(c))
                .collect();
            state.nearest_first(&mut todo);
            for c in todo {
                if in_flight >= settings.max_tasks_in_flight {
                    return;
                }
                state.need_build.remove(&c);
                let generation = state.build_gen[&c];
                let job = state.world.chunk_build(c);
                let field = state.field.clone();
                state.building.insert(
                    c,
                    pool.spawn(async move {
                        let t = std::time::Instant::now();
                        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            job.run(&field)
                        }))
                        .map_err(|p| {
                            let msg = p
                                .downcast_ref::<&str>()
                                .map(|s| s.to_string())
                                .or_else(|| p.downcast_ref::<String>().cloned())
                                .unwrap_or_else(|| "unknown panic".into());
                            format!("the field panicked: {msg}")
                        })
                        .and_then(|r| r.map_err(|e| e.to_string()));
                        BuildOut {
                            coord: c,
                            generation,
                            result,
                            ms: t.elapsed().as_secs_f64() * 1e3,
                        }
                    }),
                );
                in_flight += 1;
                if let Some(mut ch) = state.entities.get(&c).and_then(|e| chunks.get_mut(*e).ok()) {
                    ch.status = ChunkStatus::Busy;
                }
            }
        }
    })();
    stats.add_time(t0);
}

fn poll_tasks(
    mut volumes: Query<(Entity, &mut VolumeState)>,
    mut chunks: Query<&mut KdChunk>,
    mut failed: MessageWriter<ChunkFailed>,
    mut stats: ResMut<KdContourStats>,
) {
    let t0 = std::time::Instant::now();
    for (entity, mut state) in &mut volumes {
        let state = &mut *state;
        let done: Vec<IVec3> = state.building.keys().copied().collect();
        for c in done {
            let task = state.building.get_mut(&c).expect("listed");
            let Some(out) = check_ready(task) else {
                continue;
            };
            state.building.remove(&c);
            stats.builds += 1;
            let n = stats.builds;
            ema(&mut stats.build_ms, out.ms, n);
            if out.generation != state.build_gen[&out.coord] {
                continue; // an edit came after this build started; a newer one is queued
            }
            match out.result {
                Ok(tree) => {
                    state.world.insert_tree(out.coord, tree);
                    state.mark_extract(out.coord);
                }
                Err(error) => {
                    error!("chunk {} of volume {entity}: {error}", out.coord);
                    state.world.remove_tree(out.coord);
                    state.mark_extract(out.coord);
                    if let Some(mut ch) = state
                        .entities
                        .get(&out.coord)
                        .and_then(|e| chunks.get_mut(*e).ok())
                    {
                        ch.status = ChunkStatus::Failed(error.clone());
                    }
                    failed.write(ChunkFailed {
                        volume: entity,
                        coord: out.coord,
                        error,
                    });
                }
            }
        }
        let done: Vec<IVec3> = state.extracting.keys().copied().collect();
        for c in done {
            let task = state.extracting.get_mut(&c).expect("listed");
            let Some(out) = check_ready(task) else {
                continue;
            };
            state.extracting.remove(&c);
            stats.extractions += 1;
            let n = stats.extractions;
            ema(&mut stats.extract_ms, out.ms, n);
            if out.stamp == state.extract_stamp[&out.coord] {
                state.ready.insert(out.coord, (out.threshold, out.mesh));
            }
        }
    }
    stats.add_time(t0);
}

/// One material per threshold band, for [`KdContourSettings::color_by_lod`].
#[derive(Resource)]
struct LodPalette(Vec<Handle<StandardMaterial>>);

/// Bands of the LOD palette.
const LOD_BANDS: usize = 8;

/// The band of `threshold` on the LOD curve: 0 at `base`, the last at `max`.
fn lod_band(threshold: f32, lod: &LodSettings) -> usize {
    let (lo, hi) = (
        lod.base.max(1e-9).ln(),
        lod.max.max(lod.base).max(1e-9).ln(),
    );
    let t = if hi > lo {
        (threshold.max(1e-9).ln() - lo) / (hi - lo)
    } else {
        0.0
    };
    ((t.clamp(0.0, 1.0) * (LOD_BANDS - 1) as f32).round() as usize).min(LOD_BANDS - 1)
}

/// Gives each meshed chunk its volume's material, or its LOD band's colour.
fn color_chunks(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    mut stats: ResMut<KdContourStats>,
    palette: Option<Res<LodPalette>>,
    materials: Option<ResMut<Assets<StandardMaterial>>>,
    volumes: Query<&KdVolume>,
    chunks: Query<(Entity, Ref<KdChunk>, &MeshMaterial3d<StandardMaterial>)>,
) {
    let t0 = std::time::Instant::now();
    let palette = match palette {
        Some(p) => p.0.clone(),
        None if settings.color_by_lod && materials.is_some() => {
            let mut materials = materials.expect("checked");
            let p: Vec<_> = (0..LOD_BANDS)
                .map(|i| {
                    let t = i as f32 / (LOD_BANDS - 1) as f32;
                    materials.add(StandardMaterial {
                        base_color: Color::hsl(240.0 * (1.0 - t), 0.75, 0.55),
                        perceptual_roughness: 0.8,
                        ..default()
                    })
                })
                .collect();
            commands.insert_resource(LodPalette(p.clone()));
            p
        }
        None => Vec::new(),
    };
    let all = settings.is_changed();
    for (entity, chunk, material) in &chunks {
        if !(all || chunk.is_changed()) {
            continue;
        }
        let want = if settings.color_by_lod && !palette.is_empty() {
            palette[lod_band(chunk.threshold, &settings.lod)].clone()
        } else if let Ok(vol) = volumes.get(chunk.volume) {
            vol.material.clone()
        } else {
            continue;
        };
        if material.0 != want {
            commands.entity(entity).insert(MeshMaterial3d(want));
        }
    }
    stats.add_time(t0);
}

/// Totals for [`KdContourStats`].
fn gather_stats(
    mut stats: ResMut<KdContourStats>,
    volumes: Query<&VolumeState>,
    chunks: Query<&KdChunk>,
) {
    let t0 = std::time::Instant::now();
    let (mut n, mut tris, mut running, mut queued) = (0, 0, 0, 0);
    let mut range = (f32::INFINITY, f32::NEG_INFINITY);
    for state in &volumes {
        n += state.world.len();
        running += state.building.len() + state.extracting.len();
        queued += state.need_build.len() + state.need_extract.len();
    }
    let mut meshed = 0;
    for chunk in &chunks {
        if chunk.triangles > 0 {
            meshed += 1;
            tris += chunk.triangles;
            range = (range.0.min(chunk.threshold), range.1.max(chunk.threshold));
        }
    }
    stats.chunks = n;
    stats.meshed_chunks = meshed;
    stats.triangles = tris;
    stats.tasks_in_flight = running;
    stats.queued = queued;
    stats.threshold_range = if meshed > 0 { range } else { (0.0, 0.0) };
    stats.add_time(t0);
    stats.main_thread_ms = stats.frame_ms;
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

fn apply_meshes(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut volumes: Query<(Entity, &KdVolume, &mut VolumeState)>,
    mut chunks: Query<(&mut KdChunk, Option<&Mesh3d>)>,
    mut meshed: MessageWriter<ChunkMeshed>,
    mut stats: ResMut<KdContourStats>,
) {
    let t0 = std::time::Instant::now();
    #[allow(clippy::redundant_closure_call)]
    (|| {
        let mut budget = settings.max_uploads_per_frame;
        for (entity, vol, mut state) in &mut volumes {
            let mut coords: Vec<IVec3> = state.ready.keys().copied().collect();
            state.nearest_first(&mut coords);
            for c in coords {
                if budget == 0 {
                    return;
                }
                budget -= 1;
                let (threshold, mesh) = state.ready.remove(&c).expect("listed");
                let Some(&chunk) = state.entities.get(&c) else {
                    continue;
                };
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
    })();
    stats.add_time(t0);
}

/// The README's code, compiled and run as a doctest so it cannot drift.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
