//! Topology-preserving node clustering (section 5), bottom up: whether a node may
//! stand in for its subtree, and if so its components (merged from its children's)
//! and their vertices.
//!
//! [`cluster`] runs the steps in the order below; each returns early when the node
//! fails it, and nothing is written until the last:
//! 1. [`clusterable_children`], [`inhomogeneous_corners`] and
//!    [`edge_sign_changes`]: the paper's three conditions (a leaf; one clusterable
//!    child and inhomogeneous corners; two clusterable children and at most one
//!    sign change on each edge crossing the split plane), and no child above the
//!    tree's largest threshold.
//! 2. [`merge_across_split_plane`] and [`component_classes`]: "combining adjacent
//!    components of its child nodes while simultaneously inheriting disadjacent
//!    components".
//! 3. [`equivalent_to_one_cell`]: the paper's claim that such a node is equivalent
//!    to one cell, checked rather than assumed.
//! 4. [`sum_component_qefs`]: each component's QEF is the sum of its children's,
//!    and its vertex their minimiser.

use super::arena::{Arena, Ctx, NO_EDGE};
use super::{comp_in, Comp, KdNode, NONE};
use crate::cell::{corner_offset, edge_corners, edge_index, face_corners, NO_COMP};
use crate::qef::Qef;
use glam::Vec3;

/// Returned for a node that is not clusterable: no components, no edge crossings.
const NOT_CLUSTERABLE: (usize, [u16; 12]) = (0, [NO_EDGE; 12]);

/// Decides whether `node` is clusterable (section 5) and, if so, merges its
/// children's components into its own.
///
/// The paper's three conditions come first: a leaf; one clusterable child and
/// inhomogeneous corners; two clusterable children and at most one sign change on
/// each of the four edges that cross the split plane. Components then merge across
/// every crossing edge in the split plane. Finally the node must be *equivalent to
/// one cell*, the claim the paper makes for these conditions, which is checked
/// rather than assumed. Each node edge has at most one crossing; the grouping of
/// those crossings by component must be the Dual Marching Cubes grouping of the
/// node's 8 corner signs under some face resolution; every component must reach the
/// node's edges (no bubbles or tubes hidden inside); and no component may take all
/// four crossings of an ambiguous face (that would let two neighbours share two
/// segments of one face). A node that fails stays unclusterable; its children are
/// still leaves of any threshold they meet.
///
/// The children's component QEFs are `stack[base..]`. When the node clusters they
/// are replaced by its own components' QEFs; returns how many there are (0 when
/// not clusterable, and then the stack is left to the caller) and the node's edge
/// crossings.
pub(super) fn cluster(
    ctx: &Ctx,
    arena: &mut Arena,
    node: &mut KdNode,
    stack: &mut Vec<Qef>,
    base: usize,
    left_ids: &[u32],
) -> (usize, [u16; 12]) {
    match merge_children(ctx, arena, node, stack.len() - base, left_ids) {
        Some(merged) => {
            sum_component_qefs(arena, node, &merged, stack, base);
            (merged.ncomp as usize, merged.edges)
        }
        None => NOT_CLUSTERABLE,
    }
}

/// How a clusterable node's components come from its children's.
struct Merged {
    /// The clusterable children, low side first.
    kids: [u32; 2],
    /// How many of `kids` there are.
    nkids: usize,
    /// Per child component (child 0's first): the node component it merges into.
    class: [u8; 8],
    /// Number of node components.
    ncomp: u8,
    /// Per node edge: the cell coordinate of its one sign change, or [`NO_EDGE`].
    edges: [u16; 12],
}

