//! A bounding-sphere hierarchy over a union's children, so a union of many
//! bounded children (a scene of thousands of primitives) evaluates the few near a
//! point instead of testing every child's bound.
//!
//! The result is a union's, bit for bit: the least value, and of children with
//! that value the first in the union's order (its gradient and material). A
//! child is skipped only when its bound proves it cannot win: above the best
//! value so far, or equal to it and later in the union. NaN stays NaN.

use super::bound::{enclose, Bound};
use super::compile::Node;
use glam::Vec3;

/// Unions with at least this many bounded children get a hierarchy (below it,
/// testing each child's bound is as quick).
pub(super) const MIN_CHILDREN: usize = 16;

/// Children per leaf.
const LEAF: usize = 4;

/// One node: a sphere around its children, and either two nodes or a run of
/// the hierarchy's child indices.
struct BvhNode {
    bound: Bound,
    /// Inner: the two nodes; leaf: `order[start..end]`.
    kids: Kids,
}

enum Kids {
    Inner(u32, u32),
    Leaf(u32, u32),
}

/// The hierarchy over a union's bounded children; its unbounded children are
/// tested one by one.
pub(super) struct Bvh {
    nodes: Vec<BvhNode>,
    /// Child indices, grouped by leaf.
    order: Vec<u32>,
    /// Children with no bound (evaluated at every point).
    unbounded: Vec<u32>,
}

impl Bvh {
    /// A hierarchy over `children`, or `None` with fewer than [`MIN_CHILDREN`]
    /// bounded ones.
    pub(super) fn over(children: &[Node]) -> Option<Bvh> {
        let mut bounded: Vec<u32> = Vec::new();
        let mut unbounded = Vec::new();
        for (i, c) in children.iter().enumerate() {
            match c.bound {
                Some(_) => bounded.push(i as u32),
                None => unbounded.push(i as u32),
            }
        }
        if bounded.len() < MIN_CHILDREN {
            return None;
        }
        let bound = |i: u32| children[i as usize].bound.expect("bounded");
        let mut bvh = Bvh {
            nodes: Vec::new(),
            order: Vec::with_capacity(bounded.len()),
            unbounded,
        };
        bvh.build(&mut bounded, &bound);
        Some(bvh)
    }

    /// Adds the node over `ids` (and its subtree); returns its index.
    fn build(&mut self, ids: &mut [u32], bound: &dyn Fn(u32) -> Bound) -> u32 {
        let spheres: Vec<Option<Bound>> = ids.iter().map(|&i| Some(bound(i))).collect();
        let b = enclose(&spheres).expect("every child here is bounded");
        // Rounding must never let the node's lower bound pass a child's.
        let b = b.grow(b.radius * 1e-5 + 1e-6);
        let at = self.nodes.len() as u32;
        self.nodes.push(BvhNode {
            bound: b,
            kids: Kids::Leaf(0, 0),
        });
        if ids.len() <= LEAF {
            let start = self.order.len() as u32;
            self.order.extend_from_slice(ids);
            self.nodes[at as usize].kids = Kids::Leaf(start, self.order.len() as u32);
            return at;
        }
        // Split at the median of the centers along their widest axis.
        let (lo, hi) = ids
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
                let c = bound(i).center;
                (lo.min(c), hi.max(c))
            });
        let axis = (hi - lo).max_position();
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |&a, &b| {
            bound(a).center[axis]
                .total_cmp(&bound(b).center[axis])
                .then(a.cmp(&b))
        });
        let (left, right) = ids.split_at_mut(mid);
        let l = self.build(left, bound);
        let r = self.build(right, bound);
        self.nodes[at as usize].kids = Kids::Inner(l, r);
        at
    }

    /// The union of `children` at `p` through the hierarchy: `eval` gives a
    /// child's result (value first); `T` is the value alone or with a gradient.
    pub(super) fn union<T: Copy>(
        &self,
        children: &[Node],
        p: Vec3,
        none: T,
        value_of: fn(&T) -> f32,
        eval: &dyn Fn(&Node) -> T,
    ) -> T {
        // The best so far: its result, value and child index (-1: `none`, which
        // a tie never replaces, as in the union's own loop).
        let mut best = (none, f32::INFINITY, -1i64);
        let consider = |i: u32, best: &mut (T, f32, i64)| -> bool {
            let r = eval(&children[i as usize]);
            let v = value_of(&r);
            if v.is_nan() {
                *best = (r, v, i as i64);
                return false;
            }
            if v < best.1 || (v == best.1 && (i as i64) < best.2) {
                *best = (r, v, i as i64);
            }
            true
        };
        for &i in &self.unbounded {
            if !consider(i, &mut best) {
                return best.0;
            }
        }
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.bound.lower(p) > best.1 {
                continue;
            }
            match node.kids {
                Kids::Inner(l, r) => {
                    // The nearer node is popped first.
                    let (dl, dr) = (
                        self.nodes[l as usize].bound.lower(p),
                        self.nodes[r as usize].bound.lower(p),
                    );
                    if dl <= dr {
                        stack.extend([r, l]);
                    } else {
                        stack.extend([l, r]);
                    }
                }
                Kids::Leaf(start, end) => {
                    for &i in &self.order[start as usize..end as usize] {
                        let lower = children[i as usize].bound.expect("bounded").lower(p);
                        if lower > best.1 || (lower == best.1 && i as i64 > best.2) {
                            continue;
                        }
                        if !consider(i, &mut best) {
                            return best.0;
                        }
                    }
                }
            }
        }
        best.0
    }
}

