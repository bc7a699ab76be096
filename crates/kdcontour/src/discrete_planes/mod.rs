//! Boada and Navazo's octree isosurface codification based on discrete planes
//! (*An Octree Isosurface Codification Based On Discrete Planes*), as a mesher
//! over the same [`Hermite`] samples as Marching Cubes ([`crate::mc`]).
//!
//! 1. **Discretized Marching Cubes** ([`coding`]): every vertex sits at the
//!    midpoint of its crossing edge, so every polygon lies on one of a finite set
//!    of integer planes `<V, d>` ([`plane`]); each cell's contour loops are cut
//!    into planar convex facets and the cell is coded as one of five classes,
//!    Face, Edge, DoubleEdge, Band or SpecialBand ([`classes`]).
//! 2. **Bottom-up merge** ([`merge`]): the octree over the cells is visited from
//!    the parents of the cells upward; eight children are replaced by their parent
//!    when their facets together make one codifiable node (coplanar facets merge
//!    into one convex polygon per plane), which adds no error.
//! 3. **Reconstruction** ([`output`]): one polygon per plane of each terminal
//!    node, triangulated.
//!
//! ## Choices where the paper is silent
//! - *Cell loops and ambiguity*: the loops of [`crate::cell`] (Marching Cubes'
//!   own, with its face rule), so the output has Marching Cubes' topology. A loop
//!   is cut along diagonals into the fewest planar convex facets (at most three);
//!   a cell whose loops cannot be, or whose facets fit no class, is kept as its
//!   Marching Cubes polygons and never merged (counted in [`Stats::terminals`]'s
//!   last slot).
//! - *The Merging Table* is replaced by classifying the union of the eight
//!   children directly (see [`merge`]).
//! - *A plane's polygon* is the union of the children's facets on it, which the
//!   paper's intersect-and-select reconstruction equals when the merge is exact;
//!   it must be a single convex polygon, as plane-in-cube-cut-by-planes is.
//! - *Cracks and T-junctions* between a large polygon and smaller neighbours:
//!   avoided by keeping, in the large polygon, the collinear boundary points that
//!   a neighbour has as corners (see [`output`]). Closed, 2-manifold and oriented
//!   wherever Marching Cubes is, with the same Euler characteristic.
//! - *Triangles*: ear clipping of each convex polygon at strict corners (no
//!   zero-area triangles). The paper counts polygons; [`Stats::polygons`] gives
//!   those, the mesh gives triangles.
//! - *Normals*: the field's normal at the true crossing on the edge (the vertex
//!   itself is at the midpoint).
//! - *Octree*: cells are the leaves, the root covers the grid's longest side
//!   rounded up to a power of two; children outside the grid have no surface.
//!
//! ## Error
//! The paper's: vertices stand up to half a cell from the crossing along their
//! edge, and merging adds nothing (the surface is the Discretized Marching
//! Cubes surface, re-cut into larger polygons).

pub mod classes;
pub mod coding;
pub mod merge;
pub mod output;
pub mod plane;

pub use classes::{Class, Code};
pub use plane::{Facet, Plane, Point};

use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use rayon::prelude::*;

/// What the codification made, beside the mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Polygons of the Discretized Marching Cubes: planar facets of the cells
    /// before merging (one per loop for non-codifiable cells).
    pub cell_polygons: usize,
    /// Polygons after merging: one per plane of each terminal surface node, plus
    /// the loops of non-codifiable cells.
    pub polygons: usize,
    /// Terminal surface nodes by class: `F, E, DE, B^n, B*`, then non-codifiable
    /// cells.
    pub terminals: [usize; 6],
    /// Terminal surface nodes per octree level (0 = cells).
    pub per_level: Vec<usize>,
}

impl Stats {
    /// Counts `codes` as terminal nodes at `level`.
    fn add_terminals(&mut self, level: usize, codes: &[Code]) {
        if self.per_level.len() <= level {
            self.per_level.resize(level + 1, 0);
        }
        self.per_level[level] += codes.len();
        for c in codes {
            self.terminals[c.class.slot()] += 1;
            self.polygons += c.facets.len();
        }
    }
}

/// The mesh and its statistics.
#[derive(Clone, Debug, Default)]
pub struct Extraction {
    /// The triangulated polygons.
    pub mesh: IndexedMesh,
    /// Counts of polygons and terminal nodes.
    pub stats: Stats,
}

/// Meshes `h` with Boada and Navazo's discrete-planes octree.
pub fn discrete_planes(h: &Hermite) -> IndexedMesh {
    extract(h).mesh
}

/// Meshes `h` with Boada and Navazo's discrete-planes octree and counts what it
/// made.
pub fn extract(h: &Hermite) -> Extraction {
    let (pts, index) = coding::midpoints(h);
    let cells: Vec<_> = h
        .cells
        .par_iter()
        .map(|c| {
            let key = c.coord.map(u32::from);
            (key, coding::code_cell(h, c, &index))
        })
        .collect();
    let longest = h.grid.cells.max_element().max(1);
    let depth = longest.next_power_of_two().trailing_zeros();
    let mut stats = Stats::default();
    let polygons = merge::merge(cells, depth, &pts, &mut stats);
    let mesh = output::to_mesh(h, &pts, &polygons);
    Extraction { mesh, stats }
}
