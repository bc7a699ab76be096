//! The main demo: endless noise terrain with overhangs and caves, seen to the
//! horizon (2,048 cells by default) through chunk levels whose cells double with
//! distance from a fly camera, crack-free between levels with no skirts; inside
//! each level every chunk is cut at a threshold set by its distance to the
//! camera; sculpted with the mouse. The brush is aimed by a ray cast against the
//! field itself, not the mesh, so it hits what the field says is there even
//! before a chunk is meshed.
//!
//! The ground shows the field's materials (grass on the flats, rock on slopes,
//! dirt in patches, on low ground and in caves, snow up high), textured by
//! triplanar projection (`TerrainMaterial`).
//!
//! Keys: WASD move, E / Space up, Q down, Shift faster, arrow keys or middle mouse
//! drag to look. Left mouse adds ground, right mouse digs, the wheel sets the
//! brush size; P switches the left button to painting (1 grass, 2 rock, 3 dirt,
//! 4 snow) and back. Ctrl+Z takes back the last stroke, Ctrl+Shift+Z (or Ctrl+Y)
//! puts it back. L colours chunks by level (blue finest, red coarsest). V walks
//! (a capsule player with gravity on the terrain; Space jumps) or flies again.
//! G places four agents at the cursor (turning the navmesh on), then sends them
//! to it: they walk the navmesh around what was dug and up what was raised,
//! drawing their paths. F1 hides the panel.
//!
//! The sculpting is saved to `terrain-seed<SEED>.kdsave` in the working
//! directory two seconds after the last stroke and on exit, and loaded at the
//! next start with the same seed (`--save PATH` elsewhere, `--no-save` not at
//! all; screenshot runs neither load nor save).
//!
//! ```text
//! cargo run --release --example terrain
//! cargo run --release --example terrain -- --screenshot terrain.png
//! cargo run --release --example terrain -- --overview --screenshot levels.png
//! cargo run --release --example terrain -- --agents --screenshot agents.png
//! cargo run --release --example terrain -- --flat --view-distance 160
//! ```

mod common;

use bevy::input::mouse::AccumulatedMouseScroll;
use bevy::prelude::*;
use bevy_kdcontour::avian3d::prelude::PhysicsPlugins;
use bevy_kdcontour::kdcontour::field::raycast;
use bevy_kdcontour::kdcontour::field::terrain::{Density, DensityParams};
use bevy_kdcontour::kdcontour::material::terrain_ids;
use bevy_kdcontour::kdcontour::Field;
use bevy_kdcontour::net::{Cursor, Follower, LocalCursor, NetVolume, PeerCursors};
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::agents::{place_or_send, Agents, AgentsPlugin};
use common::{FlyCam, ShotArgs};
use std::sync::Arc;

/// Streaming terrain with camera LOD and sculpting.
#[derive(Parser, Debug)]
struct Args {
    /// Noise seed.
    #[arg(long, default_value_t = 7)]
    seed: u32,
    /// How far the terrain reaches from the camera, in cells.
    #[arg(long, default_value_t = 2048.0)]
    view_distance: f32,
    /// How far the finest chunks reach from the camera, in cells.
    #[arg(long, default_value_t = 64)]
    level0_cells: u32,
    /// One level of equal chunks streamed within --view-distance (the plugin
    /// before chunk levels; keep the distance small, at most 512).
    #[arg(long)]
    flat: bool,
    /// Look straight down from high above, chunks coloured by level.
    #[arg(long)]
    overview: bool,
    /// Cells per chunk side (even).
    #[arg(long, default_value_t = 32)]
    chunk_res: u32,
    /// Where the sculpting is saved and loaded from (default
    /// `terrain-seed<SEED>.kdsave` in the working directory).
    #[arg(long)]
    save: Option<std::path::PathBuf>,
    /// Neither load nor save the sculpting.
    #[arg(long)]
    no_save: bool,
    /// Start walking (as the V key does): a capsule drops from the camera.
    #[arg(long)]
    walk: bool,
    /// In a screenshot: four agents walking from below the dug crater to
    /// beyond it, their paths drawn (as the G key places and sends them).
    #[arg(long)]
    agents: bool,
    #[command(flatten)]
    net: common::net::NetArgs,
    #[command(flatten)]
    shot: ShotArgs,
}

