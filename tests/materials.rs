//! Materials in the plugin (issue 16), headless: a volume drawn with the
//! terrain material gets per-layer weights on every chunk vertex, equal to the
//! field's materials there and summing to one; a volume with a plain material
//! gets none (they would tint it).

mod common;

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy_kdcontour::material::layer_weights;
use bevy_kdcontour::prelude::*;
use common::{app_with, applied_edits, settle};
use kdcontour::material::MaterialBlend;
use kdcontour::Field;
use std::sync::Arc;

/// Ground at `y = 3.1`: grass (0) for `x < 7`, rock (1) for `x > 9`, blended
/// between, and snow (3) with a little sand (4) on a patch around x = z = 12.
struct Ground;

impl Field for Ground {
    fn value(&self, p: Vec3) -> f32 {
        p.y - 3.1
    }
    fn gradient(&self, _p: Vec3) -> Vec3 {
        Vec3::Y
    }
    fn lipschitz(&self) -> Option<f32> {
        Some(1.0)
    }
    fn has_materials(&self) -> bool {
        true
    }
    fn material(&self, p: Vec3) -> MaterialBlend {
        if p.xz().distance(Vec2::splat(12.0)) < 2.0 {
            return MaterialBlend {
                ids: [3, 4, 3, 3],
                weights: [0.75, 0.25, 0.0, 0.0],
            };
        }
        let t = ((p.x - 7.0) / 2.0).clamp(0.0, 1.0);
        MaterialBlend {
            ids: [0, 1, 0, 0],
            weights: [1.0 - t, t, 0.0, 0.0],
        }
    }
}

/// A settled app with the ground in 4 x 2 x 4 chunks of 8 cells of 0.5.
fn ground(material: impl FnOnce(KdVolume) -> KdVolume) -> (App, Entity) {
    let mut app = app_with(LodSettings::default());
    let field: Arc<dyn Field> = Arc::new(Ground);
    let volume = app
        .world_mut()
        .spawn(material(KdVolume::new(field, UVec3::new(4, 2, 4), 8, 0.5)))
        .id();
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(8.0, 30.0, 8.0)));
    settle(&mut app, volume);
    (app, volume)
}

/// Every shown chunk mesh: positions and, if present, the two weight attributes.
#[allow(clippy::type_complexity)]
fn shown_meshes(
    app: &mut App,
) -> Vec<(Vec<[f32; 3]>, Option<Vec<[f32; 4]>>, Option<Vec<[f32; 2]>>)> {
    let mut q = app.world_mut().query::<(&KdChunk, &Mesh3d)>();
    let meshes = app.world().resource::<Assets<Mesh>>();
    q.iter(app.world())
        .map(|(_, m)| {
            let mesh = meshes.get(m.id()).expect("mesh asset");
            let Some(VertexAttributeValues::Float32x3(p)) =
                mesh.attribute(Mesh::ATTRIBUTE_POSITION)
            else {
                panic!("no positions")
            };
            let lo = match mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
                Some(VertexAttributeValues::Float32x4(v)) => Some(v.clone()),
                None => None,
                other => panic!("colour attribute {other:?}"),
            };
            let hi = match mesh.attribute(Mesh::ATTRIBUTE_UV_0) {
                Some(VertexAttributeValues::Float32x2(v)) => Some(v.clone()),
                None => None,
                other => panic!("uv_0 attribute {other:?}"),
            };
            (p.clone(), lo, hi)
        })
        .collect()
}

