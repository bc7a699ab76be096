//! The split search (section 4.3): for a node's box, the axis and the discrete plane
//! whose halves have equal `E1`, found by binary search over probes of the halves'
//! QEFs.
//!
//! Interval summation: instead of the paper's mipmap, each node carries the list of
//! its active cells and sums their QEFs into one slab per plane position along each
//! axis (one pass for all three); prefix sums of the slabs give both halves of every
//! candidate split in O(1). Flat nodes (zero `E1`) skip the search, whose outcome
//! is known for them. The cost is O(active cells) per tree level, memory is
//! proportional to the surface rather than the volume (a 3-D summed-area table at
//! res 128 would hold 2.1 M QEFs, 340 MB), and each child's total QEF comes for free
//! from the prefix.
//!
//! Empty space first: a node of at most [`EMPTY_CUT_CELLS`] cells whose cells
//! leave a slab of its box empty is split at the face of that slab (the
//! largest one), before any search ([`empty_cut`]). The equal-`E1` search
//! cuts such slabs off too, but only once a node's cells share one plane
//! position, one cut per node and often two per cell: a height field's
//! columns of one or two cells, cut from 32 cells tall down to one, made a
//! third of the plugin's terrain chunk's nodes.

use super::arena::Ctx;
use crate::qef::Qef;

thread_local! {
    /// The slab sums of [`kd_split`], reused across nodes on each thread.
    static SCRATCH: std::cell::RefCell<Vec<Qef>> = const { std::cell::RefCell::new(Vec::new()) };
}
/// `E1` (squared grid units) at or below which a node counts as flat in the split
/// search: far below its tie tolerance (1e-9), so a flat node splits where the full
/// search would.
const FLAT_E1: f64 = 1e-12;

/// The split (section 4.3): on each axis, the plane that gives both halves equal
/// `E1`; of those, the one whose halves' errors sum lowest. Returns the axis, the
/// plane and the two halves' QEFs.
///
/// This departs from the paper, which takes the axis of largest per-dimension error
/// `E2` and searches that axis only. Measured against the octree baseline (k-d /
/// octree triangles, res 64 and 128, thresholds 0.01 and 0.1, same Hermite data),
/// the paper's rule lost to the octree on smooth round shapes: 1.58 on `sphere` at
/// 128 / 0.1, 1.04 on `torus` at 64 / 0.1. On a curved patch `E2` at the QEF
/// minimiser (near the center of curvature) is largest along the patch normal, so
/// it cuts slabs across the patch that never cluster. Evaluating every axis put all
/// 40 cases below 1 (sphere 0.41 to 0.70, torus 0.38 to 0.62, disk_pole 0.33 to
/// 0.51, anisotropic 0.008 to 0.018, box 0.58 to 0.67 where the paper's rule gave
/// 0.45 to 0.57), for a build about 1.3 to 1.5 times longer. The sum scored slightly
/// better than the larger half. `E2` still orders the axes, and so breaks ties.
pub(super) fn kd_split(
    ctx: &Ctx,
    ids: &[u32],
    min: [u16; 3],
    max: [u16; 3],
    total: &Qef,
) -> (usize, u16, Qef, Qef) {
    let total = *total;
    let ext = [max[0] - min[0], max[1] - min[1], max[2] - min[2]];
    // Axis: the largest per-dimension error E2 at the minimiser; among equals (a flat
    // patch has E2 = 0 everywhere) the longest side. Skip axes one cell thick.
    let x = total.fast_minimizer();
    // `E1` of the whole: `fast_min_error`, from the minimiser already found.
    let e1 = if total.count <= 0.0 {
        0.0
    } else {
        total.error_at(x)
    };
    let e2 = total.error_per_axis(x);
    let e2 = [e2.x, e2.y, e2.z];
    let scale = e2[0] + e2[1] + e2[2];
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| {
        let (ea, eb) = (e2[a], e2[b]);
        if (ea - eb).abs() > 1e-9 * scale + 1e-12 {
            eb.partial_cmp(&ea).unwrap()
        } else {
            ext[b].cmp(&ext[a])
        }
    });
    // The slabs that hold cells, per axis (relative to `min`).
    let (mut occ_lo, mut occ_hi) = ([u16::MAX; 3], [0u16; 3]);
    for &id in ids {
        let c = ctx.h.cells[id as usize].coord;
        for a in 0..3 {
            occ_lo[a] = occ_lo[a].min(c[a] - min[a]);
            occ_hi[a] = occ_hi[a].max(c[a] - min[a]);
        }
    }
    // A flat node (every plane the same one: `E1` of the whole is zero to
    // rounding) leaves zero error on both sides of every split, so the search below
    // would find all positions equal and every axis scoring zero, and take the
    // first axis in order at the middle of its occupied slabs. Take it without the
    // search: one sum over the left cells instead of three slab passes and the
    // probes. On `disk_pole` and the boxed terrain, a third of the summation work
    // is in such nodes (box faces, the disk).
    if e1 <= FLAT_E1 {
        let axis = *order
            .iter()
            .find(|&&a| ext[a] > 1)
            .expect("a node wider than one cell");
        let len = ext[axis] as usize;
        let s = occupied_mid(occ_lo[axis] as usize, occ_hi[axis] as usize, len).clamp(1, len - 1);
        let split = min[axis] + s as u16;
        let (ltotal, rtotal) = halves(ctx, ids, axis, split, &total);
        return (axis, split, ltotal, rtotal);
    }
    // Interval sums: one QEF per occupied slab along each axis, then prefix sums.
    // `pre[k]` sums the slabs `occ_lo..occ_lo + k`. All three axes are summed in
    // one pass over the cells (each cell's QEF is read once). The sums live in a
    // per-thread scratch buffer (no allocation per node; the buffer is free again
    // before the recursion).
    let mut scratch = SCRATCH.with(|s| std::mem::take(&mut *s.borrow_mut()));
    let span = [0, 1, 2].map(|a| {
        if ext[a] > 1 {
            (occ_hi[a] - occ_lo[a]) as usize + 1
        } else {
            0
        }
    });
    let start = [0, span[0] + 1, span[0] + span[1] + 2];
    scratch.clear();
    scratch.resize(start[2] + span[2] + 1, Qef::ZERO);
    let (mut active, mut nactive) = ([0usize; 3], 0);
    for a in 0..3 {
        if span[a] > 0 {
            active[nactive] = a;
            nactive += 1;
        }
    }
    let active = &active[..nactive];
    // Offset of each axis' slab 0 in `scratch`, so a cell's slot is `base + c`.
    let base = [0, 1, 2].map(|a| start[a] as isize + 1 - (min[a] + occ_lo[a]) as isize);
    for &id in ids {
        let q = &ctx.cell_qef[id as usize];
        let c = ctx.h.cells[id as usize].coord;
        for &a in active {
            scratch[(base[a] + c[a] as isize) as usize] += q;
        }
    }
    for &a in active {
        let pre = &mut scratch[start[a]..=start[a] + span[a]];
        for i in 1..pre.len() {
            let prev = pre[i - 1];
            pre[i] += &prev;
        }
    }
    let mut best: Option<(f64, usize, u16, Qef, Qef)> = None;
    for &axis in order.iter().filter(|&&a| ext[a] > 1) {
        let occ = (occ_lo[axis] as usize, occ_hi[axis] as usize);
        let pre = &scratch[start[axis]..=start[axis] + span[axis]];
        let (split, l, r, score) = split_on_axis(pre, min, ext, axis, occ, &total, e1);
        if best
            .as_ref()
            .is_none_or(|b| score < b.0 * (1.0 - 1e-9) - 1e-12)
        {
            best = Some((score, axis, split, l, r));
        }
    }
    SCRATCH.with(|sc| *sc.borrow_mut() = scratch);
    let (_, axis, split, l, r) = best.unwrap();
    (axis, split, l, r)
}