/// Steps 1 to 3: the conditions, the merge and the equivalence check. `None` when
/// `node` is not clusterable. Reads only; `kid_comps` is how many components the
/// children have.
fn merge_children(
    ctx: &Ctx,
    arena: &Arena,
    node: &KdNode,
    kid_comps: usize,
    left_ids: &[u32],
) -> Option<Merged> {
    let (kids, nkids) = clusterable_children(arena, node, ctx.max_threshold)?;
    let bounds = NodeBox::of(node);
    let config = inhomogeneous_corners(ctx, &bounds)?;
    let edges = edge_sign_changes(arena, node)?;
    let children = ChildComps::new(arena, node, &kids[..nkids]);
    let mut uf = Uf([0, 1, 2, 3, 4, 5, 6, 7]);
    if nkids == 2 {
        merge_across_split_plane(ctx, node, &children, left_ids, &mut uf);
    }
    let (class, ncomp) = component_classes(&mut uf, kid_comps)?;
    equivalent_to_one_cell(ctx, config, &bounds, &edges, &children, &class, ncomp).then_some(
        Merged {
            kids,
            nkids,
            class,
            ncomp,
            edges,
        },
    )
}

/// The node's children that exist (a pruned half holds no active cell), all of
/// which must be clusterable, with errors no higher than the tree's largest
/// threshold `max` ([`crate::Settings::max_threshold`]): above a child that
/// exceeds it the node would too (errors never decrease going up), so no cut
/// could ever reach it, and it is not clustered at all.
fn clusterable_children(arena: &Arena, node: &KdNode, max: f32) -> Option<([u32; 2], usize)> {
    let mut kids = [NONE; 2];
    let mut nkids = 0;
    for c in node.children {
        if c != NONE {
            let kid = &arena.nodes[c as usize];
            if !kid.clusterable || kid.error > max {
                return None;
            }
            kids[nkids] = c;
            nkids += 1;
        }
    }
    Some((kids, nkids))
}

/// The box of a node in cell coordinates.
struct NodeBox {
    min: [u32; 3],
    max: [u32; 3],
}

impl NodeBox {
    fn of(node: &KdNode) -> NodeBox {
        NodeBox {
            min: node.min.map(|v| v as u32),
            max: node.max.map(|v| v as u32),
        }
    }

    /// Grid coordinates of corner `i` (numbered as a cell's, see [`crate::cell`]).
    fn corner(&self, i: usize) -> [u32; 3] {
        let o = corner_offset(i);
        [0, 1, 2].map(|a| if o[a] == 1 { self.max[a] } else { self.min[a] })
    }

    /// The box `[lo, hi]` in grid units.
    fn bounds(&self) -> (Vec3, Vec3) {
        let v = |c: [u32; 3]| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
        (v(self.min), v(self.max))
    }
}

/// The node's corner signs as a cell config, unless all 8 share one sign.
fn inhomogeneous_corners(ctx: &Ctx, bounds: &NodeBox) -> Option<u8> {
    let mut cfg = 0u8;
    for i in 0..8 {
        if ctx.outside(bounds.corner(i)) {
            cfg |= 1 << i;
        }
    }
    (cfg != 0 && cfg != 255).then_some(cfg)
}

/// Every node edge: at most one sign change, and where it is. The children know
/// theirs: an edge across the split plane is a left child's edge followed by a
/// right child's, every other edge is an edge of the child on its side (a pruned
/// child holds no active cell, so its edges have no change).
fn edge_sign_changes(arena: &Arena, node: &KdNode) -> Option<[u16; 12]> {
    let w = node.axis as usize;
    let kid_edges = |side: usize| {
        let c = node.children[side];
        if c == NONE {
            [NO_EDGE; 12]
        } else {
            arena.edges[c as usize]
        }
    };
    let (left_edges, right_edges) = (kid_edges(0), kid_edges(1));
    let mut edges = [NO_EDGE; 12];
    for e in 0..12 {
        edges[e] = if e / 4 == w {
            if left_edges[e] != NO_EDGE && right_edges[e] != NO_EDGE {
                return None;
            }
            left_edges[e].min(right_edges[e])
        } else if (edge_corners(e).0 >> w) & 1 == 0 {
            left_edges[e]
        } else {
            right_edges[e]
        };
    }
    Some(edges)
}

/// The children's components, numbered child 0's first, then child 1's.
struct ChildComps<'a> {
    arena: &'a Arena,
    node: &'a KdNode,
    kids: &'a [u32],
    /// How many components child 0 has (the offset of child 1's).
    first_count: u8,
}

