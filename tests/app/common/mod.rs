//! What the plugin's headless tests share: stepping an app until a volume
//! settles, and reading back the mesh a chunk entity shows.
#![allow(dead_code)] // not every test uses every helper

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy_kdcontour::headless::{run_until_settled, HeadlessPlugins};
use bevy_kdcontour::prelude::*;

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
