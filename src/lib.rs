//! # bevy_kdcontour
//!
//! A Bevy 0.19 plugin that meshes signed-distance, CSG and noise fields through the
//! discrete k-d tree of [`kdcontour`], in chunks: each chunk's tree is built by the
//! plugin's chunk worker threads (one per core), kept, and
//! re-cut at a new error threshold when the [`LodCamera`] moves (no re-sampling);
//! edits ([`ApplyEdit`]) rebuild only the chunks they reach; seams between chunks
//! at different thresholds are contoured across the chunk trees, so there are no
//! cracks, skirts or transition cells.
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
//!     .add_plugins((DefaultPlugins, KdContourPlugins::default()))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! ## Subsystems
//! [`KdContourPlugins`] is a plugin group, one plugin per subsystem, each in its
//! own module; replace or leave one out with Bevy's `PluginGroupBuilder`
//! (`KdContourPlugins::default().build().disable::<StreamingPlugin>()`):
//!
//! | module | plugin | job |
//! |---|---|---|
//! | `settings` | [`SettingsPlugin`] | the [`KdContourSettings`] resource |
//! | `messages` | [`MessagesPlugin`] | registers every message |
//! | `stats` | [`StatsPlugin`] | [`KdContourStats`]; the main-thread clock |
//! | `volume` | [`VolumePlugin`] | [`KdVolume`], [`KdChunk`]; a [`VolumeState`] per volume; the system sets |
//! | `edits` | [`EditsPlugin`] | [`ApplyEdit`], [`UndoEdit`], [`RedoEdit`], [`ReplaceField`] |
//! | `streaming` | [`StreamingPlugin`] | loads and drops chunks around the camera; lays horizon volumes out in chunk levels (`horizon`) |
//! | `lod` | [`LodPlugin`] | thresholds from the camera; the lowest threshold each volume's trees are built for |
//! | `tasks` | [`TasksPlugin`] | builds and extractions on the task pool |
//! | `upload` | [`UploadPlugin`] | meshes onto the chunk entities |
//! | `persist` | [`PersistPlugin`] | saves and loads the edits of [`KdSave`] volumes |
//! | `debug` (feature `debug`) | `DebugPlugin` | colours chunks by LOD band |
//! | `colliders` (feature `avian`) | `CollidersPlugin` | avian3d trimesh colliders near the camera and `ColliderAnchor`s, built in the meshing tasks |
//! | `navmesh` (feature `navmesh`) | `NavmeshPlugin` | navmesh tiles near the camera and `NavAnchor`s, built in the meshing tasks, linked across seams and levels; path queries |
//! | `net` (feature `replicon`) | `NetPlugin` (added by the app, not in the group) | multiplayer: a server's accepted edits reach every client |
//!
//! [`material`] holds [`TerrainMaterial`] (its plugin, [`TerrainMaterialPlugin`],
//! is for apps that render and is not in the group): the field's materials per
//! vertex, textured by triplanar projection.
//!
//! A volume's chunks live in one [`kdcontour::World`] (one level for bounded and
//! streaming volumes, several for the horizon); [`headless`] runs the plugin with
//! no renderer; `panel` (feature `egui`) is the egui
//! panel the examples show.
//!
//! ## Frame by frame
//! [`KdContourSystems`] runs in [`PostUpdate`], chained and before transform
//! propagation: `Edits` (apply brushes, mark chunks to rebuild) → `Lod` (thresholds
//! from the camera, with hysteresis) → `Schedule` (start builds and extractions, at
//! most [`KdContourSettings::max_tasks_in_flight`]) → `Poll` (collect finished tasks
//! with `check_ready`; results from an older field or threshold are dropped) →
//! `Apply` (upload at most [`KdContourSettings::max_uploads_per_frame`] meshes) →
//! `Stats`. `Lod` also streams the chunks of unbounded volumes
//! ([`KdVolume::streaming`]) in and out around the camera, nearest first, and
//! lays horizon volumes ([`KdVolume::horizon`]) out in chunk levels whose cells
//! double with distance; `Apply` shows a level change in one frame.
//!
//! Each chunk mesh holds the chunk's interior and the seams it owns (see
//! [`kdcontour::world`] for the ownership rule), in the volume's local space.

use bevy::prelude::*;

#[cfg(feature = "avian")]
pub use avian3d;
#[cfg(feature = "inspector")]
pub use bevy_inspector_egui;
#[cfg(feature = "replicon")]
pub use bevy_replicon;
#[cfg(feature = "replicon")]
pub use bevy_replicon_renet;
pub use kdcontour;
#[cfg(feature = "navmesh")]
pub use kdcontour_nav;

