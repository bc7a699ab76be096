//! Polygon generation at an error threshold (section 6): every minimal edge with a
//! sign change between leaves gives a triangle or a quad of its 3 or 4 surrounding
//! leaves.
//!
//! A *leaf of threshold e* is a cell, or a clusterable node whose error is at most
//! `e` (errors never decrease going up, so the first such node on the way down is
//! the cut). Extraction reads the tree only: no field sample, no rebuild.
//!
//! The inside of one tree is contoured edge by edge from its cells' leaves
//! (`edges.rs`). Seams are walked (`face_proc` and `edge_proc`, as the paper's
//! `cell_proc` does) over several trees at once ([`Part`]s placed on one lattice
//! of cells, each with its own threshold): `face_proc` on two chunk roots and
//! `edge_proc` on the four chunk roots around a chunk edge meet each tree at its
//! own cut, so neighbours at different thresholds join without cracks.

mod edges;
pub(super) mod levels;

use super::{KdNode, KdTree, NONE};
use crate::mesh::IndexedMesh;
use glam::IVec3;

/// Quadrants around an edge along axis `d`, with `u = (d + 1) % 3` and
/// `v = (d + 2) % 3`: 0 = (u-, v-), 1 = (u+, v-), 2 = (u+, v+), 3 = (u-, v+). In this
/// order the quadrants turn counter-clockwise about +d.
const QUADRANT: [(i32, i32); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// One tree in a walk: where its cell (0, 0, 0) sits on the shared lattice, and the
/// threshold it is cut at.
#[derive(Clone, Copy)]
pub struct Part<'a> {
    /// The tree.
    pub tree: &'a KdTree,
    /// Lattice coordinates of the tree's cell (0, 0, 0).
    pub offset: IVec3,
    /// Its error threshold.
    pub threshold: f32,
    /// Its cells are `2^shift` lattice units wide (a chunk `shift` levels coarser
    /// than the lattice; 0 for a chunk on the lattice itself). `offset` is in
    /// lattice units and a multiple of `2^shift`.
    pub shift: u32,
}

/// What to contour.
#[derive(Clone, Copy, Debug)]
pub enum Job {
    /// Everything inside part `0`.
    Cell(usize),
    /// The face between part `low` and part `high`, neighbours along `axis`.
    Face {
        /// The part below the face.
        low: usize,
        /// The part above it.
        high: usize,
        /// The axis the face is perpendicular to.
        axis: usize,
    },
    /// The edge along `axis` where four parts meet, through the lattice line
    /// `line` (its coordinates on the two axes other than `axis`; the third is
    /// ignored). One part may fill two quadrants (a coarser chunk whose face the
    /// line lies on).
    Edge {
        /// The four parts, in quadrant order (u-, v-), (u+, v-), (u+, v+),
        /// (u-, v+) with `u = (axis + 1) % 3`.
        parts: [usize; 4],
        /// The edge's axis.
        axis: usize,
        /// A point of the line (lattice units).
        line: [i32; 3],
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct NodeRef {
    t: u32,
    n: u32,
}

impl NodeRef {
    fn none() -> Self {
        NodeRef {
            t: u32::MAX,
            n: NONE,
        }
    }
    fn is_none(self) -> bool {
        self.n == NONE
    }
}

struct Walker<'a, 'b> {
    parts: &'b [Part<'a>],
    /// Per part: the vertex made for each component, or `u32::MAX`.
    vertex_of: Vec<Vec<u32>>,
    mesh: &'b mut IndexedMesh,
}

/// Trees with at least this many components find their polygons in parallel when
/// the pool has more than one thread (below it the batches' set-up outweighs the
/// work).
const PARALLEL_COMPS: usize = 16_384;

/// Contours `jobs` over `parts` into `out` (appended; vertices are shared between
/// the jobs of one call).
pub fn contour(parts: &[Part], jobs: &[Job], out: &mut IndexedMesh) {
    let mut w = Walker {
        parts,
        vertex_of: parts
            .iter()
            .map(|p| vec![u32::MAX; p.tree.comps.len()])
            .collect(),
        mesh: out,
    };
    for job in jobs {
        let root = |i: usize| NodeRef {
            t: i as u32,
            n: parts[i].tree.root,
        };
        match *job {
            Job::Cell(i) => {
                let tree = parts[i].tree;
                let parallel =
                    rayon::current_num_threads() > 1 && tree.comps.len() >= PARALLEL_COMPS;
                let polygons = edges::inside(tree, parts[i].threshold, parallel);
                w.emit_polygons(i as u32, &polygons);
            }
            Job::Face { low, high, axis } => w.face_proc([root(low), root(high)], axis),
            Job::Edge {
                parts: p,
                axis,
                line,
            } => {
                let r = p.map(root);
                if r.iter().any(|x| x.is_none()) {
                    continue;
                }
                w.edge_job(r, axis, line);
            }
        }
    }
}

impl KdTree {
    /// Contours the tree at `threshold` into `out` (cleared first, capacity kept).
    /// A negative threshold gives uniform Dual Marching Cubes.
    ///
    /// Large trees find their polygons in parallel on the current rayon pool
    /// (batches of cells, emitted in order), so the mesh is the same on any
    /// number of threads.
    pub fn extract(&self, threshold: f32, out: &mut IndexedMesh) {
        out.reset();
        let parts = [Part {
            tree: self,
            offset: IVec3::ZERO,
            threshold,
            shift: 0,
        }];
        contour(&parts, &[Job::Cell(0)], out);
    }

