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
    let h = smin_weight(a.0, b.0, k);
    if h == 1.0 {
        return a;
    }
    if h == 0.0 {
        return b;
    }
    (blend(a.0, b.0, h, k), b.1.lerp(a.1, h))
}

/// [`smin`]'s value alone, bit for bit (the same operations on the values).
pub(super) fn smin_value(a: f32, b: f32, k: f32) -> f32 {
    let h = smin_weight(a, b, k);
    if h == 1.0 {
        a
    } else if h == 0.0 {
        b
    } else {
        blend(a, b, h, k)
    }
}

/// The weight of `a` in the smooth minimum of `a` and `b` over radius `k`.
#[inline]
fn smin_weight(a: f32, b: f32, k: f32) -> f32 {
    (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0)
}

/// The smooth minimum's value where it blends (`h` strictly between 0 and 1).
#[inline]
fn blend(a: f32, b: f32, h: f32, k: f32) -> f32 {
    b + (a - b) * h - k * h * (1.0 - h)
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
    /// bound proves they cannot change the result, and booleans read a noise
    /// terrain only until the other side decides ([`Node::eval_unless_below`]).
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
                    if c.surely_above(p, best.0) {
                        continue;
                    }
                    let v = c.eval(p);
                    if above(-v.0, -best.0) {
                        best = v;
                    }
                }
                best
            }
            Op::Intersection(ch) => intersection_eval(ch, p),
            Op::Difference(a, b) => {
                let a = a.eval(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a.0 {
                        return a;
                    }
                }
                if b.surely_above(p, -a.0) {
                    return a;
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
                    if c.blends_nothing(p, r.0 + *k) {
                        continue;
                    }
                    r = smin(r, c.eval(p), *k);
                }
                r
            }
            Op::SmoothIntersection(k, ch) => smooth_intersection_eval(*k, ch, p),
            Op::SmoothDifference(k, a, b) => {
                let a = neg(a.eval(p));
                if b.blends_nothing(p, a.0 + *k) {
                    return neg(a);
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
                    if c.surely_above(p, best) {
                        continue;
                    }
                    best = nan_min(best, c.value(p));
                }
                best
            }
            Op::Intersection(ch) => intersection_value(ch, p),
            Op::Difference(a, b) => {
                let a = a.value(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a {
                        return a;
                    }
                }
                if b.surely_above(p, -a) {
                    return a;
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
            Op::SmoothUnion(k, ch) => smooth_union_value(*k, ch, p),
            Op::SmoothIntersection(k, ch) => smooth_intersection_value(*k, ch, p),
            Op::SmoothDifference(k, a, b) => {
                let a = -a.value(p);
                if b.blends_nothing(p, a + *k) {
                    return -a;
                }
                -smin_value(a, b.value(p), *k)
            }
        }
    }
}

impl Node {
    /// Bounds on the value at `p` that cost no noise evaluation, for the nodes
    /// whose value does (noise terrain, transformed or given a material);
    /// `None` for the rest, and where the value may be NaN.
    pub(super) fn range(&self, p: Vec3) -> Option<(f32, f32)> {
        match &self.op {
            Op::Heightfield(h) => h.range_at(p),
            Op::Density(d) => d.range_at(p),
            Op::Material(_, child) => child.range(p),
            Op::Transform {
                inv_rot,
                translate,
                scale,
                child,
                ..
            } => child
                .range(*inv_rot * (p - *translate) / *scale)
                .map(|(lo, hi)| (lo * scale, hi * scale)),
            _ => None,
        }
    }

    /// Whether the value at `p` is surely below `v` (so an intersection
    /// already at `v` need not read it).
    #[inline]
    pub(super) fn surely_below(&self, p: Vec3, v: f32) -> bool {
        // Noise has no bounding sphere: a node with one is read as before.
        self.bound.is_none() && self.range(p).is_some_and(|(_, hi)| hi < v)
    }

