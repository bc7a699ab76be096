//! What the plugin's headless tests share: stepping an app until a volume
//! settles, reading back the mesh a chunk entity shows, and comparing every
//! shown mesh with a from-scratch build.
#![allow(dead_code)] // not every test uses every helper

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy_kdcontour::headless::{run_until_settled, HeadlessPlugins};
use bevy_kdcontour::prelude::*;
use kdcontour::{Field, IndexedMesh, World};
use std::collections::BTreeMap;

/// The edits applied since the last call (drained).
pub fn applied_edits(app: &mut App) -> Vec<EditApplied> {
    app.world_mut()
        .resource_mut::<Messages<EditApplied>>()
        .drain()
        .collect()
}

/// A headless app with the plugin group and these LOD settings.
pub fn app_with(lod: LodSettings) -> App {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        KdContourPlugins {
            settings: KdContourSettings {
                lod,
                ..Default::default()
            },
        },
    ));
    app
}

/// Steps `app` until `volume` has no meshing work left (fails the test after
/// 5,000 frames).
pub fn settle(app: &mut App, volume: Entity) {
    let pause = std::time::Duration::from_micros(200);
    assert!(
        run_until_settled(app, volume, 5000, pause),
        "the volume did not settle"
    );
}

/// The mesh a chunk entity shows, as positions and indices (`None`: no mesh).
pub fn shown(app: &App, chunk: Entity) -> Option<(Vec<[f32; 3]>, Vec<u32>)> {
    let handle = app.world().get::<Mesh3d>(chunk)?;
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle.id())?;
    let Some(VertexAttributeValues::Float32x3(p)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("no positions")
    };
    let idx = match mesh.indices() {
        Some(bevy::mesh::Indices::U32(i)) => i.clone(),
        other => panic!("{other:?}"),
    };
    Some((p.clone(), idx))
}

/// Every shown chunk's mesh equals the same chunk built from scratch from
/// `field`, on the volume's layout and thresholds.
pub fn assert_shown_match_fresh(app: &App, volume: Entity, field: &dyn Field) {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let world = state.world();
    let showing = state.shown_chunks();
    let mut fresh = World::new(
        world.origin,
        world.cell_size,
        world.chunk_res,
        world.layout().clone(),
        0.01,
        world.settings.clone(),
    )
    .unwrap();
    let keys: Vec<ChunkKey> = showing.iter().map(|(k, _)| *k).collect();
    let stray: Vec<_> = keys
        .iter()
        .filter(|k| !world.layout().contains(k))
        .collect();
    assert!(
        stray.is_empty(),
        "shown but not in the layout {:?}..{:?}: {stray:?}",
        world.layout().lo(),
        world.layout().hi()
    );
    for k in &keys {
        fresh.set_threshold(k, world.threshold(k));
    }
    fresh.build(&keys, field).unwrap();
    let mut meshed = 0;
    for (k, e) in &showing {
        let mut want = IndexedMesh::default();
        if let Some(s) = fresh.snapshot(k) {
            s.extract(&mut want);
        }
        match shown(app, *e) {
            None => assert!(want.is_empty(), "chunk {k:?} shows nothing"),
            Some((p, i)) => {
                meshed += 1;
                let wp: Vec<[f32; 3]> = want.positions.iter().map(|v| v.to_array()).collect();
                assert!(p == wp && i == want.indices, "chunk {k:?} differs");
            }
        }
    }
    assert!(meshed > 10, "only {meshed} chunks show a mesh");
}

/// Every shown chunk's mesh, by chunk.
pub type Meshes = BTreeMap<(u32, [i32; 3]), Option<(Vec<[f32; 3]>, Vec<u32>)>>;

pub fn meshes(app: &App, volume: Entity) -> Meshes {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    state
        .shown_chunks()
        .into_iter()
        .map(|(k, e)| ((k.level, k.coord.to_array()), shown(app, e)))
        .collect()
}
