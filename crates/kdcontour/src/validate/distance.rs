//! Distances between a mesh and the surface of its field, without dividing by the
//! gradient: a distance is the length to a sign change of the field, bracketed and
//! refined on the field itself, so it is a real surface point's distance (an upper
//! bound on the true one, exact along the normal of a distance field).

use super::spatial::TriGrid;
use crate::field::Field;
use crate::grid::Grid;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// Distances are searched up to this many cells; a point with no surface (or no
/// triangle) nearer reports this.
pub const DISTANCE_CAP_CELLS: f32 = 8.0;
/// A surface point farther than this many cells from every triangle is lost.
pub const LOST_CELLS: f32 = 2.0;
/// Crossings are refined to this many cells.
const ROOT_TOL_CELLS: f32 = 1e-4;
/// March step along a line when the field has no Lipschitz bound, in cells.
const STEP_CELLS: f32 = 0.25;

fn outside(v: f32) -> bool {
    v >= 0.0
}

/// The crossing between `a` (value `fa`) and `b` (value `fb`, opposite side),
/// refined by the Illinois method to `tol` (world units).
pub(crate) fn crossing(field: &dyn Field, a: Vec3, fa: f32, b: Vec3, fb: f32, tol: f32) -> Vec3 {
    let (mut t0, mut f0, mut t1, mut f1) = (0f32, fa, 1f32, fb);
    let len = a.distance(b).max(f32::MIN_POSITIVE);
    let mut side = 0i8;
    for _ in 0..60 {
        if (t1 - t0) * len <= tol || f0 == f1 {
            break;
        }
        let t = (t0 - f0 * (t1 - t0) / (f1 - f0)).clamp(t0, t1);
        // Bisect when false position stalls at an end.
        let t = if t <= t0 || t >= t1 {
            0.5 * (t0 + t1)
        } else {
            t
        };
        let ft = field.value(a.lerp(b, t));
        if ft == 0.0 {
            return a.lerp(b, t);
        }
        if !ft.is_finite() {
            break;
        }
        if outside(ft) == outside(f0) {
            (t0, f0) = (t, ft);
            if side == -1 {
                f1 *= 0.5;
            }
            side = -1;
        } else {
            (t1, f1) = (t, ft);
            if side == 1 {
                f0 *= 0.5;
            }
            side = 1;
        }
    }
    a.lerp(b, 0.5 * (t0 + t1))
}

/// Distance from `p` (value `f0`) along unit `dir` to the first sign change or
/// value within `zero` of 0, up to `limit`, marching by `|f| / L` with a
/// Lipschitz bound `L`, by [`STEP_CELLS`] without.
fn along(
    field: &dyn Field,
    p: Vec3,
    f0: f32,
    dir: Vec3,
    zero: f32,
    limit: f32,
    cell: f32,
) -> Option<f32> {
    let lip = field.lipschitz().filter(|l| l.is_finite() && *l > 0.0);
    let (mut t, mut f) = (0f32, f0);
    while t < limit {
        let step = match lip {
            Some(l) => (f.abs() / l).clamp(0.01 * cell, 2.0 * cell),
            None => STEP_CELLS * cell,
        };
        let t1 = (t + step).min(limit);
        let f1 = field.value(p + dir * t1);
        if !f1.is_finite() {
            return None;
        }
        if f1.abs() <= zero {
            return Some(t1);
        }
        if outside(f1) != outside(f) {
            let (a, b) = (p + dir * t, p + dir * t1);
            return Some(p.distance(crossing(field, a, f, b, f1, ROOT_TOL_CELLS * cell)));
        }
        (t, f) = (t1, f1);
    }
    None
}

/// Newton iterations of [`projection`].
const NEWTON_STEPS: usize = 32;

