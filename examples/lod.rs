//! Level of detail you can see: a bounded block of terrain chunks, each coloured by
//! the threshold it is cut at (blue: finest, red: coarsest), with the camera flying
//! a circle over it. Watch the rings of detail follow the camera and the seams
//! between chunks of different colours stay closed. The panel edits the LOD curve
//! (base, near, growth, max, hysteresis) and toggles wireframe and colouring.
//!
//! Keys: P pauses the flight (then WASD / E / Q and arrows or middle mouse fly by
//! hand). F1 hides the panel.
//!
//! ```text
//! cargo run --release --example lod
//! ```

mod common;

use bevy::pbr::wireframe::WireframeConfig;
use bevy::prelude::*;
use bevy_kdcontour::kdcontour::field::terrain::{Heightfield, HeightfieldParams};
use bevy_kdcontour::kdcontour::Field;
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::{FlyCam, ShotArgs};
use std::sync::Arc;

/// Terrain chunks coloured by their LOD threshold.
#[derive(Parser, Debug)]
struct Args {
    /// Chunks along x and z (the block is 2 chunks high).
    #[arg(long, default_value_t = 10)]
    chunks: u32,
    /// Cells per chunk side.
    #[arg(long, default_value_t = 16)]
    chunk_res: u32,
    #[command(flatten)]
    shot: ShotArgs,
}

#[derive(Resource)]
struct Flight {
    paused: bool,
    angle: f32,
    center: Vec3,
    radius: f32,
}

fn main() {
    let args = Args::parse();
    if !(1..=64).contains(&args.chunks) || !(4..=64).contains(&args.chunk_res) {
        common::fail(format!(
            "--chunks must be 1 to 64 and --chunk-res 4 to 64, got {} and {}",
            args.chunks, args.chunk_res
        ));
    }
    let side = (args.chunks * args.chunk_res) as f32;
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.12, 0.13, 0.16)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: lod",
        &args.shot,
        KdContourSettings {
            color_by_lod: true,
            lod: LodSettings {
                base: 0.01,
                near: side * 0.12,
                growth: 2.0,
                max: 5.0,
                ..default()
            },
            ..common::preset()
        },
        KdContourPanel::default(),
    )
    .insert_resource(Flight {
        paused: false,
        angle: 0.6,
        center: Vec3::new(side * 0.5, args.chunk_res as f32, side * 0.5),
        radius: side * 0.32,
    })
    .insert_resource(Block {
        chunks: args.chunks,
        res: args.chunk_res,
    })
    .add_systems(Startup, setup)
    .add_systems(Update, (fly, common::fly_camera).chain())
    .run();
}

#[derive(Resource)]
struct Block {
    chunks: u32,
    res: u32,
}

fn setup(mut commands: Commands, block: Res<Block>, mut wireframe: ResMut<WireframeConfig>) {
    wireframe.global = true;
    wireframe.default_color = Color::srgba(0.0, 0.0, 0.0, 0.6);
    let field: Arc<dyn Field> = Arc::new(Heightfield::new(HeightfieldParams {
        seed: 11,
        base: block.res as f32,
        amplitude: block.res as f32 * 0.8,
        frequency: 1.2 / (block.res as f32 * 4.0),
        octaves: 5,
    }));
    commands.spawn(KdVolume::new(
        field,
        UVec3::new(block.chunks, 2, block.chunks),
        block.res,
        1.0,
    ));
    let (fly, t) = FlyCam::looking(Vec3::new(0.0, 60.0, 0.0), Vec3::ZERO, 40.0);
    commands.spawn((Camera3d::default(), fly, t, LodCamera));
    common::spawn_lights(&mut commands);
}

/// Flies the camera around the block, looking ahead and down.
fn fly(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    shot: Res<ShotArgs>,
    mut flight: ResMut<Flight>,
    mut cams: Query<(&mut FlyCam, &mut Transform)>,
) {
    if keys.just_pressed(KeyCode::KeyP) {
        flight.paused = !flight.paused;
    }
    if flight.paused {
        return;
    }
    // A screenshot shows one fixed moment of the flight.
    if shot.screenshot.is_none() {
        flight.angle += time.delta_secs() * 0.15;
    }
    let (a, r, c) = (flight.angle, flight.radius, flight.center);
    let pos = c + Vec3::new(a.cos() * r, r * 0.9, a.sin() * r);
    let ahead = c + Vec3::new((a + 1.2).cos() * r * 0.5, 0.0, (a + 1.2).sin() * r * 0.5);
    for (mut cam, mut t) in &mut cams {
        let look = Transform::from_translation(pos).looking_at(ahead, Vec3::Y);
        let (yaw, pitch, _) = look.rotation.to_euler(EulerRot::YXZ);
        cam.yaw = yaw;
        cam.pitch = pitch;
        *t = look;
    }
}
