//! Crossing chunk seams (feature `avian`), headless: a ball rolling, and an
//! upright capsule sliding, down a long slope across eleven chunk seams keep as
//! smooth a speed as over one collider of the same triangles welded together:
//! at no seam does a frame's upward jump of the vertical velocity exceed the
//! largest the single collider gives anywhere (no ghost collisions where two
//! chunks' colliders meet).

use crate::common::{app_with, settle};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_kdcontour::avian3d::prelude::*;
use bevy_kdcontour::prelude::*;
use bevy_kdcontour::{ColliderAnchor, ColliderSettings};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// Cells per chunk side, and the cell size: chunks of 2 units.
const RES: u32 = 8;
const CELL: f32 = 0.25;
/// Chunks along the slope (x), up (y) and across (z).
const CHUNKS: UVec3 = UVec3::new(16, 3, 4);
const BALL: f32 = 0.25;

/// The slope: down along x, in a shallow channel along z = 4 (so the body
/// stays on it and the surface is not a plane).
fn height(x: f32, z: f32) -> f32 {
    5.5 - 0.17 * x - 0.15 * (0.8 * (z - 4.0)).cos()
}

/// A headless app with physics at 60 updates a simulated second.
fn physics_app(colliders: bool) -> App {
    let mut app = app_with(LodSettings::default());
    app.add_plugins(PhysicsPlugins::default())
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            1.0 / 60.0,
        )))
        .insert_resource(ColliderSettings {
            enabled: colliders,
            distance: 1000.0,
            ..Default::default()
        });
    app.finish();
    app.cleanup();
    app
}

/// The slope meshed in chunks, every chunk with its collider.
fn chunked() -> (App, Entity) {
    let mut app = physics_app(true);
    let field: Arc<dyn kdcontour::Field> =
        Arc::new(kdcontour::field::FnField(|p: Vec3| p.y - height(p.x, p.z)));
    let volume = app
        .world_mut()
        .spawn(KdVolume::new(field, CHUNKS, RES, CELL))
        .id();
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(16.0, 50.0, 2.0)));
    settle(&mut app, volume);
    (app, volume)
}

/// The chunk colliders' triangles welded into one trimesh (vertices at the
/// same position are one), chunk by chunk in coordinate order, so the same
/// surface gives the same trimesh on every run.
fn welded(app: &mut App) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut q = app.world_mut().query::<(&KdChunk, &Collider)>();
    let mut chunks: Vec<_> = q.iter(app.world()).collect();
    chunks.sort_by_key(|(k, _)| (k.level, k.coord.to_array()));
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for (_, c) in chunks {
        let t = c.shape().as_trimesh().expect("a trimesh");
        let v = t.vertices();
        for tri in t.indices() {
            triangles.push(tri.map(|i| {
                let p = Vec3::new(v[i as usize].x, v[i as usize].y, v[i as usize].z);
                let key = p.to_array().map(f32::to_bits);
                *index.entry(key).or_insert_with(|| {
                    vertices.push(p);
                    vertices.len() as u32 - 1
                })
            }));
        }
    }
    (vertices, triangles)
}

/// The bodies that go down the slope.
#[derive(Clone, Copy, Debug)]
enum Body {
    /// A ball that rolls.
    Ball,
    /// An upright capsule that slides without friction and never tips (as a
    /// character controller's).
    Capsule,
}

/// Sends a body down the slope from x = 3 for `frames`; returns its velocity
/// and position each frame.
fn roll(app: &mut App, body: Body, frames: usize) -> Vec<(Vec3, Vec3)> {
    let lift = match body {
        Body::Ball => BALL,
        Body::Capsule => 0.5 + BALL,
    };
    let start = Vec3::new(3.0, height(3.0, 4.0) + lift + 0.01, 4.0);
    let mut e = app.world_mut().spawn((
        RigidBody::Dynamic,
        ColliderAnchor,
        Transform::from_translation(start),
    ));
    match body {
        Body::Ball => e.insert(Collider::sphere(BALL)),
        Body::Capsule => e.insert((
            Collider::capsule(BALL, 1.0),
            LockedAxes::ROTATION_LOCKED,
            Friction::ZERO.with_combine_rule(CoefficientCombine::Min),
        )),
    };
    let body = e.id();
    let mut out = Vec::new();
    for _ in 0..frames {
        app.update();
        let v = app.world().get::<LinearVelocity>(body).unwrap().0;
        let p = app.world().get::<Transform>(body).unwrap().translation;
        out.push((v, p));
    }
    out
}

/// The largest upward jump of the vertical velocity between two frames while
/// the body is on the slope, the largest while its lowest point is within 0.1
/// of a seam (a chunk boundary across x), and the seams it crossed.
fn largest_jump(track: &[(Vec3, Vec3)]) -> (f32, f32, usize) {
    let side = RES as f32 * CELL;
    let on = |p: Vec3| p.x > 3.5 && p.x < 26.0;
    let near_seam = |p: Vec3| {
        let f = p.x / side;
        (f - f.round()).abs() * side < BALL + 0.1
    };
    let mut jump: f32 = 0.0;
    let mut at = 0.0f32;
    for w in track.windows(2) {
        if on(w[0].1) && on(w[1].1) {
            let dv = w[1].0.y - w[0].0.y;
            jump = jump.max(dv);
            if near_seam(w[0].1) || near_seam(w[1].1) {
                at = at.max(dv);
            }
        }
    }
    let seams = track
        .windows(2)
        .filter(|w| on(w[1].1) && (w[0].1.x / side).floor() != (w[1].1.x / side).floor())
        .count();
    (jump, at, seams)
}

#[test]
fn a_ball_and_a_capsule_cross_chunk_seams_as_smoothly_as_over_one_collider() {
    const FRAMES: usize = 480;
    for body in [Body::Ball, Body::Capsule] {
        let (mut app, volume) = chunked();
        let (vertices, triangles) = welded(&mut app);
        let chunked_track = roll(&mut app, body, FRAMES);
        drop((app, volume));

        let mut one = physics_app(false);
        one.world_mut().spawn((
            RigidBody::Static,
            Collider::trimesh_with_config(vertices, triangles, TrimeshFlags::FIX_INTERNAL_EDGES),
        ));
        let single_track = roll(&mut one, body, FRAMES);

        let (single, _, _) = largest_jump(&single_track);
        let (anywhere, at_seams, seams) = largest_jump(&chunked_track);
        eprintln!(
            "{body:?}: largest upward jump of the vertical velocity in a frame: one collider \
             {single:.4} m/s; chunk colliders {at_seams:.4} m/s at the {seams} seams crossed \
             ({anywhere:.4} m/s anywhere)"
        );
        assert!(seams >= 10, "{body:?} crossed only {seams} seams");
        assert!(
            at_seams <= single,
            "{body:?} jumps {at_seams} m/s at a seam, more than the {single} m/s it \
             jumps anywhere on one collider of the same triangles"
        );
        let end = chunked_track.last().unwrap().1;
        assert!(end.x > 26.0, "{body:?} stopped at {end}");
    }
}