impl<'a> ChildComps<'a> {
    fn new(arena: &'a Arena, node: &'a KdNode, kids: &'a [u32]) -> Self {
        ChildComps {
            arena,
            node,
            kids,
            first_count: arena.nodes[kids[0] as usize].comp_count,
        }
    }

    /// The child component that edge `edge` of fine cell `cell` belongs to.
    fn comp_of(&self, cell: [u32; 3], edge: usize) -> u8 {
        let k = if self.kids.len() == 1 {
            0
        } else {
            (cell[self.node.axis as usize] >= self.node.split as u32) as usize
        };
        let offset = if k == 0 { 0 } else { self.first_count };
        let comps = &self.arena.comps;
        offset
            + comp_in(
                &self.arena.nodes,
                |i| comps[i].parent,
                self.kids[k],
                cell,
                edge,
            )
    }
}

/// Merges the child components across every crossing edge in the split plane. Such
/// an edge lies on the high face of a left cell next to the plane, and that cell's
/// table says which of its face edges cross; the cell across the face is its
/// partner.
fn merge_across_split_plane(
    ctx: &Ctx,
    node: &KdNode,
    children: &ChildComps,
    left_ids: &[u32],
    uf: &mut Uf,
) {
    let w = node.axis as usize;
    let p = node.split as u32;
    for &id in left_ids {
        let c = ctx.h.cells[id as usize];
        if c.coord[w] as u32 + 1 != p {
            continue;
        }
        let ca = c.coord.map(|v| v as u32);
        let mut cb = ca;
        cb[w] = p;
        let cc = ctx.tables.cell(c.config, c.mask);
        for d in [(w + 1) % 3, (w + 2) % 3] {
            let u = (d + 1) % 3;
            for b_other in 0..2u32 {
                // Bits along u and v of edge d: the w bit is 1 on the left cell's
                // high face, 0 on the right cell's low face.
                let (ea, eb) = if u == w {
                    (edge_index(d, 1, b_other), edge_index(d, 0, b_other))
                } else {
                    (edge_index(d, b_other, 1), edge_index(d, b_other, 0))
                };
                if cc.edge_comp[ea] != NO_COMP {
                    uf.union(children.comp_of(ca, ea), children.comp_of(cb, eb));
                }
            }
        }
    }
}

/// Classes of the `total` child components become the node's components (at most
/// four, as in a cell): per child component its class, and the class count.
fn component_classes(uf: &mut Uf, total: usize) -> Option<([u8; 8], u8)> {
    let mut class = [NO_COMP; 8];
    let mut ncomp = 0u8;
    let mut roots = [NO_COMP; 8];
    for c in 0..total as u8 {
        let r = uf.find(c);
        if roots[r as usize] == NO_COMP {
            roots[r as usize] = ncomp;
            ncomp += 1;
        }
        class[c as usize] = roots[r as usize];
    }
    (ncomp <= 4).then_some((class, ncomp))
}

/// Whether the node, with corner signs `config`, edge crossings `edges` and its
/// components `class`, is equivalent to one Dual Marching Cubes cell: no component
/// takes all four crossings of an ambiguous face, and some face resolution groups
/// the crossings by component the way the node does.
fn equivalent_to_one_cell(
    ctx: &Ctx,
    config: u8,
    bounds: &NodeBox,
    edges: &[u16; 12],
    children: &ChildComps,
    class: &[u8; 8],
    ncomp: u8,
) -> bool {
    // The node component of each crossing edge, through the fine cell that holds
    // the crossing.
    let mut observed = [NO_COMP; 12];
    for e in 0..12 {
        if edges[e] == NO_EDGE {
            continue;
        }
        let a = e / 4;
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        let c0 = bounds.corner(edge_corners(e).0);
        let mut cell = c0;
        cell[a] = edges[e] as u32;
        let bu = (c0[u] == bounds.max[u]) as u32;
        let bv = (c0[v] == bounds.max[v]) as u32;
        cell[u] -= bu;
        cell[v] -= bv;
        observed[e] = class[children.comp_of(cell, edge_index(a, bu, bv)) as usize];
    }
    let amb = ctx.tables.ambiguous[config as usize];
    for f in 0..6 {
        if amb & (1 << f) != 0 {
            let fc = face_corners(f);
            let fe = [0, 1, 2, 3].map(|i| observed[edge_between(fc[i], fc[(i + 1) % 4])]);
            if fe.iter().all(|&c| c == fe[0]) {
                return false;
            }
        }
    }
    let mut mask = amb;
    loop {
        let t = ctx.tables.cell(config, mask);
        if t.count == ncomp && same_partition(&t.edge_comp, &observed) {
            return true;
        }
        if mask == 0 {
            return false;
        }
        mask = (mask - 1) & amb;
    }
}

