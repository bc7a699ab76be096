//! Sharing information and iso lines: the padis that tile each box face, and the
//! iso line segments each padi contributes.
//!
//! Two boxes that meet across a face must cut it the same way or the mesh cracks.
//! The paper re-lays each farm's padis so that none crosses a box face's boundary
//! on either side. Boxes here are aligned along every axis, so two box faces on
//! one plane overlap in an aligned rectangle (per axis, one extent holds the
//! other): the padis of a face are its overlaps with the faces of the boxes across
//! it, and both boxes find the same padis.

use super::Climb;

/// An aligned rectangle of a farm: the plane `axis = plane`, samples `u0..=u1`
/// along `(axis + 1) % 3` and `v0..=v1` along `(axis + 2) % 3`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Padi {
    pub axis: usize,
    pub plane: u32,
    pub u: [u32; 2],
    pub v: [u32; 2],
}

impl Padi {
    /// Grid sample at `(u, v)` of this padi's plane.
    #[inline]
    fn sample(&self, u: u32, v: u32) -> [u32; 3] {
        let a = self.axis;
        let mut p = [0; 3];
        p[a] = self.plane;
        p[(a + 1) % 3] = u;
        p[(a + 2) % 3] = v;
        p
    }

    /// Its corners in counter-clockwise order in `(u, v)`.
    fn corners(&self) -> [[u32; 3]; 4] {
        let ([u0, u1], [v0, v1]) = (self.u, self.v);
        [
            self.sample(u0, v0),
            self.sample(u1, v0),
            self.sample(u1, v1),
            self.sample(u0, v1),
        ]
    }
}

/// The padis tiling face `(axis, side)` of box `b` (side 1: its high face).
pub(super) fn face_padis(
    c: &Climb,
    b: &super::boxes::SimpleBox,
    axis: usize,
    side: u32,
) -> Vec<Padi> {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let plane = if side == 1 { b.hi(axis) } else { b.lo[axis] };
    let whole = Padi {
        axis,
        plane,
        u: [b.lo[u], b.hi(u)],
        v: [b.lo[v], b.hi(v)],
    };
    // The cells across the face.
    let across = if side == 1 {
        plane as i64
    } else {
        plane as i64 - 1
    };
    let mut out = Vec::new();
    for cv in b.lo[v]..b.hi(v) {
        // Along a row of cells, jump from padi to padi.
        let mut cu = b.lo[u];
        while cu < b.hi(u) {
            let mut cell = [0i64; 3];
            cell[axis] = across;
            cell[u] = cu as i64;
            cell[v] = cv as i64;
            let padi = match c.box_at(cell) {
                // Nothing across (the grid's end, or a block without crossings,
                // whose face has none either): the whole face is one padi.
                None => whole,
                Some(o) => {
                    let clip = |a: usize, lo: u32, hi: u32| {
                        if o.size(a) < hi - lo {
                            [o.lo[a], o.hi(a)]
                        } else {
                            [lo, hi]
                        }
                    };
                    Padi {
                        axis,
                        plane,
                        u: clip(u, b.lo[u], b.hi(u)),
                        v: clip(v, b.lo[v], b.hi(v)),
                    }
                }
            };
            if padi.v[0] == cv {
                out.push(padi);
            }
            cu = padi.u[1];
        }
    }
    out
}

/// The key (`3 * corner index + axis`, as [`crate::hermite::EdgeCrossing::key`]) of
/// the unit edge with a sign change on the dike from sample `p` along `axis`,
/// `len` unit edges long (simple, so there is at most one).
fn dike_crossing(c: &Climb, p: [u32; 3], axis: usize, len: u32) -> Option<u64> {
    let mut q = p;
    let mut prev = c.h.is_outside(q);
    for _ in 0..len {
        let lo = q;
        q[axis] += 1;
        let next = c.h.is_outside(q);
        if next != prev {
            return Some(3 * c.h.grid.corner_index(lo[0], lo[1], lo[2]) as u64 + axis as u64);
        }
        prev = next;
    }
    None
}

