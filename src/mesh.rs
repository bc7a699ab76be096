//! Chunk meshes as Bevy shows them: a core mesh converted ([`to_bevy_mesh`]), a
//! chunk's finished extraction waiting for upload ([`ReadyMesh`]), and what a
//! subsystem adds to it ([`MeshExtra`]: colliders, navmesh tiles).

use bevy::asset::RenderAssetUsages;
use bevy::ecs::system::EntityCommands;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use kdcontour::IndexedMesh;
use std::sync::Arc;

/// What a subsystem adds to a chunk's mesh (a collider, a navmesh tile): built
/// from the welded mesh in the chunk's extraction task, put on the chunk entity
/// in the frame its mesh is shown, so the two never disagree.
pub(crate) trait MeshExtra: Send + Sync + 'static {
    /// What it is, as a failure names it ("collider", "navmesh tile").
    fn name(&self) -> &'static str;

    /// Builds it from `mesh`, or, with `None`, what takes an old one away (the
    /// chunk should have none now).
    fn build(&self, mesh: Option<&IndexedMesh>) -> ExtraPayload;
}

/// Each of `extras` built from `mesh` where the chunk carries it (`true`),
/// taken away where it does not: the payloads in order, and a message for
/// each that panicked. A panicking extra is taken away instead (the chunk
/// then has none, rather than one of a surface it no longer shows), so the
/// chunk's mesh and its other extras still land.
pub(crate) fn build_extras(
    extras: Vec<(Arc<dyn MeshExtra>, bool)>,
    mesh: &IndexedMesh,
) -> (Vec<ExtraPayload>, Vec<String>) {
    let mut failures = Vec::new();
    let payloads = extras
        .into_iter()
        .map(|(b, wanted)| {
            let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                b.build(wanted.then_some(mesh))
            }));
            built.unwrap_or_else(|p| {
                failures.push(format!(
                    "building its {} panicked ({}); the chunk is shown without one",
                    b.name(),
                    crate::tasks::panic_message(&*p)
                ));
                b.build(None)
            })
        })
        .collect();
    (payloads, failures)
}

/// Which subsystem's extra (an index into a chunk's extras).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ExtraKind {
    /// A trimesh collider (feature `avian`).
    #[cfg_attr(not(feature = "avian"), allow(dead_code))]
    Collider = 0,
    /// A navmesh tile (feature `navmesh`).
    #[cfg_attr(not(feature = "navmesh"), allow(dead_code))]
    NavTile = 1,
}

/// How many kinds of extra there are.
pub(crate) const EXTRA_KINDS: usize = 2;

/// A built extra: puts itself on the chunk entity.
pub(crate) type ExtraPayload = Box<dyn FnOnce(&mut EntityCommands) + Send + Sync>;

/// A volume's mesh extra and the threshold its chunks are capped at.
#[derive(Clone)]
pub(crate) struct ChunkExtra {
    /// What builds it.
    pub builder: Arc<dyn MeshExtra>,
    /// `Some(threshold)` while it is on: the chunks that carry it are cut no
    /// coarser; `None` while it is off (every chunk's old one is taken away).
    pub on: Option<f32>,
}

/// A chunk mesh ready to show: made into a Bevy mesh on the task thread, so
/// showing it on the main thread is a move, however many show in one frame.
pub(crate) struct ReadyMesh {
    /// The threshold it was cut at.
    pub threshold: f32,
    /// Its triangles.
    pub triangles: usize,
    /// The Bevy mesh; `None` when the chunk has no surface.
    pub mesh: Option<Mesh>,
    /// What the subsystems add to it (a collider of the same triangles, a
    /// navmesh tile of its floor).
    pub extra: Vec<ExtraPayload>,
    /// Why an extra is missing: one message per extra whose build panicked
    /// (reported as the chunk's failure when the extraction lands).
    pub extra_failures: Vec<String>,
}