    /// [`Node::eval`], unless the value is surely below `v` (`None`): a height
    /// field stops reading its noise's octaves as soon as they prove it.
    pub(super) fn eval_unless_below(&self, p: Vec3, v: f32) -> Option<(f32, Vec3)> {
        match &self.op {
            Op::Heightfield(h) => h.value_gradient_unless_below(p, v),
            Op::Material(_, child) => child.eval_unless_below(p, v),
            _ => (!self.surely_below(p, v)).then(|| self.eval(p)),
        }
    }

    /// [`Node::value`], unless it is surely below `v` (as
    /// [`Node::eval_unless_below`]).
    pub(super) fn value_unless_below(&self, p: Vec3, v: f32) -> Option<f32> {
        match &self.op {
            Op::Heightfield(h) => h.value_unless_below(p, v),
            Op::Material(_, child) => child.value_unless_below(p, v),
            _ => (!self.surely_below(p, v)).then(|| self.value(p)),
        }
    }

    /// Whether a smooth union (or difference) at `v`, the running value plus
    /// the blend radius, need not read this node: its bounding sphere or its
    /// noise's bound puts it at `v` or above, where the blend is the running
    /// value exactly (see `smin`).
    #[inline]
    pub(super) fn blends_nothing(&self, p: Vec3, v: f32) -> bool {
        self.bound.is_some_and(|b| b.lower(p) >= v) || self.surely_above(p, v)
    }

    /// Whether the value at `p` is surely above `v` (so a union already at
    /// `v` need not read it).
    #[inline]
    pub(super) fn surely_above(&self, p: Vec3, v: f32) -> bool {
        self.bound.is_none() && self.range(p).is_some_and(|(lo, _)| lo > v)
    }
}

/// The value of the intersection of `ch` at `p`, each child read only where
/// it can raise the value so far ([`Node::value_unless_below`]). Out of
/// [`Node::value`]'s body: inlined there it made every other node's
/// evaluation 5% slower (a union of eight cylinders sampled at 33³ corners).
#[inline(never)]
fn intersection_value(ch: &[Node], p: Vec3) -> f32 {
    let mut best = f32::NEG_INFINITY;
    for c in ch {
        if let Some(v) = c.value_unless_below(p, best) {
            best = nan_max(best, v);
        }
    }
    best
}

/// [`intersection_value`] with the gradient, for [`Node::eval`].
#[inline(never)]
fn intersection_eval(ch: &[Node], p: Vec3) -> (f32, Vec3) {
    let (first, rest) = ch.split_first().expect("checked: a child at least");
    let mut best = first.eval(p);
    for c in rest {
        if let Some(v) = c.eval_unless_below(p, best.0) {
            if above(v.0, best.0) {
                best = v;
            }
        }
    }
    best
}

/// The smooth intersection of `ch` over radius `k` at `p`, value and
/// gradient: a child at least `k` below the running value leaves it as it is
/// (see `smin`), which a noise terrain's bound can prove without reading it.
/// Out of [`Node::eval`]'s body, as [`intersection_value`].
#[inline(never)]
fn smooth_intersection_eval(k: f32, ch: &[Node], p: Vec3) -> (f32, Vec3) {
    let (first, rest) = ch.split_first().expect("checked: a child at least");
    let mut r = neg(first.eval(p));
    for c in rest {
        if !c.surely_below(p, -r.0 - k) {
            r = smin(r, neg(c.eval(p)), k);
        }
    }
    neg(r)
}

/// The smooth union of `ch` over radius `k` at `p`, [`Node::eval`]'s value
/// without the gradients (the children's values, and the same skips, so the
/// same bits). Out of [`Node::value`]'s body, as [`intersection_value`].
#[inline(never)]
fn smooth_union_value(k: f32, ch: &[Node], p: Vec3) -> f32 {
    let (first, rest) = ch.split_first().expect("checked: a child at least");
    let mut r = first.value(p);
    for c in rest {
        if c.blends_nothing(p, r + k) {
            continue;
        }
        r = smin_value(r, c.value(p), k);
    }
    r
}

