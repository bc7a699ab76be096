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
    // One operand `k` or more below the other is the blend, exactly (as
    // [`super::eval`]'s `smin` has it, so a far child can be skipped).
    if h == 1.0 {
        return a;
    }
    if h == 0.0 {
        return b;
    }
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
        match &self.op {
            Op::Prim(..) => (self.value(p), own),
            // Unions and differences skip the children whose bound proves they
            // cannot change the result, as `Node::value` does: a scene of
            // thousands of shapes reads the few near `p`.
            Op::Union(ch) if self.bvh.is_some() => {
                let bvh = self.bvh.as_ref().expect("matched");
                bvh.union(ch, p, (f32::INFINITY, own), |r| r.0, &|c| {
                    c.material(p, given)
                })
            }
            Op::Union(ch) => {
                let mut best: Option<(f32, MaterialBlend)> = None;
                for c in ch {
                    if let (Some(b), Some(r)) = (c.bound, best) {
                        if b.lower(p) >= r.0 {
                            continue;
                        }
                    }
                    if best.is_some_and(|r| c.surely_above(p, r.0)) {
                        continue;
                    }
                    let m = c.material(p, given);
                    best = Some(match best {
                        Some(r) => winner(r, m, nan_min),
                        None => m,
                    });
                }
                best.expect("checked: at least one child")
            }
            Op::Intersection(ch) => {
                let (first, rest) = ch.split_first().expect("checked: a child at least");
                let mut best = first.material(p, given);
                for c in rest {
                    if let Some(m) = c.material_unless_below(p, given, best.0) {
                        best = winner(best, m, nan_max);
                    }
                }
                best
            }
            Op::Difference(a, b) => {
                let a = a.material(p, given);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a.0 {
                        return a;
                    }
                }
                if b.surely_above(p, -a.0) {
                    return a;
                }
                winner(a, neg(b.material(p, given)), nan_max)
            }
            Op::SmoothUnion(k, ch) => {
                let (first, rest) = ch.split_first().expect("checked: a child at least");
                let mut r = first.material(p, given);
                for c in rest {
                    if c.blends_nothing(p, r.0 + *k) {
                        continue;
                    }
                    r = smin_material(r, c.material(p, given), *k);
                }
                r
            }
            Op::SmoothIntersection(k, ch) => {
                let (first, rest) = ch.split_first().expect("checked: a child at least");
                let mut r = neg(first.material(p, given));
                for c in rest {
                    if !c.surely_below(p, -r.0 - *k) {
                        r = smin_material(r, neg(c.material(p, given)), *k);
                    }
                }
                neg(r)
            }
            Op::SmoothDifference(k, a, b) => {
                let a = neg(a.material(p, given));
                if b.blends_nothing(p, a.0 + *k) {
                    return neg(a);
                }
                neg(smin_material(a, b.material(p, given), *k))
            }
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

    /// [`Node::material`], unless the value is surely below `v` (`None`; see
    /// [`Node::eval_unless_below`]).
    fn material_unless_below(
        &self,
        p: Vec3,
        given: Option<u8>,
        v: f32,
    ) -> Option<(f32, MaterialBlend)> {
        match &self.op {
            Op::Heightfield(h) if given.is_none() => h.value_and_material_unless_below(p, v),
            Op::Heightfield(h) => Some((
                h.value_unless_below(p, v)?,
                MaterialBlend::single(given.unwrap_or(0)),
            )),
            Op::Material(id, child) => child.material_unless_below(p, Some(*id), v),
            _ => (!self.surely_below(p, v)).then(|| self.material(p, given)),
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
    use super::{neg, smin_material, winner, Node, Op};
    use crate::field::csg::eval::{nan_max, nan_min};
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use crate::material::MaterialBlend;
    use glam::Vec3;

    /// [`Node::material`] with every child of every union and difference
    /// evaluated (no bound skipping).
    fn every_child(n: &Node, p: Vec3, given: Option<u8>) -> (f32, MaterialBlend) {
        let all = |ch: &[Node]| -> Vec<(f32, MaterialBlend)> {
            ch.iter().map(|c| every_child(c, p, given)).collect()
        };
        match &n.op {
            Op::Union(ch) => all(ch)
                .into_iter()
                .reduce(|a, b| winner(a, b, nan_min))
                .unwrap(),
            Op::SmoothUnion(k, ch) => all(ch)
                .into_iter()
                .reduce(|a, b| smin_material(a, b, *k))
                .unwrap(),
            Op::Difference(a, b) => winner(
                every_child(a, p, given),
                neg(every_child(b, p, given)),
                nan_max,
            ),
            Op::SmoothDifference(k, a, b) => neg(smin_material(
                neg(every_child(a, p, given)),
                every_child(b, p, given),
                *k,
            )),
            Op::Intersection(ch) => all(ch)
                .into_iter()
                .reduce(|a, b| winner(a, b, nan_max))
                .unwrap(),
            Op::SmoothIntersection(k, ch) => neg(all(ch)
                .into_iter()
                .map(neg)
                .reduce(|a, b| smin_material(a, b, *k))
                .unwrap()),
            Op::Material(id, c) => every_child(c, p, Some(*id)),
            _ => n.material(p, given),
        }
    }

    /// Materials skip the children a bound proves cannot change the result
    /// (a scene of thousands of shapes reads the few near a point), and give
    /// what evaluating every child gives, bit for bit: unions large enough
    /// for a hierarchy of bounds and small ones, smooth unions, differences
    /// and smooth differences, at points on, near and far from the shapes.
    #[test]
    fn materials_skip_far_children_and_give_what_every_child_gives() {
        let spheres = |n: usize, r: f32| -> String {
            (0..n)
                .map(|i| {
                    let t = i as f32 * 0.37;
                    format!(
                        r#"{{"type":"material","id":{},"child":{{"type":"sphere","radius":{r},"center":[{},{},{}]}}}}"#,
                        i % 7,
                        t.sin() * 0.8,
                        (1.3 * t).cos() * 0.8,
                        (0.7 * t).sin() * 0.8
                    )
                })
                .collect::<Vec<_>>()
                .join(",")
        };
        let scenes = [
            format!(r#"{{"type":"union","children":[{}]}}"#, spheres(400, 0.06)),
            format!(r#"{{"type":"union","children":[{}]}}"#, spheres(5, 0.3)),
            format!(
                r#"{{"type":"smooth_union","radius":0.05,"children":[{}]}}"#,
                spheres(120, 0.08)
            ),
            format!(
                r#"{{"type":"difference","a":{{"type":"union","children":[{}]}},
                    "b":{{"type":"material","id":9,"child":{{"type":"box","half_extents":[0.3,0.3,0.3]}}}}}}"#,
                spheres(200, 0.07)
            ),
            format!(
                r#"{{"type":"smooth_difference","radius":0.06,
                    "a":{{"type":"smooth_union","radius":0.04,"children":[{}]}},
                    "b":{{"type":"material","id":8,"child":{{"type":"sphere","radius":0.4}}}}}}"#,
                spheres(80, 0.09)
            ),
        ];
        let terrains = crate::field::csg::eval::TERRAIN_SCENES.map(String::from);
        for json in scenes.iter().chain(&terrains) {
            let f = CsgNode::from_json(json).unwrap().compile().unwrap();
            for i in 0..3000u32 {
                let h =
                    |k: u32| ((i.wrapping_mul(2654435761) ^ (k * 40503)) % 10007) as f32 / 10007.0;
                let p = Vec3::new(h(1), h(2), h(3)) * 2.2 - Vec3::splat(1.1);
                let (v, m) = f.root.material(p, None);
                let (v0, m0) = every_child(&f.root, p, None);
                assert_eq!(v.to_bits(), v0.to_bits(), "{json} value at {p}");
                assert_eq!(m.ids, m0.ids, "at {p}");
                assert_eq!(
                    m.weights.map(f32::to_bits),
                    m0.weights.map(f32::to_bits),
                    "at {p}"
                );
                assert_eq!(m, f.material(p), "at {p}");
            }
        }
    }

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
