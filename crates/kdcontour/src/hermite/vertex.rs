//! Cell vertices (issue 13): where each patch of an active cell puts its vertex.
//!
//! Dual contouring puts a cell's vertex at its QEF's minimiser (section 4), held
//! in the cell. Where the surface bends within a cell or two sheets pass through
//! it (thin plates, a crease between three surfaces), the minimisers of the
//! cells around an edge can sit so that the edge's dual quad folds: neither
//! diagonal splits it into two triangles that face the way the edge crosses the
//! surface and agree with their vertices' normals ([`triangle_faces`]), and the
//! mesh has a flipped or self-crossing face. The clustering's fold guard
//! (`kdtree::fold`) keeps merged leaves from folding; this keeps the cells from it.
//!
//! Every patch starts at its minimiser. Each crossing edge with four cells around
//! it tests its quad ([`quad_faces`]); the patches of a quad that folds move to their mass point
//! (the mean of their crossings, which lies on the surface's side of the cell and
//! cannot overshoot), and the test repeats on the moved vertices until nothing
//! moves or every patch of a folding quad is at its mass point. Sharp features
//! are kept everywhere the quads around them do not fold.

use super::ActiveCell;
use crate::cell::CellTables;
use crate::comp::Comp;
use crate::mesh::triangle_faces;
use crate::qef::Qef;
use glam::Vec3;
use rayon::prelude::*;

/// The most rounds of moving vertices to mass points.
const MAX_ROUNDS: usize = 4;

/// The dual quad of one crossing edge with four cells around it: their patches
/// in the contouring's order (counter-clockwise about the edge's axis), and the
/// axis pointing from the inside corner to the outside one.
#[derive(Clone, Copy)]
pub(super) struct DualQuad {
    pub patches: [u32; 4],
    pub facing: Vec3,
    /// The field's unit normal where the surface crosses the edge.
    pub normal: Vec3,
}

/// Each patch's vertex (grid units; tested where [`Comp::pack`] will round it): its QEF's
/// minimiser in its cell, or its mass point where the minimiser folds a quad of
/// `quads` (see the module docs).
pub(super) fn cell_vertices(
    cells: &[ActiveCell],
    qef: &[Qef],
    normal: &[Vec3],
    quads: &[DualQuad],
) -> Vec<Vec3> {
    let tables = CellTables::get();
    // The low corner of each patch's cell.
    let mut lo = vec![Vec3::ZERO; qef.len()];
    for c in cells {
        let at = Vec3::from_array(c.coord.map(|v| v as f32));
        let count = tables.cell(c.config, c.mask).count as usize;
        let base = c.patch_base as usize;
        lo[base..base + count].fill(at);
    }
    // Where the tree will store a vertex: the quads are tested as they will be
    // meshed.
    let stored = |v: Vec3, p: usize| {
        let (l, h) = (lo[p], lo[p] + Vec3::ONE);
        Comp::pack(v, normal[p], l, h, 0).position(l, h)
    };
    let mut vertex: Vec<Vec3> = (0..qef.len())
        .into_par_iter()
        .map(|p| qef[p].solve(lo[p], lo[p] + Vec3::ONE).0)
        .collect();
    let mut rounded: Vec<Vec3> = vertex
        .par_iter()
        .enumerate()
        .map(|(p, &v)| stored(v, p))
        .collect();
    let unit: Vec<Vec3> = normal.par_iter().map(|n| n.normalize_or_zero()).collect();
    let mut at_mass = vec![false; qef.len()];
    for _ in 0..MAX_ROUNDS {
        let mut bad: Vec<u32> = quads
            .par_iter()
            .filter(|q| !quad_faces(q, &rounded, &unit))
            .flat_map_iter(|q| q.patches)
            .filter(|&p| !at_mass[p as usize])
            .collect();
        if bad.is_empty() {
            break;
        }
        bad.sort_unstable();
        bad.dedup();
        for p in bad {
            let p = p as usize;
            at_mass[p] = true;
            vertex[p] = qef[p].mass_point().as_vec3();
            rounded[p] = stored(vertex[p], p);
        }
    }
    vertex
}

/// Whether one of the quad's diagonals splits it into two triangles that both
/// face its edge's way ([`triangle_faces`], as
/// [`crate::IndexedMesh::push_polygon_facing`] splits it) and do not oppose the
/// field's normal where the surface crosses the edge (the nearest stand-in for
/// the gradient at the triangles' centroids that `validate` checks).
fn quad_faces(q: &DualQuad, vertex: &[Vec3], unit: &[Vec3]) -> bool {
    let p = q.patches.map(|i| vertex[i as usize]);
    let n = q.patches.map(|i| unit[i as usize]);
    let tri = |i: [usize; 3]| {
        let t = i.map(|k| p[k]);
        triangle_faces(t, i.map(|k| n[k]), q.facing)
            && (t[1] - t[0]).cross(t[2] - t[0]).dot(q.normal) >= 0.0
    };
    (tri([0, 1, 2]) && tri([0, 2, 3])) || (tri([0, 1, 3]) && tri([1, 2, 3]))
}
