//! Materials in the plugin, headless: a volume drawn with the
//! terrain material gets per-layer weights on every chunk vertex, equal to the
//! field's materials there (or, for a vertex split along a hard border, those of
//! the faces on its side) and summing to one, and the border is drawn along
//! edges, not as a sawtooth; a volume with a plain material gets none (they would
//! tint it).

use crate::common::{app_with, applied_edits, settle};
use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy_kdcontour::material::layer_weights;
use bevy_kdcontour::prelude::*;
use kdcontour::material::MaterialBlend;
use kdcontour::Field;
use std::sync::Arc;

/// Where the pit is: a hemisphere of radius 1.5 sunk into the ground.
const PIT: Vec3 = Vec3::new(12.0, 3.1, 12.0);

/// Ground at `y = 3.1`: grass (0) for `x < 7`, rock (1) for `x > 9`, blended
/// between, and a round pit at x = z = 12 lined with snow (3) and a little
/// sand (4): its rim is a crease and a hard border.
struct Ground;

impl Ground {
    /// Whether the pit's wall, not the ground, is the surface nearest `p`.
    fn in_pit(p: Vec3) -> bool {
        1.5 - p.distance(PIT) > p.y - 3.1
    }
}

impl Field for Ground {
    fn value(&self, p: Vec3) -> f32 {
        (p.y - 3.1).max(1.5 - p.distance(PIT))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if Ground::in_pit(p) {
            (PIT - p).normalize_or(Vec3::Y)
        } else {
            Vec3::Y
        }
    }
    fn lipschitz(&self) -> Option<f32> {
        Some(1.0)
    }
    fn has_materials(&self) -> bool {
        true
    }
    fn material(&self, p: Vec3) -> MaterialBlend {
        if Ground::in_pit(p) {
            return MaterialBlend::weighted(&[(3, 0.75), (4, 0.25)]);
        }
        let t = ((p.x - 7.0) / 2.0).clamp(0.0, 1.0);
        MaterialBlend::weighted(&[(0, 1.0 - t), (1, t)])
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

/// A shown chunk mesh: positions, indices and, if present, the two weight
/// attributes.
type Shown = (
    Vec<[f32; 3]>,
    Vec<u32>,
    Option<Vec<[f32; 4]>>,
    Option<Vec<[f32; 2]>>,
);

/// Every shown chunk mesh.
fn shown_meshes(app: &mut App) -> Vec<Shown> {
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
            let Some(bevy::mesh::Indices::U32(indices)) = mesh.indices() else {
                panic!("no u32 indices")
            };
            (p.clone(), indices.clone(), lo, hi)
        })
        .collect()
}

#[test]
fn terrain_material_chunks_carry_the_fields_materials_as_layer_weights() {
    let (mut app, _) = ground(|v| v.with_terrain_material(Handle::default()));
    let chunks = shown_meshes(&mut app);
    assert!(chunks.len() >= 4, "{} chunks shown", chunks.len());
    let mut seen = [false; 6];
    let (mut split, mut border_faces) = (0, 0);
    for (positions, indices, lo, hi) in chunks {
        let (lo, hi) = (
            lo.expect("layer weights 0-3"),
            hi.expect("layer weights 4-5"),
        );
        assert_eq!((lo.len(), hi.len()), (positions.len(), positions.len()));
        let layers = |m: MaterialBlend| {
            let (l, h) = layer_weights(&[m]);
            (l[0], h[0])
        };
        let centroid = |t: &[u32]| {
            t.iter()
                .map(|&v| Vec3::from_array(positions[v as usize]))
                .sum::<Vec3>()
                / 3.0
        };
        for (v, ((p, l), h)) in positions.iter().zip(&lo).zip(&hi).enumerate() {
            let w: Vec<f32> = l.iter().chain(h).copied().collect();
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "weights {w:?} at {p:?}");
            // The field's material at the vertex, as layers; or, for a copy
            // split along the pit's rim, the material of the faces on its
            // side (all alike here).
            if (*l, *h) != layers(Ground.material(Vec3::from_array(*p))) {
                split += 1;
                let sides: Vec<_> = indices
                    .chunks(3)
                    .filter(|t| t.contains(&(v as u32)))
                    .map(|t| layers(Ground.material(centroid(t))))
                    .collect();
                let close = |(a, b): ([f32; 4], [f32; 2])| {
                    a.iter()
                        .chain(&b)
                        .zip(l.iter().chain(h))
                        .all(|(x, y)| (x - y).abs() < 1e-5)
                };
                assert!(
                    sides.iter().all(|s| close(*s)),
                    "vertex at {p:?}: {:?}, its faces {sides:?}",
                    (l, h)
                );
            }
            for (k, x) in w.iter().enumerate() {
                seen[k] |= *x > 0.5;
            }
        }
        // No sawtooth round the pit's rim: a face of one pure material has no
        // vertex of another.
        let dominant = |v: u32| {
            let w: Vec<f32> = lo[v as usize]
                .iter()
                .chain(&hi[v as usize])
                .copied()
                .collect();
            (0..6).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap()
        };
        for t in indices.chunks(3) {
            let c = centroid(t);
            if c.xz().distance(PIT.xz()) > 2.5 {
                continue;
            }
            let m = Ground.material(c);
            if m.weights[0] < kdcontour::material::PURE {
                continue;
            }
            let (l, h) = layers(m);
            let want = (0..6)
                .max_by(|&a, &b| {
                    let x = |k: usize| if k < 4 { l[k] } else { h[k - 4] };
                    x(a).total_cmp(&x(b))
                })
                .unwrap();
            let corners: Vec<usize> = t.iter().map(|&v| dominant(v)).collect();
            border_faces += usize::from(corners.iter().any(|&c| c != want));
        }
    }
    assert_eq!(border_faces, 0, "faces drawn across the pit's rim");
    assert!(split > 0, "no vertex was split along the pit's rim");
    assert!(
        seen[0] && seen[1] && seen[3],
        "grass, rock and snow all show: {seen:?}"
    );
}

