//! Evaluation: the value and analytic gradient of a compiled node, and [`Csg`] as
//! a [`Field`].

use super::compile::{Csg, Node, Op};
use crate::field::Field;
use glam::Vec3;

/// Polynomial smooth minimum of `(a, ga)` and `(b, gb)` over radius `k` (iq). The
/// returned gradient is exact: the blend terms' derivatives cancel.
///
/// Where one operand is `k` or more below the other, the blend is that operand,
/// exactly (the formula's rounding would move it): so a child whose bound puts
/// it `k` above the running value can be skipped without changing a bit.
fn smin(a: (f32, Vec3), b: (f32, Vec3), k: f32) -> (f32, Vec3) {
    let h = (0.5 + 0.5 * (b.0 - a.0) / k).clamp(0.0, 1.0);
    if h == 1.0 {
        return a;
    }
    if h == 0.0 {
        return b;
    }
    let d = b.0 + (a.0 - b.0) * h - k * h * (1.0 - h);
    (d, b.1.lerp(a.1, h))
}

/// The smaller of `a` and `b`, NaN if either is: a child out of its noise's
/// reach must not vanish from a union (`f32::min` drops a NaN).
pub(super) fn nan_min(a: f32, b: f32) -> f32 {
    if a.is_nan() || b.is_nan() {
        f32::NAN
    } else {
        a.min(b)
    }
}

/// The larger of `a` and `b`, NaN if either is (see [`nan_min`]).
pub(super) fn nan_max(a: f32, b: f32) -> f32 {
    if a.is_nan() || b.is_nan() {
        f32::NAN
    } else {
        a.max(b)
    }
}

/// Whether `b` replaces `a` as the larger (or, with `b` NaN, the unknown) value.
fn above(b: f32, a: f32) -> bool {
    b > a || b.is_nan()
}

/// The value and gradient of the complement.
fn neg(a: (f32, Vec3)) -> (f32, Vec3) {
    (-a.0, -a.1)
}

impl Node {
    /// The value and gradient at `p`. Unions and differences skip children whose
    /// bound proves they cannot change the result.
    pub(super) fn eval(&self, p: Vec3) -> (f32, Vec3) {
        match &self.op {
            Op::Prim(prim, c) => prim.value_gradient(p - *c),
            Op::Union(ch) if self.bvh.is_some() => {
                let bvh = self.bvh.as_ref().expect("matched");
                bvh.union(ch, p, (f32::INFINITY, Vec3::Y), |r| r.0, &|c| c.eval(p))
            }
            Op::Union(ch) => {
                let mut best = (f32::INFINITY, Vec3::Y);
                for c in ch {
                    if let Some(b) = c.bound {
                        if b.lower(p) >= best.0 {
                            continue;
                        }
                    }
                    let v = c.eval(p);
                    if above(-v.0, -best.0) {
                        best = v;
                    }
                }
                best
            }
            Op::Intersection(ch) => ch
                .iter()
                .map(|c| c.eval(p))
                .reduce(|a, b| if above(b.0, a.0) { b } else { a })
                .unwrap(),
            Op::Difference(a, b) => {
                let a = a.eval(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a.0 {
                        return a;
                    }
                }
                let b = neg(b.eval(p));
                if above(b.0, a.0) {
                    b
                } else {
                    a
                }
            }
            Op::SmoothUnion(k, ch) => {
                // A child at least `k` above the running value leaves it as it
                // is (see `smin`), as a union's far child does.
                let (first, rest) = ch.split_first().expect("checked: a child at least");
                let mut r = first.eval(p);
                for c in rest {
                    if let Some(b) = c.bound {
                        if b.lower(p) >= r.0 + *k {
                            continue;
                        }
                    }
                    r = smin(r, c.eval(p), *k);
                }
                r
            }
            Op::SmoothIntersection(k, ch) => neg(ch
                .iter()
                .map(|c| neg(c.eval(p)))
                .reduce(|a, b| smin(a, b, *k))
                .unwrap()),
            Op::SmoothDifference(k, a, b) => {
                let a = neg(a.eval(p));
                if let Some(bb) = b.bound {
                    if bb.lower(p) >= a.0 + *k {
                        return neg(a);
                    }
                }
                neg(smin(a, b.eval(p), *k))
            }
            Op::Transform {
                inv_rot,
                rot,
                translate,
                scale,
                child,
            } => {
                let q = *inv_rot * (p - *translate) / *scale;
                let (d, g) = child.eval(q);
                (d * scale, *rot * g)
            }
            Op::Material(_, child) => child.eval(p),
            Op::Heightfield(h) => h.value_gradient(p),
            Op::Density(d) => (d.value(p), d.gradient(p)),
        }
    }

