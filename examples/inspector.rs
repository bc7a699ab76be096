//! The panel next to bevy-inspector-egui 0.37 (the inspector for Bevy 0.19): the
//! world inspector lists the volume and its chunk entities, a settings window
//! edits [`KdContourSettings`] live (thresholds, LOD curve, tasks in flight), and
//! the plugin's own panel keeps working beside them. Both sit on one bevy_egui
//! (0.40) and one egui, so they share a context and one `EguiPlugin`.
//!
//! Needs the crate feature `inspector` (it is not built by `cargo test`):
//!
//! ```text
//! cargo run --release --example inspector --features inspector
//! ```

mod common;

use bevy::prelude::*;
use bevy_kdcontour::bevy_inspector_egui::{bevy_inspector, DefaultInspectorConfigPlugin};
use bevy_kdcontour::kdcontour::field::layers::{starter, Layers};
use bevy_kdcontour::kdcontour::Field;
use bevy_kdcontour::panel::bevy_egui::{
    egui, EguiContext, EguiPrimaryContextPass, PrimaryEguiContext,
};
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::{FlyCam, ShotArgs};
use std::sync::Arc;

/// The csg_editor's opening solid, inspected.
#[derive(Parser, Debug)]
struct Args {
    #[command(flatten)]
    shot: ShotArgs,
}

/// Half the side of the cube the solid is meshed in (world units).
const HALF: f32 = 1.5;

fn main() {
    let args = Args::parse();
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.14, 0.15, 0.18)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: inspector",
        &args.shot,
        common::fixed(0.005),
        KdContourPanel {
            show_iso: false,
            ..default()
        },
    )
    .add_plugins(DefaultInspectorConfigPlugin)
    .add_systems(Startup, setup)
    .add_systems(EguiPrimaryContextPass, inspector_windows)
    .add_systems(Update, common::fly_camera)
    .run();
}

/// The inspector's world and settings windows, on the right (the plugin's panel
/// is on the left), in the same egui context as the panel.
fn inspector_windows(world: &mut World) {
    let Ok(context) = world
        .query_filtered::<&mut EguiContext, With<PrimaryEguiContext>>()
        .single(world)
    else {
        return;
    };
    let mut context = context.clone();
    let ctx = context.get_mut();
    egui::Window::new("world inspector")
        .default_pos([1280.0 - 340.0, 10.0])
        .default_size([320.0, 300.0])
        .show(ctx, |ui| {
            egui::ScrollArea::both().show(ui, |ui| {
                bevy_inspector::ui_for_world(world, ui);
            });
        });
    egui::Window::new("KdContourSettings")
        .default_pos([1280.0 - 340.0, 360.0])
        .default_size([320.0, 330.0])
        .show(ctx, |ui| {
            egui::ScrollArea::both().show(ui, |ui| {
                bevy_inspector::ui_for_resource::<KdContourSettings>(world, ui);
            });
        });
}

fn setup(mut commands: Commands, mut materials: ResMut<Assets<StandardMaterial>>) {
    // The starter scene in the volume's local space (corner at -HALF), as the
    // csg_editor places it.
    let layers = Layers::new(starter()).unwrap_or_else(|e| common::fail(e));
    let field: Arc<dyn Field> = Arc::new(layers.field_at(Vec3::splat(HALF)));
    let (chunks, res) = (4, 16);
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.8, 0.72, 0.62),
        perceptual_roughness: 0.5,
        ..default()
    });
    commands.spawn((
        Name::new("csg volume"),
        KdVolume::new(
            field,
            UVec3::splat(chunks),
            res,
            2.0 * HALF / (chunks * res) as f32,
        )
        .with_material(material),
        Transform::from_translation(Vec3::splat(-HALF)),
    ));
    let (fly, t) = FlyCam::looking(Vec3::new(2.6, 2.2, 3.4), Vec3::new(0.0, -0.1, 0.0), 1.5);
    commands.spawn((Name::new("camera"), Camera3d::default(), fly, t));
    common::spawn_lights(&mut commands);
}