#[derive(Resource)]
struct Sculpt {
    volume: Entity,
    radius: f32,
    cooldown: f32,
    /// Where the brush would land (for the preview), if the ray hits.
    aim: Option<Vec3>,
    /// The material the left button paints, or `None` to add ground.
    paint: Option<u8>,
    /// A button has been held since the last dab: the next one continues its
    /// stroke (one undo takes the stroke back).
    stroke: bool,
    /// In screenshot mode, where the brush is shown aiming (there is no mouse).
    scripted_aim: Option<Vec3>,
}

fn main() {
    let args = Args::parse();
    if !(args.view_distance.is_finite() && args.view_distance > 0.0) {
        common::fail(format!(
            "--view-distance must be a positive number of cells, got {}",
            args.view_distance
        ));
    }
    if !(4..=128).contains(&args.chunk_res) || args.chunk_res % 2 == 1 {
        common::fail(format!(
            "--chunk-res must be even, 4 to 128, got {}",
            args.chunk_res
        ));
    }
    if args.flat && args.view_distance > 512.0 {
        common::fail(format!(
            "--flat streams every chunk at full resolution: --view-distance must be \
             at most 512 cells with it, got {} (leave out --flat to see further)",
            args.view_distance
        ));
    }
    let horizon_ok = args.view_distance >= args.chunk_res as f32
        && args.view_distance <= 65536.0
        && (1..=args.view_distance as u32).contains(&args.level0_cells);
    if !args.flat && !horizon_ok {
        common::fail(format!(
            "--view-distance must be {} to 65536 cells and --level0-cells 1 to the view \
             distance, got {} and {}",
            args.chunk_res, args.view_distance, args.level0_cells
        ));
    }
    let params = DensityParams::demo(args.seed);
    let field: Arc<dyn Field> = Arc::new(Density::new(params.clone()));
    let scripted = args.shot.screenshot.is_some();
    // Screenshots show the same terrain every time: no save read or written.
    // A joining player's terrain is the host's: nothing to save either.
    let save = (!args.no_save && !scripted && !args.net.joins()).then(|| {
        let path = args
            .save
            .clone()
            .unwrap_or_else(|| format!("terrain-seed{}.kdsave", args.seed).into());
        KdSave::new(path, KdSave::fingerprint_of(&params))
    });
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.62, 0.75, 0.9)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: terrain",
        &args.shot,
        KdContourSettings {
            max_tasks_in_flight: 16,
            color_by_lod: args.overview,
            lod: LodSettings {
                base: 0.02,
                near: 40.0,
                growth: 2.0,
                max: 4.0,
                ..default()
            },
            ..common::preset()
        },
        KdContourPanel {
            iso_range: -8.0..=8.0,
            ..default()
        },
    )
    .insert_resource(Seed {
        field,
        view: args.view_distance,
        level0: args.level0_cells,
        flat: args.flat,
        overview: args.overview,
        res: args.chunk_res,
        scripted,
        save,
        shared: args.net.on().then(|| KdSave::fingerprint_of(&params)),
        joins: args.net.joins(),
        agents: args.agents,
    })
    // Walking stands on the chunk colliders (`common::add_plugins` starts them off).
    .insert_resource(bevy_kdcontour::ColliderSettings::default())
    .add_plugins((
        PhysicsPlugins::default(),
        TerrainMaterialPlugin,
        AgentsPlugin,
    ))
    .init_resource::<common::walk::Walking>()
    .add_systems(Startup, setup)
    .add_systems(
        Update,
        (
            common::walk::toggle_walk,
            common::fly_camera,
            common::walk::walk,
            sculpt,
            agents_key,
            undo_redo,
            brush_preview,
            scripted_edits,
            toggle_levels,
        )
            .chain(),
    );
    if args.walk {
        app.insert_resource(common::walk::WalkAtStart);
    }
    if scripted && args.agents && !args.net.on() {
        // The picture waits for the agents to be on their way.
        app.insert_resource(common::ShotWait {
            open: false,
            linger: std::time::Duration::ZERO,
        })
        .add_systems(Update, agents_gate);
    }
    common::net::add(&mut app, &args.net);
    if args.net.on() {
        app.add_systems(Update, share_aim.after(sculpt));
        if scripted {
            // The picture waits for both players' edits and brushes.
            app.insert_resource(common::ShotWait {
                open: false,
                linger: std::time::Duration::from_secs(90),
            })
            .add_systems(Update, open_gate);
        }
    }
    app.run();
}

