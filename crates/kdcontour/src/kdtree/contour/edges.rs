//! The inside of one tree, edge by edge: each crossing edge whose four cells are
//! all the tree's gives the polygon of the leaves that hold those cells at the
//! threshold. These are the polygons `cell_proc` finds (a minimal edge between
//! leaves is a run of grid edges, each crossing one a polygon), found from the
//! cells up: each cell's leaf is looked up once ([`Cut`]), and nothing visits
//! the many faces and edges between leaves that have no crossing. The seams
//! between parts, where leaves of different trees meet, are walked.
//!
//! An edge inside one leaf, or on the face between two, has no polygon: the
//! walk never reaches it either, so both make the same vertices. The order
//! differs: polygons come in the depth-first order of their cells in the tree
//! (the same on any number of threads).

use super::{NodeRef, Walker, QUADRANT};
use crate::cell::{edge_index, CellTables, NO_COMP};
use crate::kdtree::{KdTree, CELL, NONE};
use rayon::prelude::*;

/// Cells per parallel batch of [`polygons`] (fewer in tests, so small trees
/// have several).
const BATCH_CELLS: usize = if cfg!(test) { 256 } else { 4096 };

/// One polygon: the leaf and component at each quadrant around its edge
/// (counter-clockwise about +`d`), and whether the edge's low end is outside.
#[derive(Clone, Copy)]
pub(super) struct Polygon {
    corners: [(u32, u8); 4],
    d: u8,
    flip: bool,
}

/// The leaf holding each cell of the tree at a threshold: the highest node on the
/// cell's root-to-cell path that is a leaf there. Looked up by row: the cells are
/// sorted by their linear index in the root box, with where each row of the box
/// (along x) starts, so memory follows the surface, not the box.
struct Cut {
    lo: [u32; 3],
    dims: [u32; 3],
    /// (x relative to the box, leaf) of every cell of the tree, row by row.
    cells: Vec<(u32, u32)>,
    /// Per row of the box (`y + dims[1] * z`, relative): its first cell in
    /// `cells`, and one past the last row's.
    rows: Vec<u32>,
    /// (cell leaf node, its leaf) of every cell, in the tree's depth-first order.
    order: Vec<(u32, u32)>,
}

impl Cut {
    fn new(tree: &KdTree, threshold: f32) -> Self {
        let root = &tree.nodes[tree.root as usize];
        let lo = root.min.map(u32::from);
        let dims = [0, 1, 2].map(|a| (root.max[a] - root.min[a]) as u32);
        // (row, x, leaf) of every cell.
        let mut found: Vec<(usize, u32, u32)> = Vec::new();
        let mut order = Vec::new();
        let mut stack = vec![(tree.root, NONE)];
        while let Some((n, above)) = stack.pop() {
            let node = &tree.nodes[n as usize];
            let leaf = if above == NONE && tree.is_leaf(n, threshold) {
                n
            } else {
                above
            };
            if node.axis == CELL {
                let r = [0, 1, 2].map(|a| node.min[a] as u32 - lo[a]);
                order.push((n, leaf));
                found.push((r[1] as usize + dims[1] as usize * r[2] as usize, r[0], leaf));
            } else {
                for &c in &node.children {
                    if c != NONE {
                        stack.push((c, leaf));
                    }
                }
            }
        }
        // Counting sort by row, then each (short) row by x.
        let mut rows = vec![0u32; dims[1] as usize * dims[2] as usize + 1];
        for &(row, _, _) in &found {
            rows[row + 1] += 1;
        }
        for i in 1..rows.len() {
            rows[i] += rows[i - 1];
        }
        let mut next = rows.clone();
        let mut cells = vec![(0u32, NONE); found.len()];
        for (row, x, leaf) in found {
            cells[next[row] as usize] = (x, leaf);
            next[row] += 1;
        }
        for w in rows.windows(2) {
            cells[w[0] as usize..w[1] as usize].sort_unstable_by_key(|c| c.0);
        }
        Cut {
            lo,
            dims,
            cells,
            rows,
            order,
        }
    }

    /// The leaf holding cell `c`, or [`NONE`] when the tree has no such cell.
    fn leaf(&self, c: [i64; 3]) -> u32 {
        let r = [0, 1, 2].map(|a| c[a] - self.lo[a] as i64);
        if (0..3).any(|a| r[a] < 0 || r[a] >= self.dims[a] as i64) {
            return NONE;
        }
        let row = (r[1] + self.dims[1] as i64 * r[2]) as usize;
        let cells = &self.cells[self.rows[row] as usize..self.rows[row + 1] as usize];
        let x = r[0] as u32;
        cells
            .binary_search_by_key(&x, |c| c.0)
            .map_or(NONE, |k| cells[k].1)
    }
}

