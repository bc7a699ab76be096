//! Shared by the examples: the plugin set and settings preset every example
//! starts from, the `--screenshot PATH [--frames N]` harness, a fly camera, and a
//! sun with sky light.
#![allow(dead_code)] // not every example uses every helper

pub mod agents;
pub mod net;
pub mod walk;

use bevy::prelude::*;
use bevy::render::view::screenshot::{save_to_disk, Screenshot, ScreenshotCaptured};
use bevy::window::{PresentMode, WindowResolution};
use bevy_kdcontour::panel::{KdContourPanel, KdContourPanelPlugin};
use bevy_kdcontour::prelude::*;
use std::path::PathBuf;

/// Flags every example takes.
#[derive(clap::Args, Debug, Clone, Resource)]
pub struct ShotArgs {
    /// Render, save a PNG screenshot here, and exit (non-zero if the picture is
    /// one flat colour).
    #[arg(long, value_name = "PATH")]
    pub screenshot: Option<PathBuf>,
    /// Frames to render before the screenshot; it also waits for meshing to settle.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub frames: u32,
}

/// The window and default plugins every example uses (1280x720, vsync off in
/// screenshot mode so software rendering is not throttled).
pub fn default_plugins(title: &str, shot: &ShotArgs) -> impl PluginGroup {
    DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window {
            title: title.into(),
            resolution: WindowResolution::new(1280, 720),
            present_mode: if shot.screenshot.is_some() {
                PresentMode::AutoNoVsync
            } else {
                PresentMode::AutoVsync
            },
            ..default()
        }),
        ..default()
    })
}

/// The settings every example starts from: chunk tasks take milliseconds, so
/// many may run at once and a slow (software-rendered) frame does not throttle
/// meshing.
pub fn preset() -> KdContourSettings {
    KdContourSettings {
        max_tasks_in_flight: 32,
        ..default()
    }
}

/// [`preset`] with camera LOD off: every chunk cut at `threshold`.
pub fn fixed(threshold: f32) -> KdContourSettings {
    KdContourSettings {
        default_threshold: threshold,
        lod: LodSettings {
            enabled: false,
            ..default()
        },
        ..preset()
    }
}

/// Adds what every example runs on: Bevy's default plugins with the example's
/// window, the meshing plugins with `settings` (start from [`preset`]), the egui
/// panel, and the screenshot harness. Chunk colliders and navmesh tiles start
/// off: only the terrain demo runs physics and agents (it turns them on).
pub fn add_plugins<'a>(
    app: &'a mut App,
    title: &str,
    shot: &ShotArgs,
    settings: KdContourSettings,
    panel: KdContourPanel,
) -> &'a mut App {
    app.add_plugins((
        default_plugins(title, shot),
        KdContourPlugins { settings },
        KdContourPanelPlugin { panel },
        ShotPlugin(shot.clone()),
    ))
    // The examples build with feature `avian` (the terrain demo walks on the
    // colliders); with no physics running, colliders would be wasted work.
    .insert_resource(bevy_kdcontour::ColliderSettings {
        enabled: false,
        ..default()
    })
    // Navmesh tiles start off too: the terrain demo turns them on when its
    // agents are placed.
    .insert_resource(bevy_kdcontour::NavmeshSettings {
        enabled: false,
        ..default()
    })
}

/// What an example waits for besides settled meshes (another player's edits,
/// in a multiplayer picture).
#[derive(Resource, Default)]
pub struct ShotWait {
    /// The picture may be taken.
    pub open: bool,
    /// After its picture, the app keeps running this long before it exits
    /// (the other player's picture needs this one's brush).
    pub linger: std::time::Duration,
}

/// Adds the screenshot harness when `--screenshot` was given.
pub struct ShotPlugin(pub ShotArgs);

#[derive(Resource, Default)]
struct ShotState {
    frames: u32,
    /// Frames since meshing settled.
    settled_for: u32,
    taken: bool,
    /// Set by the observer once the picture is saved: distinct colours seen.
    colours: Option<usize>,
    after: u32,
    /// When the picture was saved.
    saved_at: Option<std::time::Instant>,
}

impl Plugin for ShotPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.0.clone());
        if self.0.screenshot.is_some() {
            app.init_resource::<ShotState>()
                .add_systems(Last, take_screenshot);
        }
    }
}

/// Most frames to wait for meshing to settle before giving up.
const SETTLE_LIMIT: u32 = 20_000;

