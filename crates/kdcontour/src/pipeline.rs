//! The chunk pipeline, written once: samples -> Hermite data -> tree (the split
//! search, clustering and the fold guard) -> paint -> extract. [`KdTree::build`],
//! the world's chunks ([`crate::world::ChunkBuild`]), the meshers and the command
//! line all go through these stages; each stays callable on its own, for
//! benchmarks and for callers that keep a stage's output.
//!
//! 1. [`hermite`]: the field sampled on a grid (or samples the caller has, with
//!    [`Hermite::new`]), edge crossings and normals found on the field;
//! 2. [`tree`]: the k-d tree over some of its cells ([`Cells`]), its leaves held
//!    to the field by the fold guard, its components painted with the field's
//!    materials when it has them;
//! 3. [`KdTree::extract`]: the mesh at a threshold, as often as wanted.
//!
//! At full resolution every cell is its own leaf and no tree is needed: [`full`]
//! gives the mesh a tree gives at a threshold below zero straight from the
//! Hermite data (uniform Dual Marching Cubes, [`crate::dmc`]).

use crate::error::Result;
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::Hermite;
use crate::kdtree::{build_in, BuildStats, Coarser, KdTree};
use crate::mesh::IndexedMesh;
use crate::settings::Settings;
use std::time::Instant;

/// Which cells of the Hermite grid a tree is built over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cells {
    /// Every cell.
    All,
    /// The `res`^3 cells inside a one-cell halo (a chunk: the halo's cells decide
    /// how its boundary cells resolve ambiguous faces, but belong to its
    /// neighbours).
    Core {
        /// Cells per side.
        res: u32,
        /// The chunk's faces toward finer chunks (bit `2 * axis + side`, side 1
        /// the high face): every leaf touching one is a cell. On its other faces
        /// but those toward coarser chunks (faces toward chunks of its own
        /// level, and the world's outer faces) no leaf reaches more than two
        /// cells in.
        finer_faces: u8,
        /// The chunk's faces toward coarser chunks (bits as `finer_faces`): the
        /// fold guard holds the seam polygons across them to the coarse cells,
        /// sampled from the field. (A world's chunks also place their cells'
        /// vertices against those cells; Hermite data from [`hermite`] has
        /// them placed against the halo.)
        coarser_faces: u8,
    },
}

/// Stage 1: samples `field` on `grid` and computes the Hermite data (closing
/// the surface with caps where `settings.boundary` asks and it leaves the grid).
pub fn hermite(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<Hermite> {
    Hermite::from_field(field, grid, settings)
}

/// Stage 2: the retained tree over `cells` of `h` (sampled from `field`), with
/// `settings.partition`: built top-down, clustered bottom-up, its folding leaves
/// refused, and painted with the field's materials (when `settings.materials` and
/// the field has them).
pub fn tree(h: &Hermite, field: &dyn Field, settings: &Settings, cells: Cells) -> KdTree {
    let coarser = match cells {
        Cells::All => None,
        Cells::Core {
            res, coarser_faces, ..
        } => Coarser::new(&h.grid, field, settings, res, coarser_faces),
    };
    tree_beside(h, field, settings, cells, coarser.as_ref())
}

/// [`tree`], with the coarse cells across the chunk's faces toward coarser
/// chunks already sampled (`coarser`, from `Cells::Core`'s `coarser_faces`).
pub(crate) fn tree_beside(
    h: &Hermite,
    field: &dyn Field,
    settings: &Settings,
    cells: Cells,
    coarser: Option<&Coarser>,
) -> KdTree {
    let (core, faces) = match cells {
        Cells::All => {
            let g = h.grid.cells;
            (([0, 0, 0], [g.x as u16, g.y as u16, g.z as u16]), (0, 0))
        }
        Cells::Core {
            res,
            finer_faces,
            coarser_faces,
        } => {
            let r = res as u16;
            // The faces toward chunks of the chunk's own level (and the world's
            // outer faces, which have none).
            let same_faces = 0b11_1111 & !finer_faces & !coarser_faces;
            (
                ([1, 1, 1], [r + 1, r + 1, r + 1]),
                (finer_faces, same_faces),
            )
        }
    };
    let mut tree = build_in(
        h,
        field,
        (
            settings.partition,
            (settings.min_threshold, settings.max_threshold),
        ),
        core,
        faces,
        coarser,
    );
    crate::kdtree::paint_tree(&mut tree, field, settings);
    tree
}

/// The mesh at full resolution, every cell its own leaf: the mesh
/// `KdTree::build(field, grid, settings)?.mesh(-1.0)` gives (the same vertices,
/// normals, materials and triangles; the order may differ), from stage 1 and
/// the Hermite data's quads ([`crate::dmc::uniform_dmc`]) without building a
/// tree. The vertices carry the field's materials when it has them and
/// `settings.materials` is on. (Material borders matter only to a tree's
/// clustering, so the crossings' materials are not read.)
pub fn full(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<IndexedMesh> {
    settings.run(|| {
        let cells_only = Settings {
            material_borders: false,
            ..settings.clone()
        };
        let h = hermite(field, grid, &cells_only)?;
        Ok(full_from(&h, field, settings))
    })?
}

/// [`full`] from Hermite data already computed (`h`, sampled from `field`).
pub fn full_from(h: &Hermite, field: &dyn Field, settings: &Settings) -> IndexedMesh {
    let mut mesh = crate::dmc::uniform_dmc(h);
    if settings.materials {
        crate::material::attach(&mut mesh, field);
    }
    mesh
}

impl KdTree {
    /// Samples `field` on `grid`, computes Hermite data and builds the retained
    /// tree over every cell, on `settings.threads` threads: the one way to build a
    /// tree (the stages one by one are in [`crate::pipeline`]). Contour it with
    /// [`KdTree::extract`] at any threshold.
    pub fn build(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<KdTree> {
        settings.run(|| {
            let t0 = Instant::now();
            let h = hermite(field, grid, settings)?;
            let t1 = Instant::now();
            let mut tree = tree(&h, field, settings, Cells::All);
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
