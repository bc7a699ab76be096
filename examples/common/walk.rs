//! Walking (the terrain demo's `V` key): a capsule player with avian physics,
//! gravity and jumping on the terrain it sculpts; the camera rides at its eyes.
//! Mouse and arrow keys still look around (the fly camera's look); WASD walk,
//! Shift runs, Space jumps.

use super::FlyCam;
use bevy::prelude::*;
use bevy_kdcontour::avian3d::prelude::*;
use bevy_kdcontour::ColliderAnchor;

/// Capsule radius and the length of its middle (1.8 units tall in all).
const RADIUS: f32 = 0.4;
const LENGTH: f32 = 1.0;
/// Eyes above the capsule's center.
const EYES: f32 = 0.7;
/// Walking and running speed (units a second), and the jump's starting speed.
const WALK: f32 = 5.0;
const RUN: f32 = 12.0;
const JUMP: f32 = 6.0;

/// The walking player, when walking.
#[derive(Resource, Default)]
pub struct Walking(pub Option<Entity>);

/// Start walking at once (the demo's `--walk`), as if `V` had been pressed.
#[derive(Resource)]
pub struct WalkAtStart;

/// Marks the player's capsule.
#[derive(Component)]
pub struct Walker;

/// `V` toggles walking: a capsule drops from where the camera is, and goes away
/// when flying again.
pub fn toggle_walk(
    mut commands: Commands,
    keys: Res<ButtonInput<KeyCode>>,
    mut walking: ResMut<Walking>,
    at_start: Option<Res<WalkAtStart>>,
    cams: Query<&Transform, With<FlyCam>>,
) {
    if at_start.is_some() {
        commands.remove_resource::<WalkAtStart>();
    } else if !keys.just_pressed(KeyCode::KeyV) {
        return;
    }
    match walking.0.take() {
        Some(player) => commands.entity(player).despawn(),
        None => {
            let Ok(cam) = cams.single() else { return };
            let player = commands
                .spawn((
                    Walker,
                    RigidBody::Dynamic,
                    Collider::capsule(RADIUS, LENGTH),
                    LockedAxes::ROTATION_LOCKED,
                    Friction::new(0.0),
                    // Chunks near the player get colliders even when the camera
                    // is elsewhere.
                    ColliderAnchor,
                    Transform::from_translation(cam.translation - Vec3::Y * EYES),
                ))
                .id();
            walking.0 = Some(player);
        }
    }
}

/// The player's position and velocity (not the camera's).
type Players<'w, 's> = Query<
    'w,
    's,
    (&'static Transform, &'static mut LinearVelocity),
    (With<Walker>, Without<FlyCam>),
>;

/// Walks the player with WASD on the ground plane of the camera's yaw, jumps
/// with Space when its feet are on the ground, and puts the camera at its eyes
/// (after the fly camera's look and move, so only the look remains).
pub fn walk(
    keys: Res<ButtonInput<KeyCode>>,
    walking: Res<Walking>,
    spatial: SpatialQuery,
    mut players: Players,
    mut cams: Query<(&FlyCam, &mut Transform)>,
) {
    let Some(player) = walking.0 else { return };
    let (Ok((at, mut velocity)), Ok((cam, mut eye))) = (players.get_mut(player), cams.single_mut())
    else {
        return;
    };
    let yaw = Quat::from_rotation_y(cam.yaw);
    let (forward, right) = (yaw * -Vec3::Z, yaw * Vec3::X);
    let mut wish = Vec3::ZERO;
    for (key, dir) in [
        (KeyCode::KeyW, forward),
        (KeyCode::KeyS, -forward),
        (KeyCode::KeyD, right),
        (KeyCode::KeyA, -right),
    ] {
        if keys.pressed(key) {
            wish += dir;
        }
    }
    let speed = if keys.pressed(KeyCode::ShiftLeft) {
        RUN
    } else {
        WALK
    };
    let wish = wish.normalize_or_zero() * speed;
    velocity.x = wish.x;
    velocity.z = wish.z;
    // On the ground when a short ray from the bottom of the capsule hits.
    let feet = at.translation - Vec3::Y * (0.5 * LENGTH + RADIUS - 0.05);
    let grounded = spatial
        .cast_ray(
            feet,
            Dir3::NEG_Y,
            0.2,
            true,
            &SpatialQueryFilter::from_excluded_entities([player]),
        )
        .is_some();
    if grounded && keys.just_pressed(KeyCode::Space) {
        velocity.y = JUMP;
    }
    eye.translation = at.translation + Vec3::Y * EYES;
}