#[test]
fn terrain_material_chunks_carry_the_fields_materials_as_layer_weights() {
    let (mut app, _) = ground(|v| v.with_terrain_material(Handle::default()));
    let chunks = shown_meshes(&mut app);
    assert!(chunks.len() >= 4, "{} chunks shown", chunks.len());
    let mut seen = [false; 6];
    for (positions, lo, hi) in chunks {
        let (lo, hi) = (
            lo.expect("layer weights 0-3"),
            hi.expect("layer weights 4-5"),
        );
        assert_eq!((lo.len(), hi.len()), (positions.len(), positions.len()));
        for ((p, l), h) in positions.iter().zip(&lo).zip(&hi) {
            let w: Vec<f32> = l.iter().chain(h).copied().collect();
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "weights {w:?} at {p:?}");
            // The field's material at the vertex, as layers.
            let (el, eh) = layer_weights(&[Ground.material(Vec3::from_array(*p))]);
            assert_eq!((*l, *h), (el[0], eh[0]), "at {p:?}");
            for (k, x) in w.iter().enumerate() {
                seen[k] |= *x > 0.5;
            }
        }
    }
    assert!(seen[0] && seen[1], "grass and rock both show: {seen:?}");
}

#[test]
fn a_plain_material_volume_carries_no_layer_weights() {
    let (mut app, _) = ground(|v| v);
    let chunks = shown_meshes(&mut app);
    assert!(chunks.len() >= 4);
    for (_, lo, hi) in chunks {
        assert!(lo.is_none() && hi.is_none(), "a plain material got weights");
    }
}

#[test]
fn a_paint_stroke_rebuilds_only_the_chunks_it_reaches_and_shows_its_material() {
    let (mut app, volume) = ground(|v| v.with_terrain_material(Handle::default()));
    let trees = |app: &App| -> Vec<(IVec3, usize)> {
        let w = app.world().get::<VolumeState>(volume).unwrap().world();
        let flat = w.flat().unwrap();
        flat.coords()
            .into_iter()
            .filter_map(|c| Some((c, flat.tree(c)? as *const _ as usize)))
            .collect()
    };
    let before = trees(&app);
    // Inside chunk (1, 0, 1) (4 to 8 along x and z), three cells from its sides;
    // its top is 0.4 below chunk (1, 1, 1), whose one-cell halo it reaches.
    let centre = Vec3::new(6.0, 3.1, 6.0);
    let reached = [IVec3::new(1, 0, 1), IVec3::new(1, 1, 1)];
    app.world_mut().write_message(ApplyEdit {
        volume,
        brush: Brush::sphere(centre, 0.5, BrushOp::Paint).with_material(3),
    });
    app.update();
    let applied = applied_edits(&mut app);
    assert_eq!(applied.len(), 1);
    let rebuilt: Vec<IVec3> = applied[0].rebuilt.iter().map(|k| k.coord).collect();
    assert_eq!(rebuilt, reached);
    settle(&mut app, volume);
    let after = trees(&app);
    assert_eq!(after.len(), before.len());
    for ((c, old), (c2, new)) in before.iter().zip(&after) {
        assert_eq!(c, c2);
        assert_eq!(
            old != new,
            reached.contains(c),
            "chunk {c} rebuilt: {}",
            old != new
        );
    }
    // The painted spot shows snow on layer 3; the rest of the ground keeps its
    // grass (layer 0) and sums to one.
    let (mut painted, mut grass) = (0, 0);
    for (positions, lo, hi) in shown_meshes(&mut app) {
        let (lo, hi) = (lo.expect("layer weights"), hi.expect("layer weights"));
        for ((p, l), h) in positions.iter().zip(&lo).zip(&hi) {
            let sum: f32 = l.iter().chain(h).sum();
            assert!((sum - 1.0).abs() < 1e-5, "weights {l:?} {h:?} at {p:?}");
            let d = Vec3::from_array(*p).distance(centre);
            if d < 0.4 {
                assert!(l[3] > 0.99, "unpainted {l:?} at {p:?}, {d} from the stroke");
                painted += 1;
            } else if d > 0.6
                && p[0] < 6.5
                && Vec2::new(p[0], p[2]).distance(Vec2::splat(12.0)) > 2.0
            {
                assert!(l[0] > 0.99, "grass lost at {p:?}: {l:?}");
                grass += 1;
            }
        }
    }
    assert!(
        painted >= 3 && grass >= 20,
        "{painted} painted, {grass} grass vertices"
    );
}
