//! [`KdContourPlugins`], the one line users add: every subsystem as its own
//! plugin, so an app can replace or leave one out
//! (`KdContourPlugins::default().build().disable::<StreamingPlugin>()`).

use crate::edits::EditsPlugin;
use crate::lod::LodPlugin;
use crate::messages::MessagesPlugin;
use crate::persist::PersistPlugin;
use crate::settings::{KdContourSettings, SettingsPlugin};
use crate::stats::StatsPlugin;
use crate::streaming::StreamingPlugin;
use crate::tasks::TasksPlugin;
use crate::upload::UploadPlugin;
use crate::volume::VolumePlugin;
use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;

/// Chunked, LOD-driven meshing of [`crate::KdVolume`]s: settings, volumes and
/// chunks, messages, edits, streaming, LOD, tasks, upload, stats, saving, and (crate
/// features `debug`, `avian`, `navmesh`) LOD colouring, colliders, navmesh tiles.
#[derive(Default)]
pub struct KdContourPlugins {
    /// Initial settings (copied into the [`KdContourSettings`] resource).
    pub settings: KdContourSettings,
}

impl PluginGroup for KdContourPlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>()
            .add(SettingsPlugin {
                settings: self.settings,
            })
            .add(MessagesPlugin)
            .add(StatsPlugin)
            .add(VolumePlugin)
            .add(EditsPlugin)
            .add(StreamingPlugin)
            .add(LodPlugin)
            .add(TasksPlugin)
            .add(UploadPlugin)
            .add(PersistPlugin);
        with_navmesh(with_colliders(with_debug(group)))
    }
}

/// Adds the collider subsystem (crate feature `avian`).
#[cfg(feature = "avian")]
fn with_colliders(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group.add(crate::colliders::CollidersPlugin)
}

/// Without the `avian` feature there are no colliders.
#[cfg(not(feature = "avian"))]
fn with_colliders(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group
}

/// Adds the navmesh subsystem (crate feature `navmesh`).
#[cfg(feature = "navmesh")]
fn with_navmesh(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group.add(crate::navmesh::NavmeshPlugin)
}

/// Without the `navmesh` feature there are no navmesh tiles.
#[cfg(not(feature = "navmesh"))]
fn with_navmesh(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group
}

/// Adds the debug subsystem (crate feature `debug`).
#[cfg(feature = "debug")]
fn with_debug(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group.add(crate::debug::DebugPlugin)
}

/// Without the `debug` feature there is no debug subsystem.
#[cfg(not(feature = "debug"))]
fn with_debug(group: PluginGroupBuilder) -> PluginGroupBuilder {
    group
}

/// The whole of [`KdContourPlugins`] as one plugin, as before the plugin was split
/// into subsystems (`add_plugins(KdContourPlugin { settings })` keeps working).
/// New code adds [`KdContourPlugins`], which lets a subsystem be replaced.
#[derive(Default)]
pub struct KdContourPlugin {
    /// Initial settings (copied into the [`KdContourSettings`] resource).
    pub settings: KdContourSettings,
}

impl Plugin for KdContourPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(KdContourPlugins {
            settings: self.settings.clone(),
        });
    }
}