/// Step 4, for a clusterable node: sums the children's component QEFs (from
/// `stack[base..]`) and normals per class, places each vertex at its QEF's
/// minimiser in the node's box, links the children's components to their class and
/// replaces the children's QEFs on the stack by the node's.
fn sum_component_qefs(
    arena: &mut Arena,
    node: &mut KdNode,
    merged: &Merged,
    stack: &mut Vec<Qef>,
    base: usize,
) {
    let (lo, hi) = NodeBox::of(node).bounds();
    let kid_qefs = &stack[base..];
    let ncomp = merged.ncomp as usize;
    let mut qefs = [Qef::default(); 4];
    let mut normals = [Vec3::ZERO; 4];
    let mut child_error = 0f32;
    let mut offset = 0u8;
    for &kid in &merged.kids[..merged.nkids] {
        let kn = arena.nodes[kid as usize];
        child_error = child_error.max(kn.error);
        for j in 0..kn.comp_count {
            let ci = (kn.comp_start + j as u32) as usize;
            let cls = merged.class[(offset + j) as usize];
            qefs[cls as usize] += &kid_qefs[(offset + j) as usize];
            normals[cls as usize] += arena.normals[ci];
            arena.comps[ci].parent = cls;
        }
        offset += kn.comp_count;
    }
    let mut error = child_error;
    node.comp_start = arena.comps.len() as u32;
    for (c, q) in qefs[..ncomp].iter().enumerate() {
        let (vertex, e) = q.solve(lo, hi);
        error = error.max(e as f32);
        arena.comps.push(Comp::pack(vertex, normals[c], lo, hi, 0));
        arena.normals.push(normals[c]);
    }
    node.comp_count = merged.ncomp;
    node.clusterable = true;
    node.error = error;
    stack.truncate(base);
    stack.extend_from_slice(&qefs[..ncomp]);
}

/// Tiny union-find over at most 8 child components.
struct Uf([u8; 8]);

impl Uf {
    fn find(&mut self, mut x: u8) -> u8 {
        while self.0[x as usize] != x {
            x = self.0[x as usize];
        }
        x
    }
    fn union(&mut self, a: u8, b: u8) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}

/// The edge between corners `c0` and `c1`, which differ along one axis.
fn edge_between(c0: usize, c1: usize) -> usize {
    let a = (c0 ^ c1).trailing_zeros() as usize;
    let lo = c0 & c1;
    edge_index(
        a,
        ((lo >> ((a + 1) % 3)) & 1) as u32,
        ((lo >> ((a + 2) % 3)) & 1) as u32,
    )
}

/// Whether two edge → component maps group the crossing edges the same way.
fn same_partition(a: &[u8; 12], b: &[u8; 12]) -> bool {
    let mut ab = [NO_COMP; 8];
    let mut ba = [NO_COMP; 8];
    for e in 0..12 {
        match (a[e], b[e]) {
            (NO_COMP, NO_COMP) => {}
            (NO_COMP, _) | (_, NO_COMP) => return false,
            (x, y) => {
                if ab[x as usize] == NO_COMP && ba[y as usize] == NO_COMP {
                    ab[x as usize] = y;
                    ba[y as usize] = x;
                } else if ab[x as usize] != y || ba[y as usize] != x {
                    return false;
                }
            }
        }
    }
    true
}
