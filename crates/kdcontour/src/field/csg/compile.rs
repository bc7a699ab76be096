//! Compilation: a checked [`CsgNode`] tree becomes a [`Csg`], a tree of [`Op`]s,
//! each [`Node`] carrying its bounding sphere.

use super::bound::{enclose, Bound};
use super::bvh::Bvh;
use super::CsgNode;
use crate::error::Error;
use crate::field::sdf::Primitive;
use crate::field::terrain::{Density, Heightfield};
use crate::geometry::unit_vector;
use glam::{Quat, Vec3};

/// What a compiled node computes.
pub(super) enum Op {
    /// A primitive placed at a center.
    Prim(Primitive, Vec3),
    /// Minimum of the children.
    Union(Vec<Node>),
    /// Maximum of the children.
    Intersection(Vec<Node>),
    /// The first minus the second.
    Difference(Box<Node>, Box<Node>),
    /// Smooth minimum of the children over a radius.
    SmoothUnion(f32, Vec<Node>),
    /// Smooth maximum of the children over a radius.
    SmoothIntersection(f32, Vec<Node>),
    /// Smooth difference over a radius.
    SmoothDifference(f32, Box<Node>, Box<Node>),
    /// The child scaled, rotated and translated.
    Transform {
        /// World to child rotation.
        inv_rot: Quat,
        /// Child to world rotation.
        rot: Quat,
        /// Translation.
        translate: Vec3,
        /// Uniform scale.
        scale: f32,
        /// The transformed node.
        child: Box<Node>,
    },
    /// The child, with a material for every surface in it.
    Material(u8, Box<Node>),
    /// An fBm height-field terrain.
    Heightfield(Box<Heightfield>),
    /// A 3-D density terrain.
    Density(Box<Density>),
}

/// A compiled node with its bound (None: unbounded, e.g. terrain or a plane).
pub(super) struct Node {
    /// What the node computes.
    pub op: Op,
    /// A sphere outside which the node's value is at least the distance to it.
    pub bound: Option<Bound>,
    /// A union of many bounded children: the hierarchy over them.
    pub bvh: Option<Box<Bvh>>,
}

/// A compiled CSG tree; a [`Field`](crate::field::Field) with analytic gradients
/// where its parts have them. Unions and differences skip children whose bounding
/// sphere proves they cannot change the result, and a noise terrain in a union,
/// intersection or difference, smooth or not, is read only until the other
/// side decides (its amplitude, then each octave of a height field's
/// noise, bounds its value): the result is reading every child's, bit for bit.
pub struct Csg {
    pub(super) root: Node,
    /// Whether [`Node::eval`] costs about what [`Node::value`] does: no 3-D
    /// noise terrain in the tree (its gradient is a second evaluation of its
    /// noises with their derivatives, and the value skips noises the
    /// gradient does not).
    pub(super) cheap_gradient: bool,
}

impl Csg {
    /// A sphere `(center, radius)` outside which the field is at least the distance
    /// to the sphere (so nothing there is inside), or `None` for unbounded trees
    /// (planes, terrain).
    pub fn bounding_sphere(&self) -> Option<(Vec3, f32)> {
        self.root.bound.map(|b| (b.center, b.radius))
    }
}

impl CsgNode {
    /// Checks and compiles the tree into an evaluable field.
    pub fn compile(&self) -> Result<Csg, Error> {
        self.check("root")?;
        let root = compile(self);
        Ok(Csg {
            cheap_gradient: !has_density(&root.op),
            root,
        })
    }
}

/// Whether `op`'s subtree holds a 3-D noise terrain.
fn has_density(op: &Op) -> bool {
    match op {
        Op::Density(_) => true,
        Op::Prim(..) | Op::Heightfield(_) => false,
        Op::Union(ch)
        | Op::Intersection(ch)
        | Op::SmoothUnion(_, ch)
        | Op::SmoothIntersection(_, ch) => ch.iter().any(|c| has_density(&c.op)),
        Op::Difference(a, b) | Op::SmoothDifference(_, a, b) => {
            has_density(&a.op) || has_density(&b.op)
        }
        Op::Transform { child, .. } | Op::Material(_, child) => has_density(&child.op),
    }
}

