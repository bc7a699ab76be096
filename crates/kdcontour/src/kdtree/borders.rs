//! Material borders in the tree: which nodes may stand in for the cells around a
//! border ([`mark`]), and where a node that holds one splits ([`split`]).
//!
//! With materials tracked ([`Hermite::cell_material`]), a cell is one of three
//! kinds: a border passes through it (its crossings hold two materials,
//! [`material::MIXED`]); it is of one material beside such a cell or one of
//! another material; or it is free ([`Hermite::cell_border`] gives the direction
//! across the border for the first two). Nodes on or beside a border become
//! leaves only where the border stays put (they run along it); free regions
//! merge as any surface does.

use super::arena::{Arena, Ctx};
use super::KdNode;
use super::NONE;
use crate::hermite::Hermite;
use crate::material;
use crate::qef::Qef;
use glam::Vec3;

/// How far across a material border (cells) a node's vertex may be from
/// where the vertex of a cell next to the border is, for the node to stand in
/// for that cell: the border is drawn halfway between vertices of its two
/// sides, so it moves by half of this, an eighth of a cell, and the vertices
/// of triangles across a border stay within a cell of it
/// (`tests/materials.rs`). 0.5 cut a third more of what borders cost the demo
/// terrain's chunk but let those vertices reach 1.4 cells.
pub(crate) const BORDER_SHIFT: f32 = 0.25;

/// Material borders as features: with materials tracked, the node's material
/// code is its children's combined. A node that holds cells on or beside a
/// border (its code [`material::MIXED`], or cells next to one: see the module
/// docs) may stand in for them only where the border stays: for each such
/// cell, the vertex of the node nearest each of the cell's vertices is within
/// [`BORDER_SHIFT`] of it across the border ([`Hermite::cell_border`]; a node
/// running along the border keeps it, one reaching away from it would drag the
/// border along). A cell without a direction across (a border of three
/// materials, or a cell with no pure crossing) is never stood in for. Otherwise
/// the node's error is infinite: it is never a leaf at any threshold (nor
/// `leaf_ok`). A node of two materials with no cell near a border (two sheets
/// of the surface) is refused likewise. Cells themselves stay leaves.
pub(super) fn mark(
    ctx: &Ctx,
    arena: &mut Arena,
    node: &mut KdNode,
    ids: &[u32],
    kinds: Option<Kinds>,
) {
    let Some(kinds) = kinds else {
        return;
    };
    let code = node
        .children
        .iter()
        .filter(|&&c| c != NONE)
        .fold(material::UNSET, |m, &c| {
            material::combine(m, arena.material[c as usize])
        });
    arena.material.push(code);
    // Cells on or beside a border: the node keeps it or is refused.
    let near = kinds.near_border() && node.clusterable;
    if (code == material::MIXED && !near) || (near && moves_a_border(ctx, arena, node, ids)) {
        node.error = f32::INFINITY;
        node.leaf_ok = false;
    }
}

/// Whether a clustered node's vertices would move a material border: a cell of
/// `ids` on or next to one has no direction across it, or a patch whose
/// nearest component vertex is more than [`BORDER_SHIFT`] from the patch's
/// vertex across the border.
fn moves_a_border(ctx: &Ctx, arena: &Arena, node: &KdNode, ids: &[u32]) -> bool {
    let h = ctx.h;
    let lo = Vec3::from_array(node.min.map(|v| v as f32));
    let hi = Vec3::from_array(node.max.map(|v| v as f32));
    let start = node.comp_start as usize;
    let count = node.comp_count as usize;
    let mut vertices = [Vec3::ZERO; 4];
    for (k, v) in vertices.iter_mut().enumerate().take(count) {
        *v = arena.comps[start + k].position(lo, hi);
    }
    let vertices = &vertices[..count];
    ids.iter().any(|&id| {
        if !ctx.kinds[id as usize].near_border() {
            return false;
        }
        let across = h.cell_border[id as usize];
        if across == Vec3::ZERO {
            return true;
        }
        let c = h.cells[id as usize];
        let patches = ctx.tables.cell(c.config, c.mask).count as usize;
        let base = c.patch_base as usize;
        h.patch_vertex[base..base + patches].iter().any(|&v| {
            let nearest = vertices
                .iter()
                .copied()
                .min_by(|a, b| a.distance_squared(v).total_cmp(&b.distance_squared(v)));
            nearest.is_some_and(|u| (u - v).dot(across).abs() > BORDER_SHIFT)
        })
    })
}