/// [`smooth_intersection_eval`]'s value alone, as [`smooth_union_value`].
#[inline(never)]
fn smooth_intersection_value(k: f32, ch: &[Node], p: Vec3) -> f32 {
    let (first, rest) = ch.split_first().expect("checked: a child at least");
    let mut r = -first.value(p);
    for c in rest {
        if !c.surely_below(p, -r - k) {
            r = smin_value(r, -c.value(p), k);
        }
    }
    -r
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

/// Trees whose height fields another child often decides (a box closing the
/// terrain, sharp and smooth, unions and differences, sharp and smooth, a
/// transformed and a flat height field, one read first), for the tests that
/// skipping a noise changes no bit.
#[cfg(test)]
pub(super) const TERRAIN_SCENES: [&str; 9] = [
    r#"{"type":"intersection","children":[{"type":"box","half_extents":[0.85,0.85,0.85]},
        {"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}]}"#,
    r#"{"type":"intersection","children":[
        {"type":"material","id":4,"child":{"type":"heightfield","seed":9,"base":0.1,"amplitude":0.5,"frequency":2.5,"octaves":8}},
        {"type":"sphere","radius":0.9}]}"#,
    r#"{"type":"difference","a":{"type":"box","half_extents":[0.8,0.8,0.8]},
        "b":{"type":"material","id":3,"child":{"type":"heightfield","seed":5,"base":-0.2,"amplitude":0.3,"frequency":2.0,"octaves":6}}}"#,
    r#"{"type":"union","children":[{"type":"sphere","radius":0.3,"center":[0,0.5,0]},
        {"type":"material","id":2,"child":{"type":"heightfield","seed":1,"base":0.0,"amplitude":0.25,"frequency":1.0,"octaves":4}}]}"#,
    r#"{"type":"intersection","children":[{"type":"box","half_extents":[0.7,0.9,0.7]},
        {"type":"transform","translate":[0.1,-0.2,0],"rotate_axis":[1,0,1],"rotate_degrees":20,"scale":2.0,
         "child":{"type":"material","id":7,"child":{"type":"heightfield","seed":2,"base":0.0,"amplitude":0.2,"frequency":1.0,"octaves":5}}}]}"#,
    r#"{"type":"intersection","children":[{"type":"sphere","radius":0.8},
        {"type":"heightfield","seed":4,"base":0.1,"amplitude":0.0,"frequency":1.0,"octaves":3}]}"#,
    r#"{"type":"smooth_intersection","radius":0.08,"children":[{"type":"box","half_extents":[0.8,0.8,0.8]},
        {"type":"material","id":6,"child":{"type":"heightfield","seed":3,"base":0.0,"amplitude":0.3,"frequency":1.5,"octaves":5}}]}"#,
    r#"{"type":"smooth_union","radius":0.1,"children":[{"type":"material","id":2,"child":{"type":"sphere","radius":0.3,"center":[0,0.55,0]}},
        {"type":"heightfield","seed":7,"base":0.0,"amplitude":0.25,"frequency":1.2,"octaves":4}]}"#,
    r#"{"type":"smooth_difference","radius":0.06,"a":{"type":"box","half_extents":[0.8,0.8,0.8]},
        "b":{"type":"material","id":3,"child":{"type":"heightfield","seed":5,"base":-0.2,"amplitude":0.3,"frequency":2.0,"octaves":6}}}"#,
];

#[cfg(test)]
mod tests {
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use glam::Vec3;