fn take_screenshot(
    mut commands: Commands,
    args: Res<ShotArgs>,
    mut state: ResMut<ShotState>,
    stats: Res<KdContourStats>,
    volumes: Query<&VolumeState>,
    wait: Option<Res<ShotWait>>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(path) = args.screenshot.clone() else {
        return;
    };
    state.frames += 1;
    if let Some(colours) = state.colours {
        // Give the PNG writer a frame (and a lingering app its time), then leave.
        state.after += 1;
        let saved = *state.saved_at.get_or_insert_with(std::time::Instant::now);
        let stay = wait
            .as_ref()
            .map_or(std::time::Duration::ZERO, |w| w.linger);
        if state.after >= 2 && saved.elapsed() >= stay {
            if colours < 2 {
                error!(
                    "screenshot {}: the picture is one flat colour",
                    path.display()
                );
                exit.write(AppExit::error());
            } else {
                info!(
                    "screenshot {}: {colours} distinct colours after {} frames",
                    path.display(),
                    state.frames
                );
                exit.write(AppExit::Success);
            }
        }
        return;
    }
    if state.taken {
        return;
    }
    let settled = volumes.iter().all(|v| v.is_settled())
        && stats.queued == 0
        && wait.as_ref().is_none_or(|w| w.open);
    if state.frames.is_multiple_of(50) {
        info!(
            "frame {}: {} of {} chunks meshed, {} triangles, {} tasks running, {} queued, \
             build {:.1} ms, plugin main thread {:.2} ms",
            state.frames,
            stats.meshed_chunks,
            stats.chunks,
            stats.triangles,
            stats.tasks_in_flight,
            stats.queued,
            stats.build_ms,
            stats.main_thread_ms
        );
    }
    state.settled_for = if settled { state.settled_for + 1 } else { 0 };
    if state.frames >= SETTLE_LIMIT {
        error!("screenshot: meshing did not settle in {SETTLE_LIMIT} frames");
        exit.write(AppExit::error());
        return;
    }
    // A few settled frames so the last uploads reach the GPU.
    if state.frames < args.frames || state.settled_for < 3 {
        return;
    }
    state.taken = true;
    commands
        .spawn(Screenshot::primary_window())
        .observe(save_to_disk(path))
        .observe(
            |captured: On<ScreenshotCaptured>, mut state: ResMut<ShotState>| {
                let data = captured.image.data.as_deref().unwrap_or(&[]);
                let mut seen = std::collections::HashSet::new();
                for px in data.chunks_exact(4) {
                    seen.insert([px[0], px[1], px[2]]);
                    if seen.len() > 4096 {
                        break;
                    }
                }
                state.colours = Some(seen.len());
            },
        );
}

/// A free-flying camera: WASD to move, E / Space up, Q down, Shift for speed;
/// arrow keys or the middle mouse button to look around.
#[derive(Component)]
pub struct FlyCam {
    /// Units per second.
    pub speed: f32,
    /// Radians.
    pub yaw: f32,
    /// Radians.
    pub pitch: f32,
}

impl FlyCam {
    /// A camera at `pos` looking at `target`.
    pub fn looking(pos: Vec3, target: Vec3, speed: f32) -> (FlyCam, Transform) {
        let t = Transform::from_translation(pos).looking_at(target, Vec3::Y);
        let (yaw, pitch, _) = t.rotation.to_euler(EulerRot::YXZ);
        (FlyCam { speed, yaw, pitch }, t)
    }
}

/// Moves [`FlyCam`]s.
pub fn fly_camera(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<bevy::input::mouse::AccumulatedMouseMotion>,
    mut cams: Query<(&mut FlyCam, &mut Transform)>,
) {
    let dt = time.delta_secs();
    for (mut cam, mut t) in &mut cams {
        let mut look = Vec2::ZERO;
        if buttons.pressed(MouseButton::Middle) {
            look += motion.delta * 0.003;
        }
        let turn = 1.5 * dt;
        if keys.pressed(KeyCode::ArrowLeft) {
            look.x -= turn;
        }
        if keys.pressed(KeyCode::ArrowRight) {
            look.x += turn;
        }
        if keys.pressed(KeyCode::ArrowUp) {
            look.y -= turn;
        }
        if keys.pressed(KeyCode::ArrowDown) {
            look.y += turn;
        }
        cam.yaw -= look.x;
        cam.pitch = (cam.pitch - look.y).clamp(-1.5, 1.5);
        t.rotation = Quat::from_euler(EulerRot::YXZ, cam.yaw, cam.pitch, 0.0);
        let mut v = Vec3::ZERO;
        let (f, r) = (t.forward().as_vec3(), t.right().as_vec3());
        for (key, dir) in [
            (KeyCode::KeyW, f),
            (KeyCode::KeyS, -f),
            (KeyCode::KeyD, r),
            (KeyCode::KeyA, -r),
            (KeyCode::KeyE, Vec3::Y),
            (KeyCode::Space, Vec3::Y),
            (KeyCode::KeyQ, -Vec3::Y),
        ] {
            if keys.pressed(key) {
                v += dir;
            }
        }
        let boost = if keys.pressed(KeyCode::ShiftLeft) {
            4.0
        } else {
            1.0
        };
        t.translation += v.normalize_or_zero() * cam.speed * boost * dt;
    }
}

/// A sun with soft sky light.
pub fn spawn_lights(commands: &mut Commands) {
    commands.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(0.3, 1.0, 0.4).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        color: Color::srgb(0.75, 0.82, 1.0),
        brightness: 900.0,
        ..default()
    });
}

/// A message on the terminal and an error exit: bad input in an example.
pub fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(2);
}
