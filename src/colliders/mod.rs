//! Colliders (crate feature `avian`): [`CollidersPlugin`] gives every chunk within
//! [`ColliderSettings::distance`] of the [`LodCamera`] or of any [`ColliderAnchor`]
//! a static avian3d trimesh collider of exactly the mesh it shows.
//!
//! - **Built in the meshing task.** The extraction that makes a chunk's mesh
//!   also builds its collider (avian's `Collider::trimesh_with_config`, with its
//!   BVH) from the same buffers, on the task pool: no render `Mesh` asset is read
//!   (so it works with no renderer), and the main thread only inserts it.
//! - **Never stale.** Mesh and collider travel together and are inserted in the
//!   same frame; an edit's re-extraction replaces both at once. Not through
//!   avian's `ColliderConstructor`, whose cache is keyed by mesh asset and would
//!   return the old collider after a re-mesh.
//! - **Where they are needed.** Chunks within the distance of an anchor (and the
//!   chunks that own seams touching them, so the surface there is whole) carry
//!   a collider, cut at no coarser than [`ColliderSettings::threshold`]; a chunk
//!   that leaves the distance is re-extracted without one. Empty chunks get none.
//!
//! Add avian's `PhysicsPlugins` yourself (the plugin does not step physics).

use crate::mesh::{ChunkExtra, ExtraKind, ExtraPayload, MeshExtra};
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::{to_volume, KdChunk, LodCamera};
use crate::{KdContourStep, KdContourSystems};
use avian3d::prelude::{Collider, ColliderAabb, ColliderOf, CollisionLayers, RigidBody, Sleeping};
use bevy::ecs::system::EntityCommands;
use bevy::prelude::*;
use kdcontour::IndexedMesh;
use std::sync::Arc;

pub(crate) mod trimesh;

/// Chunk colliders near the camera and anchors.
pub struct CollidersPlugin;

impl Plugin for CollidersPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<ColliderSettings>()
            .register_type::<ColliderSettings>()
            .register_type::<ColliderAnchor>()
            .add_systems(
                PostUpdate,
                (
                    want_colliders.in_set(KdContourStep::ChooseChunks),
                    relayer_colliders.in_set(KdContourSystems::Apply),
                ),
            );
    }
}

/// Where chunks get colliders and how.
#[derive(Resource, Clone, Debug, Reflect)]
#[reflect(Resource)]
pub struct ColliderSettings {
    /// Colliders at all.
    pub enabled: bool,
    /// Chunks within this distance (the volume's local units) of the
    /// [`LodCamera`] or a [`ColliderAnchor`] get a collider.
    pub distance: f32,
    /// Chunks with a collider are cut at no coarser threshold than this (squared
    /// cells of the chunk's level, as [`crate::LodSettings`]).
    pub threshold: f32,
    /// The colliders' collision layers.
    #[reflect(ignore)]
    pub layers: CollisionLayers,
}

impl Default for ColliderSettings {
    fn default() -> Self {
        ColliderSettings {
            enabled: true,
            distance: 48.0,
            threshold: 0.02,
            layers: CollisionLayers::default(),
        }
    }
}

/// Chunks near this entity get colliders (players, NPCs, projectiles), as near
/// the [`LodCamera`].
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct ColliderAnchor;

/// The collider subsystem's mesh extra: a chunk's trimesh collider, built in
/// its extraction task, or the removal of an old one.
struct ColliderExtra {
    layers: CollisionLayers,
}

impl MeshExtra for ColliderExtra {
    fn name(&self) -> &'static str {
        "collider"
    }

    fn build(&self, mesh: Option<&IndexedMesh>) -> ExtraPayload {
        match mesh.and_then(|m| trimesh::build(m, self.layers)) {
            Some((collider, layers)) => Box::new(move |chunk: &mut EntityCommands| {
                chunk.queue(wake_bodies_on);
                chunk.insert((RigidBody::Static, collider, layers));
            }),
            None => Box::new(|chunk: &mut EntityCommands| {
                chunk.queue(wake_bodies_on);
                chunk.try_remove::<(Collider, RigidBody, CollisionLayers)>();
            }),
        }
    }
}

/// Wakes the sleeping bodies whose colliders touch the chunk's collider as it
/// is (its world bounds, grown by a hundredth), before the collider is
/// replaced or removed: a body asleep on the ground stays put when the ground
/// under it changes (avian wakes bodies on their own changes, not on a static
/// collider's), so without this a ball resting where a pit is dug would hang
/// over it.
fn wake_bodies_on(chunk: EntityWorldMut) {
    // A collider not yet in the physics step has no bounds (an empty box).
    let Some(aabb) = chunk
        .get::<ColliderAabb>()
        .copied()
        .filter(|a| a.min.is_finite() && a.max.is_finite() && a.min.cmple(a.max).all())
    else {
        return;
    };
    let aabb = aabb.grow(0.01 * (aabb.max - aabb.min).max_element() * Vec3::ONE);
    let world = chunk.into_world_mut();
    let mut colliders = world.query::<(&ColliderAabb, &ColliderOf)>();
    let mut sleeping = world.query_filtered::<(), With<Sleeping>>();
    let bodies: Vec<Entity> = colliders
        .iter(world)
        .filter(|(a, of)| a.intersects(&aabb) && sleeping.get(world, of.body).is_ok())
        .map(|(_, of)| of.body)
        .collect();
    for body in bodies {
        world.entity_mut(body).remove::<Sleeping>();
    }
}

/// Chunk entities with a collider, and its layers.
type ChunkColliders<'w, 's> =
    Query<'w, 's, (Entity, Ref<'static, CollisionLayers>), (With<KdChunk>, With<Collider>)>;

/// New collider layers in the settings reach every chunk collider at once (a
/// component swap; nothing is rebuilt), and so they do a collider from a task
/// started before the change.
fn relayer_colliders(
    mut commands: Commands,
    settings: Res<ColliderSettings>,
    clock: Res<MainThreadClock>,
    chunks: ChunkColliders,
) {
    let _time = clock.measure();
    let all = settings.is_changed();
    for (entity, layers) in &chunks {
        if (all || layers.is_changed()) && *layers != settings.layers {
            commands.entity(entity).insert(settings.layers);
        }
    }
}

/// Where colliders are wanted from: the LOD camera and every anchor.
type Anchors<'w, 's> =
    Query<'w, 's, &'static GlobalTransform, Or<(With<LodCamera>, With<ColliderAnchor>)>>;

/// Marks the chunks that want a collider; a chunk whose want changed is
/// re-extracted (with or without one). Runs before the LOD, which keeps those
/// chunks at or below the collider threshold.
fn want_colliders(
    settings: Res<ColliderSettings>,
    clock: Res<MainThreadClock>,
    anchors: Anchors,
    mut volumes: Query<(&GlobalTransform, &mut VolumeState)>,
) {
    let _time = clock.measure();
    for (vol_tf, mut state) in &mut volumes {
        let state = &mut *state;
        // Set when the settings change or the volume is new, not every frame.
        if settings.is_changed() || !state.has_extra(ExtraKind::Collider) {
            state.set_extra(
                ExtraKind::Collider,
                Some(ChunkExtra {
                    builder: Arc::new(ColliderExtra {
                        layers: settings.layers,
                    }),
                    on: settings.enabled.then_some(settings.threshold),
                }),
            );
        }
        let to_local = to_volume(vol_tf);
        let points: Vec<Vec3> = anchors.iter().map(|a| to_local(a.translation())).collect();
        state.want_near(
            ExtraKind::Collider,
            settings.enabled,
            settings.distance,
            &points,
        );
    }
}