    /// A height field is read only until another child decides (an
    /// intersection's value above it, a union's below it, a difference's
    /// `a` above its complement), and the result is reading every child's,
    /// bit for bit: value, gradient and `Csg::value`.
    #[test]
    fn noise_children_stop_where_another_child_decides_and_change_no_bit() {
        use super::{above, nan_max, neg, Op};
        // Points where a smooth intersection, union or difference skips its
        // terrain by the bound alone.
        let (mut decided, mut smooth_skips) = (0, [0usize; 3]);
        for json in super::TERRAIN_SCENES {
            let f = CsgNode::from_json(json).unwrap().compile().unwrap();
            // Each child compiled alone: read whole.
            let alone = |n: &CsgNode| n.compile().unwrap();
            let node = CsgNode::from_json(json).unwrap();
            let parts: Vec<_> = match &node {
                CsgNode::Intersection { children }
                | CsgNode::Union { children }
                | CsgNode::SmoothIntersection { children, .. }
                | CsgNode::SmoothUnion { children, .. } => children.iter().map(alone).collect(),
                CsgNode::Difference { a, b } | CsgNode::SmoothDifference { a, b, .. } => {
                    vec![alone(a), alone(b)]
                }
                _ => unreachable!("the scenes are booleans"),
            };
            for i in 0..4000u32 {
                let h =
                    |k: u32| ((i.wrapping_mul(2654435761) ^ (k * 40503)) % 10007) as f32 / 10007.0;
                let p = Vec3::new(h(1), h(2), h(3)) * 2.4 - Vec3::splat(1.2);
                let each: Vec<(f32, Vec3)> = parts.iter().map(|c| c.root.eval(p)).collect();
                let want = match &f.root.op {
                    Op::Intersection(_) => each
                        .iter()
                        .copied()
                        .reduce(|a, b| if above(b.0, a.0) { b } else { a })
                        .unwrap(),
                    Op::Union(_) => each.iter().copied().fold((f32::INFINITY, Vec3::Y), |a, b| {
                        if above(-b.0, -a.0) {
                            b
                        } else {
                            a
                        }
                    }),
                    Op::Difference(..) => {
                        let b = neg(each[1]);
                        if above(b.0, each[0].0) {
                            b
                        } else {
                            each[0]
                        }
                    }
                    Op::SmoothIntersection(k, _) => neg(each
                        .iter()
                        .map(|c| neg(*c))
                        .reduce(|a, b| super::smin(a, b, *k))
                        .unwrap()),
                    Op::SmoothUnion(k, _) => each
                        .iter()
                        .copied()
                        .reduce(|a, b| super::smin(a, b, *k))
                        .unwrap(),
                    Op::SmoothDifference(k, ..) => neg(super::smin(neg(each[0]), each[1], *k)),
                    _ => unreachable!(),
                };
                let got = f.root.eval(p);
                assert_eq!(got.0.to_bits(), want.0.to_bits(), "{json}: value at {p}");
                assert_eq!(
                    got.1.to_array().map(f32::to_bits),
                    want.1.to_array().map(f32::to_bits),
                    "{json}: gradient at {p}"
                );
                let value = match &f.root.op {
                    Op::SmoothIntersection(..) | Op::SmoothUnion(..) | Op::SmoothDifference(..) => {
                        want.0
                    }
                    Op::Intersection(_) => {
                        each.iter().fold(f32::NEG_INFINITY, |a, b| nan_max(a, b.0))
                    }
                    Op::Union(_) => each
                        .iter()
                        .fold(f32::INFINITY, |a, b| super::nan_min(a, b.0)),
                    _ => nan_max(each[0].0, -each[1].0),
                };
                assert_eq!(f.value(p).to_bits(), value.to_bits(), "{json}: {p}");
                assert_eq!(
                    f.value_and_gradient(p).map(|(v, _)| v.to_bits()),
                    Some(want.0.to_bits()),
                    "{json}: {p}"
                );
                // A child that loses by more than a cell of a 64-cell grid
                // (the height field, at many points) need not be read whole.
                decided +=
                    usize::from(each.iter().any(|c| (c.0.abs() - want.0.abs()).abs() > 0.03));
                // A smooth boolean's terrain, skipped by its bound alone
                // where the other side is more than the radius past it.
                let (kind, skipped) = match &f.root.op {
                    Op::SmoothIntersection(k, ch) => (0, ch[1].surely_below(p, each[0].0 - k)),
                    Op::SmoothUnion(k, ch) => (1, ch[1].surely_above(p, each[0].0 + k)),
                    Op::SmoothDifference(k, _, b) => (2, b.surely_above(p, -each[0].0 + k)),
                    _ => (0, false),
                };
                smooth_skips[kind] += usize::from(skipped);
            }
        }
        assert!(
            decided > 10_000,
            "points where another child decides: {decided}"
        );
        assert!(
            smooth_skips.iter().all(|&n| n > 300),
            "smooth skips: {smooth_skips:?}"
        );
    }