/// Distance from `p` (value `f0`) to the crossing on the segment from `p` to the
/// end of a Newton path (steps of `f / |∇f|` against the gradient, 5% long and
/// at most a cell each, so a crease's two sides are walked in turn), up to `cap`.
/// `g0` is the gradient at `p`. `None` where the gradient vanishes or the path
/// finds no sign change.
fn projection(
    field: &dyn Field,
    p: Vec3,
    f0: f32,
    g0: Vec3,
    zero: f32,
    cell: f32,
    cap: f32,
) -> Option<f32> {
    let mut q = p;
    let mut fq = f0;
    for k in 0..NEWTON_STEPS {
        let g = if k == 0 { g0 } else { field.gradient(q) };
        let gl = g.length();
        if !(gl.is_finite() && gl > 0.0) {
            return None;
        }
        let step = ((fq.abs() / gl) * 1.05 + 1e-3 * cell).min(cell);
        q -= g / gl * (step * fq.signum());
        if p.distance(q) > cap {
            return None;
        }
        fq = field.value(q);
        if !fq.is_finite() {
            return None;
        }
        if fq.abs() <= zero {
            return Some(p.distance(q));
        }
        if outside(fq) != outside(f0) {
            let c = crossing(field, p, f0, q, fq, ROOT_TOL_CELLS * cell);
            return Some(p.distance(c));
        }
    }
    None
}

/// Distance from `p` to the surface of `field` (world units), at most `cap`:
/// along a Newton path (see [`projection`]), and, when that finds nothing within
/// one cell, along the six axes too. The crossing found is bracketed on a
/// straight segment from `p`, so it is a real surface point. Where `|f| / |∇f|`
/// is within the root tolerance, that is the distance (f32 cannot resolve a
/// crossing there: the field rounds to a few ulps of 0 along the surface).
/// `None` where the field is not finite at `p`.
pub(crate) fn to_surface(field: &dyn Field, p: Vec3, cell: f32, cap: f32) -> Option<f32> {
    let f0 = field.value(p);
    if !f0.is_finite() {
        return None;
    }
    if f0 == 0.0 {
        return Some(0.0);
    }
    let g = field.gradient(p);
    let gl = g.length();
    // Values within the root tolerance (first order) of 0 are on the surface.
    let zero = if gl.is_finite() && gl > 0.0 {
        ROOT_TOL_CELLS * cell * gl
    } else {
        0.0
    };
    if f0.abs() <= zero {
        return Some(f0.abs() / gl);
    }
    let mut best = projection(field, p, f0, g, zero, cell, cap).map_or(cap, |t| t.min(cap));
    if best > cell {
        for dir in [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ] {
            if let Some(t) = along(field, p, f0, dir, zero, best, cell) {
                best = best.min(t);
            }
        }
    }
    Some(best)
}

/// Mesh to surface: the largest and the area-weighted mean distance (world units)
/// over the vertices and, per triangle, the centroids of its `k`² sub-triangles
/// (`k` = its longest edge in cells, rounded up, between 2 and 32).
pub(crate) fn mesh_to_surface(
    field: &dyn Field,
    pos: &[Vec3],
    tris: &[[u32; 3]],
    listed: &[bool],
    used: &[bool],
    cell: f32,
) -> (f32, f32) {
    let cap = DISTANCE_CAP_CELLS * cell;
    let d = |p: Vec3| to_surface(field, p, cell, cap).unwrap_or(0.0);
    let vmax = pos
        .par_iter()
        .zip(used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| d(*p))
        .reduce(|| 0.0, f32::max);
    let (tmax, sum, area) = tris
        .par_iter()
        .zip(listed)
        .filter(|(_, &l)| l)
        .map(|(t, _)| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
            let k = ((longest / cell).ceil() as u32).clamp(2, 32);
            let (u, v) = ((b - a) / k as f32, (c - a) / k as f32);
            let mut max = 0f32;
            let mut sum = 0f64;
            for i in 0..k {
                for j in 0..k - i {
                    // The upright sub-triangle at (i, j) and, but for the last
                    // of a row, the inverted one beside it.
                    let up = a + u * (i as f32 + 1.0 / 3.0) + v * (j as f32 + 1.0 / 3.0);
                    let e = d(up);
                    max = max.max(e);
                    sum += e as f64;
                    if j + 1 < k - i {
                        let down = a + u * (i as f32 + 2.0 / 3.0) + v * (j as f32 + 2.0 / 3.0);
                        let e = d(down);
                        max = max.max(e);
                        sum += e as f64;
                    }
                }
            }
            let area = 0.5 * (b - a).cross(c - a).length() as f64;
            (max, sum / (k * k) as f64 * area, area)
        })
        .reduce(
            || (0.0, 0.0, 0.0),
            |x, y| (x.0.max(y.0), x.1 + y.1, x.2 + y.2),
        );
    let mean = if area > 0.0 { (sum / area) as f32 } else { 0.0 };
    (vmax.max(tmax), mean)
}

