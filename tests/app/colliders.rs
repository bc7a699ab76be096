//! Colliders (feature `avian`), headless, with avian's physics: a ball
//! comes to rest on the terrain, falls into a pit dug under it, and is stopped
//! by a wall raised in its path; at no frame does a chunk's collider lag its
//! mesh; only chunks near an anchor carry colliders.

use crate::common::{app_with, settle};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_kdcontour::avian3d::prelude::*;
use bevy_kdcontour::prelude::*;
use bevy_kdcontour::{ColliderAnchor, ColliderSettings};
use kdcontour::field::csg::CsgNode;
use std::sync::Arc;
use std::time::Duration;

/// Rolling ground: `y = height(x, z)`.
fn height(x: f32, z: f32) -> f32 {
    3.0 + 0.3 * (0.5 * x).sin() * (0.5 * z).cos()
}

/// The bottom of the ground's one bowl, where `height` is least (2.7): a ball
/// dropped here comes to rest here, not wherever its bounces send it (off the
/// volume's edge, once).
const BOWL: Vec3 = Vec3::new(std::f32::consts::PI, 2.7, std::f32::consts::TAU);

const BALL: f32 = 0.3;

/// A headless app with physics (60 updates a simulated second), the ground in
/// 4 x 2 x 4 chunks of 16 cells of 0.25 (16 x 8 x 16 units), colliders within
/// `distance` of anchors, and the LOD camera far above.
fn world(distance: f32) -> (App, Entity) {
    let mut app = app_with(LodSettings::default());
    app.add_plugins(PhysicsPlugins::default())
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            1.0 / 60.0,
        )))
        .insert_resource(ColliderSettings {
            distance,
            ..Default::default()
        });
    // `App::run` does this; avian sets up its diagnostics resources in `finish`.
    app.finish();
    app.cleanup();
    let field: Arc<dyn kdcontour::Field> =
        Arc::new(kdcontour::field::FnField(|p: Vec3| p.y - height(p.x, p.z)));
    let volume = app
        .world_mut()
        .spawn(KdVolume::new(field, UVec3::new(4, 2, 4), 16, 0.25))
        .id();
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(8.0, 200.0, 8.0)));
    settle(&mut app, volume);
    (app, volume)
}

/// A ball dropped at `at`, once the chunks under it have their colliders (an
/// anchor there first; the ball is one too).
fn spawn_ball(app: &mut App, volume: Entity, at: Vec3) -> Entity {
    let anchor = app
        .world_mut()
        .spawn((ColliderAnchor, Transform::from_translation(at)))
        .id();
    settle(app, volume);
    app.world_mut().despawn(anchor);
    app.world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::sphere(BALL),
            ColliderAnchor,
            Transform::from_translation(at),
        ))
        .id()
}

/// Checks that every chunk's collider is of the mesh it shows this frame: a
/// collider only with a mesh, and the same triangles.
fn check_in_step(app: &mut App) -> usize {
    let mut q = app
        .world_mut()
        .query::<(Entity, &KdChunk, Option<&Mesh3d>, Option<&Collider>)>();
    let meshes = app.world().resource::<Assets<Mesh>>();
    let mut with = 0;
    for (e, _, mesh, collider) in q.iter(app.world()) {
        let Some(collider) = collider else { continue };
        with += 1;
        let handle = mesh.unwrap_or_else(|| panic!("chunk {e} has a collider and no mesh"));
        let mesh = meshes.get(handle.id()).expect("the mesh asset");
        let tris = mesh.indices().map_or(0, |i| i.len() / 3);
        let trimesh = collider.shape().as_trimesh().expect("a trimesh");
        assert_eq!(
            trimesh.indices().len(),
            tris,
            "chunk {e}: its collider is not of the mesh it shows"
        );
    }
    with
}

/// `frames` physics frames in lockstep with the chunk tasks: before each, the
/// physics clock stops while the volume settles, so what the ball meets does
/// not hang on how fast this machine's cores build chunks (the tests share two
/// cores with each other, and chunk workers run at a lower priority). How far
/// builds lag in real time is the horizon and frame benches' business.
fn step(app: &mut App, volume: Entity, frames: usize) {
    for _ in 0..frames {
        app.world_mut().resource_mut::<Time<Physics>>().pause();
        settle(app, volume);
        app.world_mut().resource_mut::<Time<Physics>>().unpause();
        app.update();
        check_in_step(app);
    }
}

fn ball_at(app: &App, ball: Entity) -> Vec3 {
    app.world().get::<Transform>(ball).unwrap().translation
}