#[derive(Resource)]
struct Seed {
    field: Arc<dyn Field>,
    view: f32,
    level0: u32,
    flat: bool,
    overview: bool,
    res: u32,
    scripted: bool,
    save: Option<KdSave>,
    /// Played with others: the shared volume's fingerprint.
    shared: Option<String>,
    /// This run joins another's game.
    joins: bool,
    /// Place and send agents in the screenshot.
    agents: bool,
}

fn setup(
    mut commands: Commands,
    seed: Res<Seed>,
    mut images: ResMut<Assets<Image>>,
    mut materials: ResMut<Assets<TerrainMaterial>>,
) {
    // Grass, rock, dirt and snow from the field, textured by triplanar
    // projection from generated texture arrays.
    let ground = materials.add(TerrainTextures::generate(&mut images, 256).terrain());
    let volume = if seed.flat {
        KdVolume::streaming(seed.field.clone(), seed.res, 1.0, seed.view)
    } else {
        KdVolume::horizon(seed.field.clone(), seed.res, 1.0, seed.view as u32)
            .with_level0(seed.level0)
    };
    let volume = commands
        .spawn(
            volume
                .with_rows(-3, 1)
                .with_terrain_material(ground)
                // The terrain's materials blend over narrow bands everywhere:
                // crisp borders would cost +50% triangles near and about 5x far.
                .with_material_borders(false),
        )
        .id();
    if let Some(save) = &seed.save {
        commands.entity(volume).insert(save.clone());
    }
    if let Some(fingerprint) = &seed.shared {
        commands
            .entity(volume)
            .insert(NetVolume::new(1, fingerprint.clone()));
    }
    let (fly, transform) = if seed.overview {
        // From high above, looking down at the rings of levels around a LOD
        // camera standing 40 cells over the ground (so the rings are the ones a
        // player there sees).
        commands.spawn((LodCamera, Transform::from_xyz(0.0, 40.0, 0.0)));
        let h = 1.8 * seed.view;
        common::FlyCam::looking(Vec3::new(0.0, h, 0.3 * h), Vec3::ZERO, 30.0)
    } else {
        // Over the hills, looking out to the horizon.
        common::FlyCam::looking(
            Vec3::new(-30.0, 45.0, 70.0),
            Vec3::new(120.0, -10.0, -80.0),
            30.0,
        )
    };
    // The far plane beyond the farthest chunk corner, and fog over the last
    // stretch so the horizon fades instead of ending.
    let far = 2.5 * seed.view;
    let camera = commands
        .spawn((
            Camera3d::default(),
            Projection::Perspective(PerspectiveProjection { far, ..default() }),
            fly,
            transform,
            DistanceFog {
                color: Color::srgb(0.62, 0.75, 0.9),
                falloff: FogFalloff::Linear {
                    start: if seed.overview { far } else { seed.view * 0.55 },
                    end: if seed.overview {
                        far * 1.5
                    } else {
                        seed.view * 0.95
                    },
                },
                ..default()
            },
        ))
        .id();
    if !seed.overview {
        commands.entity(camera).insert(LodCamera);
    }
    common::spawn_lights(&mut commands);
    commands.insert_resource(Sculpt {
        volume,
        radius: 5.0,
        cooldown: 0.0,
        aim: None,
        paint: None,
        stroke: false,
        scripted_aim: None,
    });
}

