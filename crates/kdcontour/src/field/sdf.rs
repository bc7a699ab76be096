//! Exact signed distance primitives, centerd at the origin, with analytic gradients.
//!
//! Formulas follow Inigo Quilez's catalogue of distance functions. Round shapes
//! (cylinder, capsule, torus, cone) have their axis along +Y.

use glam::{Vec2, Vec3};

/// A primitive shape. All lengths are in world units and must be positive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// Ball of the given radius.
    Sphere {
        /// Radius.
        radius: f32,
    },
    /// Axis-aligned box with sharp edges.
    Cuboid {
        /// Half the side lengths.
        half_extents: Vec3,
    },
    /// Box whose edges are rounded with `radius` (inside the half extents).
    RoundedBox {
        /// Half the side lengths, rounding included.
        half_extents: Vec3,
        /// Edge rounding radius.
        radius: f32,
    },
    /// Torus around the Y axis.
    Torus {
        /// Distance from the center to the tube's center line.
        major_radius: f32,
        /// Tube radius.
        minor_radius: f32,
    },
    /// Capped cylinder along Y.
    Cylinder {
        /// Radius.
        radius: f32,
        /// Half its length.
        half_height: f32,
    },
    /// Segment along Y from `-half_height` to `half_height`, thickened by `radius`.
    Capsule {
        /// Radius.
        radius: f32,
        /// Half the length of the inner segment.
        half_height: f32,
    },
    /// Capped cone along Y: base of `radius` at `-half_height`, apex at `+half_height`.
    Cone {
        /// Base radius.
        radius: f32,
        /// Half its height.
        half_height: f32,
    },
    /// Half-space `dot(normal, p) <= offset` (normal is normalised).
    Plane {
        /// Outward normal.
        normal: Vec3,
        /// Distance of the plane from the origin along the normal.
        offset: f32,
    },
}

impl Primitive {
    /// Signed distance at `p`.
    pub fn value(&self, p: Vec3) -> f32 {
        self.eval(p, false).0
    }

    /// Signed distance and its gradient at `p`.
    pub fn value_gradient(&self, p: Vec3) -> (f32, Vec3) {
        self.eval(p, true)
    }

    fn eval(&self, p: Vec3, want_grad: bool) -> (f32, Vec3) {
        match *self {
            Primitive::Sphere { radius } => {
                let l = p.length();
                let g = if want_grad && l > 0.0 { p / l } else { Vec3::Y };
                (l - radius, g)
            }
            Primitive::Cuboid { half_extents } => box_sdf(p, half_extents, 0.0, want_grad),
            Primitive::RoundedBox {
                half_extents,
                radius,
            } => box_sdf(p, half_extents - Vec3::splat(radius), radius, want_grad),
            Primitive::Torus {
                major_radius,
                minor_radius,
            } => {
                let xz = Vec2::new(p.x, p.z);
                let lxz = xz.length();
                let q = Vec2::new(lxz - major_radius, p.y);
                let lq = q.length();
                let d = lq - minor_radius;
                if !want_grad {
                    return (d, Vec3::ZERO);
                }
                let dir_xz = if lxz > 0.0 { xz / lxz } else { Vec2::X };
                let qn = if lq > 0.0 { q / lq } else { Vec2::X };
                (d, Vec3::new(qn.x * dir_xz.x, qn.y, qn.x * dir_xz.y))
            }
            Primitive::Cylinder {
                radius,
                half_height,
            } => {
                let xz = Vec2::new(p.x, p.z);
                let lxz = xz.length();
                let d = Vec2::new(lxz - radius, p.y.abs() - half_height);
                let outside = d.max(Vec2::ZERO);
                let dist = d.x.max(d.y).min(0.0) + outside.length();
                if !want_grad {
                    return (dist, Vec3::ZERO);
                }
                let radial = if lxz > 0.0 {
                    Vec3::new(p.x / lxz, 0.0, p.z / lxz)
                } else {
                    Vec3::X
                };
                let axial = Vec3::new(0.0, p.y.signum(), 0.0);
                let g = if d.x > 0.0 || d.y > 0.0 {
                    let o = outside.normalize_or_zero();
                    radial * o.x + axial * o.y
                } else if d.x > d.y {
                    radial
                } else {
                    axial
                };
                (dist, g)
            }
            Primitive::Capsule {
                radius,
                half_height,
            } => {
                let c = Vec3::new(0.0, p.y.clamp(-half_height, half_height), 0.0);
                let v = p - c;
                let l = v.length();
                (l - radius, if l > 0.0 { v / l } else { Vec3::X })
            }
            Primitive::Cone {
                radius,
                half_height,
            } => {
                // Capped cone (iq's sdCappedCone with r2 = 0), gradient by differences.
                let d = cone_sdf(p, half_height, radius);
                let g = if want_grad {
                    super::central_difference(
                        |q| cone_sdf(q, half_height, radius),
                        p,
                        1e-4 * (radius + half_height),
                    )
                } else {
                    Vec3::ZERO
                };
                (d, g)
            }
            Primitive::Plane { normal, offset } => (p.dot(normal) - offset, normal),
        }
    }

