//! Uniform Dual Marching Cubes straight from the Hermite data: one vertex per cell
//! patch (the Hermite data's patch vertices), one quad per crossing edge whose four
//! cells are in the grid. It is the mesh at full resolution, every cell its own
//! leaf: the mesh a k-d tree gives at a threshold below zero, without building
//! the tree ([`crate::pipeline::full`]). It shares no code with the tree's
//! contouring and serves as its oracle there. Vertices and normals are stored in
//! the tree's packed form ([`Comp::pack`]), so both give bitwise the same
//! positions.
//!
//! The work follows the surface: the quads are the Hermite data's crossings
//! ([`crate::hermite::Hermite::dual`]), the vertices the patches they use, in
//! patch order; both are made in parallel and come out in the same order on any
//! number of threads.

use crate::comp::Comp;
use crate::hermite::Hermite;
use crate::mesh::{quad_split, IndexedMesh};
use glam::Vec3;
use rayon::prelude::*;

/// Meshes `h` with uniform Dual Marching Cubes. Only the patches some quad uses
/// become vertices (a patch whose crossings all lie on the grid's boundary has
/// none).
pub fn uniform_dmc(h: &Hermite) -> IndexedMesh {
    let patches = h.patch_vertex.len();
    let four = |d: &[u32; 4]| !d.contains(&u32::MAX);
    let mut used = vec![false; patches];
    for d in h.dual.iter().filter(|d| four(d)) {
        for &p in d {
            used[p as usize] = true;
        }
    }
    let tables = crate::cell::CellTables::get();
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
                    let packed =
                        Comp::pack(h.patch_vertex[i], h.patch_normal[i], lo, lo + Vec3::ONE, 0);
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
    let corners = h.grid.corners();
    let (positions, normals) = (&mesh.positions, &mesh.normals);
    let triangles: Vec<[u32; 6]> = h
        .edges
        .par_iter()
        .zip(&h.dual)
        .filter(|(_, d)| four(d))
        .map(|(e, d)| {
            let axis = (e.key % 3) as usize;
            let c = e.key / 3;
            let cx = corners.x as u64;
            let cy = corners.y as u64;
            let low = [c % cx, c / cx % cy, c / (cx * cy)].map(|v| v as u32);
            let mut ids = d.map(|p| index[p as usize]);
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