/// The field point under the cursor, in the volume's local space (the volume sits
/// at the origin, unrotated).
fn aim(
    window: &Window,
    camera: (&Camera, &GlobalTransform),
    state: &VolumeState,
    max: f32,
) -> Option<Vec3> {
    let cursor = window.cursor_position()?;
    let ray = camera.0.viewport_to_world(camera.1, cursor).ok()?;
    let t = raycast(state.field(), ray.origin, *ray.direction, max, 0.5)?;
    Some(ray.origin + *ray.direction * t)
}

/// The terrain's materials, as the number keys pick them.
const PAINTS: [(KeyCode, u8, &str); 4] = [
    (KeyCode::Digit1, terrain_ids::GRASS, "grass"),
    (KeyCode::Digit2, terrain_ids::ROCK, "rock"),
    (KeyCode::Digit3, terrain_ids::DIRT, "dirt"),
    (KeyCode::Digit4, terrain_ids::SNOW, "snow"),
];

#[allow(clippy::too_many_arguments)]
fn sculpt(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    scroll: Res<AccumulatedMouseScroll>,
    windows: Query<&Window>,
    cameras: Query<(&Camera, &GlobalTransform), With<FlyCam>>,
    volumes: Query<&VolumeState>,
    mut panel: ResMut<KdContourPanel>,
    mut sculpt: ResMut<Sculpt>,
    agents: Res<Agents>,
    mut edits: MessageWriter<ApplyEdit>,
) {
    if keys.just_pressed(KeyCode::KeyP) {
        sculpt.paint = match sculpt.paint {
            None => Some(terrain_ids::DIRT),
            Some(_) => None,
        };
    }
    for (key, id, _) in PAINTS {
        if keys.just_pressed(key) {
            sculpt.paint = Some(id);
        }
    }
    let left = match sculpt.paint {
        None => "add".to_string(),
        Some(id) => {
            let name = PAINTS.iter().find(|p| p.1 == id).map_or("?", |p| p.2);
            format!("paint {name} (1-4)")
        }
    };
    panel.extra = vec![
        format!("brush radius {:.1} (wheel)", sculpt.radius),
        format!("left: {left}   right: dig   P: paint / add"),
        "Ctrl+Z: undo   Ctrl+Shift+Z: redo".to_string(),
        "G: agents (place at the cursor, then send there)".to_string(),
    ];
    if !agents.status.is_empty() {
        panel.extra.push(agents.status.clone());
    }
    if panel.pointer_over {
        sculpt.aim = None;
        return;
    }
    sculpt.radius = (sculpt.radius * (1.0 + 0.1 * scroll.delta.y)).clamp(1.0, 40.0);
    let (Ok(window), Ok(camera), Ok(state)) = (
        windows.single(),
        cameras.single(),
        volumes.get(sculpt.volume),
    ) else {
        return;
    };
    sculpt.aim = sculpt
        .scripted_aim
        .or_else(|| aim(window, camera, state, 400.0));
    sculpt.cooldown -= time.delta_secs();
    let (op, material) = if buttons.pressed(MouseButton::Left) {
        match sculpt.paint {
            Some(id) => (BrushOp::Paint, id),
            // Added ground is dirt, dug ground shows what is under it.
            None => (BrushOp::SmoothAdd { radius: 1.5 }, terrain_ids::DIRT),
        }
    } else if buttons.pressed(MouseButton::Right) {
        (BrushOp::SmoothSubtract { radius: 1.5 }, terrain_ids::DIRT)
    } else {
        sculpt.stroke = false;
        return;
    };
    let (Some(at), true) = (sculpt.aim, sculpt.cooldown <= 0.0) else {
        return;
    };
    sculpt.cooldown = 0.08;
    let brush = Brush::sphere(at, sculpt.radius, op).with_material(material);
    edits.write(if sculpt.stroke {
        ApplyEdit::continuing(sculpt.volume, brush)
    } else {
        ApplyEdit::new(sculpt.volume, brush)
    });
    sculpt.stroke = true;
}