/// What [`surface_to_mesh`] measured (world units).
pub(crate) struct SurfaceToMesh {
    pub max: f32,
    pub mean: f32,
    pub points: usize,
    pub lost: usize,
}

/// Surface to mesh: the crossings (found on `field`) of the edges of `grid` and of
/// the grid shifted by half a cell on every axis, and their distance to the
/// nearest triangle of `tris`. The shifted grid's crossings are not the mesher's
/// own samples, which a mesh of `grid` interpolates best; they count in the
/// distances only. `points` and `lost` are `grid`'s crossings, the surface the
/// mesher saw (the shifted grid also sees features thinner than a cell that
/// `grid` misses).
pub(crate) fn surface_to_mesh(field: &dyn Field, grid: &Grid, tris: &TriGrid) -> SurfaceToMesh {
    let mut s = crossings_to_mesh(field, grid, tris);
    if grid.cells.min_element() >= 2 {
        let shifted = Grid {
            origin: grid.corner_pos(UVec3::ZERO) + Vec3::splat(0.5 * grid.cell_size),
            cells: grid.cells - UVec3::ONE,
            offset: glam::IVec3::ZERO,
            ..*grid
        };
        let t = crossings_to_mesh(field, &shifted, tris);
        let n = s.points + t.points;
        if n > 0 {
            // Mean over both sets of crossings.
            s.mean = ((s.mean as f64 * s.points as f64 + t.mean as f64 * t.points as f64)
                / n as f64) as f32;
        }
        s.max = s.max.max(t.max);
    }
    s
}

/// [`surface_to_mesh`] on the edges of one grid.
fn crossings_to_mesh(field: &dyn Field, grid: &Grid, tris: &TriGrid) -> SurfaceToMesh {
    let cell = grid.cell_size;
    let cap = DISTANCE_CAP_CELLS * cell;
    let lost_at = LOST_CELLS * cell;
    let c = grid.corners();
    // Slabs of SLAB cell layers, sampled with one shared corner layer, in parallel.
    const SLAB: u32 = 8;
    let slabs: Vec<u32> = (0..grid.cells.z).step_by(SLAB as usize).collect();
    let per = slabs
        .par_iter()
        .map(|&z0| {
            let z1 = (z0 + SLAB).min(grid.cells.z);
            let layer = (c.x * c.y) as usize;
            let mut v = vec![0f32; layer * (z1 - z0 + 1) as usize];
            field.sample_grid(grid, z0..z1 + 1, &mut v);
            let at = |x: u32, y: u32, z: u32| {
                v[((z - z0) * c.y + y) as usize * c.x as usize + x as usize]
            };
            let mut acc = (0f32, 0f64, 0usize, 0usize);
            // Edges starting in corner layers z0..z1 (the last slab also owns
            // the top layer's x and y edges).
            let top = if z1 == grid.cells.z { z1 } else { z1 - 1 };
            for z in z0..=top {
                for y in 0..c.y {
                    for x in 0..c.x {
                        let f0 = at(x, y, z);
                        if !f0.is_finite() {
                            continue;
                        }
                        let p0 = grid.corner_pos(UVec3::new(x, y, z));
                        for (axis, ok) in [(0, x + 1 < c.x), (1, y + 1 < c.y), (2, z < z1)] {
                            if !ok {
                                continue;
                            }
                            let n = [
                                UVec3::new(x + 1, y, z),
                                UVec3::new(x, y + 1, z),
                                UVec3::new(x, y, z + 1),
                            ][axis];
                            let f1 = at(n.x, n.y, n.z);
                            if !f1.is_finite() || outside(f0) == outside(f1) {
                                continue;
                            }
                            let q = crossing(
                                field,
                                p0,
                                f0,
                                grid.corner_pos(n),
                                f1,
                                ROOT_TOL_CELLS * cell,
                            );
                            let d = tris.nearest(q, cap);
                            acc.0 = acc.0.max(d);
                            acc.1 += d as f64;
                            acc.2 += 1;
                            acc.3 += (d > lost_at) as usize;
                        }
                    }
                }
            }
            acc
        })
        .reduce(
            || (0.0, 0.0, 0, 0),
            |a, b| (a.0.max(b.0), a.1 + b.1, a.2 + b.2, a.3 + b.3),
        );
    SurfaceToMesh {
        max: per.0,
        mean: if per.2 > 0 {
            (per.1 / per.2 as f64) as f32
        } else {
            0.0
        },
        points: per.2,
        lost: per.3,
    }
}