/// Appends the iso line segments of `padi` to `segs`, each directed so that the
/// loops they form wind outward (towards outside samples) seen from a box whose
/// face `padi` lies on at `side` (1: the box's high face).
///
/// The padi is simple, so each side is crossed at most once: a marching squares
/// case with the crossings where the field puts them.
pub(super) fn iso_lines(c: &Climb, padi: &Padi, side: u32, segs: &mut Vec<(u64, u64)>) {
    let a = padi.axis;
    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
    let corners = padi.corners();
    let out = corners.map(|p| c.h.is_outside(p));
    if out.iter().all(|&o| o == out[0]) {
        return;
    }
    let (w, h) = (padi.u[1] - padi.u[0], padi.v[1] - padi.v[0]);
    // Side k runs from corner k to corner k + 1; walk it from its low end.
    let starts = [corners[0], corners[1], corners[3], corners[0]];
    let dirs = [(u, w), (v, h), (u, w), (v, h)];
    let crossing = |k: usize| dike_crossing(c, starts[k], dirs[k].0, dirs[k].1);
    // Going round counter-clockwise, a segment leaves the padi across the side
    // where the boundary goes from outside to inside and enters it where the
    // boundary goes from inside to outside.
    let mut emit = |from: usize, to: usize| {
        let (Some(p), Some(q)) = (crossing(from), crossing(to)) else {
            debug_assert!(false, "a side whose ends differ has a crossing");
            return;
        };
        let (p, q) = if out[from] && !out[(from + 1) % 4] {
            (p, q)
        } else {
            (q, p)
        };
        segs.push(if side == 1 { (p, q) } else { (q, p) });
    };
    let changing: Vec<usize> = (0..4).filter(|&k| out[k] != out[(k + 1) % 4]).collect();
    if changing.len() == 2 {
        emit(changing[0], changing[1]);
        return;
    }
    // Four crossings: cut off the inside corners when the outside corners are
    // joined across the padi, else the outside corners.
    let joined = outside_joined(c, padi, out);
    for k in 0..4 {
        if out[k] != joined {
            emit((k + 3) % 4, k);
        }
    }
}

/// Whether the two outside corners of an ambiguous padi (corners alternating in
/// sign) are joined across it, as Marching Cubes joins them: outside samples
/// joined along unit edges, and across each ambiguous unit face as the Marching
/// Cubes face rule resolves it ([`crate::cell`]'s resolution mask).
///
/// The paper resolves ambiguous padis by subsampling their center; with only
/// signs of samples at hand we follow the unit faces instead, so a padi never
/// joins what the uniform mesh separates.
fn outside_joined(c: &Climb, padi: &Padi, out: [bool; 4]) -> bool {
    let (w, h) = (padi.u[1] - padi.u[0], padi.v[1] - padi.v[0]);
    let (from, to) = if out[0] { (0, 2) } else { (1, 3) };
    let local = [(0, 0), (w, 0), (w, h), (0, h)];
    let at = |i: u32, j: u32| c.h.is_outside(padi.sample(padi.u[0] + i, padi.v[0] + j));
    let idx = |i: u32, j: u32| (i + (w + 1) * j) as usize;
    let mut seen = vec![false; ((w + 1) * (h + 1)) as usize];
    let mut stack = vec![local[from]];
    seen[idx(local[from].0, local[from].1)] = true;
    while let Some((i, j)) = stack.pop() {
        if (i, j) == local[to] {
            return true;
        }
        let mut next: Vec<(u32, u32)> = Vec::with_capacity(8);
        for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let (ni, nj) = (i as i64 + di, j as i64 + dj);
            if ni >= 0 && nj >= 0 && ni <= w as i64 && nj <= h as i64 {
                next.push((ni as u32, nj as u32));
            }
        }
        // Diagonals across ambiguous unit faces that join outside corners.
        for (di, dj) in [(-1i64, -1i64), (1, -1), (-1, 1), (1, 1)] {
            let (ni, nj) = (i as i64 + di, j as i64 + dj);
            if ni < 0 || nj < 0 || ni > w as i64 || nj > h as i64 {
                continue;
            }
            let (ni, nj) = (ni as u32, nj as u32);
            let (ci, cj) = (i.min(ni), j.min(nj));
            let ambiguous = at(ci, cj) == at(ci + 1, cj + 1)
                && at(ci + 1, cj) == at(ci, cj + 1)
                && at(ci, cj) != at(ci + 1, cj);
            let face = Padi {
                u: [padi.u[0] + ci, padi.u[0] + ci + 1],
                v: [padi.v[0] + cj, padi.v[0] + cj + 1],
                ..*padi
            };
            if ambiguous && unit_face_joins(c, &face) {
                next.push((ni, nj));
            }
        }
        for (ni, nj) in next {
            if at(ni, nj) && !seen[idx(ni, nj)] {
                seen[idx(ni, nj)] = true;
                stack.push((ni, nj));
            }
        }
    }
    false
}

/// Whether Marching Cubes joins the outside corners of the ambiguous unit face
/// `face`: the resolution mask bit of a cell that has it (both agree).
fn unit_face_joins(c: &Climb, face: &Padi) -> bool {
    let a = face.axis;
    let n = c.h.grid.cells;
    let mut cell = face.sample(face.u[0], face.v[0]);
    let f = if face.plane < n[a] {
        2 * a
    } else {
        cell[a] -= 1;
        2 * a + 1
    };
    let key = |p: [u32; 3]| (p[2], p[1], p[0]);
    let target = key(cell);
    c.h.cells
        .binary_search_by(|x| key(x.coord.map(u32::from)).cmp(&target))
        .map(|i| c.h.cells[i].mask >> f & 1 == 1)
        .unwrap_or(false)
}
