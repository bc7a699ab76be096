//! Distances between a mesh and the surface of its field, without dividing by the
//! gradient: a distance is the length to a sign change of the field, bracketed and
//! refined on the field itself, so it is a real surface point's distance (an upper
//! bound on the true one, exact along the normal of a distance field).

use super::spatial::TriGrid;
use crate::field::Field;
use crate::grid::Grid;
use crate::root::Bracket;
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
/// refined by the Illinois method ([`crate::root`]) to `tol` (world units).
pub(crate) fn crossing(field: &dyn Field, a: Vec3, fa: f32, b: Vec3, fb: f32, tol: f32) -> Vec3 {
    let mut br = Bracket::new(fa, fb);
    let len = a.distance(b).max(f32::MIN_POSITIVE);
    for _ in 0..60 {
        if (br.t1 - br.t0) * len <= tol || br.flat() {
            break;
        }
        let t = br.secant();
        // Bisect when false position stalls at an end.
        let t = if t <= br.t0 || t >= br.t1 {
            0.5 * (br.t0 + br.t1)
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
        br.narrow(t, ft);
    }
    a.lerp(b, 0.5 * (br.t0 + br.t1))
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

/// The values within the root tolerance (to first order, with gradient length
/// `gl`) of 0: those points are on the surface. 0 where the gradient vanishes.
fn zero_band(gl: f32, cell: f32) -> f32 {
    if gl.is_finite() && gl > 0.0 {
        ROOT_TOL_CELLS * cell * gl
    } else {
        0.0
    }
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
    let zero = zero_band(gl, cell);
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

/// Directions of the first sweep of [`ray_search`], spread evenly over the
/// sphere.
const SWEEP: usize = 64;
/// [`ray_search`] stops narrowing around its best direction below this angle
/// (radians).
const NARROWEST: f32 = 0.005;

/// The distance from `p` (value `f0`) to the nearest crossing of `field` found
/// along rays, at most `limit`: the first crossing along each of [`SWEEP`]
/// directions (a Fibonacci sphere), then along directions around the best one,
/// at half the angle whenever none is better. The nearest surface point is the
/// first crossing along the ray toward it, so this converges on the true
/// distance where the Newton path of [`projection`] does not: where the gradient
/// is not the direction to the nearest surface (inside a shell thinner than a
/// cell, at a kink of `|f|`, where a sampled volume is flat).
fn ray_search(field: &dyn Field, p: Vec3, f0: f32, zero: f32, limit: f32, cell: f32) -> f32 {
    let mut best = limit;
    let mut dir = Vec3::ZERO;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    for i in 0..SWEEP {
        let z = 1.0 - (2 * i + 1) as f32 / SWEEP as f32;
        let r = (1.0 - z * z).sqrt();
        let a = golden * i as f32;
        let d = Vec3::new(r * a.cos(), r * a.sin(), z);
        if let Some(t) = along(field, p, f0, d, zero, best, cell) {
            if t < best {
                (best, dir) = (t, d);
            }
        }
    }
    if dir == Vec3::ZERO {
        return best;
    }
    // The sweep's directions are about this far apart.
    let mut angle = (4.0 * std::f32::consts::PI / SWEEP as f32).sqrt();
    while angle > NARROWEST {
        let (u, v) = dir.any_orthonormal_pair();
        let tan = angle.tan();
        let mut moved = false;
        for (a, b) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
            let d = (dir + (u * a + v * b) * tan).normalize();
            if let Some(t) = along(field, p, f0, d, zero, best, cell) {
                if t < best {
                    (best, dir, moved) = (t, d, true);
                }
            }
        }
        if !moved {
            angle *= 0.5;
        }
    }
    best
}

/// The distance from `p` to the surface by [`to_surface`], then, when that
/// exceeds `floor` (a point nearer cannot change a maximum of `floor`), by
/// [`ray_search`] too; the smaller.
fn to_surface_searched(field: &dyn Field, p: Vec3, cell: f32, cap: f32, floor: f32) -> f32 {
    let first = to_surface(field, p, cell, cap).unwrap_or(0.0);
    if first <= floor {
        return first;
    }
    let zero = zero_band(field.gradient(p).length(), cell);
    ray_search(field, p, field.value(p), zero, first, cell).min(first)
}

/// The points of triangle `[a, b, c]` that [`mesh_to_surface`] measures: the
/// centroids of its `k`² sub-triangles (`k` = its longest edge in cells, rounded
/// up, between 2 and 32).
fn triangle_samples(a: Vec3, b: Vec3, c: Vec3, cell: f32) -> impl Iterator<Item = Vec3> {
    let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
    let k = ((longest / cell).ceil() as u32).clamp(2, 32);
    let (u, v) = ((b - a) / k as f32, (c - a) / k as f32);
    (0..k).flat_map(move |i| {
        (0..k - i).flat_map(move |j| {
            // The upright sub-triangle at (i, j) and, but for the last of a
            // row, the inverted one beside it.
            let up = a + u * (i as f32 + 1.0 / 3.0) + v * (j as f32 + 1.0 / 3.0);
            let down = (j + 1 < k - i)
                .then(|| a + u * (i as f32 + 2.0 / 3.0) + v * (j as f32 + 2.0 / 3.0));
            std::iter::once(up).chain(down)
        })
    })
}

/// Candidates refined at once by [`mesh_to_surface`]'s search of its maximum.
const BATCH: usize = 64;

/// What [`mesh_to_surface`] measures again: a vertex or a triangle's points.
#[derive(Clone, Copy)]
enum Candidate {
    Vertex(u32),
    Triangle(u32),
}

/// Mesh to surface: the largest and the area-weighted mean distance (world units)
/// over the vertices and the points of every triangle ([`triangle_samples`]).
///
/// Every point's distance is first [`to_surface`]'s, an upper bound. The mean
/// is of those. The maximum is searched: vertices and triangles in order of
/// their largest bound are measured again by [`ray_search`] (a triangle's points
/// whose bound exceeds the maximum so far), until the next bound is no larger
/// than the maximum, which then no other point can exceed.
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
    let mut bounds: Vec<(f32, Candidate)> = pos
        .par_iter()
        .zip(used)
        .enumerate()
        .filter(|(_, (_, &u))| u)
        .map(|(i, (p, _))| (d(*p), Candidate::Vertex(i as u32)))
        .collect();
    let per_tri: Vec<(f32, f64, f64, Candidate)> = tris
        .par_iter()
        .zip(listed)
        .enumerate()
        .filter(|(_, (_, &l))| l)
        .map(|(t, (tri, _))| {
            let [a, b, c] = tri.map(|i| pos[i as usize]);
            let (mut max, mut sum, mut n) = (0f32, 0f64, 0usize);
            for q in triangle_samples(a, b, c, cell) {
                let e = d(q);
                max = max.max(e);
                sum += e as f64;
                n += 1;
            }
            let area = 0.5 * (b - a).cross(c - a).length() as f64;
            let t = Candidate::Triangle(t as u32);
            (max, sum / n.max(1) as f64 * area, area, t)
        })
        .collect();
    let (sum, area) = per_tri
        .iter()
        .fold((0.0, 0.0), |acc, t| (acc.0 + t.1, acc.1 + t.2));
    let mean = if area > 0.0 { (sum / area) as f32 } else { 0.0 };
    bounds.extend(per_tri.iter().map(|t| (t.0, t.3)));
    bounds.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    let mut max = 0f32;
    let mut next = 0;
    while next < bounds.len() && bounds[next].0 > max {
        let end = (next + BATCH).min(bounds.len());
        let floor = max;
        let found = bounds[next..end]
            .par_iter()
            .filter(|b| b.0 > floor)
            .map(|&(_, candidate)| match candidate {
                Candidate::Vertex(v) => {
                    to_surface_searched(field, pos[v as usize], cell, cap, floor)
                }
                Candidate::Triangle(t) => {
                    let [a, b, c] = tris[t as usize].map(|i| pos[i as usize]);
                    triangle_samples(a, b, c, cell)
                        .map(|q| to_surface_searched(field, q, cell, cap, floor))
                        .fold(0f32, f32::max)
                }
            })
            .reduce(|| 0.0, f32::max);
        max = max.max(found);
        next = end;
    }
    (max, mean)
}

/// What [`surface_to_mesh`] measured (world units).
pub(crate) struct SurfaceToMesh {
    /// The cells whose [`REFINE`] lattice was sampled, with the largest
    /// distance found there.
    pub refined: Vec<(f32, UVec3)>,
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
///
/// With `refine`, the maximum also sees the crossings of a lattice [`REFINE`]
/// times finer inside every cell of `grid` that may hold surface
/// ([`may_hold_surface`]), and of one [`REFINE_TOP`] times finer in the cells
/// nearest the maximum.
pub(crate) fn surface_to_mesh(
    field: &dyn Field,
    grid: &Grid,
    tris: &TriGrid,
    refine: bool,
) -> SurfaceToMesh {
    let mut s = crossings_to_mesh(field, grid, tris, refine);
    if grid.cells.min_element() >= 2 {
        let shifted = Grid {
            origin: grid.corner_pos(UVec3::ZERO) + Vec3::splat(0.5 * grid.cell_size),
            cells: grid.cells - UVec3::ONE,
            offset: glam::IVec3::ZERO,
            ..*grid
        };
        let t = crossings_to_mesh(field, &shifted, tris, false);
        let n = s.points + t.points;
        if n > 0 {
            // Mean over both sets of crossings.
            s.mean = ((s.mean as f64 * s.points as f64 + t.mean as f64 * t.points as f64)
                / n as f64) as f32;
        }
        s.max = s.max.max(t.max);
    }
    s.refined.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let top = s
        .refined
        .iter()
        .take(TOP_CELLS)
        .take_while(|c| c.0 >= TOP_SHARE * s.max)
        .map(|c| c.1)
        .collect::<Vec<_>>();
    let cap = DISTANCE_CAP_CELLS * grid.cell_size;
    let finer = top
        .par_iter()
        .map(|&c| refined_max(field, grid, c, REFINE_TOP, tris, cap))
        .reduce(|| 0.0, f32::max);
    s.max = s.max.max(finer);
    s
}

/// The cells nearest the surface-to-mesh maximum are sampled again on a lattice
/// this many times finer: the farthest surface points are often features a
/// third of a cell cannot resolve (a noisy surface's sub-cell peaks on
/// `thin_plates`: 0.40 cells against 0.47 by brute force at res 24).
const REFINE_TOP: u32 = 12;
/// The cells whose [`REFINE`] maximum is at least this share of the largest
/// are sampled at [`REFINE_TOP`] ... (at 0.7, a sub-cell peak of
/// `thin_plates` whose cell's coarser maximum was below that share went
/// unseen: 0.392 cells reported against 0.459 by brute force, the farthest
/// point of the brute force's reference 0.015 cells from the field's
/// surface; at 0.5, 0.436)
const TOP_SHARE: f32 = 0.5;
/// ... at most this many, farthest first.
const TOP_CELLS: usize = 256;

/// Cells per side of the blocks [`crossings_to_mesh`] samples at once.
const BLOCK: u32 = 8;

/// Each cell that may hold surface ([`may_hold_surface`]: a sign change among its
/// corners, or too near the surface for a Lipschitz bound to prove it empty) is
/// sampled again on a lattice this many times finer, whose crossings count in
/// the surface-to-mesh maximum. The grid's own crossings are a cell apart and
/// missed the places farthest from the mesh (a box's edges, which a coarse mesh
/// cuts): at res 24 the maximum was 0.135 cells on `box` against 0.212 by brute
/// force, and 0.128 against 0.154 on a smooth volume
/// (`tests/distance_agrees.rs`); with 3 they are 0.205 and 0.144. 2 left the
/// torus at threshold 0.1 at 0.114 against 0.142; 4 lowered the maximum on `box`
/// and csg_mix (its lattice misses the points the one of 3 hits).
///
/// Refining the cells with no sign change too added the fins thinner than a cell
/// that the grid misses (anisotropic at res 24: 5.4 cells against 7.2 by brute
/// force before, 7.2 with them). The whole `mesh` command with full checks of
/// `disk_pole` at res 128 took 2.35 s before that and 3.1 s after.
const REFINE: u32 = 3;

/// Whether a cell with corner values `v` (bit `i` of the index: +1 along axis
/// `i`) may hold surface the grid's edges do not see: a sign change among its
/// corners, or, with a Lipschitz bound `lip`, no corner far enough to prove the
/// cell one-signed (a plate or fin thinner than a cell passes between the
/// corners). Without a bound, the corners' own slope stands in for one: the
/// nearest corner is within two cell diagonals of the largest change along an
/// edge.
fn may_hold_surface(v: &[f32; 8], lip: Option<f32>, cell: f32) -> bool {
    if v.iter().any(|x| !x.is_finite()) {
        return false;
    }
    if v.iter().any(|&x| outside(x) != outside(v[0])) {
        return true;
    }
    let diag = cell * 3f32.sqrt();
    match lip {
        Some(l) => v.iter().all(|x| x.abs() <= l * diag),
        None => {
            let mut slope = 0f32;
            for i in 0..8usize {
                for a in 0..3 {
                    if i & (1 << a) == 0 {
                        slope = slope.max((v[i] - v[i | (1 << a)]).abs() / cell);
                    }
                }
            }
            let nearest = v.iter().fold(f32::INFINITY, |m, x| m.min(x.abs()));
            nearest <= 2.0 * slope * diag
        }
    }
}

/// The largest distance to the mesh of the crossings of the [`REFINE`] times
/// finer lattice in cell `cell` of `grid`. The cell takes the lattice's edges
/// inside it and on its low faces (its high faces belong to the next cells), but
/// not those along its own edges, whose crossing the grid's pass found.
fn refined_max(
    field: &dyn Field,
    grid: &Grid,
    cell: UVec3,
    per_side: u32,
    tris: &TriGrid,
    cap: f32,
) -> f32 {
    let m = per_side + 1;
    let base = grid.corner_pos(cell);
    let h = grid.cell_size / per_side as f32;
    let at = |k: UVec3| base + k.as_vec3() * h;
    let mut v = vec![0f32; (m * m * m) as usize];
    let idx = |k: UVec3| ((k.z * m + k.y) * m + k.x) as usize;
    for (i, value) in v.iter_mut().enumerate() {
        let i = i as u32;
        *value = field.value(at(UVec3::new(i % m, (i / m) % m, i / (m * m))));
    }
    let mut max = 0f32;
    for i in 0..m * m * m {
        let k = UVec3::new(i % m, (i / m) % m, i / (m * m));
        for a in 0..3 {
            let (u, w) = ((a + 1) % 3, (a + 2) % 3);
            let last = per_side;
            let on_side = |b: usize| k[b] == 0 || k[b] == last;
            if k[a] == last || k[u] == last || k[w] == last || (on_side(u) && on_side(w)) {
                continue;
            }
            let n = k + UVec3::AXES[a];
            let (f0, f1) = (v[idx(k)], v[idx(n)]);
            if !(f0.is_finite() && f1.is_finite()) || outside(f0) == outside(f1) {
                continue;
            }
            let q = crossing(field, at(k), f0, at(n), f1, ROOT_TOL_CELLS * grid.cell_size);
            max = max.max(tris.nearest(q, cap));
        }
    }
    max
}

/// [`surface_to_mesh`] on the edges of one grid, block by block in parallel.
/// With a Lipschitz bound, a block whose center is farther from the surface than
/// its half diagonal allows has no crossing and is not sampled. With `refine`,
/// cells that may hold surface ([`may_hold_surface`]) add their [`refined_max`]
/// to the maximum.
fn crossings_to_mesh(
    field: &dyn Field,
    grid: &Grid,
    tris: &TriGrid,
    refine: bool,
) -> SurfaceToMesh {
    let cell = grid.cell_size;
    let cap = DISTANCE_CAP_CELLS * cell;
    let lost_at = LOST_CELLS * cell;
    let lip = field.lipschitz().filter(|l| l.is_finite() && *l > 0.0);
    let nb = (grid.cells + UVec3::splat(BLOCK - 1)) / BLOCK;
    let blocks: Vec<UVec3> = (0..nb.z)
        .flat_map(|z| (0..nb.y).flat_map(move |y| (0..nb.x).map(move |x| UVec3::new(x, y, z))))
        .collect();
    let per = blocks
        .par_iter()
        .map(|&b| {
            let mut acc = (0f32, 0f64, 0usize, 0usize, Vec::new());
            let lo = b * BLOCK;
            let top = (lo + UVec3::splat(BLOCK)).min(grid.cells);
            let (plo, ptop) = (grid.corner_pos(lo), grid.corner_pos(top));
            if let Some(l) = lip {
                let fc = field.value((plo + ptop) * 0.5);
                if fc.abs() > l * 0.5 * plo.distance(ptop) * 1.001 {
                    return acc;
                }
            }
            // The block's corners, sampled on a grid of the same lattice (so at
            // bitwise the positions of `grid`'s corners).
            let sub = Grid {
                cells: top - lo,
                offset: grid.offset + lo.as_ivec3(),
                ..*grid
            };
            let c = sub.corners();
            let mut v = vec![0f32; (c.x * c.y * c.z) as usize];
            field.sample_grid(&sub, 0..c.z, &mut v);
            let at = |k: UVec3| v[((k.z * c.y + k.y) * c.x + k.x) as usize];
            // Corners this block owns: up to its far faces, which the next block
            // owns, but for the grid's own far faces.
            let own = UVec3::select(top.cmpeq(grid.cells), c, c - UVec3::ONE);
            for z in 0..own.z {
                for y in 0..own.y {
                    for x in 0..own.x {
                        let k = UVec3::new(x, y, z);
                        let f0 = at(k);
                        if !f0.is_finite() {
                            continue;
                        }
                        for n in [k + UVec3::X, k + UVec3::Y, k + UVec3::Z] {
                            if n.cmpge(c).any() {
                                continue;
                            }
                            let f1 = at(n);
                            if !f1.is_finite() || outside(f0) == outside(f1) {
                                continue;
                            }
                            let (p0, p1) = (grid.corner_pos(lo + k), grid.corner_pos(lo + n));
                            let q = crossing(field, p0, f0, p1, f1, ROOT_TOL_CELLS * cell);
                            let d = tris.nearest(q, cap);
                            acc.0 = acc.0.max(d);
                            acc.1 += d as f64;
                            acc.2 += 1;
                            acc.3 += (d > lost_at) as usize;
                        }
                        let in_block = (k + UVec3::ONE).cmplt(c).all();
                        if refine && in_block {
                            let corners = [0u32, 1, 2, 3, 4, 5, 6, 7]
                                .map(|i| at(k + UVec3::new(i & 1, (i >> 1) & 1, i >> 2)));
                            if may_hold_surface(&corners, lip, cell) {
                                let at = lo + k;
                                let m = refined_max(field, grid, at, REFINE, tris, cap);
                                acc.0 = acc.0.max(m);
                                acc.4.push((m, at));
                            }
                        }
                    }
                }
            }
            acc
        })
        .reduce(
            || (0.0, 0.0, 0, 0, Vec::new()),
            |mut a, b| {
                a.4.extend(b.4);
                (a.0.max(b.0), a.1 + b.1, a.2 + b.2, a.3 + b.3, a.4)
            },
        );
    SurfaceToMesh {
        refined: per.4,
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
