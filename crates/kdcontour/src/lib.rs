//! # kdcontour
//!
//! Adaptive isosurface extraction through a **discrete k-d tree**, after
//! *Discrete k-d Tree Hierarchy for Isosurface Extraction*: a field is sampled on a
//! uniform grid, Hermite data (edge crossings found on the field, normals from its
//! gradient) feeds per-component quadratic error functions, a k-d tree is built top
//! down by splitting on the axis of largest per-dimension error at the plane that
//! balances the error of the halves, nodes are clustered bottom up where topology
//! allows, and the tree is contoured at any error threshold by
//! `cell_proc` / `face_proc` / `edge_proc`. The tree is retained: a new threshold is a
//! cheap re-walk, never a rebuild or a re-sample.
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
//! ## Inputs and baselines
//! - Fields: [`field::sdf`] primitives, [`field::csg`] trees and JSON scene files,
//!   [`field::terrain`] noise, [`field::volume`] sampled volumes (loaded by
//!   [`io::volume`] from raw or NIfTI-1 files), [`field::mesh_sdf`] triangle meshes
//!   (loaded by [`io::mesh`] from OBJ or PLY), or any [`Field`].
//! - Baselines on the same Hermite data ([`meshers`]): Marching Cubes ([`mc`]),
//!   uniform Dual Marching Cubes ([`dmc`]) and the octree ([`Partition::Octree`]).
//!
//! ## What the mesher guarantees
//! - **Watertight, 2-manifold, consistently oriented** output for a surface that is
//!   closed inside the grid, at every threshold. Cells hold up to four vertices (Dual
//!   Marching Cubes components) and ambiguous faces are resolved the same way by
//!   both cells that share them (see [`cell`]).
//! - **Topology is kept as the threshold grows**: a node is only clustered when it is
//!   equivalent to a single cell (checked, see `kdtree::build`), so the Euler
//!   characteristic at any threshold equals the uniform one.
//! - **Sharp features**: vertices minimise the QEF of their crossings, so box corners
//!   and CSG creases are reproduced; each vertex stays inside its cell or node.
//! - **Determinism**: one thread or many give the identical mesh.
//! - **Bad input is an [`Error`]**: NaN / infinite samples, empty or oversized grids,
//!   malformed scene files (with line and column).
//!
//! ## What it does not guarantee
//! - No self-intersection test: a coarse vertex clamped into a large node can make
//!   neighbouring triangles cross on strongly curved surfaces.
//! - Features thinner than a cell are not resolved (the grid decides topology).
//! - Surfaces that leave the grid are open along the grid's boundary.
//!
//! Error thresholds are QEF residuals in squared cells (a sum over the crossings
//! a vertex stands for), so a threshold means the same at every resolution.

// Loops over the 3 axes, 8 corners and 12 edges of a cell read best with indices.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod cell;
pub mod dmc;
pub mod edit;
pub mod error;
pub mod field;
pub mod grid;
pub mod hermite;
pub mod io;
pub mod kdtree;
pub mod mc;
pub mod mesh;
pub mod meshers;
pub mod qef;
pub mod scenes;
pub mod validate;
pub mod world;

pub use error::{Error, Result, SceneError};
pub use field::csg::{Csg, CsgNode};
pub use field::Field;
pub use grid::Grid;
pub use kdtree::{BuildStats, KdTree, Partition};
pub use mesh::IndexedMesh;
pub use validate::{validate, MeshReport};
pub use world::{ChunkWorld, Lod};

use std::time::Instant;

/// Build settings. Construct with `Settings { threads: 1, ..Default::default() }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Worker threads; 0 uses the ambient rayon pool.
    pub threads: usize,
    /// Refuse grids whose build would need more bytes than this (default 4 GiB).
    pub memory_budget: u64,
    /// Most Illinois false-position steps that refine each edge crossing on the field
    /// (0 = linear interpolation only, right for sampled volumes); each edge stops
    /// early once |f| < 1e-5 cells. Linear interpolation is exact where the field is
    /// planar along the edge, but near a box corner the SDF has a kink: on `box` at
    /// res 32, 4 steps left a corner vertex 0.2 cells off, 8 put it on the corner;
    /// 12 leaves margin.
    pub root_iterations: u32,
    /// How boxes are split: the paper's k-d tree (default) or the octree baseline.
    pub partition: kdtree::Partition,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            threads: 0,
            memory_budget: 4 << 30,
            root_iterations: 12,
            partition: kdtree::Partition::KdTree,
        }
    }
}

impl Settings {
    /// Checks every setting's range.
    pub fn check(&self) -> Result<()> {
        if self.threads > 1024 {
            return Err(Error::InvalidSetting {
                name: "threads",
                reason: format!("{} is more than 1024", self.threads),
            });
        }
        if self.root_iterations > 64 {
            return Err(Error::InvalidSetting {
                name: "root_iterations",
                reason: format!(
                    "{} is more than 64 (8 already reaches f32 precision)",
                    self.root_iterations
                ),
            });
        }
        Ok(())
    }

    /// Runs `f` on the configured number of threads. One thread uses a pool cached
    /// per calling thread, so many small builds (chunk tasks on an engine's task
    /// pool) neither oversubscribe the cores nor pay for a new pool each time.
    pub fn run<T: Send>(&self, f: impl FnOnce() -> T + Send) -> Result<T> {
        self.check()?;
        if self.threads == 0 {
            return Ok(f());
        }
        if self.threads == 1 {
            thread_local! {
                static ONE: Option<rayon::ThreadPool> =
                    rayon::ThreadPoolBuilder::new().num_threads(1).build().ok();
            }
            return ONE.with(|pool| match pool {
                Some(p) => Ok(p.install(f)),
                None => Err(Error::InvalidSetting {
                    name: "threads",
                    reason: "could not start a worker thread".into(),
                }),
            });
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .build()
            .map_err(|e| Error::InvalidSetting {
                name: "threads",
                reason: e.to_string(),
            })?;
        Ok(pool.install(f))
    }
}

impl KdTree {
    /// Samples `field` on `grid`, computes Hermite data and builds the retained tree.
    pub fn build(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<KdTree> {
        settings.run(|| {
            let t0 = Instant::now();
            let values = hermite::sample(field, grid, settings)?;
            let h = hermite::Hermite::new(field, grid, &values, settings)?;
            drop(values);
            let t1 = Instant::now();
            let mut tree = kdtree::build_with(&h, settings.partition);
            let t2 = Instant::now();
            tree.stats = BuildStats {
                sample_ms: (t1 - t0).as_secs_f64() * 1e3,
                build_ms: (t2 - t1).as_secs_f64() * 1e3,
                active_cells: h.cells.len(),
                crossings: h.crossings,
            };
            Ok(tree)
        })?
    }
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
