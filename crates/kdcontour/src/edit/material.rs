//! The material of an edited field: each brush that wins at a point (adds,
//! digs, or paints over it) leaves its material there; smooth brushes blend it
//! in with the weight they blend the value with. A paint changes no value.

use super::{smin, smin_weight, BrushOp, EditedField};
use crate::field::Field;
use crate::material::MaterialBlend;
use glam::Vec3;

impl EditedField {
    /// The base's material at `p`, then each brush's in order (see the module
    /// docs); the values are followed exactly as [`Field::value`] computes them.
    pub(super) fn material_at(&self, p: Vec3) -> MaterialBlend {
        if self.edits.is_empty() {
            return self.base.material(p);
        }
        let mut v = self.base.value(p);
        let mut m = self.base.material(p);
        for e in self.edits.iter() {
            if !Self::affects(e, p, v) {
                continue;
            }
            let own = MaterialBlend::single(e.brush.material);
            let s = e.field.value(p);
            match e.brush.op {
                BrushOp::Add => {
                    if s < v {
                        m = own;
                    }
                    v = v.min(s);
                }
                BrushOp::Subtract => {
                    if -s > v {
                        m = own;
                    }
                    v = v.max(-s);
                }
                BrushOp::SmoothAdd { radius } => {
                    m = MaterialBlend::mix(m, own, 1.0 - smin_weight(v, s, radius));
                    v = smin(v, s, radius);
                }
                BrushOp::SmoothSubtract { radius } => {
                    m = MaterialBlend::mix(m, own, 1.0 - smin_weight(-v, s, radius));
                    v = -smin(-v, s, radius);
                }
                BrushOp::Paint => {
                    if s < 0.0 {
                        m = own;
                    }
                }
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use crate::edit::{Brush, BrushOp, EditedField};
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use crate::material::MaterialBlend;
    use glam::Vec3;
    use std::sync::Arc;

    #[test]
    fn brushes_leave_their_material_and_paint_moves_nothing() {
        let base: Arc<dyn Field> = Arc::new(
            CsgNode::from_json(r#"{"type":"box","half_extents":[2,1,2]}"#)
                .unwrap()
                .compile()
                .unwrap(),
        );
        let plain = EditedField::new(base.clone())
            .with_edit(Brush::sphere(Vec3::new(2.0, 0.0, 0.0), 0.5, BrushOp::Add))
            .unwrap();
        assert!(!plain.has_materials());
        let f = EditedField::new(base)
            .with_edit(Brush::sphere(Vec3::new(2.0, 0.0, 0.0), 0.5, BrushOp::Add).with_material(3))
            .unwrap()
            .with_edit(
                Brush::sphere(Vec3::new(0.0, 1.0, 0.0), 0.5, BrushOp::Subtract).with_material(4),
            )
            .unwrap();
        assert!(f.has_materials());
        assert_eq!(f.material(Vec3::new(2.5, 0.0, 0.0)).dominant(), 3);
        assert_eq!(f.material(Vec3::new(0.0, 0.5, 0.0)).dominant(), 4);
        assert_eq!(f.material(Vec3::new(-2.0, 0.0, 0.0)).dominant(), 0);
        // A paint over the top face: the same values, a new material inside it.
        let painted = f
            .with_edit(Brush {
                shape: CsgNode::Sphere {
                    radius: 1.0,
                    center: Vec3::new(-1.0, 1.0, 0.0),
                },
                op: BrushOp::Paint,
                material: 6,
            })
            .unwrap();
        for i in 0..200 {
            let t = i as f32 * 0.1;
            let p = Vec3::new(t.sin() * 2.5, t.cos() * 1.5, (t * 0.3).sin());
            assert_eq!(painted.value(p).to_bits(), f.value(p).to_bits(), "{p}");
        }
        assert_eq!(painted.material(Vec3::new(-1.0, 1.0, 0.0)).dominant(), 6);
        assert_eq!(painted.material(Vec3::new(-1.0, 2.1, 0.0)).dominant(), 0);
        // A smooth add blends, its weights summing to 1.
        let smooth = EditedField::new(Arc::new(
            CsgNode::from_json(r#"{"type":"sphere","radius":1}"#)
                .unwrap()
                .compile()
                .unwrap(),
        ))
        .with_edit(
            Brush::sphere(
                Vec3::new(1.5, 0.0, 0.0),
                0.6,
                BrushOp::SmoothAdd { radius: 0.5 },
            )
            .with_material(2),
        )
        .unwrap();
        let m: MaterialBlend = smooth.material(Vec3::new(1.0, 0.3, 0.0));
        assert!(m.weight_of(2) > 0.0 && m.weight_of(0) > 0.0, "{m:?}");
        assert!((m.weights.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn old_logs_load_as_material_zero() {
        let old = r#"{"shape":{"type":"sphere","radius":1.0},"op":{"op":"add"}}"#;
        let b: Brush = serde_json::from_str(old).unwrap();
        assert_eq!(b.material, 0);
        let paint = r#"{"shape":{"type":"sphere","radius":1.0},"op":{"op":"paint"},"material":9}"#;
        let b: Brush = serde_json::from_str(paint).unwrap();
        assert_eq!((b.op, b.material), (BrushOp::Paint, 9));
    }
}
