//! Marching Cubes, the primal baseline every user knows: one vertex per edge
//! crossing, one polygon per contour loop of a cell. Ambiguous faces use the same
//! rule as the dual meshers ([`crate::cell`]), so both cells sharing a face cut it
//! the same way and the mesh is watertight.

use crate::cell::{edge_corners, CellTables};
use crate::grid::Grid;
use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use std::collections::HashMap;

/// Meshes `h` with Marching Cubes (polygons fanned into triangles).
pub fn marching_cubes(h: &Hermite) -> IndexedMesh {
    let tables = CellTables::get();
    let grid = &h.grid;
    let mut mesh = IndexedMesh::default();
    let mut index = HashMap::with_capacity(h.edges.len());
    for (i, x) in h.edges.iter().enumerate() {
        mesh.positions.push(grid.to_world(x.point));
        mesh.normals.push(x.normal);
        index.insert(x.key, i as u32);
    }
    for c in &h.cells {
        let loops = &tables.loops[c.config as usize * 64 + c.mask as usize];
        for k in 0..loops.count as usize {
            let edges = loops.edges_of(k);
            let mut ids: Vec<u32> = edges
                .iter()
                .map(|&e| index[&edge_key(grid, c.coord, e)])
                .collect();
            if !forward(c.config, edges) {
                ids.reverse();
            }
            for i in 1..ids.len() - 1 {
                mesh.indices
                    .extend_from_slice(&[ids[0], ids[i], ids[i + 1]]);
            }
        }
    }
    mesh
}

/// The [`crate::hermite::EdgeCrossing::key`] of edge `e` of the cell at `coord`.
pub(crate) fn edge_key(grid: &Grid, coord: [u16; 3], e: u8) -> u64 {
    let e = e as usize;
    let (lo, _) = edge_corners(e);
    let o = crate::cell::corner_offset(lo);
    let p = [0, 1, 2].map(|a| coord[a] as u32 + o[a]);
    3 * grid.corner_index(p[0], p[1], p[2]) as u64 + (e / 4) as u64
}

/// Whether the loop's order makes a polygon facing the outside corners.
///
/// Take the loop's first edge `e` along axis `a` at offsets `(bu, bv)` on the other
/// axes `u, v`. Its two neighbours in the loop lie on its two faces: the face across
/// `u` (displaced from `e` along `v`) and the face across `v` (displaced along `u`).
/// Going from the `u`-face neighbour through `e` to the `v`-face neighbour turns by
/// `(1 - 2bu)(1 - 2bv) e_a`; the polygon faces the right way when that has the sign
/// of `e`'s inside-to-outside direction.
pub(crate) fn forward(config: u8, edges: &[u8]) -> bool {
    let e = edges[0] as usize;
    let a = e / 4;
    let u = (a + 1) % 3;
    let bu = (e % 4) & 1;
    let bv = (e % 4) >> 1;
    let next = edges[1] as usize;
    // Is `next` on e's u-face (perpendicular to u at side bu)?
    let on_u_face = {
        let (x, y) = edge_corners(next);
        next / 4 != u && (x >> u) & 1 == bu && (y >> u) & 1 == bu
    };
    let turn = (1 - 2 * bu as i32) * (1 - 2 * bv as i32);
    let (lo, _) = edge_corners(e);
    let outward = if (config >> lo) & 1 == 1 { -1 } else { 1 };
    // The loop order goes e -> next; "u-face neighbour -> e -> v-face neighbour"
    // means next is on the v-face.
    let u_to_v = !on_u_face;
    (turn == outward) == u_to_v
}
