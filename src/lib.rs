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

/// Everything a user of the plugin needs.
pub mod prelude {
    pub use crate::{
        ApplyEdit, ChunkFailed, ChunkMeshed, ChunkStatus, EditApplied, KdChunk, KdContourPlugin,
        KdContourSettings, KdContourSystems, KdVolume, LodCamera, LodChanged, LodSettings,
        VolumeState,
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
}

impl Default for KdContourSettings {
    fn default() -> Self {
        KdContourSettings {
            max_tasks_in_flight: 8,
            max_uploads_per_frame: 16,
            default_threshold: 0.01,
            lod: LodSettings::default(),
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
    /// Sets thresholds from the [`LodCamera`].
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
            .register_type::<KdContourSettings>()
            .register_type::<LodSettings>()
            .register_type::<KdVolume>()
            .register_type::<KdChunk>()
            .register_type::<ChunkStatus>()
            .register_type::<LodCamera>()
            .add_message::<ApplyEdit>()
            .add_message::<EditApplied>()
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
                    (init_volumes, apply_edits)
                        .chain()
                        .in_set(KdContourSystems::Edits),
                    update_lod.in_set(KdContourSystems::Lod),
                    schedule_tasks.in_set(KdContourSystems::Schedule),
                    poll_tasks.in_set(KdContourSystems::Poll),
                    apply_meshes.in_set(KdContourSystems::Apply),
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

/// A bounded volume of `chunks` chunks of `chunk_res`³ cells of side `cell_size`,
/// sampled from `field` in the entity's local space (lattice corner (0, 0, 0) at the
/// entity's origin). Its chunks are spawned as children.
#[derive(Component, Clone, Reflect)]
#[reflect(Component)]
#[require(Transform, Visibility)]
pub struct KdVolume {
    /// The field (negative inside).
    #[reflect(ignore)]
    pub field: SharedField,
    /// Chunks along x, y, z.
    pub chunks: UVec3,
    /// Cells per chunk along each axis.
    pub chunk_res: u32,
    /// Side of one cell (local units).
    pub cell_size: f32,
    /// Material of the chunk meshes.
    pub material: Handle<StandardMaterial>,
}

impl KdVolume {
    /// A volume with the default material.
    pub fn new(field: Arc<dyn Field>, chunks: UVec3, chunk_res: u32, cell_size: f32) -> Self {
        KdVolume {
            field: SharedField(field),
            chunks,
            chunk_res,
            cell_size,
            material: Handle::default(),
        }
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
    pub coord: UVec3,
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

/// An edit was applied; these chunks are being rebuilt.
#[derive(Message, Clone, Debug)]
pub struct EditApplied {
    /// The volume entity.
    pub volume: Entity,
    /// Chunks whose box (grown by a cell) the brush reaches.
    pub rebuilt: Vec<UVec3>,
}

/// A chunk now shows a new mesh.
#[derive(Message, Clone, Debug)]
pub struct ChunkMeshed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk entity.
    pub chunk: Entity,
    /// Its coordinates.
    pub coord: UVec3,
    /// Triangles in the mesh (0: the chunk is empty).
    pub triangles: usize,
}

/// The camera moved a chunk to a new threshold.
#[derive(Message, Clone, Debug)]
pub struct LodChanged {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk.
    pub coord: UVec3,
    /// Its new threshold.
    pub threshold: f32,
}

/// A chunk's build failed (a field error or a panic inside the task).
#[derive(Message, Clone, Debug)]
pub struct ChunkFailed {
    /// The volume entity.
    pub volume: Entity,
    /// The chunk.
    pub coord: UVec3,
    /// What went wrong.
    pub error: String,
}

struct BuildOut {
    coord: UVec3,
    generation: u64,
    result: Result<KdTree, String>,
}

struct ExtractOut {
    coord: UVec3,
    stamp: u64,
    threshold: f32,
    mesh: IndexedMesh,
}

/// The meshing state of one volume (added by the plugin).
#[derive(Component)]
pub struct VolumeState {
    world: ChunkWorld,
    field: EditedField,
    entities: HashMap<UVec3, Entity>,
    build_gen: HashMap<UVec3, u64>,
    extract_stamp: HashMap<UVec3, u64>,
    need_build: HashSet<UVec3>,
    need_extract: HashSet<UVec3>,
    building: HashMap<UVec3, Task<BuildOut>>,
    extracting: HashMap<UVec3, Task<ExtractOut>>,
    ready: HashMap<UVec3, (f32, IndexedMesh)>,
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
    pub fn chunk_entity(&self, c: UVec3) -> Option<Entity> {
        self.entities.get(&c).copied()
    }

    fn mark_extract(&mut self, c: UVec3) {
        for o in self.world.seam_owners_touching(c) {
            *self.extract_stamp.entry(o).or_default() += 1;
            self.need_extract.insert(o);
        }
    }

    fn mark_build(&mut self, c: UVec3) {
        *self.build_gen.entry(c).or_default() += 1;
        self.need_build.insert(c);
    }
}

fn init_volumes(
    mut commands: Commands,
    settings: Res<KdContourSettings>,
    volumes: Query<(Entity, &KdVolume), Without<VolumeState>>,
) {
    for (entity, vol) in &volumes {
        let core = kdcontour::Settings {
            threads: 1,
            ..Default::default()
        };
        let world = match ChunkWorld::new(
            Vec3::ZERO,
            vol.cell_size,
            vol.chunk_res,
            vol.chunks,
            settings.default_threshold,
            core,
        ) {
            Ok(w) => w,
            Err(e) => {
                error!("KdVolume {entity}: {e}");
                commands.entity(entity).remove::<KdVolume>();
                continue;
            }
        };
        let mut state = VolumeState {
            field: EditedField::new(vol.field.0.clone()),
            world,
            entities: HashMap::new(),
            build_gen: HashMap::new(),
            extract_stamp: HashMap::new(),
            need_build: HashSet::new(),
            need_extract: HashSet::new(),
            building: HashMap::new(),
            extracting: HashMap::new(),
            ready: HashMap::new(),
        };
        let coords: Vec<UVec3> = state.world.coords().collect();
        for c in coords {
            let chunk = commands
                .spawn((
                    KdChunk {
                        volume: entity,
                        coord: c,
                        threshold: settings.default_threshold,
                        triangles: 0,
                        status: ChunkStatus::Pending,
                    },
                    Transform::default(),
                    Visibility::default(),
                    ChildOf(entity),
                ))
                .id();
            state.entities.insert(c, chunk);
            state.mark_build(c);
        }
        commands.entity(entity).insert(state);
    }
}

fn apply_edits(
    mut edits: MessageReader<ApplyEdit>,
    mut applied: MessageWriter<EditApplied>,
    mut volumes: Query<&mut VolumeState>,
) {
    for edit in edits.read() {
        let Ok(mut state) = volumes.get_mut(edit.volume) else {
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
        let grow = state.world.cell_size;
        let coords: Vec<UVec3> = state.world.coords().collect();
        let mut rebuilt = Vec::new();
        for c in coords {
            let (lo, hi) = state.world.chunk_bounds(c);
            // The chunk's samples reach one cell beyond its box (the halo).
            if centre.clamp(lo - grow, hi + grow).distance(centre) <= reach {
                state.mark_build(c);
                rebuilt.push(c);
            }
        }
        applied.write(EditApplied {
            volume: edit.volume,
            rebuilt,
        });
    }
}

fn update_lod(
    settings: Res<KdContourSettings>,
    camera: Query<&GlobalTransform, With<LodCamera>>,
    mut volumes: Query<(Entity, &GlobalTransform, &mut VolumeState)>,
    mut changed: MessageWriter<LodChanged>,
) {
    let lod = &settings.lod;
    if !lod.enabled {
        return;
    }
    let Some(cam) = camera.iter().next() else {
        return;
    };
    let curve = lod.curve();
    for (entity, vol_tf, mut state) in &mut volumes {
        let local = vol_tf
            .affine()
            .inverse()
            .transform_point3(cam.translation());
        let coords: Vec<UVec3> = state.world.coords().collect();
        for c in coords {
            let (lo, hi) = state.world.chunk_bounds(c);
            let want = curve.threshold(local.clamp(lo, hi).distance(local));
            let have = state.world.threshold(c);
            let differs = if have > 0.0 && want > 0.0 {
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
}

fn schedule_tasks(
    settings: Res<KdContourSettings>,
    mut volumes: Query<&mut VolumeState>,
    mut chunks: Query<&mut KdChunk>,
) {
    let pool = AsyncComputeTaskPool::get();
    let mut in_flight: usize = volumes
        .iter()
        .map(|s| s.building.len() + s.extracting.len())
        .sum();
    for mut state in &mut volumes {
        let state = &mut *state;
        // Builds before extractions (an extraction waits for its chunk's build), in
        // a fixed order so runs are reproducible.
        let mut todo: Vec<UVec3> = state
            .need_build
            .iter()
            .copied()
            .filter(|c| !state.building.contains_key(c))
            .collect();
        todo.sort_by_key(|c| (c.z, c.y, c.x));
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
                    let result =
                        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job.run(&field)))
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
                    }
                }),
            );
            in_flight += 1;
            if let Some(mut ch) = state.entities.get(&c).and_then(|e| chunks.get_mut(*e).ok()) {
                ch.status = ChunkStatus::Busy;
            }
        }
        let mut todo: Vec<UVec3> = state
            .need_extract
            .iter()
            .copied()
            .filter(|c| !state.building.contains_key(c) && !state.need_build.contains(c))
            .collect();
        todo.sort_by_key(|c| (c.z, c.y, c.x));
        for c in todo {
            if in_flight >= settings.max_tasks_in_flight {
                return;
            }
            state.need_extract.remove(&c);
            // A newer extraction replaces a running one: dropping its task cancels
            // it (its stamp would be stale anyway).
            let Some(snapshot) = state.world.snapshot(c) else {
                continue;
            };
            let stamp = state.extract_stamp[&c];
            let threshold = state.world.threshold(c);
            let snapshot: ChunkSnapshot = snapshot;
            state.extracting.insert(
                c,
                pool.spawn(async move {
                    let mut mesh = IndexedMesh::default();
                    snapshot.extract(&mut mesh);
                    ExtractOut {
                        coord: c,
                        stamp,
                        threshold,
                        mesh,
                    }
                }),
            );
            in_flight += 1;
        }
    }
}

fn poll_tasks(
    mut volumes: Query<(Entity, &mut VolumeState)>,
    mut chunks: Query<&mut KdChunk>,
    mut failed: MessageWriter<ChunkFailed>,
) {
    for (entity, mut state) in &mut volumes {
        let state = &mut *state;
        let done: Vec<UVec3> = state.building.keys().copied().collect();
        for c in done {
            let task = state.building.get_mut(&c).expect("listed");
            let Some(out) = check_ready(task) else {
                continue;
            };
            state.building.remove(&c);
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
        let done: Vec<UVec3> = state.extracting.keys().copied().collect();
        for c in done {
            let task = state.extracting.get_mut(&c).expect("listed");
            let Some(out) = check_ready(task) else {
                continue;
            };
            state.extracting.remove(&c);
            if out.stamp == state.extract_stamp[&out.coord] {
                state.ready.insert(out.coord, (out.threshold, out.mesh));
            }
        }
    }
}

fn to_bevy_mesh(m: &IndexedMesh) -> Mesh {
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
) {
    let mut budget = settings.max_uploads_per_frame;
    for (entity, vol, mut state) in &mut volumes {
        let mut coords: Vec<UVec3> = state.ready.keys().copied().collect();
        coords.sort_by_key(|c| (c.z, c.y, c.x));
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
}

/// The README's code, compiled and run as a doctest so it cannot drift.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