/// The polygons of the crossing edges that the cells `cells` (cell leaf, its
/// leaf) own (each edge along `d` by the cell on its high side in both other
/// axes), in order.
fn polygons(tree: &KdTree, cut: &Cut, cells: &[(u32, u32)]) -> Vec<Polygon> {
    let tables = CellTables::get();
    let mut out = Vec::new();
    for &(n, leaf) in cells {
        let node = &tree.nodes[n as usize];
        let own = tables.cell(node.config, node.mask);
        let coord = node.min.map(|v| v as i64);
        let held = &tree.nodes[leaf as usize].min;
        'edges: for d in 0..3 {
            if own.edge_comp[edge_index(d, 0, 0)] == NO_COMP {
                continue;
            }
            let (u, v) = ((d + 1) % 3, (d + 2) % 3);
            // The cell's leaf holds the other three cells too: no polygon.
            if coord[u] > held[u] as i64 && coord[v] > held[v] as i64 {
                continue;
            }
            let mut cells = [[0i64; 3]; 4];
            let mut leaves = [NONE; 4];
            for (q, &(qu, qv)) in QUADRANT.iter().enumerate() {
                cells[q] = coord;
                cells[q][u] += qu as i64 - 1;
                cells[q][v] += qv as i64 - 1;
                leaves[q] = cut.leaf(cells[q]);
                if leaves[q] == NONE {
                    continue 'edges;
                }
            }
            // Inside one leaf, or on the face between two (boxes: a leaf holds
            // one, two side by side or all four of the cells): no polygon.
            if (0..4).filter(|&i| leaves[i] != leaves[(i + 3) % 4]).count() < 3 {
                continue;
            }
            let corners = [0, 1, 2, 3].map(|q| {
                let (qu, qv) = QUADRANT[q];
                let e = edge_index(d, (1 - qu) as u32, (1 - qv) as u32);
                (
                    leaves[q],
                    tree.comp_of(leaves[q], cells[q].map(|x| x as u32), e),
                )
            });
            out.push(Polygon {
                corners,
                d: d as u8,
                flip: tree.is_outside(node.min.map(u32::from)),
            });
        }
    }
    out
}

/// Every polygon inside `tree` at `threshold` (see the module docs), in parallel
/// batches of cells when `parallel`.
pub(super) fn inside(tree: &KdTree, threshold: f32, parallel: bool) -> Vec<Polygon> {
    if tree.root == NONE {
        return Vec::new();
    }
    let cut = Cut::new(tree, threshold);
    let cells = &cut.order;
    if parallel && cells.len() > BATCH_CELLS {
        let batches: Vec<Vec<Polygon>> = cells
            .par_chunks(BATCH_CELLS)
            .map(|batch| polygons(tree, &cut, batch))
            .collect();
        batches.concat()
    } else {
        polygons(tree, &cut, cells)
    }
}

impl Walker<'_, '_> {
    /// Emits `polygons` of part `t`, making their vertices as the walk does.
    pub(super) fn emit_polygons(&mut self, t: u32, polygons: &[Polygon]) {
        for p in polygons {
            let mut ids = p
                .corners
                .map(|(n, local)| self.vertex(NodeRef { t, n }, local));
            // Inside at the low end: the surface faces +d, so keep the
            // counter-clockwise quadrant order.
            let mut facing = glam::Vec3::ZERO;
            facing[p.d as usize] = 1.0;
            if p.flip {
                ids.reverse();
                facing = -facing;
            }
            self.mesh.push_polygon_facing(ids, facing);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Part, Walker};
    use crate::kdtree::KdTree;
    use crate::mesh::IndexedMesh;
    use crate::{scenes, Grid, Settings};
    use glam::IVec3;

    /// The mesh `cell_proc`'s walk down the tree gives.
    fn walked(tree: &KdTree, threshold: f32) -> IndexedMesh {
        let parts = [Part {
            tree,
            offset: IVec3::ZERO,
            threshold,
            shift: 0,
        }];
        let mut mesh = IndexedMesh::default();
        let mut w = Walker {
            parts: &parts,
            vertex_of: vec![vec![u32::MAX; tree.comps.len()]],
            mesh: &mut mesh,
        };
        if tree.root != crate::kdtree::NONE {
            w.cell_proc(super::NodeRef { t: 0, n: tree.root });
        }
        mesh
    }

    /// The mesh's vertices and its triangles (each from its least vertex, its
    /// winding kept), as bits, sorted: the same surface in any order.
    fn canonical(m: &IndexedMesh) -> (Vec<[u32; 3]>, Vec<[[u32; 3]; 3]>) {
        let bits = |i: u32| m.positions[i as usize].to_array().map(f32::to_bits);
        let mut vertices: Vec<[u32; 3]> = (0..m.positions.len() as u32).map(bits).collect();
        vertices.sort_unstable();
        let mut triangles: Vec<[[u32; 3]; 3]> = m
            .indices
            .chunks(3)
            .map(|t| {
                let p = [bits(t[0]), bits(t[1]), bits(t[2])];
                let k = (0..3).min_by_key(|&k| p[k]).expect("three corners");
                [p[k], p[(k + 1) % 3], p[(k + 2) % 3]]
            })
            .collect();
        triangles.sort_unstable();
        (vertices, triangles)
    }

    /// Edge by edge, the inside of a tree has the walk's vertices and triangles
    /// at every threshold, on one thread and in parallel batches.
    #[test]
    fn edges_give_the_walks_polygons() {
        for (name, res) in [
            ("sphere", 24),
            ("disk_pole", 32),
            ("csg_mix", 32),
            ("caves", 24),
        ] {
            let scene = scenes::scene(name).unwrap();
            let grid = Grid::cube(1.0, res);
            let tree = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
            for t in [-1.0, 0.001, 0.01, 0.1, 1.0, f32::MAX] {
                let walk = canonical(&walked(&tree, t));
                let serial = tree.mesh(t);
                assert_eq!(canonical(&serial), walk, "{name} at {t}");
                // Batches of cells in parallel give the serial mesh, index for index.
                let parts = [Part {
                    tree: &tree,
                    offset: IVec3::ZERO,
                    threshold: t,
                    shift: 0,
                }];
                let polygons = super::inside(&tree, t, true);
                let mut batched = IndexedMesh::default();
                let mut w = Walker {
                    parts: &parts,
                    vertex_of: vec![vec![u32::MAX; tree.comps.len()]],
                    mesh: &mut batched,
                };
                w.emit_polygons(0, &polygons);
                assert_eq!(batched.indices, serial.indices, "{name} at {t}");
                assert_eq!(batched.positions, serial.positions, "{name} at {t}");
            }
        }
    }
}