impl ReadyMesh {
    /// `mesh` (from the core) at `threshold`, as Bevy will show it.
    pub fn new(threshold: f32, mesh: &IndexedMesh) -> Self {
        ReadyMesh {
            threshold,
            triangles: mesh.triangle_count(),
            mesh: (!mesh.is_empty()).then(|| to_bevy_mesh(mesh)),
            extra: Vec::new(),
            extra_failures: Vec::new(),
        }
    }
}

/// A core mesh as a Bevy triangle-list mesh (positions, normals, u32 indices), as
/// the plugin uploads it. A mesh that carries materials also gets the terrain
/// material's layer weights ([`crate::material::layer_weights`]): layers 0-3 as
/// vertex colours, 4-5 as the UV set (`ATTRIBUTE_UV_0`: chunk meshes have no texture
/// coordinates, and Bevy 0.19 does not build a second UV set without a first).
pub fn to_bevy_mesh(m: &IndexedMesh) -> Mesh {
    let mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        m.positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_NORMAL,
        m.normals.iter().map(|n| n.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_indices(Indices::U32(m.indices.clone()));
    if m.materials.len() != m.positions.len() {
        return mesh;
    }
    let (lo, hi) = crate::material::layer_weights(&m.materials);
    mesh.with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, lo)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Builds its mark, or panics when asked for one of a mesh.
    struct Marks {
        name: &'static str,
        panics: bool,
    }

    /// What a [`Marks`] extra put on the chunk: its name, and whether it was
    /// one of a mesh (`false`: the removal of an old one).
    #[derive(Component, Debug, PartialEq)]
    struct Mark(&'static str, bool);

    impl MeshExtra for Marks {
        fn name(&self) -> &'static str {
            self.name
        }

        fn build(&self, mesh: Option<&IndexedMesh>) -> ExtraPayload {
            if mesh.is_some() && self.panics {
                panic!("no {} for this mesh", self.name);
            }
            let mark = Mark(self.name, mesh.is_some());
            Box::new(move |chunk: &mut EntityCommands| {
                chunk.insert(mark);
            })
        }
    }

    /// A panic inside one extra's build is caught: that extra is taken away
    /// (its removal payload), the message names it and carries the panic's,
    /// and the other extras, before and after it, are built as asked.
    #[test]
    fn an_extra_that_panics_is_taken_away_and_reported_and_the_others_build() {
        let triangle = IndexedMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            indices: vec![0, 1, 2],
            materials: Vec::new(),
        };
        let extra = |name, panics| -> Arc<dyn MeshExtra> { Arc::new(Marks { name, panics }) };
        let (payloads, failures) = build_extras(
            vec![
                (extra("collider", false), true),
                (extra("navmesh tile", true), true),
                (extra("other", true), false),
            ],
            &triangle,
        );
        assert_eq!(failures.len(), 1, "{failures:?}");
        assert!(
            failures[0].contains("navmesh tile")
                && failures[0].contains("no navmesh tile for this mesh")
                && failures[0].contains("shown without one"),
            "{failures:?}"
        );
        // Each payload puts what its extra built on an entity of its own.
        let mut world = bevy::ecs::world::World::new();
        let mut commands_queue = bevy::ecs::world::CommandQueue::default();
        let entities: Vec<Entity> = (0..3).map(|_| world.spawn_empty().id()).collect();
        {
            let mut commands = Commands::new(&mut commands_queue, &world);
            for (put, &e) in payloads.into_iter().zip(&entities) {
                put(&mut commands.entity(e));
            }
        }
        commands_queue.apply(&mut world);
        let marks: Vec<Option<&Mark>> = entities.iter().map(|&e| world.get::<Mark>(e)).collect();
        assert_eq!(
            marks,
            [
                Some(&Mark("collider", true)),
                Some(&Mark("navmesh tile", false)),
                Some(&Mark("other", false)),
            ]
        );
    }
}
