//! Running without a renderer or a window, as a game server or a test does:
//! [`HeadlessPlugins`] is Bevy's `MinimalPlugins` plus the asset, mesh and
//! transform plugins the meshing needs, and [`run_until_settled`] steps an app
//! until a volume's meshing is done.

use crate::state::VolumeState;
use bevy::app::PluginGroupBuilder;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;

/// `MinimalPlugins`, `AssetPlugin`, `MeshPlugin` and `TransformPlugin`: what
/// [`crate::KdContourPlugins`] needs when there is no renderer. Add the
/// plugins after these.
pub struct HeadlessPlugins;

impl PluginGroup for HeadlessPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add_group(MinimalPlugins)
            .add(AssetPlugin::default())
            .add(MeshPlugin)
            .add(TransformPlugin)
    }
}

/// Updates `app` until `volume` has no meshing work queued, running or waiting
/// for upload (nor navmesh tiles waiting to be linked in), and is still settled
/// after one more update (so the last uploads' commands have applied and that
/// update started nothing new, such as a horizon volume's next level change);
/// at most `max_frames` updates, sleeping `pause` between them (tasks run on
/// other threads). Returns whether it settled.
pub fn run_until_settled(
    app: &mut App,
    volume: Entity,
    max_frames: usize,
    pause: std::time::Duration,
) -> bool {
    let settled = |app: &App| {
        let world = app.world();
        // Navmesh tiles waiting to be linked in are work left too.
        #[cfg(feature = "navmesh")]
        if world
            .get::<crate::VolumeNavMesh>(volume)
            .is_some_and(|n| n.waiting() > 0)
        {
            return false;
        }
        world
            .get::<VolumeState>(volume)
            .is_some_and(|s| s.is_settled())
    };
    let mut frames = 0;
    while frames < max_frames {
        app.update();
        frames += 1;
        if settled(app) {
            app.update();
            frames += 1;
            if settled(app) {
                return true;
            }
        }
        if !pause.is_zero() {
            std::thread::sleep(pause);
        }
    }
    false
}