/// G places the agents at the cursor, then sends them there.
fn agents_key(keys: Res<ButtonInput<KeyCode>>, sculpt: Res<Sculpt>, mut spawn: AgentSpawn) {
    if let (true, Some(at)) = (keys.just_pressed(KeyCode::KeyG), sculpt.aim) {
        spawn.place_or_send(sculpt.volume, at);
    }
}

/// What placing and sending the agents needs.
#[derive(bevy::ecs::system::SystemParam)]
struct AgentSpawn<'w, 's> {
    commands: Commands<'w, 's>,
    meshes: ResMut<'w, Assets<Mesh>>,
    materials: ResMut<'w, Assets<StandardMaterial>>,
    agents: ResMut<'w, Agents>,
    navmesh: ResMut<'w, bevy_kdcontour::NavmeshSettings>,
}

impl AgentSpawn<'_, '_> {
    fn place_or_send(&mut self, volume: Entity, at: Vec3) {
        place_or_send(
            &mut self.commands,
            &mut self.meshes,
            &mut self.materials,
            &mut self.agents,
            &mut self.navmesh,
            volume,
            at,
        );
    }
}

/// In a screenshot: the picture once the agents have walked a while.
fn agents_gate(agents: Res<Agents>, mut wait: ResMut<common::ShotWait>) {
    wait.open = agents.walked >= 25;
}

/// Ctrl+Z takes back the last stroke, Ctrl+Shift+Z or Ctrl+Y puts it back.
fn undo_redo(
    keys: Res<ButtonInput<KeyCode>>,
    sculpt: Res<Sculpt>,
    mut undo: MessageWriter<UndoEdit>,
    mut redo: MessageWriter<RedoEdit>,
) {
    let ctrl = keys.any_pressed([
        KeyCode::ControlLeft,
        KeyCode::ControlRight,
        KeyCode::SuperLeft,
        KeyCode::SuperRight,
    ]);
    if !ctrl {
        return;
    }
    let shift = keys.any_pressed([KeyCode::ShiftLeft, KeyCode::ShiftRight]);
    let volume = sculpt.volume;
    if keys.just_pressed(KeyCode::KeyZ) && !shift {
        undo.write(UndoEdit { volume });
    } else if keys.just_pressed(KeyCode::KeyZ) || keys.just_pressed(KeyCode::KeyY) {
        redo.write(RedoEdit { volume });
    }
}

fn brush_preview(sculpt: Res<Sculpt>, mut gizmos: Gizmos) {
    if let Some(at) = sculpt.aim {
        gizmos.sphere(
            Isometry3d::from_translation(at),
            sculpt.radius,
            Color::srgb(1.0, 0.85, 0.2),
        );
    }
}

/// L toggles colouring chunks by level (a horizon volume) or by threshold band.
fn toggle_levels(keys: Res<ButtonInput<KeyCode>>, mut settings: ResMut<KdContourSettings>) {
    if keys.just_pressed(KeyCode::KeyL) {
        settings.color_by_lod = !settings.color_by_lod;
    }
}

