//! A CSG tree of primitives, booleans and transforms, and its JSON scene format.
//!
//! [`CsgNode`] is the serialisable description (what a scene file holds); it is
//! checked and compiled into a [`Csg`] field that evaluates fast. A scene file is one
//! node, tagged by `"type"`:
//!
//! ```json
//! { "type": "smooth_union", "radius": 0.1, "children": [
//!     { "type": "box", "half_extents": [0.5, 0.3, 0.3] },
//!     { "type": "sphere", "radius": 0.35, "center": [0.5, 0.0, 0.0] },
//!     { "type": "transform", "translate": [0, 0.4, 0], "rotate_axis": [1, 0, 0],
//!       "rotate_degrees": 90, "scale": 1.0,
//!       "child": { "type": "torus", "major_radius": 0.3, "minor_radius": 0.08 } }
//! ] }
//! ```
//!
//! Node types: primitives `sphere`, `box`, `rounded_box`, `torus`, `cylinder`,
//! `capsule`, `cone`, `plane` (each with an optional `center`); booleans `union`,
//! `intersection` (over `children`), `difference` (`a` minus `b`); smooth variants
//! `smooth_union`, `smooth_intersection` (with `radius`) and `smooth_difference`;
//! `transform` (`translate`, `rotate_axis` + `rotate_degrees`, uniform `scale`); and
//! noise terrain `heightfield` and `density` (see [`super::terrain`]).

use super::sdf::Primitive;
use super::terrain::{self, Density, DensityParams, Heightfield, HeightfieldParams};
use super::Field;
use crate::error::{Error, SceneError};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