#[cfg(test)]
mod tests {
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use glam::Vec3;

    /// A union of `n` spheres and boxes scattered over [-1, 1]^3, some of them
    /// twice (exact ties), with a plane among them (unbounded).
    fn scene(n: usize, seed: u64) -> String {
        let mut s = seed;
        let mut unit = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
        };
        let mut children = Vec::new();
        for i in 0..n {
            let c = [unit(), unit(), unit()];
            let child = if i % 3 == 0 {
                format!(r#"{{"type":"box","half_extents":[0.05,0.08,0.03],"center":{c:?}}}"#)
            } else {
                format!(
                    r#"{{"type":"sphere","radius":{},"center":{c:?}}}"#,
                    0.02 + 0.05 * unit().abs()
                )
            };
            if i % 17 == 0 {
                children.push(child.clone());
            }
            children.push(child);
        }
        children.insert(
            n / 2,
            r#"{"type":"plane","normal":[0,1,0],"offset":0.9}"#.into(),
        );
        format!(r#"{{"type":"union","children":[{}]}}"#, children.join(","))
    }

    #[test]
    fn a_union_through_its_hierarchy_is_the_union_bit_for_bit() {
        for (n, seed) in [(40, 1u64), (300, 2), (2000, 3)] {
            let node = CsgNode::from_json(&scene(n, seed)).unwrap();
            let fast = node.compile().unwrap();
            assert!(fast.root.bvh.is_some(), "{n} children get a hierarchy");
            let mut slow = node.compile().unwrap();
            slow.root.bvh = None;
            let mut s = seed * 7 + 1;
            for i in 0..4000 {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let r = |k: u32| ((s >> k) & 0xffff) as f32 / 65535.0 * 2.6 - 1.3;
                let p = Vec3::new(r(0), r(16), r(32));
                let (a, b) = (fast.root.eval(p), slow.root.eval(p));
                assert_eq!(a.0.to_bits(), b.0.to_bits(), "{n}: value at {p}, point {i}");
                assert_eq!(
                    a.1.to_array().map(f32::to_bits),
                    b.1.to_array().map(f32::to_bits),
                    "{n}: gradient at {p}"
                );
                assert_eq!(fast.value(p).to_bits(), slow.value(p).to_bits(), "{n}: {p}");
            }
        }
        // Few children: no hierarchy.
        let few = CsgNode::from_json(&scene(10, 4))
            .unwrap()
            .compile()
            .unwrap();
        assert!(few.root.bvh.is_none());
    }
}
