//! Polygon generation at an error threshold (section 6): `cell_proc`, `face_proc`
//! and `edge_proc` walk the retained tree to every minimal edge with a sign change;
//! its 3 or 4 surrounding leaves give a triangle or a quad.
//!
//! A *leaf of threshold e* is a cell, or a clusterable node whose error is at most
//! `e` (errors never decrease going up, so the first such node on the way down is
//! the cut). Extraction reads the tree only: no field sample, no rebuild.

use super::{KdTree, NONE};
use crate::cell::edge_index;
use crate::mesh::IndexedMesh;

/// Quadrants around an edge along axis `d`, with `u = (d + 1) % 3` and
/// `v = (d + 2) % 3`: 0 = (u-, v-), 1 = (u+, v-), 2 = (u+, v+), 3 = (u-, v+). In this
/// order the quadrants turn counter-clockwise about +d.
const QUADRANT: [(u32, u32); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

struct Walker<'a> {
    tree: &'a KdTree,
    e: f32,
    vertex_of: Vec<u32>,
    mesh: &'a mut IndexedMesh,
}

impl KdTree {
    /// Contours the tree at `threshold` into `out` (cleared first, capacity kept).
    /// A negative threshold gives uniform Dual Marching Cubes.
    pub fn extract(&self, threshold: f32, out: &mut IndexedMesh) {
        out.reset();
        if self.root == NONE {
            return;
        }
        let mut w = Walker {
            tree: self,
            e: threshold,
            vertex_of: vec![u32::MAX; self.comps.len()],
            mesh: out,
        };
        w.cell_proc(self.root);
    }

    /// Contours the tree at `threshold` into a new mesh.
    pub fn mesh(&self, threshold: f32) -> IndexedMesh {
        let mut m = IndexedMesh::default();
        self.extract(threshold, &mut m);
        m
    }
}