    /// The largest distance from the origin at which the shape can have surface, or
    /// infinity for unbounded shapes (used to skip chunks an edit cannot reach).
    pub fn bounding_radius(&self) -> f32 {
        match *self {
            Primitive::Sphere { radius } => radius,
            Primitive::Cuboid { half_extents } | Primitive::RoundedBox { half_extents, .. } => {
                half_extents.length()
            }
            Primitive::Torus {
                major_radius,
                minor_radius,
            } => major_radius + minor_radius,
            Primitive::Cylinder {
                radius,
                half_height,
            }
            | Primitive::Cone {
                radius,
                half_height,
            } => Vec2::new(radius, half_height).length(),
            Primitive::Capsule {
                radius,
                half_height,
            } => radius + half_height,
            Primitive::Plane { .. } => f32::INFINITY,
        }
    }
}

fn box_sdf(p: Vec3, b: Vec3, r: f32, want_grad: bool) -> (f32, Vec3) {
    let q = p.abs() - b;
    let outside = q.max(Vec3::ZERO);
    let ol = outside.length();
    let inside = q.max_element().min(0.0);
    let d = ol + inside - r;
    if !want_grad {
        return (d, Vec3::ZERO);
    }
    let s = Vec3::new(sign(p.x), sign(p.y), sign(p.z));
    let g = if ol > 0.0 {
        outside / ol * s
    } else if q.x >= q.y && q.x >= q.z {
        Vec3::new(s.x, 0.0, 0.0)
    } else if q.y >= q.z {
        Vec3::new(0.0, s.y, 0.0)
    } else {
        Vec3::new(0.0, 0.0, s.z)
    };
    (d, g)
}

fn sign(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

fn cone_sdf(p: Vec3, h: f32, r1: f32) -> f32 {
    // iq: sdCappedCone(p, h, r1, r2) with r2 = 0, y from -h (radius r1) to h (apex).
    let r2 = 0.0f32;
    let q = Vec2::new(Vec2::new(p.x, p.z).length(), p.y);
    let k1 = Vec2::new(r2, h);
    let k2 = Vec2::new(r2 - r1, 2.0 * h);
    let ca = Vec2::new(
        q.x - q.x.min(if q.y < 0.0 { r1 } else { r2 }),
        q.y.abs() - h,
    );
    let cb = q - k1 + k2 * ((k1 - q).dot(k2) / k2.dot(k2)).clamp(0.0, 1.0);
    let s = if cb.x < 0.0 && ca.y < 0.0 { -1.0 } else { 1.0 };
    s * ca.length_squared().min(cb.length_squared()).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_gradient(prim: Primitive) {
        let mut rng = 12345u32;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 17;
            rng ^= rng << 5;
            rng as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let p = Vec3::new(next(), next(), next()) * 1.3;
            let (d, g) = prim.value_gradient(p);
            let fd = super::super::central_difference(|q| prim.value(q), p, 1e-3);
            assert!((d - prim.value(p)).abs() < 1e-6);
            // Skip points on the medial axis where the gradient is discontinuous.
            if fd.length() > 0.98 && fd.length() < 1.02 {
                assert!(
                    (g - fd).length() < 0.05,
                    "{prim:?} at {p}: analytic {g} vs differences {fd}"
                );
            }
        }
    }

    #[test]
    fn analytic_gradients_match_differences() {
        check_gradient(Primitive::Sphere { radius: 0.5 });
        check_gradient(Primitive::Cuboid {
            half_extents: Vec3::new(0.5, 0.3, 0.2),
        });
        check_gradient(Primitive::RoundedBox {
            half_extents: Vec3::new(0.5, 0.3, 0.2),
            radius: 0.1,
        });
        check_gradient(Primitive::Torus {
            major_radius: 0.5,
            minor_radius: 0.2,
        });
        check_gradient(Primitive::Cylinder {
            radius: 0.4,
            half_height: 0.3,
        });
        check_gradient(Primitive::Capsule {
            radius: 0.2,
            half_height: 0.4,
        });
        check_gradient(Primitive::Plane {
            normal: Vec3::new(0.0, 1.0, 0.0),
            offset: 0.1,
        });
    }

    #[test]
    fn signs_are_inside_negative() {
        for prim in [
            Primitive::Sphere { radius: 0.5 },
            Primitive::Cuboid {
                half_extents: Vec3::splat(0.5),
            },
            Primitive::Cylinder {
                radius: 0.4,
                half_height: 0.3,
            },
            Primitive::Cone {
                radius: 0.4,
                half_height: 0.3,
            },
        ] {
            assert!(prim.value(Vec3::new(0.0, -0.1, 0.0)) < 0.0, "{prim:?}");
            assert!(prim.value(Vec3::splat(2.0)) > 0.0, "{prim:?}");
        }
    }
}
