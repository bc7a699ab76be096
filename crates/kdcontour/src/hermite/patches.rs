//! The build's third step: each crossing's plane added to the QEF of every cell
//! patch around its edge, the edge's dual quad (for the vertex step), and the
//! materials the cells see.

use super::active::CellLookup;
use super::crossing::Crossing;
use super::vertex;
use super::{ActiveCell, EdgeCrossing};
use crate::cell::{edge_index, CellTables, NO_COMP};
use crate::error::Result;
use crate::grid::Grid;
use crate::kdtree::Coarser;
use crate::material;
use crate::qef::Qef;
use glam::Vec3;
use std::collections::HashMap;

/// What the crossings add up to.
pub(super) struct Patches {
    /// QEF of each cell patch.
    pub(super) qef: Vec<Qef>,
    /// Sum of the unit normals of each patch's crossings.
    pub(super) normal: Vec<Vec3>,
    /// Edges with a sign change.
    pub(super) crossings: usize,
    /// Every edge crossing, in cell order.
    pub(super) edges: Vec<EdgeCrossing>,
    /// The dual quads of the crossings whose four cells are in the grid (forced
    /// crossings left out).
    pub(super) quads: Vec<vertex::DualQuad>,
    /// Per active cell, with borders kept: the material code of its own edges'
    /// crossings; empty otherwise.
    pub(super) own_material: Vec<u16>,
    /// The coarse cells' corners that quads across faces toward coarser chunks
    /// take instead of halo cells: vertex and unit normal (quad patch
    /// `qef.len() + i` is the `i`th).
    pub(super) fixed: Vec<(Vec3, Vec3)>,
}

/// Adds up `found` (the crossings, in cell order) over the `patches` patches of
/// `cells`; the first error in order is returned. With `coarser` (a chunk's
/// coarse cells across its faces toward coarser chunks), a quad's halo cells
/// across such a face are the coarse corners the seam will take there.
#[allow(clippy::too_many_arguments)]
pub(super) fn accumulate(
    found: Vec<Result<Vec<Crossing>>>,
    cells: &[ActiveCell],
    lookup: &CellLookup,
    values: &[f32],
    grid: &Grid,
    patches: u32,
    borders: bool,
    coarser: Option<&Coarser>,
) -> Result<Patches> {
    let tables = CellTables::get();
    let n = grid.cells;
    let cidx = |x: u32, y: u32, z: u32| grid.corner_index(x, y, z);
    let mut patch_qef = vec![Qef::default(); patches as usize];
    let mut patch_normal = vec![Vec3::ZERO; patches as usize];
    let mut crossings = 0usize;
    let mut edges = Vec::new();
    let mut quads = Vec::new();
    let mut fixed = Vec::new();
    // Each coarse corner's place in `fixed`, by its id.
    let mut fixed_index: HashMap<u32, u32> = HashMap::new();
    let mut own_material = if borders {
        vec![material::UNSET; cells.len()]
    } else {
        Vec::new()
    };
    for list in found {
        for x in list? {
            crossings += 1;
            let owner = cells[x.cell as usize];
            let e = x.edge as usize;
            let a = e / 4;
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            let mut g = [
                owner.coord[0] as u32,
                owner.coord[1] as u32,
                owner.coord[2] as u32,
            ];
            g[u] += (e % 4) as u32 & 1;
            g[v] += (e % 4) as u32 >> 1;
            edges.push(EdgeCrossing {
                key: 3 * cidx(g[0], g[1], g[2]) as u64 + a as u64,
                point: x.point,
                normal: x.normal,
            });
            // The (up to) four cells around the edge, and the edge's dual quad
            // when all four are in the grid.
            let mut quad = [u32::MAX; 4];
            for su in 0..2u32 {
                for sv in 0..2u32 {
                    if (su == 0 && g[u] == 0) || (sv == 0 && g[v] == 0) {
                        continue;
                    }
                    let mut c = g;
                    c[u] = g[u] + su - 1;
                    c[v] = g[v] + sv - 1;
                    if c[u] >= n[u] || c[v] >= n[v] {
                        continue;
                    }
                    let idx = lookup.get(c);
                    debug_assert!(idx != u32::MAX, "a cell around a crossing is active");
                    let cell = cells[idx as usize];
                    let comp = tables.cell(cell.config, cell.mask).edge_comp
                        [edge_index(a, 1 - su, 1 - sv)];
                    debug_assert!(comp != NO_COMP);
                    let p = (cell.patch_base + comp as u32) as usize;
                    // Counter-clockwise about the axis, as the contouring walks.
                    quad[[[0, 3], [1, 2]][su as usize][sv as usize]] = p as u32;
                    patch_qef[p].add_plane(x.point, x.normal);
                    patch_normal[p] += x.normal;
                    if let Some(m) = own_material.get_mut(idx as usize) {
                        *m = material::combine(*m, x.material);
                    }
                }
            }
            // A forced crossing's quad is not the field's surface (a halo
            // forced inside, a conformed face): its cells' vertices are not
            // judged by it.
            if !quad.contains(&u32::MAX) && !x.forced {
                if let Some(k) = coarser {
                    // The quadrants' cells, and which are halo cells. Only an
                    // edge the chunk's own cells touch is on a seam (one on the
                    // face, or along the chunk's edge); an edge of halo cells
                    // alone is no seam's.
                    let halo = |c: [u32; 3]| (0..3).any(|i| c[i] == 0 || c[i] + 1 == n[i]);
                    let quadrants = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(su, sv)| {
                        let mut c = g;
                        c[u] = g[u] + su - 1;
                        c[v] = g[v] + sv - 1;
                        c
                    });
                    let seam = !quadrants.iter().all(|&c| halo(c));
                    for (q, c) in quadrants.into_iter().enumerate() {
                        if !seam || !halo(c) {
                            continue;
                        }
                        if let Some(corner) = k.corner(c, g, a, q) {
                            let next = patches + fixed.len() as u32;
                            quad[q] = *fixed_index.entry(corner.id).or_insert_with(|| {
                                fixed.push((corner.pos, corner.normal));
                                next
                            });
                        }
                    }
                }
                let mut facing = Vec3::ZERO;
                facing[a] = 1.0;
                if values[cidx(g[0], g[1], g[2])] >= 0.0 {
                    quad.reverse();
                    facing = -facing;
                }
                quads.push(vertex::DualQuad {
                    patches: quad,
                    facing,
                    normal: x.normal,
                });
            }
        }
    }
    Ok(Patches {
        qef: patch_qef,
        normal: patch_normal,
        crossings,
        edges,
        quads,
        own_material,
        fixed,
    })
}