    /// Contours the tree at `threshold` into a new mesh.
    pub fn mesh(&self, threshold: f32) -> IndexedMesh {
        let mut m = IndexedMesh::default();
        self.extract(threshold, &mut m);
        m
    }
}

impl Walker<'_, '_> {
    fn part(&self, r: NodeRef) -> &Part<'_> {
        &self.parts[r.t as usize]
    }

    fn node(&self, r: NodeRef) -> &KdNode {
        &self.part(r).tree.nodes[r.n as usize]
    }

    fn leaf(&self, r: NodeRef) -> bool {
        let p = self.part(r);
        p.tree.is_leaf(r.n, p.threshold)
    }

    /// The node's box on the shared lattice.
    fn bounds(&self, r: NodeRef) -> ([i32; 3], [i32; 3]) {
        let nd = self.node(r);
        let p = self.part(r);
        let (o, s) = (p.offset.to_array(), p.shift);
        (
            [0, 1, 2].map(|a| ((nd.min[a] as i32) << s) + o[a]),
            [0, 1, 2].map(|a| ((nd.max[a] as i32) << s) + o[a]),
        )
    }

    /// An edge job: the four roots around `line` along `axis`, over the stretch
    /// all four boxes share.
    fn edge_job(&mut self, r: [NodeRef; 4], axis: usize, line: [i32; 3]) {
        let (lo, hi) = r.iter().fold((i32::MIN, i32::MAX), |(lo, hi), &x| {
            let b = self.bounds(x);
            (lo.max(b.0[axis]), hi.min(b.1[axis]))
        });
        self.edge_proc(r, axis, line, lo, hi, false);
    }

    fn split(&self, r: NodeRef) -> (usize, i32, NodeRef, NodeRef) {
        let nd = self.node(r);
        let a = nd.axis as usize;
        let child = |c: u32| {
            if c == NONE {
                NodeRef::none()
            } else {
                NodeRef { t: r.t, n: c }
            }
        };
        let p = self.part(r);
        (
            a,
            ((nd.split as i32) << p.shift) + p.offset[a],
            child(nd.children[0]),
            child(nd.children[1]),
        )
    }

    fn volume(&self, r: NodeRef) -> i64 {
        let (lo, hi) = self.bounds(r);
        (0..3).map(|a| (hi[a] - lo[a]) as i64).product()
    }

    /// Whether lattice corner `g` is outside, read from part `t` (which must hold it).
    fn outside(&self, t: u32, g: [i32; 3]) -> bool {
        let p = &self.parts[t as usize];
        let o = p.offset.to_array();
        p.tree
            .is_outside([0, 1, 2].map(|a| ((g[a] - o[a]) >> p.shift) as u32))
    }

