//! The seam walk across chunk levels: a coarser part's leaves cover `2^shift`
//! lattice cells per side, so a fine seam edge is mapped to the coarse cell and
//! edge it lies on (the rules are in [`crate::world`]).

use super::{NodeRef, Walker, QUADRANT};
use crate::cell::edge_index;

/// The first edge with a sign change on face `side` (0 low, 1 high) of `cell`
/// perpendicular to axis `w`, as a cell edge index (`outside` reads the corner
/// signs).
fn face_crossing(
    outside: &impl Fn([u32; 3]) -> bool,
    cell: [u32; 3],
    w: usize,
    side: u32,
) -> Option<usize> {
    for a in [(w + 1) % 3, (w + 2) % 3] {
        let r = 3 - a - w;
        for k in 0..2u32 {
            let mut lo = cell;
            lo[w] += side;
            lo[r] += k;
            let mut hi = lo;
            hi[a] += 1;
            if outside(lo) != outside(hi) {
                // Offsets along (a + 1) % 3 and (a + 2) % 3.
                let (bw, br) = (side, k);
                let e = if (a + 1) % 3 == w {
                    edge_index(a, bw, br)
                } else {
                    edge_index(a, br, bw)
                };
                return Some(e);
            }
        }
    }
    None
}

/// The cell in quadrant `q` around the seam line along `d` through `line`, at
/// lattice step `x`, of a part whose cells are `2^shift` lattice units wide
/// (`line` and `x` in lattice units from the part's cell (0, 0, 0)), and the
/// edge of that cell whose component the polygon takes; `outside` reads the
/// part's corner signs. `None` when the line crosses a cell face that holds no
/// crossing edge.
///
/// On the part's own lattice that is the cell's edge on the line. A coarser part
/// (see [`crate::world`]) may fill two quadrants, with the line crossing
/// the middle of one of its cell faces: the finer side's conformed samples give
/// such a fine edge a crossing only when the coarse face holds a single contour
/// segment, so any crossing edge of that face names the component.
pub(in crate::kdtree) fn seam_edge(
    line: [i32; 3],
    x: i32,
    d: usize,
    q: usize,
    shift: u32,
    outside: impl Fn([u32; 3]) -> bool,
) -> Option<([u32; 3], usize)> {
    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
    let (qu, qv) = QUADRANT[q];
    let (lu, lv) = (line[u], line[v]);
    let mut cell = [0i32; 3];
    cell[d] = x >> shift;
    cell[u] = (lu + qu - 1) >> shift;
    cell[v] = (lv + qv - 1) >> shift;
    let local = cell.map(|c| c as u32);
    let mask = (1 << shift) - 1;
    let (on_u, on_v) = (lu & mask == 0, lv & mask == 0);
    if on_u && on_v {
        return Some((local, edge_index(d, (1 - qu) as u32, (1 - qv) as u32)));
    }
    debug_assert!(on_u || on_v, "a seam line through the inside of a cell");
    // The face the line crosses: perpendicular to the on-lattice axis, on the
    // quadrant's side of the line. The fine edge runs from the midpoint of a
    // coarse edge (along the off-lattice axis) to the face center; the fine
    // contour through it cuts off the part of that coarse edge the midpoint
    // shares, so it takes that edge's component when the edge crosses. When it
    // does not, the face holds a single segment and any crossing edge names it.
    let (w, side, off) = if on_v {
        (v, (1 - qv) as u32, u)
    } else {
        (u, (1 - qu) as u32, v)
    };
    let od = if x & mask == 0 { 0 } else { 1 };
    let mut lo = local;
    lo[d] += od;
    lo[w] += side;
    let mut hi = lo;
    hi[off] += 1;
    if outside(lo) != outside(hi) {
        let at = |b: usize| if b == d { od } else { side };
        return Some((local, edge_index(off, at((off + 1) % 3), at((off + 2) % 3))));
    }
    face_crossing(&outside, local, w, side).map(|e| (local, e))
}

impl Walker<'_, '_> {
    /// The part whose signs a seam line is read from: the finest of the slots (the
    /// first of equals), whose lattice holds every corner on the line.
    pub(super) fn finest(&self, slots: &[NodeRef; 4]) -> u32 {
        let mut best = slots[0].t;
        for s in &slots[1..] {
            if self.parts[s.t as usize].shift < self.parts[best as usize].shift {
                best = s.t;
            }
        }
        best
    }

    /// The cell of `leaf`'s part (its own coordinates) in quadrant `q` around the
    /// line along `d`, at lattice step `x`, and the edge of that cell whose
    /// component the polygon takes ([`seam_edge`]).
    pub(super) fn seam_cell(
        &self,
        leaf: NodeRef,
        d: usize,
        line: [i32; 3],
        x: i32,
        q: usize,
    ) -> ([u32; 3], usize) {
        let p = self.part(leaf);
        let o = p.offset.to_array();
        let rel = [0, 1, 2].map(|a| line[a] - o[a]);
        seam_edge(rel, x - o[d], d, q, p.shift, |c| p.tree.is_outside(c))
            .expect("a coarse face with a fine crossing has a crossing edge")
    }
}
