//! The fold measure: per face, the angle between its normal and the field's
//! gradient at its centroid, as a histogram, and the share of faces folded more
//! than [`FOLD_DEGREES`] away from creases.
//!
//! A well-placed face follows the surface, so its normal is close to the gradient.
//! Next to a crease (a box's edge, a CSG seam) a face that bridges the crease
//! leans by up to half the crease angle, and its centroid may fall where the
//! gradient points the other side's way: large angles there are expected and say
//! nothing about folds. So a face counts as folded only when its angle exceeds
//! [`FOLD_DEGREES`] and its centroid is not *near a crease*: no point one cell
//! from the centroid along the six axis directions has a gradient more than
//! [`CREASE_DEGREES`] from the centroid's. A smooth surface turns by 30 degrees
//! over a cell only where its radius of curvature is under two cells, which the
//! grid barely resolves anyway.
//!
//! Angles come from `atan2(|n x g|, n . g)`, never from a division by `|g|`; a
//! face whose gradient is zero or not finite (the flat regions of a sampled
//! volume) is counted in [`Folds::no_gradient`] and left out of the rest.

use super::faces::corners;
use crate::field::Field;
use crate::geometry::CREASE_DEGREES;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Upper edges (degrees) of the buckets of [`Folds::histogram`]; the first
/// bucket starts at 0, the last ends at 180 (inclusive).
pub const FOLD_BUCKET_DEGREES: [f32; 8] = [10.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0, 180.0];
/// A face whose normal is more than this many degrees from the gradient, away
/// from creases, is folded.
pub const FOLD_DEGREES: f32 = 60.0;

/// The fold measure of a mesh against its field (what counts as a fold and a
/// crease: [`FOLD_DEGREES`], [`CREASE_DEGREES`]).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Folds {
    /// Faces per angle bucket ([`FOLD_BUCKET_DEGREES`]).
    pub histogram: [usize; 8],
    /// Faces measured: nonzero area and a nonzero finite gradient.
    pub measured: usize,
    /// Faces left out because the gradient at their centroid vanishes.
    pub no_gradient: usize,
    /// Largest angle, in degrees.
    pub max_degrees: f32,
    /// Mean angle, in degrees.
    pub mean_degrees: f32,
    /// Faces beyond [`FOLD_DEGREES`] whose centroid is near a crease.
    pub near_crease: usize,
    /// Faces beyond [`FOLD_DEGREES`] away from creases: folded.
    pub folded: usize,
    /// `folded` over `measured` (0 when nothing was measured).
    pub folded_share: f32,
}

/// Angle in degrees between `a` and `b`, or `None` when either is zero or not
/// finite.
fn angle(a: DVec3, b: DVec3) -> Option<f32> {
    let ok = |v: DVec3| v.is_finite() && v.length_squared() > 0.0;
    (ok(a) && ok(b)).then(|| a.cross(b).length().atan2(a.dot(b)).to_degrees() as f32)
}

/// Whether the gradient turns by more than [`CREASE_DEGREES`] between `p` (where
/// it is `g`) and a point one cell away along an axis.
fn near_crease(field: &dyn Field, p: Vec3, g: DVec3, cell: f32) -> bool {
    [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
        .iter()
        .any(|d| {
            let q = field.gradient(p + *d * cell).as_dvec3();
            angle(g, q).is_some_and(|a| a > CREASE_DEGREES)
        })
}

/// The fold measure of the listed triangles against `field` (`cell` in world
/// units).
pub(crate) fn folds(
    field: &dyn Field,
    cell: f32,
    pos: &[Vec3],
    tris: &[[u32; 3]],
    listed: &[bool],
) -> Folds {
    // Per face: its angle (None without a gradient) and whether it is folded.
    let per_face: Vec<(Option<f32>, bool)> = tris
        .par_iter()
        .zip(listed)
        .filter(|(_, &ok)| ok)
        .map(|(t, _)| {
            let [a, b, c] = corners(pos, *t);
            let n = (b - a).cross(c - a);
            let centroid = ((a + b + c) / 3.0).as_vec3();
            let g = field.gradient(centroid).as_dvec3();
            let deg = angle(n, g);
            let beyond = deg.is_some_and(|d| d > FOLD_DEGREES);
            let folded = beyond && !near_crease(field, centroid, g, cell);
            (deg, folded)
        })
        .collect();
    let mut f = Folds::default();
    let mut sum = 0f64;
    for &(deg, folded) in &per_face {
        let Some(d) = deg else {
            f.no_gradient += 1;
            continue;
        };
        f.measured += 1;
        sum += d as f64;
        f.max_degrees = f.max_degrees.max(d);
        let bucket = FOLD_BUCKET_DEGREES
            .iter()
            .position(|&edge| d < edge)
            .unwrap_or(FOLD_BUCKET_DEGREES.len() - 1);
        f.histogram[bucket] += 1;
        if folded {
            f.folded += 1;
        } else if d > FOLD_DEGREES {
            f.near_crease += 1;
        }
    }
    if f.measured > 0 {
        f.mean_degrees = (sum / f.measured as f64) as f32;
        f.folded_share = f.folded as f32 / f.measured as f32;
    }
    f
}