/// One node of a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum CsgNode {
    /// A ball.
    Sphere {
        /// Radius (> 0).
        radius: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// An axis-aligned box with sharp edges.
    Box {
        /// Half side lengths (each > 0).
        half_extents: Vec3,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// A box with rounded edges.
    RoundedBox {
        /// Half side lengths (each > radius).
        half_extents: Vec3,
        /// Rounding radius (> 0).
        radius: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// A torus around Y.
    Torus {
        /// Ring radius (> minor radius).
        major_radius: f32,
        /// Tube radius (> 0).
        minor_radius: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// A capped cylinder along Y.
    Cylinder {
        /// Radius (> 0).
        radius: f32,
        /// Half length (> 0).
        half_height: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// A capsule along Y.
    Capsule {
        /// Radius (> 0).
        radius: f32,
        /// Half length of the inner segment (>= 0).
        half_height: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// A capped cone along Y, apex up.
    Cone {
        /// Base radius (> 0).
        radius: f32,
        /// Half height (> 0).
        half_height: f32,
        /// Centre.
        #[serde(default)]
        center: Vec3,
    },
    /// The half-space below a plane.
    Plane {
        /// Outward normal (non-zero; normalised on load).
        normal: Vec3,
        /// Plane offset along the normal.
        #[serde(default)]
        offset: f32,
    },
    /// Union (min) of the children.
    Union {
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Intersection (max) of the children.
    Intersection {
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// `a` with `b` removed.
    Difference {
        /// The base shape.
        a: Box<CsgNode>,
        /// The shape cut away.
        b: Box<CsgNode>,
    },
    /// Union blended over `radius`.
    SmoothUnion {
        /// Blend radius (> 0).
        radius: f32,
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Intersection blended over `radius`.
    SmoothIntersection {
        /// Blend radius (> 0).
        radius: f32,
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Difference blended over `radius`.
    SmoothDifference {
        /// Blend radius (> 0).
        radius: f32,
        /// The base shape.
        a: Box<CsgNode>,
        /// The shape cut away.
        b: Box<CsgNode>,
    },
    /// Moves, rotates and uniformly scales its child (scale, then rotate, then
    /// translate).
    Transform {
        /// Translation.
        #[serde(default)]
        translate: Vec3,
        /// Rotation axis (non-zero when `rotate_degrees` is not 0).
        #[serde(default = "default_axis")]
        rotate_axis: Vec3,
        /// Rotation angle in degrees.
        #[serde(default)]
        rotate_degrees: f32,
        /// Uniform scale (> 0).
        #[serde(default = "one")]
        scale: f32,
        /// The transformed node.
        child: Box<CsgNode>,
    },
    /// An fBm height-field terrain.
    Heightfield(HeightfieldParams),
    /// A 3-D density terrain with overhangs and optional caves.
    Density(DensityParams),
}

fn default_axis() -> Vec3 {
    Vec3::Y
}
fn one() -> f32 {
    1.0
}

impl CsgNode {
    /// Parses a scene file's text. Syntax and schema errors carry line and column;
    /// impossible values (negative radius, empty union) name the node's path.
    pub fn from_json(text: &str) -> Result<CsgNode, SceneError> {
        let node: CsgNode = serde_json::from_str(text).map_err(|e| SceneError::Syntax {
            line: e.line(),
            column: e.column(),
            message: e
                .to_string()
                .split(" at line ")
                .next()
                .unwrap_or("")
                .to_string(),
        })?;
        node.check("root")?;
        Ok(node)
    }

    /// Pretty JSON of this node.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("CsgNode always serialises")
    }

    /// Checks every value in the tree; the error names the first bad node's path.
    pub fn check(&self, path: &str) -> Result<(), SceneError> {
        let bad = |field: &str, message: String| SceneError::Semantic {
            path: format!("{path}.{field}"),
            message,
        };
        let positive = |field: &str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(field, format!("must be a finite number > 0, got {v}")))
            }
        };
        let finite3 = |field: &str, v: Vec3| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(bad(field, format!("must be finite, got {v}")))
            }
        };
        let children_ok = |children: &[CsgNode]| {
            if children.is_empty() {
                return Err(bad("children", "needs at least one child".into()));
            }
            for (i, c) in children.iter().enumerate() {
                c.check(&format!("{path}.children[{i}]"))?;
            }
            Ok(())
        };
        match self {
            CsgNode::Sphere { radius, center } => {
                positive("radius", *radius)?;
                finite3("center", *center)
            }
            CsgNode::Box {
                half_extents,
                center,
            } => {
                for (a, v) in ["x", "y", "z"].iter().zip(half_extents.to_array()) {
                    positive(&format!("half_extents.{a}"), v)?;
                }
                finite3("center", *center)
            }
            CsgNode::RoundedBox {
                half_extents,
                radius,
                center,
            } => {
                positive("radius", *radius)?;
                for (a, v) in ["x", "y", "z"].iter().zip(half_extents.to_array()) {
                    if !(v.is_finite() && v > *radius) {
                        return Err(bad(
                            &format!("half_extents.{a}"),
                            format!("must be finite and larger than radius {radius}, got {v}"),
                        ));
                    }
                }
                finite3("center", *center)
            }
            CsgNode::Torus {
                major_radius,
                minor_radius,
                center,
            } => {
                positive("minor_radius", *minor_radius)?;
                positive("major_radius", *major_radius)?;
                if minor_radius >= major_radius {
                    return Err(bad(
                        "minor_radius",
                        format!(
                            "must be smaller than major_radius {major_radius}, got {minor_radius}"
                        ),
                    ));
                }
                finite3("center", *center)
            }
            CsgNode::Cylinder {
                radius,
                half_height,
                center,
            }
            | CsgNode::Cone {
                radius,
                half_height,
                center,
            } => {
                positive("radius", *radius)?;
                positive("half_height", *half_height)?;
                finite3("center", *center)
            }
            CsgNode::Capsule {
                radius,
                half_height,
                center,
            } => {
                positive("radius", *radius)?;
                if !(half_height.is_finite() && *half_height >= 0.0) {
                    return Err(bad(
                        "half_height",
                        format!("must be finite and >= 0, got {half_height}"),
                    ));
                }
                finite3("center", *center)
            }
            CsgNode::Plane { normal, offset } => {
                finite3("normal", *normal)?;
                if normal.length_squared() < 1e-12 {
                    return Err(bad("normal", "must not be zero".into()));
                }
                if !offset.is_finite() {
                    return Err(bad("offset", format!("must be finite, got {offset}")));
                }
                Ok(())
            }
            CsgNode::Union { children } | CsgNode::Intersection { children } => {
                children_ok(children)
            }
            CsgNode::SmoothUnion { radius, children }
            | CsgNode::SmoothIntersection { radius, children } => {
                positive("radius", *radius)?;
                children_ok(children)
            }
            CsgNode::Difference { a, b } => {
                a.check(&format!("{path}.a"))?;
                b.check(&format!("{path}.b"))
            }
            CsgNode::SmoothDifference { radius, a, b } => {
                positive("radius", *radius)?;
                a.check(&format!("{path}.a"))?;
                b.check(&format!("{path}.b"))
            }
            CsgNode::Transform {
                translate,
                rotate_axis,
                rotate_degrees,
                scale,
                child,
            } => {
                finite3("translate", *translate)?;
                finite3("rotate_axis", *rotate_axis)?;
                if !rotate_degrees.is_finite() {
                    return Err(bad("rotate_degrees", "must be finite".into()));
                }
                if *rotate_degrees != 0.0 && rotate_axis.length_squared() < 1e-12 {
                    return Err(bad("rotate_axis", "must not be zero".into()));
                }
                positive("scale", *scale)?;
                child.check(&format!("{path}.child"))
            }
            CsgNode::Heightfield(p) => terrain::check_noise(p.amplitude, p.frequency, p.octaves)
                .map_err(|m| SceneError::Semantic {
                    path: path.to_string(),
                    message: m,
                }),
            CsgNode::Density(p) => {
                terrain::check_noise(p.amplitude, p.frequency, p.octaves).map_err(|m| {
                    SceneError::Semantic {
                        path: path.to_string(),
                        message: m,
                    }
                })?;
                if let Some(c) = &p.caves {
                    positive("caves.frequency", c.frequency)?;
                    positive("caves.radius", c.radius)?;
                }
                Ok(())
            }
        }
    }

    /// Checks and compiles the tree into an evaluable field.
    pub fn compile(&self) -> Result<Csg, Error> {
        self.check("root")?;
        Ok(Csg {
            root: compile(self),
        })
    }
}

enum Op {
    Prim(Primitive, Vec3),
    Union(Vec<Node>),
    Intersection(Vec<Node>),
    Difference(Box<Node>, Box<Node>),
    SmoothUnion(f32, Vec<Node>),
    SmoothIntersection(f32, Vec<Node>),
    SmoothDifference(f32, Box<Node>, Box<Node>),
    Transform {
        inv_rot: Quat,
        rot: Quat,
        translate: Vec3,
        scale: f32,
        child: Box<Node>,
    },
    Heightfield(Box<Heightfield>),
    Density(Box<Density>),
}

fn compile(n: &CsgNode) -> Node {
    let op = compile_op(n);
    let bound = bound_of(&op);
    Node { op, bound }
}

fn compile_op(n: &CsgNode) -> Op {
    let prim = |p: Primitive, c: &Vec3| Op::Prim(p, *c);
    match n {
        CsgNode::Sphere { radius, center } => prim(Primitive::Sphere { radius: *radius }, center),
        CsgNode::Box {
            half_extents,
            center,
        } => prim(
            Primitive::Cuboid {
                half_extents: *half_extents,
            },
            center,
        ),
        CsgNode::RoundedBox {
            half_extents,
            radius,
            center,
        } => prim(
            Primitive::RoundedBox {
                half_extents: *half_extents,
                radius: *radius,
            },
            center,
        ),
        CsgNode::Torus {
            major_radius,
            minor_radius,
            center,
        } => prim(
            Primitive::Torus {
                major_radius: *major_radius,
                minor_radius: *minor_radius,
            },
            center,
        ),
        CsgNode::Cylinder {
            radius,
            half_height,
            center,
        } => prim(
            Primitive::Cylinder {
                radius: *radius,
                half_height: *half_height,
            },
            center,
        ),
        CsgNode::Capsule {
            radius,
            half_height,
            center,
        } => prim(
            Primitive::Capsule {
                radius: *radius,
                half_height: *half_height,
            },
            center,
        ),
        CsgNode::Cone {
            radius,
            half_height,
            center,
        } => prim(
            Primitive::Cone {
                radius: *radius,
                half_height: *half_height,
            },
            center,
        ),
        CsgNode::Plane { normal, offset } => Op::Prim(
            Primitive::Plane {
                normal: normal.normalize(),
                offset: *offset,
            },
            Vec3::ZERO,
        ),
        CsgNode::Union { children } => Op::Union(children.iter().map(compile).collect()),
        CsgNode::Intersection { children } => {
            Op::Intersection(children.iter().map(compile).collect())
        }
        CsgNode::Difference { a, b } => Op::Difference(Box::new(compile(a)), Box::new(compile(b))),
        CsgNode::SmoothUnion { radius, children } => {
            Op::SmoothUnion(*radius, children.iter().map(compile).collect())
        }
        CsgNode::SmoothIntersection { radius, children } => {
            Op::SmoothIntersection(*radius, children.iter().map(compile).collect())
        }
        CsgNode::SmoothDifference { radius, a, b } => {
            Op::SmoothDifference(*radius, Box::new(compile(a)), Box::new(compile(b)))
        }
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
                Quat::from_axis_angle(rotate_axis.normalize(), rotate_degrees.to_radians())
            };
            Op::Transform {
                inv_rot: rot.inverse(),
                rot,
                translate: *translate,
                scale: *scale,
                child: Box::new(compile(child)),
            }
        }
        CsgNode::Heightfield(p) => Op::Heightfield(Box::new(Heightfield::new(p.clone()))),
        CsgNode::Density(p) => Op::Density(Box::new(Density::new(p.clone()))),
    }
}

/// Polynomial smooth minimum of `(a, ga)` and `(b, gb)` over radius `k` (iq). The
/// returned gradient is exact: the blend terms' derivatives cancel.
fn smin(a: (f32, Vec3), b: (f32, Vec3), k: f32) -> (f32, Vec3) {
    let h = (0.5 + 0.5 * (b.0 - a.0) / k).clamp(0.0, 1.0);
    let d = b.0 + (a.0 - b.0) * h - k * h * (1.0 - h);
    (d, b.1.lerp(a.1, h))
}

fn neg(a: (f32, Vec3)) -> (f32, Vec3) {
    (-a.0, -a.1)
}

/// A sphere with `value(p) >= |p - center| - radius` everywhere: for an exact SDF any
/// sphere enclosing the shape (inside, the distance to the shape's boundary is at
/// most the distance to the sphere's).
#[derive(Clone, Copy, Debug)]
struct Bound {
    center: Vec3,
    radius: f32,
}

impl Bound {
    fn lower(&self, p: Vec3) -> f32 {
        p.distance(self.center) - self.radius
    }
    fn grow(self, by: f32) -> Bound {
        Bound {
            center: self.center,
            radius: self.radius + by,
        }
    }
}

fn enclose(bounds: &[Option<Bound>]) -> Option<Bound> {
    let b: Option<Vec<Bound>> = bounds.iter().cloned().collect();
    let b = b?;
    let (lo, hi) = b
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x.center - x.radius), hi.max(x.center + x.radius))
        });
    let center = (lo + hi) * 0.5;
    let radius = b
        .iter()
        .map(|x| x.center.distance(center) + x.radius)
        .fold(0.0, f32::max);
    Some(Bound { center, radius })
}