/// The QEFs of the cells `ids` below `plane` along `axis` and of the rest
/// (`total` less the first), for a split chosen without the slab sums.
pub(super) fn halves(ctx: &Ctx, ids: &[u32], axis: usize, plane: u16, total: &Qef) -> (Qef, Qef) {
    let mut below = Qef::ZERO;
    for &id in ids {
        if ctx.h.cells[id as usize].coord[axis] < plane {
            below += &ctx.cell_qef[id as usize];
        }
    }
    let mut rest = *total;
    rest -= &below;
    (below, rest)
}

/// The middle of the slabs `occ_lo..=occ_hi` that hold cells, as a split position
/// in `1..len` relative to the node; when all cells share one slab, the plane just
/// above it (the split cuts the empty rest off in one step).
fn occupied_mid(occ_lo: usize, occ_hi: usize, len: usize) -> usize {
    if occ_lo == occ_hi {
        if occ_lo + 1 < len {
            occ_lo + 1
        } else {
            occ_lo
        }
    } else {
        (occ_lo + occ_hi + 1).div_ceil(2)
    }
}

/// The plane along `axis` that gives both halves equal `E1`, the halves' QEFs and
/// the sum of their `E1`. `occ` is the range of slabs (relative to `min`) that hold
/// cells, `pre` the prefix sums of their QEFs and `total_e1` the whole's `E1`.
///
/// A split at `s` has the cells of slabs below `s` on its left, so its left QEF is
/// zero for `s <= occ_lo` and the whole sum for `s > occ_hi` (those positions cost
/// no QEF work).
fn split_on_axis(
    pre: &[Qef],
    min: [u16; 3],
    ext: [u16; 3],
    axis: usize,
    occ: (usize, usize),
    total: &Qef,
    total_e1: f64,
) -> (u16, Qef, Qef, f64) {
    let total = *total;
    let len = ext[axis] as usize;
    let (occ_lo, occ_hi) = occ;
    let span = occ_hi - occ_lo + 1;
    let left_of = |s: usize| -> &Qef {
        if s <= occ_lo {
            &Qef::ZERO
        } else {
            &pre[(s - occ_lo).min(span)]
        }
    };
    // E1 of the left and right halves at `s`, memoised: both binary searches
    // below start on the same probes, the final choice looks at two of them again,
    // and the caller scores the split by their sum.
    let mut memo: [(usize, f64, f64); 40] = [(usize::MAX, 0.0, 0.0); 40];
    let mut memo_len = 0usize;
    let mut errors = |s: usize| {
        let key = if s <= occ_lo {
            0
        } else if s > occ_hi {
            usize::MAX - 1
        } else {
            s
        };
        if let Some(&(_, l, r)) = memo[..memo_len].iter().find(|m| m.0 == key) {
            return (l, r);
        }
        let left = left_of(s);
        let mut right = total;
        right -= left;
        let (l, r) = (left.fast_min_error(), right.fast_min_error());
        if memo_len < memo.len() {
            memo[memo_len] = (key, l, r);
            memo_len += 1;
        }
        (l, r)
    };
    let mut diff = |s: usize| {
        let (l, r) = errors(s);
        l - r
    };
    // Position: binary search for the split whose halves have equal E1 (the left
    // half's error grows with s, the right's shrinks). Where a run of positions is
    // equal within tolerance (flat surface: every E1 is zero), take the one nearest
    // the middle of the slabs that hold cells, so neither side is empty unless all
    // cells share one slab (then the split cuts the empty rest off in one step).
    let tol = 1e-9 + 1e-6 * total_e1;
    let first = |diff: &mut dyn FnMut(usize) -> f64, pred: &dyn Fn(f64) -> bool, from: usize| {
        let (mut lo, mut hi) = (from, len);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if pred(diff(mid)) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo
    };
    let s1 = first(&mut diff, &|d| d >= -tol, 1);
    // The run of equal halves ends at or after s1 (the difference grows with s);
    // most often it is empty, and s1 already differs by more than the tolerance.
    let s2 = if s1 < len && diff(s1) > tol {
        s1 - 1
    } else {
        first(&mut diff, &|d| d > tol, s1.max(1)) - 1
    };
    let occupied_mid = occupied_mid(occ_lo, occ_hi, len);
    let s = if s1 <= s2 && s1 < len {
        occupied_mid.clamp(s1, s2.min(len - 1)).max(1)
    } else if s1 >= len {
        len - 1
    } else if s1 > 1 && diff(s1 - 1).abs() < diff(s1).abs() {
        s1 - 1
    } else {
        s1
    };
    let (el, er) = errors(s);
    let split = min[axis] + s as u16;
    let ltotal = *left_of(s);
    let mut rtotal = total;
    rtotal -= &ltotal;
    (split, ltotal, rtotal, el + er)
}

