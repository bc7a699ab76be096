//! Every primitive node's parameters in one place: the fields its scene-file entry
//! has, the range each must lie in (checked in the order listed), and the
//! [`Primitive`] and center they compile to.

use super::param::{param, Param, Range, Range::*};
use super::CsgNode;
use crate::field::sdf::Primitive;
use crate::geometry::unit_vector;
use glam::Vec3;

/// A primitive node read out of a [`CsgNode`].
pub(super) struct PrimitiveNode {
    /// The shape, at the origin.
    pub shape: Primitive,
    /// Where the shape's origin goes.
    pub center: Vec3,
    /// The node's fields with their ranges, in the order they are checked.
    pub params: Vec<Param>,
}

impl CsgNode {
    /// The primitive this node describes, or `None` for booleans, transforms and
    /// terrain.
    pub(super) fn primitive(&self) -> Option<PrimitiveNode> {
        let (shape, center, mut params) = match *self {
            CsgNode::Sphere { radius, center } => (
                Primitive::Sphere { radius },
                center,
                vec![param("radius", radius, Positive)],
            ),
            CsgNode::Box {
                half_extents,
                center,
            } => (
                Primitive::Cuboid { half_extents },
                center,
                vec![param("half_extents", half_extents, Positive)],
            ),
            CsgNode::RoundedBox {
                half_extents,
                radius,
                center,
            } => (
                Primitive::RoundedBox {
                    half_extents,
                    radius,
                },
                center,
                vec![
                    param("radius", radius, Positive),
                    param("half_extents", half_extents, Above("radius", radius)),
                ],
            ),
            CsgNode::Torus {
                major_radius,
                minor_radius,
                center,
            } => (
                Primitive::Torus {
                    major_radius,
                    minor_radius,
                },
                center,
                vec![
                    param("minor_radius", minor_radius, Positive),
                    param("major_radius", major_radius, Positive),
                    param(
                        "minor_radius",
                        minor_radius,
                        Below("major_radius", major_radius),
                    ),
                ],
            ),
            CsgNode::Cylinder {
                radius,
                half_height,
                center,
            } => (
                Primitive::Cylinder {
                    radius,
                    half_height,
                },
                center,
                along_y(radius, half_height, Positive),
            ),
            CsgNode::Capsule {
                radius,
                half_height,
                center,
            } => (
                Primitive::Capsule {
                    radius,
                    half_height,
                },
                center,
                along_y(radius, half_height, NonNegative),
            ),
            CsgNode::Cone {
                radius,
                half_height,
                center,
            } => (
                Primitive::Cone {
                    radius,
                    half_height,
                },
                center,
                along_y(radius, half_height, Positive),
            ),
            CsgNode::Plane { normal, offset } => {
                return Some(PrimitiveNode {
                    shape: Primitive::Plane {
                        normal: unit_vector(normal).unwrap_or(Vec3::ZERO),
                        offset,
                    },
                    center: Vec3::ZERO,
                    params: vec![
                        param("normal", normal, Finite),
                        param("normal", normal, NonZero),
                        param("offset", offset, Finite),
                    ],
                })
            }
            CsgNode::Union { .. }
            | CsgNode::Intersection { .. }
            | CsgNode::Difference { .. }
            | CsgNode::SmoothUnion { .. }
            | CsgNode::SmoothIntersection { .. }
            | CsgNode::SmoothDifference { .. }
            | CsgNode::Transform { .. }
            | CsgNode::Material { .. }
            | CsgNode::Heightfield(_)
            | CsgNode::Density(_) => return None,
        };
        params.push(param("center", center, Finite));
        Some(PrimitiveNode {
            shape,
            center,
            params,
        })
    }
}

/// The fields of a shape along Y: its radius (> 0) and its half height, in
/// `half_height_range`.
fn along_y(radius: f32, half_height: f32, half_height_range: Range) -> Vec<Param> {
    vec![
        param("radius", radius, Positive),
        param("half_height", half_height, half_height_range),
    ]
}