/// A compiled node with its bound (None: unbounded, e.g. terrain or a plane).
struct Node {
    op: Op,
    bound: Option<Bound>,
}

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
        Op::Heightfield(_) | Op::Density(_) => None,
    }
}

fn exact(op: &Op) -> bool {
    match op {
        Op::Prim(..) => true,
        Op::Union(ch)
        | Op::Intersection(ch)
        | Op::SmoothUnion(_, ch)
        | Op::SmoothIntersection(_, ch) => ch.iter().all(|c| exact(&c.op)),
        Op::Difference(a, b) | Op::SmoothDifference(_, a, b) => exact(&a.op) && exact(&b.op),
        Op::Transform { child, .. } => exact(&child.op),
        Op::Heightfield(_) | Op::Density(_) => false,
    }
}

impl Node {
    fn eval(&self, p: Vec3) -> (f32, Vec3) {
        match &self.op {
            Op::Union(ch) => {
                let mut best = (f32::INFINITY, Vec3::Y);
                for c in ch {
                    if let Some(b) = c.bound {
                        if b.lower(p) >= best.0 {
                            continue;
                        }
                    }
                    let v = c.eval(p);
                    if v.0 < best.0 {
                        best = v;
                    }
                }
                best
            }
            Op::Difference(a, b) => {
                let a = a.eval(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a.0 {
                        return a;
                    }
                }
                let b = neg(b.eval(p));
                if b.0 > a.0 {
                    b
                } else {
                    a
                }
            }
            _ => self.op.eval(p),
        }
    }