    #[cfg(test)]
    fn cell_proc(&mut self, r: NodeRef) {
        if r.is_none() || self.leaf(r) {
            return;
        }
        let (axis, _, a, b) = self.split(r);
        self.cell_proc(a);
        self.cell_proc(b);
        if !a.is_none() && !b.is_none() {
            self.face_proc([a, b], axis);
        }
    }

    /// `n[0]` lies below the common face (perpendicular to `axis`), `n[1]` above.
    fn face_proc(&mut self, n: [NodeRef; 2], axis: usize) {
        if n[0].is_none() || n[1].is_none() {
            return;
        }
        let leaf = [self.leaf(n[0]), self.leaf(n[1])];
        if leaf[0] && leaf[1] {
            return;
        }
        // Refine the larger non-leaf.
        let k = if leaf[0] {
            1
        } else if leaf[1] || self.volume(n[0]) >= self.volume(n[1]) {
            0
        } else {
            1
        };
        let (s, p, lo_child, hi_child) = self.split(n[k]);
        if s == axis {
            // Keep the child that touches the face.
            let mut m = n;
            m[k] = if k == 0 { hi_child } else { lo_child };
            self.face_proc(m, axis);
            return;
        }
        let (nb, ob) = (self.bounds(n[k]), self.bounds(n[1 - k]));
        let flo = nb.0[s].max(ob.0[s]);
        let fhi = nb.1[s].min(ob.1[s]);
        let mut m = n;
        if p <= flo {
            m[k] = hi_child;
            self.face_proc(m, axis);
        } else if p >= fhi {
            m[k] = lo_child;
            self.face_proc(m, axis);
        } else {
            m[k] = lo_child;
            self.face_proc(m, axis);
            m[k] = hi_child;
            self.face_proc(m, axis);
            // The split plane cuts the face along an edge in direction d.
            let d = 3 - axis - s;
            let u = (d + 1) % 3;
            let o = n[1 - k];
            let mut slots = [NodeRef::none(); 4];
            for (q, &(qu, qv)) in QUADRANT.iter().enumerate() {
                let (side_face, side_split) = if axis == u { (qu, qv) } else { (qv, qu) };
                slots[q] = if side_face as usize == k {
                    if side_split == 0 {
                        lo_child
                    } else {
                        hi_child
                    }
                } else {
                    o
                };
            }
            let mut line = [0i32; 3];
            line[axis] = self.bounds(n[0]).1[axis];
            line[s] = p;
            let dlo = nb.0[d].max(ob.0[d]);
            let dhi = nb.1[d].min(ob.1[d]);
            self.edge_proc(slots, d, line, dlo, dhi, false);
        }
    }

    /// The four nodes around the segment `[lo, hi]` along axis `d` through `line`
    /// (its coordinates on the two other axes).
    /// `crossing`: the segment is already known to change sign (the caller
    /// refined a node without shortening it), so it is not scanned again.
    fn edge_proc(
        &mut self,
        slots: [NodeRef; 4],
        d: usize,
        line: [i32; 3],
        lo: i32,
        hi: i32,
        crossing: bool,
    ) {
        if slots.iter().any(|s| s.is_none())
            || lo >= hi
            || !(crossing || self.has_crossing(self.finest(&slots), d, line, lo, hi))
        {
            return;
        }
        // Refine the largest non-leaf.
        let mut pick = None;
        let mut best = 0;
        for &n in &slots {
            if !self.leaf(n) {
                let vol = self.volume(n);
                if pick.is_none() || vol > best {
                    pick = Some(n);
                    best = vol;
                }
            }
        }
        let Some(n) = pick else {
            self.emit(slots, d, line, lo, hi);
            return;
        };
        let (s, p, lc, hc) = self.split(n);
        let replace = |f: &dyn Fn(usize) -> NodeRef| {
            let mut out = slots;
            for q in 0..4 {
                if slots[q] == n {
                    out[q] = f(q);
                }
            }
            out
        };
        if s == d {
            if p > lo && p < hi {
                self.edge_proc(replace(&|_| lc), d, line, lo, p, false);
                self.edge_proc(replace(&|_| hc), d, line, p, hi, false);
            } else if p <= lo {
                self.edge_proc(replace(&|_| hc), d, line, lo, hi, true);
            } else {
                self.edge_proc(replace(&|_| lc), d, line, lo, hi, true);
            }
            return;
        }
        let u = (d + 1) % 3;
        let l = line[s];
        let next = if p == l {
            // The split plane contains the edge: children take the quadrants on
            // their side.
            replace(&|q| {
                let side = if s == u { QUADRANT[q].0 } else { QUADRANT[q].1 };
                if side == 0 {
                    lc
                } else {
                    hc
                }
            })
        } else if l < p {
            replace(&|_| lc)
        } else {
            replace(&|_| hc)
        };
        self.edge_proc(next, d, line, lo, hi, true);
    }