/// What the cells of a region hold, for [`split`]: which kinds of cell
/// (`THROUGH`, `BESIDE`, `FREE` bits), the materials of the cells beside a
/// border and of the free cells (each the range of their codes, [`Span`]),
/// and how many cells.
#[derive(Clone, Copy)]
pub(super) struct Kinds {
    flags: u8,
    beside: Span,
    free: Span,
    cells: u32,
}

/// The lowest and highest of a set of pure material codes: one material when
/// they are equal, none when the lowest is above the highest. Combining two
/// is a minimum and a maximum, with no branch ([`material::combine`] reads the
/// same for pure codes).
#[derive(Clone, Copy, PartialEq, Eq)]
struct Span {
    lo: u16,
    hi: u16,
}

impl Span {
    const EMPTY: Span = Span {
        lo: u16::MAX,
        hi: 0,
    };

    /// Of one cell's code ([`material::UNSET`]: none).
    fn of(code: u16) -> Span {
        if code == material::UNSET {
            Span::EMPTY
        } else {
            Span { lo: code, hi: code }
        }
    }

    #[inline]
    fn add(self, o: Span) -> Span {
        Span {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// At most one material.
    fn single(self) -> bool {
        self.lo >= self.hi
    }
}

/// A cell a border passes through.
const THROUGH: u8 = 1;
/// A cell of one material beside a border.
const BESIDE: u8 = 2;
/// Any other cell.
const FREE: u8 = 4;

impl Kinds {
    const NONE: Kinds = Kinds {
        flags: 0,
        beside: Span::EMPTY,
        free: Span::EMPTY,
        cells: 0,
    };

    /// Active cell `id`'s.
    fn of(h: &Hermite, id: u32) -> Kinds {
        let code = h.cell_material[id as usize];
        let mut k = Kinds {
            cells: 1,
            ..Kinds::NONE
        };
        if code == material::MIXED {
            k.flags = THROUGH;
        } else if h.cell_border[id as usize] != Vec3::ZERO {
            k.flags = BESIDE;
            k.beside = Span::of(code);
        } else {
            k.flags = FREE;
            k.free = Span::of(code);
        }
        k
    }

    /// The cells of both regions.
    #[inline]
    fn add(self, o: Kinds) -> Kinds {
        Kinds {
            flags: self.flags | o.flags,
            beside: self.beside.add(o.beside),
            free: self.free.add(o.free),
            cells: self.cells + o.cells,
        }
    }

    /// Whether the region holds cells on or beside a border.
    fn near_border(&self) -> bool {
        self.flags & (BESIDE | THROUGH) != 0
    }

    /// One kind only, and one material: a region whose cells can all be
    /// treated alike (cells on a border, or beside one, merge along it; free
    /// cells of one material merge freely).
    fn alike(&self) -> bool {
        self.flags.count_ones() == 1 && self.beside.single() && self.free.single()
    }
}

thread_local! {
    /// [`split`]'s slabs (three axes) and their suffix sums, reused across
    /// nodes on each thread.
    static SLABS: std::cell::RefCell<(Vec<Kinds>, Vec<Kinds>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// Each active cell's [`Kinds`] when materials are tracked (empty otherwise),
/// read by every node's [`of_cells`].
pub(super) fn cell_kinds(h: &Hermite) -> Vec<Kinds> {
    if h.cell_material.is_empty() {
        return Vec::new();
    }
    (0..h.cells.len() as u32)
        .map(|id| Kinds::of(h, id))
        .collect()
}

/// What the cells `ids` hold, when materials are tracked.
pub(super) fn of_cells(ctx: &Ctx, ids: &[u32]) -> Option<Kinds> {
    if ctx.kinds.is_empty() {
        return None;
    }
    Some(
        ids.iter()
            .fold(Kinds::NONE, |k, &id| k.add(ctx.kinds[id as usize])),
    )
}

/// [`split`] must put at least one in this many of a node's cells into halves
/// whose cells are alike; below that the node splits by its error (a split
/// that peels off a few cells at a time would make the tree as deep as the node
/// is wide). Half, measured against a quarter (`defects` example, terrain,
/// caves and csg_mix at res 32 and 64, and their level worlds): a quarter cut
/// more triangles (csg_mix at 64 and threshold 1: 2,780 against 2,998) but
/// left more flipped faces on level seams (3,429 against 3,268).
const SPLIT_SHARE: usize = 2;

/// The most runs of alike slabs (module docs of [`split`]) along an axis for
/// [`split`] to cut between them whatever their share of the cells: a border
/// with the strips beside it and the free regions on both sides.
const MAX_RUNS: usize = 5;

/// How many runs of equal slabs (kind and material) the non-empty `slabs`
/// make, in order.
fn runs(slabs: &[Kinds]) -> usize {
    let mut count = 0;
    let mut last: Option<(u8, Span, Span)> = None;
    for k in slabs.iter().filter(|k| k.cells != 0) {
        let key = (k.flags, k.beside, k.free);
        if last != Some(key) {
            count += 1;
            last = Some(key);
        }
    }
    count
}

/// For a node whose cells are not alike (a border, the cells beside it and
/// free cells together, or two materials): the plane that puts the most cells
/// into halves whose cells are alike (at least half of them, [`SPLIT_SHARE`]), so
/// the border's cells, the strips beside it and the free regions each become
/// nodes of their own. `None` when the cells are alike (`whole`: what they
/// hold, [`of_cells`]), or no plane does it (the search by error decides). Returns the axis,
/// the plane and the halves' QEFs.
pub(super) fn split(
    ctx: &Ctx,
    ids: &[u32],
    min: [u16; 3],
    max: [u16; 3],
    total: &Qef,
    whole: Kinds,
) -> Option<(usize, u16, Qef, Qef)> {
    let h = ctx.h;
    if whole.alike() {
        return None;
    }
    // (cells in alike halves, axis, plane)
    let mut best: Option<(usize, usize, u16)> = None;
    let len = [0, 1, 2].map(|a| (max[a] - min[a]) as usize);
    let start = [0, len[0], len[0] + len[1]];
    let n = ids.len();
    SLABS.with(|scratch| {
        let (slabs, right) = &mut *scratch.borrow_mut();
        // Every axis's slabs in one pass over the cells.
        slabs.clear();
        slabs.resize(start[2] + len[2], Kinds::NONE);
        for &id in ids {
            let c = h.cells[id as usize].coord;
            let k = ctx.kinds[id as usize];
            for a in 0..3 {
                let s = start[a] + (c[a] - min[a]) as usize;
                slabs[s] = slabs[s].add(k);
            }
        }
        right.clear();
        right.extend_from_slice(slabs);
        for axis in 0..3 {
            if len[axis] <= 1 {
                continue;
            }
            let (slab, right) = (
                &slabs[start[axis]..start[axis] + len[axis]],
                &mut right[start[axis]..start[axis] + len[axis]],
            );
            // `right[s]`: slabs `s..`.
            for s in (0..len[axis] - 1).rev() {
                right[s] = right[s].add(right[s + 1]);
            }
            // Bands: every slab along the axis alike on its own, in few runs
            // of one kind and material (a border running across the axis: the
            // strips beside it, its own cells, the free regions). Splits
            // between runs then take at most as many levels as there are runs,
            // so any of them may be taken.
            let banded = slab.iter().all(|k| k.cells == 0 || k.alike()) && runs(slab) <= MAX_RUNS;
            let mut left = Kinds::NONE;
            for s in 1..len[axis] {
                left = left.add(slab[s - 1]);
                let r = right[s];
                if left.cells == 0 || r.cells == 0 {
                    continue;
                }
                let alike = left.alike() as usize * left.cells as usize
                    + r.alike() as usize * r.cells as usize;
                let enough = alike * SPLIT_SHARE >= n || (banded && alike > 0);
                if enough && best.is_none_or(|b| alike > b.0) {
                    best = Some((alike, axis, min[axis] + s as u16));
                }
            }
        }
    });
    let (_, axis, plane) = best?;
    let (ltotal, rtotal) = super::split::halves(ctx, ids, axis, plane, total);
    Some((axis, plane, ltotal, rtotal))
}