    /// `n` spheres (JSON) of radius `radius(i)` along a Lissajous curve:
    /// sphere `i` at `(sin t, cos(fy t), sin(fz t)) * scale`, `t = i * step`.
    fn scattered_spheres(
        n: usize,
        step: f32,
        [fy, fz]: [f32; 2],
        scale: f32,
        radius: impl Fn(usize) -> f32,
    ) -> Vec<String> {
        (0..n)
            .map(|i| {
                let t = i as f32 * step;
                let c = Vec3::new(t.sin(), (fy * t).cos(), (fz * t).sin()) * scale;
                format!(
                    r#"{{"type":"sphere","radius":{},"center":[{},{},{}]}}"#,
                    radius(i),
                    c.x,
                    c.y,
                    c.z
                )
            })
            .collect()
    }

    /// Skipping far children of a smooth union (and a smooth difference's far
    /// `b`) changes no bit of the value or gradient: the pruned tree equals the
    /// plain left fold of every child.
    #[test]
    fn smooth_unions_skip_far_children_exactly() {
        let children = scattered_spheres(60, 0.9, [1.3, 0.7], 0.8, |i| 0.05 + 0.002 * i as f32);
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

    /// A smooth boolean's value is computed without gradients, and is
    /// `eval`'s value bit for bit: nested smooth unions, intersections and
    /// differences of primitives, transformed, under materials, over noise
    /// terrain, and a smooth union of 300 spheres (far ones skipped), at
    /// points in and around every tree, blends and skips both met.
    #[test]
    fn smooth_values_are_the_values_of_eval() {
        let spheres = scattered_spheres(300, 0.77, [1.7, 0.3], 0.9, |_| 0.06);
        let hf = r#"{"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}"#;
        let density = r#"{"type":"density","seed":11,"base":0.1,"amplitude":0.3,"frequency":1.8,"octaves":4,
             "caves":{"frequency":2.0,"radius":0.12}}"#;
        let trees = [
            format!(
                r#"{{"type":"smooth_union","radius":0.05,"children":[{}]}}"#,
                spheres.join(",")
            ),
            r#"{"type":"smooth_difference","radius":0.2,
                "a":{"type":"smooth_union","radius":0.15,"children":[
                    {"type":"sphere","radius":0.5},
                    {"type":"material","id":3,"child":{"type":"box","half_extents":[0.2,0.6,0.2],"center":[0.3,0,0]}}]},
                "b":{"type":"transform","rotate_axis":[1,1,0],"rotate_degrees":30,"scale":0.5,
                     "child":{"type":"smooth_intersection","radius":0.1,"children":[
                        {"type":"cylinder","radius":0.4,"half_height":0.9},
                        {"type":"torus","major_radius":0.5,"minor_radius":0.2}]}}}"#
                .to_string(),
            format!(
                r#"{{"type":"smooth_intersection","radius":0.08,"children":[
                    {{"type":"box","half_extents":[0.8,0.8,0.8]}},{hf},
                    {{"type":"sphere","radius":0.95}}]}}"#
            ),
            format!(
                r#"{{"type":"smooth_union","radius":0.1,"children":[{density},
                    {{"type":"capsule","radius":0.2,"half_height":0.4,"center":[0,0.5,0]}}]}}"#
            ),
        ];
        for json in &trees {
            let f = CsgNode::from_json(json).unwrap().compile().unwrap();
            let (mut blended, mut far) = (0, 0);
            for i in 0..6000 {
                let t = i as f32 * 0.618;
                let p = (Vec3::new(t, t * 0.414, t * 0.732).fract() - 0.5) * 2.4;
                let want = f.root.eval(p).0;
                assert_eq!(f.root.value(p).to_bits(), want.to_bits(), "{json}: {p}");
                assert_eq!(f.value(p).to_bits(), want.to_bits(), "{json}: {p}");
                if want.abs() < 0.05 {
                    blended += 1;
                } else {
                    far += 1;
                }
            }
            assert!(blended > 20 && far > 1000, "{json}: {blended} {far}");
        }
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