    fn value(&self, p: Vec3) -> f32 {
        match &self.op {
            Op::Union(ch) => {
                let mut best = f32::INFINITY;
                for c in ch {
                    if let Some(b) = c.bound {
                        if b.lower(p) >= best {
                            continue;
                        }
                    }
                    best = best.min(c.value(p));
                }
                best
            }
            Op::Difference(a, b) => {
                let a = a.value(p);
                if let Some(bb) = b.bound {
                    if -bb.lower(p) <= a {
                        return a;
                    }
                }
                a.max(-b.value(p))
            }
            _ => self.op.value(p),
        }
    }
}

impl Node {
    /// Whether sampling a grid pays off batched: the subtree holds a height field
    /// reached through unions, intersections and differences only, so the height
    /// field is evaluated once per (x, z) column instead of once per corner.
    fn batches(&self) -> bool {
        match &self.op {
            Op::Heightfield(_) => true,
            Op::Union(ch) | Op::Intersection(ch) => ch.iter().any(Node::batches),
            Op::Difference(a, b) => a.batches() || b.batches(),
            _ => false,
        }
    }

    /// [`Field::sample_grid`] of this subtree: the same values as [`Node::value`]
    /// at every corner, bit for bit (min and max are exact, and a height field's
    /// column sampling computes each corner as `value` does).
    fn sample(&self, grid: &crate::grid::Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        let combine =
            |out: &mut [f32], ch: &mut dyn Iterator<Item = &Node>, f: fn(f32, f32) -> f32| {
                let mut tmp = vec![0f32; out.len()];
                for c in ch {
                    c.sample(grid, z_range.clone(), &mut tmp);
                    for (o, t) in out.iter_mut().zip(&tmp) {
                        *o = f(*o, *t);
                    }
                }
            };
        match &self.op {
            Op::Heightfield(h) if self.batches() => h.sample_grid(grid, z_range, out),
            Op::Union(ch) if self.batches() => {
                out.fill(f32::INFINITY);
                combine(out, &mut ch.iter(), f32::min);
            }
            Op::Intersection(ch) if self.batches() => {
                out.fill(f32::NEG_INFINITY);
                combine(out, &mut ch.iter(), f32::max);
            }
            Op::Difference(a, b) if self.batches() => {
                a.sample(grid, z_range.clone(), out);
                combine(out, &mut std::iter::once(&**b), |a, b| a.max(-b));
            }
            _ => super::sample_each(grid, z_range, out, |p| self.value(p)),
        }
    }
}