/// In screenshot mode: dig a crater, raise a mound and paint a patch where the
/// screen center looks, the way a user's clicks would, so the picture shows edits.
#[allow(clippy::too_many_arguments)]
fn scripted_edits(
    seed: Res<Seed>,
    mut done: Local<bool>,
    mut sculpt: ResMut<Sculpt>,
    cameras: Query<(&Camera, &GlobalTransform), With<FlyCam>>,
    volumes: Query<&VolumeState>,
    followers: Query<&Follower>,
    mut edits: MessageWriter<ApplyEdit>,
    mut spawn: AgentSpawn,
) {
    if !seed.scripted || *done {
        return;
    }
    // A joining player edits once the host's terrain has arrived.
    if seed.joins && !followers.get(sculpt.volume).is_ok_and(Follower::joined) {
        return;
    }
    let (Ok((camera, tf)), Ok(state)) = (cameras.single(), volumes.get(sculpt.volume)) else {
        return;
    };
    let Some(size) = camera.logical_viewport_size() else {
        return;
    };
    *done = true;
    // A crater (its walls dirt), a mound, and a patch painted snow. With two
    // players, each digs, raises and paints its own three, right of the panel.
    let dig = BrushOp::SmoothSubtract { radius: 2.0 };
    let raise = BrushOp::SmoothAdd { radius: 3.0 };
    let brushes = match (seed.shared.is_some(), seed.joins) {
        (false, _) => [
            (0.5, 0.55, dig, 11.0, terrain_ids::DIRT),
            (0.3, 0.6, raise, 8.0, terrain_ids::DIRT),
            (0.72, 0.62, BrushOp::Paint, 9.0, terrain_ids::SNOW),
        ],
        (true, false) => [
            (0.5, 0.6, dig, 10.0, terrain_ids::DIRT),
            (0.85, 0.6, raise, 7.0, terrain_ids::DIRT),
            (0.62, 0.45, BrushOp::Paint, 6.0, terrain_ids::SNOW),
        ],
        (true, true) => [
            (0.7, 0.75, dig, 9.0, terrain_ids::DIRT),
            (0.6, 0.52, raise, 6.0, terrain_ids::ROCK),
            (0.9, 0.47, BrushOp::Paint, 6.0, terrain_ids::GRASS),
        ],
    };
    // Each player's brush shown aiming somewhere (the other sees it too).
    let aim_at = if seed.joins {
        (0.78, 0.58)
    } else {
        (0.55, 0.5)
    };
    let ray = camera.viewport_to_world(tf, size * Vec2::new(aim_at.0, aim_at.1));
    if let (Some(_), Ok(ray)) = (&seed.shared, ray) {
        sculpt.scripted_aim = raycast(state.field(), ray.origin, *ray.direction, 400.0, 0.5)
            .map(|t| ray.origin + *ray.direction * t);
    }
    let ground = |fx: f32, fy: f32| {
        let ray = camera
            .viewport_to_world(tf, size * Vec2::new(fx, fy))
            .ok()?;
        let t = raycast(state.field(), ray.origin, *ray.direction, 400.0, 0.5)?;
        Some(ray.origin + *ray.direction * t)
    };
    for (fx, fy, op, r, material) in brushes {
        if let Some(at) = ground(fx, fy) {
            edits.write(ApplyEdit::new(
                sculpt.volume,
                Brush::sphere(at, r, op).with_material(material),
            ));
        }
    }
    // One player's picture: agents on their way from below the crater to
    // beyond it, around it.
    if seed.agents && seed.shared.is_none() {
        for (fx, fy) in [AGENTS_FROM, AGENTS_TO] {
            if let Some(at) = ground(fx, fy) {
                spawn.place_or_send(sculpt.volume, at);
            }
        }
    }
}

/// Where the screenshot's agents start and go (fractions of the view).
const AGENTS_FROM: (f32, f32) = (0.56, 0.86);
const AGENTS_TO: (f32, f32) = (0.52, 0.36);

/// Where this player's brush aims, for the others to see.
fn share_aim(sculpt: Res<Sculpt>, mut cursor: ResMut<LocalCursor>) {
    let now = LocalCursor(sculpt.aim.map(|at| Cursor {
        volume: sculpt.volume,
        at,
        radius: sculpt.radius,
    }));
    if *cursor != now {
        *cursor = now;
    }
}

/// In a multiplayer screenshot: the picture waits until both players' edits
/// are in the terrain and the other's brush is seen (each app then stays 90 s,
/// so the other's picture shows its brush too).
fn open_gate(
    sculpt: Res<Sculpt>,
    volumes: Query<&VolumeState>,
    peers: Res<PeerCursors>,
    mut wait: ResMut<common::ShotWait>,
) {
    let edits = volumes
        .get(sculpt.volume)
        .map_or(0, |s| s.history().brush_count());
    wait.open = edits >= 6 && !peers.0.is_empty();
}