impl Walker<'_> {
    fn leaf(&self, n: u32) -> bool {
        self.tree.is_leaf(n, self.e)
    }

    fn node(&self, n: u32) -> &super::KdNode {
        &self.tree.nodes[n as usize]
    }

    fn volume(&self, n: u32) -> u64 {
        let nd = self.node(n);
        (0..3).map(|a| (nd.max[a] - nd.min[a]) as u64).product()
    }

    fn cell_proc(&mut self, n: u32) {
        if n == NONE || self.leaf(n) {
            return;
        }
        let nd = *self.node(n);
        let [a, b] = nd.children;
        self.cell_proc(a);
        self.cell_proc(b);
        if a != NONE && b != NONE {
            self.face_proc([a, b], nd.axis as usize);
        }
    }

    /// `n[0]` lies below the common face (perpendicular to `axis`), `n[1]` above.
    fn face_proc(&mut self, n: [u32; 2], axis: usize) {
        if n[0] == NONE || n[1] == NONE {
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
        let nd = *self.node(n[k]);
        let s = nd.axis as usize;
        let [lo_child, hi_child] = nd.children;
        if s == axis {
            // Keep the child that touches the face.
            let mut m = n;
            m[k] = if k == 0 { hi_child } else { lo_child };
            self.face_proc(m, axis);
            return;
        }
        let other = self.node(n[1 - k]);
        let flo = nd.min[s].max(other.min[s]);
        let fhi = nd.max[s].min(other.max[s]);
        let p = nd.split;
        if p <= flo {
            let mut m = n;
            m[k] = hi_child;
            self.face_proc(m, axis);
        } else if p >= fhi {
            let mut m = n;
            m[k] = lo_child;
            self.face_proc(m, axis);
        } else {
            let mut m = n;
            m[k] = lo_child;
            self.face_proc(m, axis);
            m[k] = hi_child;
            self.face_proc(m, axis);
            // The split plane cuts the face along an edge in direction d.
            let d = 3 - axis - s;
            let (u, _v) = ((d + 1) % 3, (d + 2) % 3);
            let o = n[1 - k];
            // Place children and the other node into quadrants.
            let mut slots = [NONE; 4];
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
            let nd0 = self.node(n[0]);
            let mut line = [0u16; 3];
            line[axis] = nd0.max[axis];
            line[s] = p;
            let other_n = self.node(o);
            let dlo = nd.min[d].max(other_n.min[d]);
            let dhi = nd.max[d].min(other_n.max[d]);
            self.edge_proc(slots, d, line, dlo, dhi);
        }
    }

    /// The four nodes around the segment `[lo, hi]` along axis `d` through `line`
    /// (its coordinates on the two other axes).
    fn edge_proc(&mut self, slots: [u32; 4], d: usize, line: [u16; 3], lo: u16, hi: u16) {
        if slots.contains(&NONE) || lo >= hi || !self.has_crossing(d, line, lo, hi) {
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
        let nd = *self.node(n);
        let s = nd.axis as usize;
        let p = nd.split;
        let [lc, hc] = nd.children;
        let replace = |slots: [u32; 4], f: &dyn Fn(usize) -> u32| {
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
                self.edge_proc(replace(slots, &|_| lc), d, line, lo, p);
                self.edge_proc(replace(slots, &|_| hc), d, line, p, hi);
            } else if p <= lo {
                self.edge_proc(replace(slots, &|_| hc), d, line, lo, hi);
            } else {
                self.edge_proc(replace(slots, &|_| lc), d, line, lo, hi);
            }
            return;
        }
        let u = (d + 1) % 3;
        let l = line[s];
        let next = if p == l {
            // The split plane contains the edge: children take the quadrants on
            // their side.
            replace(slots, &|q| {
                let side = if s == u { QUADRANT[q].0 } else { QUADRANT[q].1 };
                if side == 0 {
                    lc
                } else {
                    hc
                }
            })
        } else if l < p {
            replace(slots, &|_| lc)
        } else {
            replace(slots, &|_| hc)
        };
        self.edge_proc(next, d, line, lo, hi);
    }

    /// Whether the segment `[lo, hi]` along `d` through `line` changes sign. Most
    /// segments the walk meets do not, and they need no refinement at all.
    fn has_crossing(&self, d: usize, line: [u16; 3], lo: u16, hi: u16) -> bool {
        let mut g = [line[0] as u32, line[1] as u32, line[2] as u32];
        g[d] = lo as u32;
        let first = self.tree.is_outside(g);
        for t in lo as u32 + 1..=hi as u32 {
            g[d] = t;
            if self.tree.is_outside(g) != first {
                return true;
            }
        }
        false
    }

    fn emit(&mut self, slots: [u32; 4], d: usize, line: [u16; 3], lo: u16, hi: u16) {
        let (u, v) = ((d + 1) % 3, (d + 2) % 3);
        let mut g = [line[0] as u32, line[1] as u32, line[2] as u32];
        g[d] = lo as u32;
        let mut prev = self.tree.is_outside(g);
        for t in lo as u32..hi as u32 {
            let mut h = g;
            h[d] = t + 1;
            let next = self.tree.is_outside(h);
            if next != prev {
                let mut ids = [0u32; 4];
                for (q, &(qu, qv)) in QUADRANT.iter().enumerate() {
                    let mut cell = g;
                    cell[d] = t;
                    cell[u] = cell[u] + qu - 1;
                    cell[v] = cell[v] + qv - 1;
                    let e = edge_index(d, 1 - qu, 1 - qv);
                    let leaf = slots[q];
                    let local = self.tree.comp_of(leaf, cell, e);
                    ids[q] = self.vertex(leaf, local);
                }
                // Inside at the low end: the surface faces +d, so keep the
                // counter-clockwise quadrant order.
                if prev {
                    ids.reverse();
                }
                self.polygon(ids);
            }
            prev = next;
        }
    }

    fn vertex(&mut self, leaf: u32, local: u8) -> u32 {
        let ci = (self.node(leaf).comp_start + local as u32) as usize;
        if self.vertex_of[ci] == u32::MAX {
            let c = self.tree.comps[ci];
            self.vertex_of[ci] = self.mesh.positions.len() as u32;
            self.mesh.positions.push(self.tree.grid.to_world(c.vertex));
            self.mesh.normals.push(c.normal);
        }
        self.vertex_of[ci]
    }

    fn polygon(&mut self, ids: [u32; 4]) {
        self.mesh.push_polygon(ids);
    }
}