/// Compiles a checked node and its subtree.
fn compile(n: &CsgNode) -> Node {
    let op = compile_op(n);
    let bound = bound_of(&op);
    let bvh = match &op {
        Op::Union(ch) => Bvh::over(ch).map(Box::new),
        _ => None,
    };
    Node { op, bound, bvh }
}

/// The op of a checked node, its children compiled.
fn compile_op(n: &CsgNode) -> Op {
    if let Some(primitive) = n.primitive() {
        return Op::Prim(primitive.shape, primitive.center);
    }
    let all = |children: &[CsgNode]| children.iter().map(compile).collect();
    let one = |child: &CsgNode| Box::new(compile(child));
    match n {
        CsgNode::Union { children } => Op::Union(all(children)),
        CsgNode::Intersection { children } => Op::Intersection(all(children)),
        CsgNode::Difference { a, b } => Op::Difference(one(a), one(b)),
        CsgNode::SmoothUnion { radius, children } => Op::SmoothUnion(*radius, all(children)),
        CsgNode::SmoothIntersection { radius, children } => {
            Op::SmoothIntersection(*radius, all(children))
        }
        CsgNode::SmoothDifference { radius, a, b } => Op::SmoothDifference(*radius, one(a), one(b)),
        CsgNode::Transform {
            translate,
            rotate_axis,
            rotate_degrees,
            scale,
            child,
        } => {
            let rot = if *rotate_degrees == 0.0 {
                Quat::IDENTITY
            } else {
                Quat::from_axis_angle(
                    unit_vector(*rotate_axis).expect("checked: a rotation's axis is not zero"),
                    rotate_degrees.to_radians(),
                )
            };
            Op::Transform {
                inv_rot: rot.inverse(),
                rot,
                translate: *translate,
                scale: *scale,
                child: one(child),
            }
        }
        CsgNode::Material { id, child } => Op::Material(*id, one(child)),
        CsgNode::Heightfield(p) => Op::Heightfield(Box::new(Heightfield::new(p.clone()))),
        CsgNode::Density(p) => Op::Density(Box::new(Density::new(p.clone()))),
        _ => unreachable!("every other node is a primitive, compiled above"),
    }
}

/// The bound of a node computing `op` (its children already bounded).
fn bound_of(op: &Op) -> Option<Bound> {
    match op {
        Op::Prim(prim, c) => {
            let r = prim.bounding_radius();
            r.is_finite().then_some(Bound {
                center: *c,
                radius: r,
            })
        }
        Op::Union(ch) => enclose(&ch.iter().map(|c| c.bound).collect::<Vec<_>>()),
        Op::SmoothUnion(k, ch) => {
            enclose(&ch.iter().map(|c| c.bound).collect::<Vec<_>>()).map(|b| b.grow(k * 0.25))
        }
        Op::Intersection(ch) => ch
            .iter()
            .filter_map(|c| c.bound)
            .min_by(|a, b| a.radius.total_cmp(&b.radius)),
        Op::SmoothIntersection(k, ch) => ch
            .iter()
            .filter_map(|c| c.bound)
            .min_by(|a, b| a.radius.total_cmp(&b.radius))
            .map(|b| b.grow(k * 0.25)),
        Op::Difference(a, _) => a.bound,
        Op::SmoothDifference(k, a, _) => a.bound.map(|b| b.grow(k * 0.25)),
        Op::Transform {
            rot,
            translate,
            scale,
            child,
            ..
        } => child.bound.map(|b| Bound {
            center: *rot * (b.center * *scale) + *translate,
            radius: b.radius * scale,
        }),
        Op::Material(_, child) => child.bound,
        Op::Heightfield(_) | Op::Density(_) => None,
    }
}