    /// Whether the segment `[lo, hi]` along `d` through `line` changes sign. Most
    /// segments the walk meets do not, and they need no refinement at all.
    fn has_crossing(&self, t: u32, d: usize, line: [i32; 3], lo: i32, hi: i32) -> bool {
        // Corner by corner along d: one index step (the axis' stride) per corner.
        let p = &self.parts[t as usize];
        let o = p.offset.to_array();
        let (grid, bits) = (&p.tree.grid, &p.tree.outside);
        let mut g = line;
        g[d] = lo;
        let g = [0, 1, 2].map(|a| ((g[a] - o[a]) >> p.shift) as u32);
        let c = grid.corners();
        let stride = [1, c.x as usize, c.x as usize * c.y as usize][d];
        let mut i = grid.corner_index(g[0], g[1], g[2]);
        let bit = |i: usize| (bits[i / 64] >> (i % 64)) & 1;
        let first = bit(i);
        for _ in 0..(hi - lo) >> p.shift {
            i += stride;
            if bit(i) != first {
                return true;
            }
        }
        false
    }

    fn emit(&mut self, slots: [NodeRef; 4], d: usize, line: [i32; 3], lo: i32, hi: i32) {
        let t0 = self.finest(&slots);
        let step = 1 << self.parts[t0 as usize].shift;
        let mut g = line;
        g[d] = lo;
        let mut prev = self.outside(t0, g);
        let mut x = lo;
        while x < hi {
            let mut h = g;
            h[d] = x + step;
            let next = self.outside(t0, h);
            if next != prev {
                let mut ids = [0u32; 4];
                for (q, &leaf) in slots.iter().enumerate() {
                    let (local, e) = self.seam_cell(leaf, d, line, x, q);
                    let comp = self.part(leaf).tree.comp_of(leaf.n, local, e);
                    ids[q] = self.vertex(leaf, comp);
                }
                // Inside at the low end: the surface faces +d, so keep the
                // counter-clockwise quadrant order.
                let mut facing = glam::Vec3::ZERO;
                facing[d] = 1.0;
                if prev {
                    ids.reverse();
                    facing = -facing;
                }
                self.mesh.push_polygon_facing(ids, facing);
            }
            prev = next;
            x += step;
        }
    }

    fn vertex(&mut self, leaf: NodeRef, local: u8) -> u32 {
        let parts = self.parts;
        let tree = parts[leaf.t as usize].tree;
        let ci = (tree.nodes[leaf.n as usize].comp_start + local as u32) as usize;
        let slot = &mut self.vertex_of[leaf.t as usize][ci];
        if *slot == u32::MAX {
            let c = tree.comps[ci];
            let (lo, hi) = tree.node_box(leaf.n);
            *slot = self.mesh.positions.len() as u32;
            self.mesh
                .positions
                .push(tree.grid.to_world(c.position(lo, hi)));
            self.mesh.normals.push(c.normal());
            // One blend per vertex when any part has materials (a part built
            // without them gives material 0).
            if parts.iter().any(|p| !p.tree.materials.is_empty()) {
                let m = tree.materials.get(ci).copied().unwrap_or_default();
                self.mesh.materials.push(m);
            }
        }
        *slot
    }
}
