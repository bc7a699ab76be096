//! # kdcontour
//!
//! Adaptive isosurface extraction through a **discrete k-d tree**, after
//! *Discrete k-d Tree Hierarchy for Isosurface Extraction*: a field is sampled on a
//! uniform grid, Hermite data (edge crossings found on the field, normals from its
//! gradient) feeds per-component quadratic error functions, a k-d tree is built top
//! down by splitting on the axis of largest per-dimension error at the plane that
//! balances the error of the halves, nodes are clustered bottom up where topology
//! allows, and the tree is contoured at any error threshold: each crossing edge's
//! polygon joins the leaves that hold its cells (the polygons of the paper's
//! `cell_proc` / `face_proc` / `edge_proc`, which walk the seams between chunks). The
//! tree is retained: a new threshold is a cheap re-extraction, never a rebuild or a
//! re-sample.
//!
//! ```
//! use kdcontour::{Grid, KdTree, Settings, validate};
//! let field = kdcontour::scenes::scene("torus").unwrap().field;
//! let grid = Grid::cube(1.0, 32);
//! let tree = KdTree::build(&*field, &grid, &Settings::default()).unwrap();
//! let fine = tree.mesh(-1.0);   // uniform Dual Marching Cubes
//! let coarse = tree.mesh(0.01); // adaptive, same topology
//! assert!(coarse.triangle_count() < fine.triangle_count());
//! assert!(validate(&coarse, None).is_closed_manifold());
//! ```
//!
//! ## Pipeline and modules
//! Data flows one way: [`field`] -> [`hermite`] (built on [`qef`] and [`cell`]) ->
//! [`kdtree`] -> [`world`], with [`io`], [`validate`](mod@validate) and
//! [`mesh`](mod@mesh) beside. [`settings`] (with the memory [`budget`]) and
//! [`error`] sit below them all. The chunk pipeline (samples -> Hermite data ->
//! tree -> paint -> extract) is written once, in [`pipeline`]: [`KdTree::build`]
//! runs it over a grid, a [`World`]'s chunks over their own grids. At full
//! resolution (every cell its own leaf) no tree is needed: [`pipeline::full`]
//! gives the mesh a tree gives below threshold 0 straight from the Hermite data,
//! in the time of sampling and the Hermite data alone.
//!
//! ## Inputs and baselines
//! - Fields: [`field::sdf`] primitives, [`field::csg`] trees and JSON scene files,
//!   [`field::terrain`] noise, [`field::volume`] sampled volumes (loaded by
//!   [`io::volume`] from raw or NIfTI-1 files), [`field::mesh_sdf`] triangle meshes
//!   (loaded by [`io::mesh`] from OBJ or PLY), or any [`Field`].
//! - Materials ([`material`]): a field may say which material is where
//!   ([`Field::material`]); meshes then carry one [`MaterialBlend`] per vertex
//!   and the tree keeps material borders crisp ([`Settings::material_borders`]).
//! - Baselines on the same Hermite data ([`meshers`]): Marching Cubes ([`mc`]),
//!   uniform Dual Marching Cubes ([`dmc`]), the octree ([`Partition::Octree`]) and
//!   Boada and Navazo's discrete-planes octree ([`discrete_planes`]).
//!
//! ## What the mesher guarantees
//! - **Watertight, 2-manifold, consistently oriented** output for a surface that is
//!   closed inside the grid, at every threshold. Cells hold up to four vertices (Dual
//!   Marching Cubes components) and ambiguous faces are resolved the same way by
//!   both cells that share them (see [`cell`]).
//! - **Topology is kept as the threshold grows**: a node is only clustered when it is
//!   equivalent to a single cell (checked, see `kdtree/cluster.rs` and [`kdtree`]),
//!   so the Euler characteristic at any threshold equals the uniform one.
//! - **Sharp features**: vertices minimise the QEF of their crossings, so box corners
//!   and CSG creases are reproduced; each vertex stays inside its cell or node.
//! - **Crack-free chunk worlds**: the chunks of a [`World`], at different
//!   thresholds and at different levels, cells doubling per level (2:1 balanced
//!   [`world::Layout`]s), weld into one closed, 2-manifold, oriented mesh with no
//!   skirts, transition cells or overlap: the finer side of a level seam conforms
//!   to the coarser (see [`world`]).
//! - **Surfaces that leave the grid** ([`Settings::boundary`], see [`boundary`]):
//!   by default ([`Boundary::Open`]) the mesh ends half a cell inside the grid's
//!   faces at every threshold, covering what the uniform mesh covers (nodes the
//!   surface leaves through stay one cell thick across that face, and one cell
//!   where its trace on the face turns); with
//!   [`Boundary::Capped`] the solid is cut by the grid's box and closed in its
//!   faces, so the mesh is watertight and 2-manifold (check it against
//!   [`boundary::CappedField`]).
//! - **Determinism**: one thread or many give the identical mesh.
//! - **Bad input is an [`Error`]**: NaN / infinite samples, empty or oversized grids,
//!   malformed scene files (with line and column).
//!
//! - **No polygon folds**: every polygon of a chunk's own mesh, at every
//!   threshold, faces the way its grid edge crosses the surface, does not oppose
//!   its vertices' normals, has more than zero area, and no triangle of it is flipped
//!   against the field's gradient at its centroid, where [`validate`](mod@validate) counts
//!   flipped faces ([`facing`]); a node whose polygons would fold is never a leaf
//!   (`kdtree/fold.rs`), and a cell whose quads would fold moves its vertex toward
//!   its mass point (`hermite/vertex.rs`). On every analytic and CSG built-in
//!   scene (all but the noise terrain and caves) at res 32 and 64 and thresholds
//!   -1 to 1 the meshes have no flipped, zero-area, crossing or overlapping face,
//!   with material borders or without (`tests/folds.rs`); so do planes, slabs,
//!   cylinders and boxes crossing the grid, open or capped (`tests/boundary.rs`).
//!
//! ## What it does not guarantee
//! - The uniform (threshold -1) mesh can have defects of its own, and so every
//!   threshold: where two surfaces pass within a fraction of a cell (csg_mix's
//!   capsule under its box at res 96 and 128, the gyroid's shell where its sphere
//!   cuts it at res 128, a rough height field's sub-cell bumps) the cells'
//!   vertices are clamped onto a shared face and no move unfolds them, and a
//!   union of touching solids has a zero field inside the solid, where a face's
//!   centroid can read a gradient that points the wrong way. The vertex tests
//!   read the gradient only for triangles more than
//!   [`facing::FIELD_CHECK_DEGREES`] from a vertex normal. Chunk seams are checked
//!   only against the neighbour's finest cells, so a seam next to a coarser chunk
//!   can still fold. [`validate_with`] counts all of these (see
//!   [`validate`](mod@validate) for what each figure means); the tests record
//!   today's counts per scene (`tests/geometry.rs`).
//! - A vertex holds one material blend, so a border between materials is drawn
//!   along mesh edges only where [`material::split_borders`] splits the vertices
//!   on it: on creases (a CSG cut, a cave mouth; the plugin does this for every
//!   chunk it draws). A border across smooth surface fades over the faces that
//!   cross it.
//! - Features thinner than a cell are not resolved (the grid decides topology).
//! - A surface that leaves the grid is open there by default
//!   ([`Boundary::Open`]); [`Boundary::Capped`] closes it along the grid's faces.
//! - Next to a coarser chunk a finer chunk follows the coarse contour, so its
//!   vertices there may stand up to about a cell further from the surface than
//!   its threshold alone allows; away from level seams each chunk keeps its bound
//!   in its own cells.
//! - A tree built with [`Settings::max_threshold`] is cut at that threshold when
//!   asked for a higher one: its mesh there keeps the error bound of the limit,
//!   not of the coarser threshold asked, and has more triangles than it would.
//! - A tree built with [`Settings::min_threshold`] is cut at that threshold when
//!   asked for a lower one (full resolution too): its mesh there is the coarser
//!   one, whose polygons the fold guard checked; lower cuts are not checked.
//!
//! Error thresholds are QEF residuals in squared cells (a sum over the crossings
//! a vertex stands for), so a threshold means the same at every resolution.