#[cfg(feature = "avian")]
pub mod colliders;
#[cfg(feature = "debug")]
pub mod debug;
mod edits;
pub mod headless;
mod horizon;
mod lod;
pub mod material;
mod mesh;
mod messages;
#[cfg(feature = "navmesh")]
pub mod navmesh;
#[cfg(feature = "replicon")]
pub mod net;
#[cfg(feature = "egui")]
pub mod panel;
pub mod persist;
mod plugins;
mod settings;
mod state;
mod stats;
mod streaming;
mod tasks;
mod upload;
mod volume;
mod workers;

#[cfg(feature = "avian")]
pub use colliders::{ColliderAnchor, ColliderSettings, CollidersPlugin};
#[cfg(feature = "debug")]
pub use debug::DebugPlugin;
pub use edits::{EditsPlugin, RemoteEdits};
pub use horizon::HorizonKeep;
pub use lod::LodPlugin;
pub use material::{TerrainExtension, TerrainMaterial, TerrainMaterialPlugin, TerrainTextures};
pub use mesh::to_bevy_mesh;
pub use messages::{
    ApplyEdit, ChunkFailed, ChunkMeshed, EditApplied, LodChanged, MessagesPlugin, RedoEdit,
    ReplaceField, UndoEdit,
};
#[cfg(feature = "navmesh")]
pub use navmesh::{NavAnchor, NavStats, NavmeshPlugin, NavmeshSettings, VolumeNavMesh};
pub use persist::{EditsLoaded, EditsSaved, KdSave, PersistFailed, PersistPlugin};
pub use plugins::{KdContourPlugin, KdContourPlugins};
pub use settings::{KdContourSettings, LodSettings, SettingsPlugin};
pub use state::VolumeState;
pub use stats::{KdContourStats, MainThreadClock, StatsPlugin};
pub use streaming::StreamingPlugin;
pub use tasks::TasksPlugin;
pub use upload::UploadPlugin;
pub use volume::{
    ChunkStatus, KdChunk, KdVolume, LodCamera, SharedField, VolumeExtent, VolumeMaterial,
    VolumePlugin,
};

/// Everything a user of the plugin needs.
pub mod prelude {
    pub use crate::{
        ApplyEdit, ChunkFailed, ChunkMeshed, ChunkStatus, EditApplied, EditsLoaded, EditsSaved,
        KdChunk, KdContourPlugin, KdContourPlugins, KdContourSettings, KdContourStats,
        KdContourStep, KdContourSystems, KdSave, KdVolume, LodCamera, LodChanged, LodSettings,
        PersistFailed, RedoEdit, ReplaceField, SharedField, TerrainMaterial, TerrainMaterialPlugin,
        TerrainTextures, UndoEdit, VolumeExtent, VolumeMaterial, VolumeState,
    };
    pub use kdcontour::edit::{Brush, BrushOp};
    pub use kdcontour::world::ChunkKey;
}

/// The plugin's systems, in the order they run (chained, in [`PostUpdate`], before
/// transform propagation).
#[derive(SystemSet, Debug, Hash, PartialEq, Eq, Clone)]
pub enum KdContourSystems {
    /// Applies [`ApplyEdit`], [`UndoEdit`] and [`RedoEdit`] messages.
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
    /// Totals [`KdContourStats`] for the frame.
    Stats,
}

/// The steps inside the [`KdContourSystems`] sets, chained within their set: the
/// subsystems order their systems against these, never against each other's
/// systems, and an app may too.
#[derive(SystemSet, Debug, Hash, PartialEq, Eq, Clone, Copy)]
pub enum KdContourStep {
    /// In [`KdContourSystems::Edits`]: new volumes get their meshing state.
    CreateVolumes,
    /// In [`KdContourSystems::Edits`]: saved edits are loaded into new volumes.
    LoadEdits,
    /// In [`KdContourSystems::Edits`]: volumes whose field or iso changed swap
    /// their field and replay their edits.
    SyncVolumes,
    /// In [`KdContourSystems::Edits`]: edits from the network are taken in
    /// (the `net` subsystem, crate feature `replicon`).
    ReceiveEdits,
    /// In [`KdContourSystems::Edits`]: [`ApplyEdit`], [`UndoEdit`] and
    /// [`RedoEdit`] messages are applied.
    ApplyEdits,
    /// In [`KdContourSystems::Edits`]: what was applied goes out to the network
    /// (the `net` subsystem).
    SendEdits,
    /// In [`KdContourSystems::Lod`]: the chunks to load, drop or give colliders
    /// and navmesh tiles are chosen.
    ChooseChunks,
    /// In [`KdContourSystems::Lod`]: thresholds from the camera.
    Thresholds,
    /// In [`KdContourSystems::Apply`]: meshes onto the chunk entities.
    Upload,
    /// In [`KdContourSystems::Apply`]: what reads the uploaded meshes (the
    /// debug colouring).
    AfterUpload,
}

/// The README's code, compiled and run as a doctest so it cannot drift.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