    /// The value at `p`, without the gradient where that is cheaper; the same
    /// bound skipping as [`Node::eval`].
    pub(super) fn value(&self, p: Vec3) -> f32 {
        match &self.op {
            Op::Prim(prim, c) => prim.value(p - *c),
            Op::Union(ch) if self.bvh.is_some() => {
                let bvh = self.bvh.as_ref().expect("matched");
                bvh.union(ch, p, f32::INFINITY, |v| *v, &|c| c.value(p))
            }
            Op::Union(ch) => {
                let mut best = f32::INFINITY;
                for c in ch {
                    if let Some(b) = c.bound {
                        if b.lower(p) >= best {
                            continue;
                        }
                    }
                    best = nan_min(best, c.value(p));
                }
                best
            }
            Op::Intersection(ch) => ch
                .iter()
                .map(|c| c.value(p))
                .fold(f32::NEG_INFINITY, nan_max),
            Op::Difference(a, b) => {
                let a = a.value(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a {
                        return a;
                    }
                }
                nan_max(a, -b.value(p))
            }
            Op::Transform {
                inv_rot,
                translate,
                scale,
                child,
                ..
            } => child.value(*inv_rot * (p - *translate) / *scale) * scale,
            Op::Material(_, child) => child.value(p),
            Op::Heightfield(h) => h.value(p),
            Op::Density(d) => d.value(p),
            Op::SmoothUnion(..) | Op::SmoothIntersection(..) | Op::SmoothDifference(..) => {
                self.eval(p).0
            }
        }
    }
}

/// Whether `op`'s subtree is an exact distance bound (no noise terrain in it).
fn exact(op: &Op) -> bool {
    match op {
        Op::Prim(..) => true,
        Op::Union(ch)
        | Op::Intersection(ch)
        | Op::SmoothUnion(_, ch)
        | Op::SmoothIntersection(_, ch) => ch.iter().all(|c| exact(&c.op)),
        Op::Difference(a, b) | Op::SmoothDifference(_, a, b) => exact(&a.op) && exact(&b.op),
        Op::Transform { child, .. } | Op::Material(_, child) => exact(&child.op),
        Op::Heightfield(_) | Op::Density(_) => false,
    }
}

impl Node {
    /// Why this node (at `path`, named as the scene file's checks name it) or a
    /// node below it gives no finite value at `p`: a noise node out of its reach.
    fn explain(&self, p: Vec3, path: &str) -> Option<String> {
        let all = |ch: &[Node]| {
            ch.iter()
                .enumerate()
                .find_map(|(i, c)| c.explain(p, &format!("{path}.children[{i}]")))
        };
        let pair = |a: &Node, b: &Node| {
            a.explain(p, &format!("{path}.a"))
                .or_else(|| b.explain(p, &format!("{path}.b")))
        };
        let (kind, fault) = match &self.op {
            Op::Prim(..) => return None,
            Op::Union(ch)
            | Op::Intersection(ch)
            | Op::SmoothUnion(_, ch)
            | Op::SmoothIntersection(_, ch) => return all(ch),
            Op::Difference(a, b) | Op::SmoothDifference(_, a, b) => return pair(a, b),
            Op::Transform {
                inv_rot,
                translate,
                scale,
                child,
                ..
            } => {
                let q = *inv_rot * (p - *translate) / *scale;
                return child.explain(q, &format!("{path}.child"));
            }
            Op::Material(_, child) => return child.explain(p, &format!("{path}.child")),
            Op::Heightfield(h) => ("heightfield", h.reach_fault(p)),
            Op::Density(d) => ("density", d.reach_fault(p)),
        };
        fault.map(|f| format!("scene node `{path}` ({kind}): {f}"))
    }
}

impl Field for Csg {
    fn value(&self, p: Vec3) -> f32 {
        self.root.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.root.eval(p).1
    }
    /// The tree's value with its analytic gradient (the value bit for bit
    /// [`Field::value`]'s: the same primitives, the same choices of child, the
    /// same bound skipping), where it costs about a value: not with 3-D noise
    /// terrain in the tree.
    fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
        self.cheap_gradient.then(|| self.root.eval(p))
    }
    fn sample_grid(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
    ) {
        self.root.sample(grid, z_range, out)
    }
    /// Column by column where a height field is batched, with the children
    /// evaluated corner by corner skipped where the batched ones already put
    /// the corner more than `far` from zero.
    fn sample_grid_far(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: f32,
    ) {
        self.root.sample_far(grid, z_range, out, far)
    }
    /// The first noise node (depth first) out of its reach at `p`, by its node
    /// path: `scene node `root.child` (heightfield): noise evaluated too far ...`.
    fn explain_non_finite(&self, p: Vec3) -> Option<String> {
        self.root.explain(p, "root")
    }
    fn material(&self, p: Vec3) -> crate::material::MaterialBlend {
        self.root.material(p, None).1
    }
    fn has_materials(&self) -> bool {
        self.root.has_materials()
    }
    fn lipschitz(&self) -> Option<f32> {
        // Primitives are exact distances; min, max, the polynomial smooth min (whose
        // gradient is a convex blend of unit gradients) and uniform scaling keep the
        // bound at 1. Noise terrain has no bound.
        exact(&self.root.op).then_some(1.0)
    }
}

