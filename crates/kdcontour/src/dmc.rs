//! Uniform Dual Marching Cubes straight from the Hermite data: one vertex per cell
//! patch (the Hermite data's patch vertices), one quad per crossing edge whose four
//! cells are in the grid. It is the mesh at full resolution, every cell its own
//! leaf: the mesh a k-d tree gives at a threshold below zero, without building
//! the tree ([`crate::pipeline::full`]). It shares no code with the tree's
//! contouring and serves as its oracle there. Vertices and normals are stored in
//! the tree's packed form ([`crate::comp::Comp::pack`]), so both give bitwise the same
//! positions.
//!
//! The work follows the surface: the quads are the Hermite data's crossings,
//! each edge's four cells found in a table of the active cells by position, the
//! vertices the patches they use, in patch order; all are made in parallel and
//! come out in the same order on any number of threads.

use crate::cell::{edge_index, CellTables, NO_COMP};
use crate::hermite::{CellLookup, Hermite};
use crate::mesh::{quad_split, IndexedMesh};
use glam::Vec3;
use rayon::prelude::*;

/// The low corner and axis of the edge of Hermite key `key` on a grid of
/// `corners` corners.
fn edge_of(key: u64, corners: glam::UVec3) -> ([u32; 3], usize) {
    let (c, cx, cy) = (key / 3, corners.x as u64, corners.y as u64);
    (
        [c % cx, c / cx % cy, c / (cx * cy)].map(|v| v as u32),
        (key % 3) as usize,
    )
}

/// The patches of the four cells around edge `g` along `a`, counter-clockwise
/// about the axis from (u-, v-); `None` when a cell is past the grid (an open
/// edge on its boundary).
fn quad(h: &Hermite, lookup: &CellLookup, g: [u32; 3], a: usize) -> Option<[u32; 4]> {
    let tables = CellTables::get();
    let n = h.grid.cells;
    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
    if g[u] == 0 || g[v] == 0 || g[u] >= n[u] || g[v] >= n[v] {
        return None;
    }
    let mut ids = [0u32; 4];
    for (q, (qu, qv)) in [(0u32, 0u32), (1, 0), (1, 1), (0, 1)]
        .into_iter()
        .enumerate()
    {
        let mut c = g;
        c[u] = g[u] + qu - 1;
        c[v] = g[v] + qv - 1;
        let cell = h.cells[lookup.get(c) as usize];
        let comp = tables.cell(cell.config, cell.mask).edge_comp[edge_index(a, 1 - qu, 1 - qv)];
        debug_assert!(comp != NO_COMP, "a crossing edge crosses in its cells");
        ids[q] = cell.patch_base + comp as u32;
    }
    Some(ids)
}

/// Meshes `h` with uniform Dual Marching Cubes. Only the patches some quad uses
/// become vertices (a patch whose crossings all lie on the grid's boundary has
/// none).
pub fn uniform_dmc(h: &Hermite) -> IndexedMesh {
    let patches = h.patch_vertex.len();
    let corners = h.grid.corners();
    let lookup = CellLookup::new(&h.cells, h.grid.cells);
    // (edge's low corner, axis, patches) of every quad, in the edges' order.
    let quads: Vec<([u32; 3], usize, [u32; 4])> = h
        .edges
        .par_iter()
        .filter_map(|e| {
            let (g, a) = edge_of(e.key, corners);
            quad(h, &lookup, g, a).map(|ids| (g, a, ids))
        })
        .collect();
    drop(lookup);
    let mut used = vec![false; patches];
    for (_, _, ids) in &quads {
        for &p in ids {
            used[p as usize] = true;
        }
    }
    let tables = CellTables::get();
    // (patch, world position, normal) of every used patch, in patch order.
    let vertices: Vec<(u32, Vec3, Vec3)> = h
        .cells
        .par_iter()
        .flat_map_iter(|c| {
            let lo = Vec3::from_array(c.coord.map(f32::from));
            let count = tables.cell(c.config, c.mask).count as u32;
            (c.patch_base..c.patch_base + count)
                .filter(|&p| used[p as usize])
                .map(move |p| {
                    let i = p as usize;
                    let packed = h.patch_comp[i];
                    (
                        p,
                        h.grid.to_world(packed.position(lo, lo + Vec3::ONE)),
                        packed.normal(),
                    )
                })
        })
        .collect();
    let mut index = vec![u32::MAX; patches];
    let mut mesh = IndexedMesh::default();
    mesh.positions.reserve_exact(vertices.len());
    mesh.normals.reserve_exact(vertices.len());
    for (k, &(p, pos, normal)) in vertices.iter().enumerate() {
        index[p as usize] = k as u32;
        mesh.positions.push(pos);
        mesh.normals.push(normal);
    }
    // Each quad as the mesh splits it (`IndexedMesh::push_polygon_facing`: four
    // distinct cells give four distinct vertices).
    let (positions, normals) = (&mesh.positions, &mesh.normals);
    let triangles: Vec<[u32; 6]> = quads
        .par_iter()
        .map(|&(low, axis, patches)| {
            let mut ids = patches.map(|p| index[p as usize]);
            let mut facing = Vec3::ZERO;
            facing[axis] = 1.0;
            if h.is_outside(low) {
                ids.reverse();
                facing = -facing;
            }
            let [a, b] = quad_split(
                ids.map(|i| positions[i as usize]),
                ids.map(|i| normals[i as usize]),
                facing,
            );
            [
                ids[a[0]], ids[a[1]], ids[a[2]], ids[b[0]], ids[b[1]], ids[b[2]],
            ]
        })
        .collect();
    mesh.indices = triangles.into_iter().flatten().collect();
    mesh
}
