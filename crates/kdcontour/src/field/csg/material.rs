//! Materials of a compiled tree: which side wins each boolean decides the
//! material, and the smooth variants blend the two sides' materials with the
//! same factor that blends their distances.

use super::compile::{Node, Op};
use super::eval::{nan_max, nan_min};
use crate::field::Field;
use crate::material::MaterialBlend;
use glam::Vec3;

/// The polynomial smooth minimum's weight of `a` against `b` over radius `k`
/// (the factor [`super::eval`]'s `smin` blends values and gradients with).
fn smin_weight(a: f32, b: f32, k: f32) -> f32 {
    (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0)
}

/// The smooth minimum of `(value, material)` pairs over radius `k`: the value as
/// [`Node::value`] computes it, the materials mixed by the same weight.
fn smin_material(a: (f32, MaterialBlend), b: (f32, MaterialBlend), k: f32) -> (f32, MaterialBlend) {
    let h = smin_weight(a.0, b.0, k);
    let d = b.0 + (a.0 - b.0) * h - k * h * (1.0 - h);
    (d, MaterialBlend::mix(a.1, b.1, 1.0 - h))
}

/// The winner of a hard boolean: `b` where `pick(a, b)` is `b`'s value.
fn winner(
    a: (f32, MaterialBlend),
    b: (f32, MaterialBlend),
    pick: fn(f32, f32) -> f32,
) -> (f32, MaterialBlend) {
    let v = pick(a.0, b.0);
    if v.to_bits() == a.0.to_bits() || v.is_nan() {
        (v, a.1)
    } else {
        (v, b.1)
    }
}

fn neg(a: (f32, MaterialBlend)) -> (f32, MaterialBlend) {
    (-a.0, a.1)
}

impl Node {
    /// The value at `p` and the material there: `given` inside a `material`
    /// node, otherwise material 0 for primitives and the terrain's own.
    pub(super) fn material(&self, p: Vec3, given: Option<u8>) -> (f32, MaterialBlend) {
        let own = MaterialBlend::single(given.unwrap_or(0));
        fn all(
            ch: &[Node],
            p: Vec3,
            given: Option<u8>,
        ) -> impl Iterator<Item = (f32, MaterialBlend)> + '_ {
            ch.iter().map(move |c| c.material(p, given))
        }
        match &self.op {
            Op::Prim(..) => (self.value(p), own),
            Op::Union(ch) => all(ch, p, given)
                .reduce(|a, b| winner(a, b, nan_min))
                .expect("checked: at least one child"),
            Op::Intersection(ch) => all(ch, p, given)
                .reduce(|a, b| winner(a, b, nan_max))
                .expect("checked: at least one child"),
            Op::Difference(a, b) => {
                winner(a.material(p, given), neg(b.material(p, given)), nan_max)
            }
            Op::SmoothUnion(k, ch) => all(ch, p, given)
                .reduce(|a, b| smin_material(a, b, *k))
                .expect("checked: at least one child"),
            Op::SmoothIntersection(k, ch) => neg(all(ch, p, given)
                .map(neg)
                .reduce(|a, b| smin_material(a, b, *k))
                .expect("checked: at least one child")),
            Op::SmoothDifference(k, a, b) => neg(smin_material(
                neg(a.material(p, given)),
                b.material(p, given),
                *k,
            )),
            Op::Transform {
                inv_rot,
                translate,
                scale,
                child,
                ..
            } => {
                let (v, m) = child.material(*inv_rot * (p - *translate) / *scale, given);
                (v * scale, m)
            }
            Op::Material(id, child) => child.material(p, Some(*id)),
            Op::Heightfield(h) if given.is_none() => h.value_and_material(p),
            Op::Heightfield(h) => (h.value(p), own),
            Op::Density(d) => (d.value(p), given.map_or_else(|| d.material(p), |_| own)),
        }
    }

    /// Whether the subtree holds a `material` node or noise terrain.
    pub(super) fn has_materials(&self) -> bool {
        match &self.op {
            Op::Prim(..) => false,
            Op::Union(ch)
            | Op::Intersection(ch)
            | Op::SmoothUnion(_, ch)
            | Op::SmoothIntersection(_, ch) => ch.iter().any(Node::has_materials),
            Op::Difference(a, b) | Op::SmoothDifference(_, a, b) => {
                a.has_materials() || b.has_materials()
            }
            Op::Transform { child, .. } => child.has_materials(),
            Op::Material(..) | Op::Heightfield(_) | Op::Density(_) => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use glam::Vec3;

    #[test]
    fn booleans_take_the_winning_side_and_smooth_ones_blend() {
        let text = |op: &str, extra: &str| {
            format!(
                r#"{{"type":"{op}",{extra}
                "children":[{{"type":"material","id":2,"child":{{"type":"sphere","radius":0.5}}}},
                {{"type":"material","id":5,"child":{{"type":"sphere","radius":0.5,"center":[0.6,0,0]}}}}]}}"#
            )
        };
        let hard = CsgNode::from_json(&text("union", ""))
            .unwrap()
            .compile()
            .unwrap();
        assert!(hard.has_materials());
        assert_eq!(hard.material(Vec3::new(-0.4, 0.0, 0.0)).dominant(), 2);
        assert_eq!(hard.material(Vec3::new(1.0, 0.0, 0.0)).dominant(), 5);
        let smooth = CsgNode::from_json(&text("smooth_union", r#""radius":0.3,"#))
            .unwrap()
            .compile()
            .unwrap();
        // Half way between the spheres both weigh the same; every blend sums to 1.
        let mid = smooth.material(Vec3::new(0.3, 0.3, 0.0));
        assert!((mid.weight_of(2) - 0.5).abs() < 1e-5, "{mid:?}");
        for i in 0..100 {
            let p = Vec3::new(i as f32 * 0.02 - 0.5, 0.35, 0.0);
            let m = smooth.material(p);
            assert!((m.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{m:?}");
        }
        // A difference's cut takes the cutter's material.
        let cut = CsgNode::from_json(
            r#"{"type":"difference","a":{"type":"box","half_extents":[1,1,1]},
                "b":{"type":"material","id":7,"child":{"type":"sphere","radius":0.5,"center":[1,0,0]}}}"#,
        )
        .unwrap()
        .compile()
        .unwrap();
        assert_eq!(cut.material(Vec3::new(0.5, 0.0, 0.0)).dominant(), 7);
        assert_eq!(cut.material(Vec3::new(-1.0, 0.0, 0.0)).dominant(), 0);
        // Without material nodes nothing has materials.
        let plain = CsgNode::from_json(r#"{"type":"sphere","radius":1}"#)
            .unwrap()
            .compile()
            .unwrap();
        assert!(!plain.has_materials());
    }

    #[test]
    fn material_ids_are_checked_by_path() {
        let err = CsgNode::from_json(
            r#"{"type":"union","children":[{"type":"material","id":300,"child":{"type":"sphere","radius":1}}]}"#,
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            err,
            "scene node `root.children[0].id`: invalid value: integer `300`, expected an \
             integer from 0 to 255"
        );
        let err = CsgNode::from_json(
            r#"{"type":"material","id":1,"child":{"type":"sphere","radius":-1}}"#,
        )
        .unwrap_err()
        .to_string();
        assert!(err.starts_with("scene node `root.child.radius`"), "{err}");
    }
}