#[cfg(test)]
mod tests {
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use glam::Vec3;

    /// Skipping far children of a smooth union (and a smooth difference's far
    /// `b`) changes no bit of the value or gradient: the pruned tree equals the
    /// plain left fold of every child.
    #[test]
    fn smooth_unions_skip_far_children_exactly() {
        let children: Vec<String> = (0..60)
            .map(|i| {
                let t = i as f32 * 0.9;
                let c = Vec3::new(t.sin(), (1.3 * t).cos(), (0.7 * t).sin()) * 0.8;
                format!(
                    r#"{{"type":"sphere","radius":{},"center":[{},{},{}]}}"#,
                    0.05 + 0.002 * i as f32,
                    c.x,
                    c.y,
                    c.z
                )
            })
            .collect();
        let k = 0.04;
        let union = CsgNode::from_json(&format!(
            r#"{{"type":"smooth_union","radius":{k},"children":[{}]}}"#,
            children.join(",")
        ))
        .unwrap()
        .compile()
        .unwrap();
        let parts: Vec<_> = children
            .iter()
            .map(|c| CsgNode::from_json(c).unwrap().compile().unwrap())
            .collect();
        let diff = CsgNode::from_json(&format!(
            r#"{{"type":"smooth_difference","radius":{k},"a":{{"type":"box","half_extents":[0.7,0.7,0.7]}},"b":{}}}"#,
            children[3]
        ))
        .unwrap()
        .compile()
        .unwrap();
        let (a, b) = (
            CsgNode::from_json(r#"{"type":"box","half_extents":[0.7,0.7,0.7]}"#)
                .unwrap()
                .compile()
                .unwrap(),
            &parts[3],
        );
        let mut skipped_any = false;
        for i in 0..3000 {
            let t = i as f32 * 0.618;
            let p = (Vec3::new(t, t * 0.414, t * 0.732).fract() - 0.5) * 2.0;
            let naive = parts
                .iter()
                .map(|c| c.root.eval(p))
                .reduce(|x, y| super::smin(x, y, k))
                .unwrap();
            let got = union.root.eval(p);
            assert_eq!(got.0.to_bits(), naive.0.to_bits(), "{p}");
            assert_eq!(got.1, naive.1, "{p}");
            assert_eq!(union.value(p).to_bits(), naive.0.to_bits(), "{p}");
            let plain = super::neg(super::smin(super::neg(a.root.eval(p)), b.root.eval(p), k));
            let got = diff.root.eval(p);
            assert_eq!(got.0.to_bits(), plain.0.to_bits(), "{p}");
            assert_eq!(got.1, plain.1, "{p}");
            skipped_any |= parts.iter().any(|c| c.value(p) > naive.0 + 2.0 * k);
        }
        assert!(skipped_any);
    }

    #[test]
    fn smooth_gradients_match_differences() {
        let node = CsgNode::from_json(
            r#"{"type":"smooth_difference","radius":0.2,
                "a":{"type":"smooth_union","radius":0.15,"children":[
                    {"type":"sphere","radius":0.5},
                    {"type":"box","half_extents":[0.2,0.6,0.2],"center":[0.3,0,0]}]},
                "b":{"type":"transform","rotate_axis":[1,1,0],"rotate_degrees":30,"scale":0.5,
                     "child":{"type":"cylinder","radius":0.3,"half_height":2}}}"#,
        )
        .unwrap();
        let f = node.compile().unwrap();
        for i in 0..200 {
            let t = i as f32 * 0.37;
            let p = Vec3::new(t.sin(), (t * 1.3).cos(), (t * 0.7).sin()) * 0.7;
            let g = f.gradient(p);
            let fd = crate::field::central_difference(|q| f.value(q), p, 1e-3);
            if fd.length() > 0.3 {
                assert!(
                    (g - fd).length() < 0.05 * fd.length().max(1.0),
                    "{p}: {g} vs {fd}"
                );
            }
        }
    }
}