impl Op {
    fn eval(&self, p: Vec3) -> (f32, Vec3) {
        match self {
            Op::Prim(prim, c) => prim.value_gradient(p - *c),
            Op::Union(ch) => ch
                .iter()
                .map(|c| c.eval(p))
                .reduce(|a, b| if b.0 < a.0 { b } else { a })
                .unwrap(),
            Op::Intersection(ch) => ch
                .iter()
                .map(|c| c.eval(p))
                .reduce(|a, b| if b.0 > a.0 { b } else { a })
                .unwrap(),
            Op::Difference(a, b) => {
                let a = a.eval(p);
                let b = neg(b.eval(p));
                if b.0 > a.0 {
                    b
                } else {
                    a
                }
            }
            Op::SmoothUnion(k, ch) => ch
                .iter()
                .map(|c| c.eval(p))
                .reduce(|a, b| smin(a, b, *k))
                .unwrap(),
            Op::SmoothIntersection(k, ch) => neg(ch
                .iter()
                .map(|c| neg(c.eval(p)))
                .reduce(|a, b| smin(a, b, *k))
                .unwrap()),
            Op::SmoothDifference(k, a, b) => neg(smin(neg(a.eval(p)), b.eval(p), *k)),
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
            Op::Heightfield(h) => (h.value(p), h.gradient(p)),
            Op::Density(d) => (d.value(p), d.gradient(p)),
        }
    }

    fn value(&self, p: Vec3) -> f32 {
        match self {
            Op::Prim(prim, c) => prim.value(p - *c),
            Op::Union(ch) => ch.iter().map(|c| c.value(p)).fold(f32::INFINITY, f32::min),
            Op::Intersection(ch) => ch
                .iter()
                .map(|c| c.value(p))
                .fold(f32::NEG_INFINITY, f32::max),
            Op::Difference(a, b) => a.value(p).max(-b.value(p)),
            Op::Transform {
                inv_rot,
                translate,
                scale,
                child,
                ..
            } => child.value(*inv_rot * (p - *translate) / *scale) * scale,
            Op::Heightfield(h) => h.value(p),
            Op::Density(d) => d.value(p),
            _ => self.eval(p).0,
        }
    }
}

