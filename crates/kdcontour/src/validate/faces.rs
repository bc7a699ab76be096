//! Per-triangle geometry: zero-area faces, slivers, coincident vertices, and
//! against the field the first-order error and flipped faces.

use super::distance::{to_surface, DISTANCE_CAP_CELLS};
use crate::field::Field;
use crate::geometry::{face_normal, opposes, ZERO_AREA_CELLS2};
use glam::{DVec3, Vec3};
use std::collections::HashSet;

/// A triangle whose smallest angle is below this many degrees is a sliver.
pub const SLIVER_DEGREES: f64 = 5.0;
/// Up to this many cells the error is the first-order `|f| / |∇f|`; beyond it (or
/// where the gradient vanishes) the distance is searched on the field.
const FIRST_ORDER_CELLS: f32 = 1.0;

/// What [`faces`] found.
pub(crate) struct Faces {
    /// Per triangle: distinct indices and nonzero area (the ones the intersection
    /// and distance checks use).
    pub listed: Vec<bool>,
    pub zero_area: usize,
    pub slivers: usize,
    pub coincident_vertices: usize,
}

/// Zero-area triangles, slivers and coincident vertices (`cell` in world units).
pub(crate) fn faces(pos: &[Vec3], tris: &[[u32; 3]], used: &[bool], cell: f32) -> Faces {
    let min_area = ZERO_AREA_CELLS2 * (cell as f64).powi(2);
    let min_sin = SLIVER_DEGREES.to_radians().sin();
    let mut f = Faces {
        listed: vec![false; tris.len()],
        zero_area: 0,
        slivers: 0,
        coincident_vertices: 0,
    };
    for (ti, t) in tris.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        let p = t.map(|i| pos[i as usize].as_dvec3());
        let twice = (p[1] - p[0]).cross(p[2] - p[0]).length();
        if twice * 0.5 < min_area {
            f.zero_area += 1;
            continue;
        }
        f.listed[ti] = true;
        // The smallest angle faces the shortest edge: sin = 2A / (b c) of the two
        // longer edges.
        let mut e: [f64; 3] = [0, 1, 2].map(|i| p[i].distance(p[(i + 1) % 3]));
        e.sort_by(f64::total_cmp);
        let sin_min = twice / (e[1] * e[2]);
        if sin_min < min_sin {
            f.slivers += 1;
        }
    }
    let mut seen = HashSet::new();
    for (p, _) in pos.iter().zip(used).filter(|(_, &u)| u) {
        // `+ 0.0` makes -0.0 and 0.0 one key.
        if !seen.insert((*p + Vec3::ZERO).to_array().map(f32::to_bits)) {
            f.coincident_vertices += 1;
        }
    }
    f
}

/// What [`against_field`] measured, in cells.
pub(crate) struct FieldStats {
    pub max_error: f32,
    pub mean_error: f32,
    pub max_vertex_error: f32,
    pub flipped: usize,
}

/// The vertex and centroid error and the flipped faces of the listed triangles.
pub(crate) fn against_field(
    field: &dyn Field,
    cell: f32,
    pos: &[Vec3],
    tris: &[[u32; 3]],
    used: &[bool],
    listed: &[bool],
) -> FieldStats {
    let cap = DISTANCE_CAP_CELLS * cell;
    // The error in cells at `p`, and the gradient there.
    let dist = |p: Vec3| {
        let (v, g) = (field.value(p), field.gradient(p));
        let first = v.abs() / g.length() / cell;
        let d = if first.is_finite() && first <= FIRST_ORDER_CELLS {
            first
        } else {
            to_surface(field, p, cell, cap).map_or(0.0, |d| d / cell)
        };
        (d, g)
    };
    let mut sum = 0f64;
    let mut n = 0usize;
    let mut max = 0f32;
    for (p, _) in pos.iter().zip(used).filter(|(_, &u)| u) {
        let d = dist(*p).0;
        max = max.max(d);
        sum += d as f64;
        n += 1;
    }
    let max_vertex_error = max;
    let mut flipped = 0;
    for (t, &ok) in tris.iter().zip(listed) {
        let [a, b, c] = t.map(|i| pos[i as usize]);
        let (d, g) = dist((a + b + c) / 3.0);
        max = max.max(d);
        sum += d as f64;
        n += 1;
        if ok && opposes(face_normal([a, b, c]), g) {
            flipped += 1;
        }
    }
    FieldStats {
        max_error: max,
        mean_error: if n > 0 { (sum / n as f64) as f32 } else { 0.0 },
        max_vertex_error,
        flipped,
    }
}

/// The f64 corners of triangle `t`.
pub(crate) fn corners(pos: &[Vec3], t: [u32; 3]) -> [DVec3; 3] {
    t.map(|i| pos[i as usize].as_dvec3())
}