#[test]
fn a_ball_rests_on_the_ground_and_falls_into_a_pit_dug_under_it() {
    let (mut app, volume) = world(3.0);
    let start = BOWL + Vec3::Y;
    let ball = spawn_ball(&mut app, volume, start);
    // Three simulated seconds: it falls, bounces and settles.
    step(&mut app, volume, 180);
    let rest = ball_at(&app, ball);
    let ground = height(rest.x, rest.z);
    assert!(
        (rest.y - BALL - ground).abs() < 0.04,
        "the ball rests at {rest}, {} above the ground",
        rest.y - BALL - ground
    );
    // Only the chunks near the ball have colliders.
    let with = check_in_step(&mut app);
    assert!(with > 0 && with < 32, "{with} of 32 chunks have colliders");

    // Asleep, as a resting body soon is (avian wakes a body on its own
    // changes, not when the static ground under it changes): the new
    // collider wakes it.
    app.world_mut().entity_mut(ball).insert(Sleeping);
    // Dig a pit under it: it falls in within a simulated second.
    app.world_mut().write_message(ApplyEdit::new(
        volume,
        Brush::sphere(Vec3::new(rest.x, ground, rest.z), 1.5, BrushOp::Subtract),
    ));
    let mut fell = None;
    for frame in 0..60 {
        step(&mut app, volume, 1);
        if ball_at(&app, ball).y < rest.y - 0.5 {
            fell = Some(frame);
            break;
        }
    }
    assert!(
        fell.is_some(),
        "the ball stayed at {} over the pit",
        ball_at(&app, ball)
    );
}

#[test]
fn a_wall_raised_in_its_path_stops_a_rolling_ball() {
    let (mut app, volume) = world(3.0);
    let ball = spawn_ball(&mut app, volume, BOWL + Vec3::Y);
    step(&mut app, volume, 120);
    // A wall across the path at x = 9..10, well above the ground and wider
    // than the volume.
    app.world_mut().write_message(ApplyEdit::new(
        volume,
        kdcontour::edit::Brush {
            shape: CsgNode::Box {
                half_extents: Vec3::new(0.5, 2.0, 10.0),
                center: Vec3::new(9.5, 4.0, 8.0),
            },
            op: BrushOp::Add,
            material: 0,
        },
    ));
    step(&mut app, volume, 10);
    // Push it straight at the wall at 4 units a second for three seconds (it
    // would be past x = 15 without the wall). Its sideways speed is held at
    // zero: past x = 2 pi the ground is a ridge across its path, and a ball
    // let slide along the wall leaves the volume at z = 0 and goes round it.
    let mut farthest = f32::MIN;
    for _ in 0..180 {
        let mut v = app.world_mut().get_mut::<LinearVelocity>(ball).unwrap();
        v.x = 4.0;
        v.z = 0.0;
        step(&mut app, volume, 1);
        farthest = farthest.max(ball_at(&app, ball).x);
    }
    assert!(
        farthest < 9.0 - BALL + 0.05,
        "the ball went through the wall to x = {farthest}"
    );
    assert!(
        farthest > 8.0,
        "the ball never reached the wall ({farthest})"
    );
}

#[test]
fn new_collider_layers_reach_every_chunk_collider_at_once() {
    let (mut app, volume) = world(6.0);
    let anchor = app
        .world_mut()
        .spawn((ColliderAnchor, Transform::from_xyz(8.0, 3.0, 8.0)))
        .id();
    settle(&mut app, volume);
    let layers = |app: &mut App| {
        let mut q = app
            .world_mut()
            .query_filtered::<&CollisionLayers, (With<KdChunk>, With<Collider>)>();
        q.iter(app.world()).copied().collect::<Vec<_>>()
    };
    let before = layers(&mut app);
    assert!(!before.is_empty(), "no chunk collider near the anchor");
    assert!(before.iter().all(|l| *l == CollisionLayers::default()));
    let wanted = CollisionLayers::new(0b100, 0b011);
    app.world_mut().resource_mut::<ColliderSettings>().layers = wanted;
    step(&mut app, volume, 1);
    let after = layers(&mut app);
    assert_eq!(after.len(), before.len(), "colliders came or went");
    assert!(after.iter().all(|l| *l == wanted), "{after:?}");
    // Colliders built later (the anchor moves on) carry them too.
    app.world_mut()
        .get_mut::<Transform>(anchor)
        .unwrap()
        .translation = Vec3::new(2.0, 3.0, 2.0);
    settle(&mut app, volume);
    let moved = layers(&mut app);
    assert!(
        !moved.is_empty() && moved.iter().all(|l| *l == wanted),
        "{moved:?}"
    );
}
