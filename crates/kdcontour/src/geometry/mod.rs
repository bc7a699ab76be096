//! The geometric predicates the mesher and its checker share, so that what the
//! pipeline keeps out ([`crate::facing`], the cells' vertices, the fold guard,
//! material borders) is judged by the same definitions [`crate::validate()`]
//! counts: a triangle's normal, a flip against the field's gradient, zero area,
//! a crease, and the triangle-triangle contact test (`tritri`).

pub(crate) mod tritri;

use crate::field::Field;
use glam::{DVec3, Vec3};

/// A triangle with less area than this many square cells has zero area (f32
/// rounding of a collinear triangle one cell long at coordinates up to 64 cells
/// leaves about 1e-6; the thinnest 5° sliver on a one-cell edge has 0.02).
pub const ZERO_AREA_CELLS2: f64 = 1e-5;

/// The gradient turning by more than this many degrees within a cell of a face's
/// centroid marks a crease there.
pub const CREASE_DEGREES: f32 = 30.0;

/// Coplanarity and crossing tolerance of the intersection test, in cells.
pub const INTERSECTION_TOL_CELLS: f64 = 1e-3;

/// The length of `v`, computed without overflow or underflow in its square
/// (`v` is divided by its largest component first): `[1e20, 1e20, 0]` is
/// `1.41e20`, not infinity, and `[1e-25, 0, 0]` is `1e-25`, not 0.
pub(crate) fn safe_length(v: Vec3) -> f32 {
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    m * (v / m).length()
}

/// `v` scaled to unit length ([`safe_length`]'s way, so no finite non-zero
/// vector turns into zero or NaN), or `None` when it is zero or not finite.
pub(crate) fn unit_vector(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    (v.is_finite() && m > 0.0).then(|| (v / m).normalize())
}

/// The (unnormalised) normal of triangle `t`, counter-clockwise seen from its
/// front, in f64.
pub(crate) fn face_normal([a, b, c]: [Vec3; 3]) -> DVec3 {
    (b.as_dvec3() - a.as_dvec3()).cross(c.as_dvec3() - a.as_dvec3())
}

/// Whether a face of normal `normal` is flipped against the field's gradient `g`
/// at its centroid: they point more than 90 degrees apart. The one definition
/// the checker counts and the mesher's guards keep (`hermite::vertex`,
/// `kdtree::fold`).
pub(crate) fn opposes(normal: DVec3, g: Vec3) -> bool {
    g.is_finite() && normal.dot(g.as_dvec3()) < 0.0
}

/// Whether triangle `t` (world units) is flipped ([`opposes`] at its centroid).
pub(crate) fn flipped(field: &dyn Field, t: [Vec3; 3]) -> bool {
    opposes(face_normal(t), field.gradient((t[0] + t[1] + t[2]) / 3.0))
}