// Loops over the 3 axes, 8 corners and 12 edges of a cell read best with indices.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod boundary;
pub mod budget;
pub mod cell;
pub mod comp;
pub mod discrete_planes;
pub mod dmc;
pub mod edit;
pub mod error;
pub mod facing;
pub mod field;
pub mod geometry;
pub mod grid;
pub mod hermite;
pub mod io;
pub mod kdtree;
pub mod material;
pub mod mc;
pub mod mesh;
pub mod meshers;
pub mod pipeline;
pub mod qef;
mod root;
pub mod scenes;
pub mod settings;
pub mod skeleton_climbing;
pub mod validate;
pub mod world;

pub use budget::Budget;
pub use error::{Error, Result, SceneError};
pub use field::csg::{Csg, CsgNode};
pub use field::Field;
pub use grid::Grid;
pub use kdtree::{BuildStats, KdTree};
pub use material::MaterialBlend;
pub use mesh::IndexedMesh;
pub use settings::{Boundary, Partition, Settings};
pub use validate::{validate, validate_with, Checks, MeshReport};
pub use world::{Lod, World};

/// What most users of the core need, in one import: `use kdcontour::prelude::*;`.
pub mod prelude {
    pub use crate::edit::{Brush, BrushOp, EditedField};
    pub use crate::field::csg::{Csg, CsgNode};
    pub use crate::field::Field;
    pub use crate::grid::Grid;
    pub use crate::kdtree::KdTree;
    pub use crate::material::MaterialBlend;
    pub use crate::mesh::IndexedMesh;
    pub use crate::settings::{Boundary, Budget, Partition, Settings};
    pub use crate::validate::{validate, validate_with, Checks, MeshReport};
    pub use crate::world::{ChunkKey, Layout, Lod, World};
    pub use crate::{Error, Result};
}

/// Builds the tree and contours it once at `threshold`.
pub fn mesh(
    field: &dyn Field,
    grid: &Grid,
    threshold: f32,
    settings: &Settings,
) -> Result<IndexedMesh> {
    Ok(KdTree::build(field, grid, settings)?.mesh(threshold))
}
