//! Uniform Dual Marching Cubes straight from the Hermite data: one vertex per cell
//! patch (the Hermite data's patch vertices), one quad per crossing edge. It shares no
//! code with the k-d tree walk and serves as the oracle for threshold < 0. Vertices and normals are stored in the
//! k-d tree's packed form ([`Comp::pack`]), so both give bitwise the same positions.

use crate::cell::{edge_index, CellTables};
use crate::comp::Comp;
use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use glam::Vec3;

/// Meshes `h` with uniform Dual Marching Cubes.
pub fn uniform_dmc(h: &Hermite) -> IndexedMesh {
    let tables = CellTables::get();
    let n = h.grid.cells;
    let mut mesh = IndexedMesh::default();
    for c in &h.cells {
        let lo = Vec3::new(c.coord[0] as f32, c.coord[1] as f32, c.coord[2] as f32);
        for k in 0..tables.cell(c.config, c.mask).count as usize {
            let p = c.patch_base as usize + k;
            let packed = Comp::pack(h.patch_vertex[p], h.patch_normal[p], lo, lo + Vec3::ONE, 0);
            mesh.positions
                .push(h.grid.to_world(packed.position(lo, lo + Vec3::ONE)));
            mesh.normals.push(packed.normal());
        }
    }
    let find = |c: [u32; 3]| {
        let key = (c[2], c[1], c[0]);
        h.cells
            .binary_search_by(|a| {
                (a.coord[2] as u32, a.coord[1] as u32, a.coord[0] as u32).cmp(&key)
            })
            .ok()
    };
    let corners = h.grid.corners();
    for z in 0..corners.z {
        for y in 0..corners.y {
            for x in 0..corners.x {
                let g = [x, y, z];
                for d in 0..3 {
                    if g[d] >= n[d] {
                        continue;
                    }
                    let mut e = g;
                    e[d] += 1;
                    let inside_low = !h.is_outside(g);
                    if inside_low != h.is_outside(e) {
                        continue;
                    }
                    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
                    if g[u] == 0 || g[v] == 0 || g[u] >= n[u] || g[v] >= n[v] {
                        continue; // on the grid boundary: an open edge
                    }
                    let mut ids = [0u32; 4];
                    for (q, (qu, qv)) in [(0u32, 0u32), (1, 0), (1, 1), (0, 1)]
                        .into_iter()
                        .enumerate()
                    {
                        let mut c = g;
                        c[u] = g[u] + qu - 1;
                        c[v] = g[v] + qv - 1;
                        let cell = h.cells[find(c).expect("cells around a crossing are active")];
                        let comp = tables.cell(cell.config, cell.mask).edge_comp
                            [edge_index(d, 1 - qu, 1 - qv)];
                        ids[q] = cell.patch_base + comp as u32;
                    }
                    let mut facing = glam::Vec3::ZERO;
                    facing[d] = 1.0;
                    if !inside_low {
                        ids.reverse();
                        facing = -facing;
                    }
                    mesh.push_polygon_facing(ids, facing);
                }
            }
        }
    }
    mesh
}