#[test]
fn a_plain_material_volume_carries_no_layer_weights() {
    let (mut app, _) = ground(|v| v);
    let chunks = shown_meshes(&mut app);
    assert!(chunks.len() >= 4);
    for (_, _, lo, hi) in chunks {
        assert!(lo.is_none() && hi.is_none(), "a plain material got weights");
    }
}

#[test]
fn a_paint_stroke_rebuilds_only_the_chunks_it_reaches_and_shows_its_material() {
    let (mut app, volume) = ground(|v| v.with_terrain_material(Handle::default()));
    let trees = |app: &App| -> Vec<(IVec3, usize)> {
        let w = app.world().get::<VolumeState>(volume).unwrap().world();
        w.chunks()
            .into_iter()
            .filter_map(|c| Some((c.coord, w.tree(&c)? as *const _ as usize)))
            .collect()
    };
    let before = trees(&app);
    // Inside chunk (1, 0, 1) (4 to 8 along x and z), three cells from its sides;
    // its top is 0.4 below chunk (1, 1, 1), whose one-cell halo it reaches.
    let center = Vec3::new(6.0, 3.1, 6.0);
    let reached = [IVec3::new(1, 0, 1), IVec3::new(1, 1, 1)];
    app.world_mut().write_message(ApplyEdit::new(
        volume,
        Brush::sphere(center, 0.5, BrushOp::Paint).with_material(3),
    ));
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
    // A vertex on the stroke's edge is split: a snow copy for the painted
    // faces and a grass one for the rest. Every place within 0.4 of the
    // stroke's center has a snow vertex, every place beyond 0.6 (on the grass
    // side of the ground) a grass one.
    let mut at: Vec<([f32; 3], [f32; 4])> = Vec::new();
    for (positions, _, lo, hi) in shown_meshes(&mut app) {
        let (lo, hi) = (lo.expect("layer weights"), hi.expect("layer weights"));
        for ((p, l), h) in positions.iter().zip(&lo).zip(&hi) {
            let sum: f32 = l.iter().chain(h).sum();
            assert!((sum - 1.0).abs() < 1e-5, "weights {l:?} {h:?} at {p:?}");
            at.push((*p, *l));
        }
    }
    let has = |p: [f32; 3], layer: usize| at.iter().any(|(q, l)| *q == p && l[layer] > 0.99);
    let (mut painted, mut grass) = (0, 0);
    for &(p, l) in &at {
        let d = Vec3::from_array(p).distance(center);
        if d < 0.4 {
            assert!(has(p, 3), "unpainted {l:?} at {p:?}, {d} from the stroke");
            painted += usize::from(l[3] > 0.99);
        } else if d > 0.6 && p[0] < 6.5 && Vec2::new(p[0], p[2]).distance(Vec2::splat(12.0)) > 2.0 {
            assert!(has(p, 0), "grass lost at {p:?}: {l:?}");
            grass += usize::from(l[0] > 0.99);
        }
    }
    assert!(
        painted >= 3 && grass >= 20,
        "{painted} painted, {grass} grass vertices"
    );
}