/// A compiled CSG tree; a [`Field`] with analytic gradients where its parts have
/// them. Unions and differences skip children whose bounding sphere proves they
/// cannot change the result.
pub struct Csg {
    root: Node,
}

impl Csg {
    /// A sphere `(centre, radius)` outside which the field is at least the distance
    /// to the sphere (so nothing there is inside), or `None` for unbounded trees
    /// (planes, terrain).
    pub fn bounding_sphere(&self) -> Option<(Vec3, f32)> {
        self.root.bound.map(|b| (b.center, b.radius))
    }
}

impl Field for Csg {
    fn value(&self, p: Vec3) -> f32 {
        self.root.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.root.eval(p).1
    }
    fn sample_grid(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
    ) {
        self.root.sample(grid, z_range, out)
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
    use super::*;

    #[test]
    fn documented_example_parses() {
        let text = r#"{ "type": "smooth_union", "radius": 0.1, "children": [
            { "type": "box", "half_extents": [0.5, 0.3, 0.3] },
            { "type": "sphere", "radius": 0.35, "center": [0.5, 0.0, 0.0] },
            { "type": "transform", "translate": [0, 0.4, 0], "rotate_axis": [1, 0, 0],
              "rotate_degrees": 90, "scale": 1.0,
              "child": { "type": "torus", "major_radius": 0.3, "minor_radius": 0.08 } }
        ] }"#;
        let node = CsgNode::from_json(text).unwrap();
        let again = CsgNode::from_json(&node.to_json()).unwrap();
        assert_eq!(node, again);
        let f = node.compile().unwrap();
        assert!(f.value(Vec3::ZERO) < 0.0);
        assert!(f.value(Vec3::splat(0.95)) > 0.0);
    }

    #[test]
    fn unknown_primitive_has_line_and_column() {
        let err = CsgNode::from_json("{\n  \"type\": \"blob\", \"radius\": 1 }").unwrap_err();
        match &err {
            SceneError::Syntax { line, message, .. } => {
                assert_eq!(*line, 2);
                assert!(message.contains("blob"), "{message}");
            }
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().contains("line 2"), "{err}");
    }

    #[test]
    fn negative_radius_names_the_path() {
        let err = CsgNode::from_json(
            r#"{"type":"union","children":[{"type":"sphere","radius":0.2},{"type":"sphere","radius":-1}]}"#,
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "scene node `root.children[1].radius`: must be a finite number > 0, got -1"
        );
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

    #[test]
    fn batched_grid_sampling_matches_value_bit_for_bit() {
        // Height fields under unions, intersections and differences are sampled by
        // column; everything else (a transformed height field, smooth operators,
        // primitives) per corner. Either way the samples are `value`'s.
        let hf = r#"{"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}"#;
        let scenes = [
            format!(
                r#"{{"type":"intersection","children":[{{"type":"box","half_extents":[0.85,0.85,0.85]}},{hf}]}}"#
            ),
            format!(
                r#"{{"type":"difference","a":{{"type":"union","children":[{hf},
                    {{"type":"sphere","radius":0.3,"center":[0.2,0.5,0]}}]}},
                    "b":{{"type":"transform","translate":[0,0.1,0],"child":{hf}}}}}"#
            ),
            format!(
                r#"{{"type":"smooth_union","radius":0.1,"children":[{hf},{{"type":"sphere","radius":0.4}}]}}"#
            ),
            hf.to_string(),
        ];
        let grid = crate::grid::Grid {
            origin: Vec3::splat(-1.0),
            cell_size: 2.0 / 20.0,
            cells: glam::UVec3::new(20, 17, 23),
            offset: glam::IVec3::new(3, -2, 1),
        };
        let c = grid.corners();
        for (k, json) in scenes.iter().enumerate() {
            let f = CsgNode::from_json(json).unwrap().compile().unwrap();
            assert_eq!(f.root.batches(), k != 2, "{json}");
            let (z0, z1) = (2, 7);
            let mut out = vec![0f32; (c.x * c.y * (z1 - z0)) as usize];
            f.sample_grid(&grid, z0..z1, &mut out);
            let mut i = 0;
            for z in z0..z1 {
                for y in 0..c.y {
                    for x in 0..c.x {
                        let v = f.value(grid.corner_pos(glam::UVec3::new(x, y, z)));
                        assert_eq!(out[i].to_bits(), v.to_bits(), "{json} at {x} {y} {z}");
                        i += 1;
                    }
                }
            }
        }
    }
}