/// The most cells a node may have for [`empty_cut`] to apply. Measured over
/// the built-in scenes at res 32, 64 and 128 and thresholds 0.001 to 1 (node
/// count, worst triangle count against the search alone): 8 cells, 7.8% fewer
/// nodes and at most 1.9% more triangles (the rotated box at 64, whose other
/// resolutions lose up to 2.3%); every node, 10.3% fewer nodes but the box at
/// 64 7.5% more triangles (its flat faces' nodes take other shapes); 2 cells,
/// 3.0% and 0.5%.
pub(super) const EMPTY_CUT_CELLS: usize = 8;

/// The cut that takes the largest empty slab (by volume) off the box
/// `min..max` whose cells `ids` leave it, and the halves' QEFs (the empty
/// half's is zero); `None` when the cells reach every side of the box.
pub(super) fn empty_cut(
    ctx: &Ctx,
    ids: &[u32],
    min: [u16; 3],
    max: [u16; 3],
    total: &Qef,
) -> Option<(usize, u16, Qef, Qef)> {
    // The cells' bounding box.
    let (mut lo, mut hi) = (max, min);
    for &id in ids {
        let c = ctx.h.cells[id as usize].coord;
        for a in 0..3 {
            lo[a] = lo[a].min(c[a]);
            hi[a] = hi[a].max(c[a] + 1);
        }
    }
    let ext = [0, 1, 2].map(|a| (max[a] - min[a]) as u64);
    // (empty volume, axis, plane, whether the empty slab is below the plane)
    let mut best: Option<(u64, usize, u16, bool)> = None;
    for a in 0..3 {
        let area = ext[(a + 1) % 3] * ext[(a + 2) % 3];
        for (gap, at, below) in [
            ((lo[a] - min[a]) as u64, lo[a], true),
            ((max[a] - hi[a]) as u64, hi[a], false),
        ] {
            if gap > 0 && best.is_none_or(|b| gap * area > b.0) {
                best = Some((gap * area, a, at, below));
            }
        }
    }
    let (_, axis, split, below) = best?;
    Some(if below {
        (axis, split, Qef::ZERO, *total)
    } else {
        (axis, split, *total, Qef::ZERO)
    })
}
