//! Hermite data (section 3): corner samples, active cells with their Dual Marching
//! Cubes components, and for every edge with a sign change its crossing (found on
//! the field by false position, not just interpolated) and the unit normal there.
//!
//! Positions are in grid units. A NaN or infinite sample is an error, never a mesh.

use crate::boundary::{self, Boundary, Cap};
use crate::cell::CellTables;
use crate::error::{Error, Result};
use crate::facing::Facing;
use crate::field::Field;
use crate::grid::Grid;
use crate::kdtree::Coarser;
use crate::material;
use crate::qef::Qef;
use crate::settings::Settings;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

mod active;
pub(crate) use active::CellLookup;
mod crossing;
mod kept;
mod patches;
mod sample;
mod vertex;

pub(crate) use crate::grid::FAR;
pub use kept::KeptCrossings;
pub use sample::{one_sign, sample};

/// A cell with at least one sign change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ActiveCell {
    /// Cell coordinates.
    pub coord: [u16; 3],
    /// Outside bits of its corners (see [`crate::cell`]).
    pub config: u8,
    /// Face resolution mask (see [`crate::cell`]).
    pub mask: u8,
    /// Index of its first patch in the patch QEFs.
    pub patch_base: u32,
}

/// Hermite data of a sampled grid.
pub struct Hermite {
    /// The grid.
    pub(crate) grid: Grid,
    /// One bit per corner: set when the corner is outside (value >= 0).
    pub(crate) outside: Vec<u64>,
    /// Active cells, ordered by linear index (x fastest).
    pub(crate) cells: Vec<ActiveCell>,
    /// QEF of each cell patch (grid units).
    pub(crate) patch_qef: Vec<Qef>,
    /// Sum of the unit normals of each patch's crossings.
    pub(crate) patch_normal: Vec<Vec3>,
    /// Each patch's vertex in its cell (grid units, before
    /// [`crate::comp::Comp::pack`] rounds it): the QEF's minimiser, moved toward
    /// the mass point where that would fold a quad (module `vertex`).
    pub(crate) patch_vertex: Vec<Vec3>,
    /// Each patch's vertex and normal as a cell leaf of the tree stores them
    /// ([`crate::comp::Comp::pack`] of [`Hermite::patch_vertex`] and
    /// [`Hermite::patch_normal`] in its cell), packed once.
    pub(crate) patch_comp: Vec<crate::comp::Comp>,
    /// Number of edges with a sign change.
    pub(crate) crossings: usize,
    /// Every edge crossing, in a fixed order.
    pub(crate) edges: Vec<EdgeCrossing>,
    /// Per active cell, when the field has materials and
    /// [`Settings::material_borders`] is on: the dominant material of its
    /// crossings, or [`material::MIXED`] where they differ (a border passes
    /// through it); a cell with no pure crossing takes the code of the 3x3x3
    /// block around it (see `border_codes`). Empty otherwise.
    pub(crate) cell_material: Vec<u16>,
    /// Per active cell (with [`Hermite::cell_material`]): for a cell of one
    /// material with a cell of another in the 3x3x3 block around it, the unit
    /// direction toward them (across the border); for a cell a border passes
    /// through, with pure cells of exactly two materials in that block, the
    /// unit direction from the one side to the other (across the border too);
    /// zero elsewhere. A node of the tree that holds such a cell may be a leaf
    /// only while its vertex keeps the cell's distance to the border
    /// (`BORDER_SHIFT` in `kdtree/borders.rs`).
    pub(crate) cell_border: Vec<Vec3>,
    /// With [`Boundary::Capped`] and a solid that reaches the grid's faces, the
    /// grid the caps close (this data's grid less its caps); `None`
    /// otherwise.
    pub(crate) capped: Option<Grid>,
}

/// What [`Hermite::surface`] gives: a field, or a field cut by caps.
pub enum Surface<'a> {
    /// The field itself.
    Field(&'a dyn Field),
    /// The field cut by the box the caps close.
    Capped(boundary::CappedField<'a>),
}

impl<'a> Surface<'a> {
    /// `field`, cut by the box of `capped` when there is one.
    fn of(field: &'a dyn Field, capped: Option<&Grid>) -> Self {
        match capped {
            Some(g) => Surface::Capped(boundary::CappedField::new(field, g)),
            None => Surface::Field(field),
        }
    }

    /// The surface as a field.
    pub fn field(&self) -> &dyn Field {
        match self {
            Surface::Field(f) => *f,
            Surface::Capped(c) => c,
        }
    }
}

/// The surface crossing on one grid edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeCrossing {
    /// The edge: `3 * (linear index of its low corner) + axis`.
    pub key: u64,
    /// Where the surface crosses it (grid units).
    pub point: Vec3,
    /// The unit normal there.
    pub normal: Vec3,
}

/// Estimated bytes the build needs for `grid` (samples, sign bits, the cell lookup
/// and a surface-proportional allowance for patches and tree nodes).
pub fn estimate_bytes(grid: &Grid) -> u64 {
    let corners = grid.corner_count();
    let cells = grid.cell_count();
    corners * 4 + corners / 8 + cells * 4 + surface_bytes(grid.cells.as_u64vec3())
}

/// The surface-proportional part of [`estimate_bytes`] for a box of `cells`:
/// patches and tree nodes for a surface as large as the box's six faces
/// (saturating, so an absurd box compares as too large instead of wrapping).
pub fn surface_bytes(cells: glam::U64Vec3) -> u64 {
    let c = cells;
    let faces =
        c.x.saturating_mul(c.y)
            .saturating_add(c.y.saturating_mul(c.z))
            .saturating_add(c.z.saturating_mul(c.x));
    faces.saturating_mul(2 * 8 * 420)
}

/// Checks the grid and the memory budget before anything is allocated.
pub fn check_grid(grid: &Grid, settings: &Settings) -> Result<()> {
    grid.validate()?;
    let needed = estimate_bytes(grid);
    if needed > settings.memory_budget.get() {
        return Err(Error::MemoryBudget {
            cells: grid.cell_count(),
            needed,
            budget: settings.memory_budget.get(),
        });
    }
    crate::budget::check_machine(
        format!("a grid of {} cells and its tree", grid.cell_count()),
        needed,
    )
}

impl Hermite {
    /// The grid the data is on (a capped grid's padded one).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Cells with a sign change (active cells).
    pub fn active_cells(&self) -> usize {
        self.cells.len()
    }

    /// Edges with a sign change.
    pub fn crossing_count(&self) -> usize {
        self.crossings
    }
}

impl Hermite {
    /// Samples `field` on `grid` ([`sample`]) and builds its Hermite data
    /// ([`Hermite::new`]); the samples are dropped before returning. Runs on the
    /// calling thread pool (wrap in [`Settings::run`] to honour `settings.threads`).
    ///
    /// With [`Boundary::Capped`] and a solid that reaches the grid's faces, the
    /// data is of the grid grown by one cell of caps ([`crate::boundary`]), and
    /// [`Hermite::grid`] is that grid.
    pub fn from_field(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<Self> {
        let values = sample(field, grid, settings)?;
        if settings.boundary == Boundary::Capped && boundary::reaches_faces(grid, &values) {
            let big = boundary::padded(grid);
            check_grid(&big, settings)?;
            let values = boundary::pad_values(grid, &values)?;
            let cap = Cap { cells: big.cells };
            let capped = Some((cap, *grid));
            return Ok(Hermite::build(field, &big, &values, settings, capped, None, None)?.0);
        }
        Hermite::new(field, grid, &values, settings)
    }

    /// Builds Hermite data from samples of `field` on `grid` (from [`sample`]).
    pub fn new(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
    ) -> Result<Self> {
        Ok(Hermite::build(field, grid, values, settings, None, None, None)?.0)
    }

    /// [`Hermite::new`], taking each edge's crossing from `kept` (crossings an
    /// earlier build of `grid` with the same field and settings kept) where
    /// the edge's two samples are the same as then, and keeping this build's
    /// crossings for the next. The data is the data [`Hermite::new`] gives.
    pub fn reusing(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
        kept: Option<&KeptCrossings>,
    ) -> Result<(Self, KeptCrossings)> {
        let (h, kept) = Hermite::build(field, grid, values, settings, None, Some(kept), None)?;
        Ok((h, kept.unwrap_or_default()))
    }

    /// A chunk's data ([`Hermite::new`], or [`Hermite::reusing`] with `keep`),
    /// its cells' vertices placed against the coarse cells across its faces
    /// toward coarser chunks (`coarser`), which the seams there take instead
    /// of its halo's.
    pub(crate) fn for_chunk(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
        keep: Option<Option<&KeptCrossings>>,
        coarser: Option<&Coarser>,
    ) -> Result<(Self, Option<KeptCrossings>)> {
        Hermite::build(field, grid, values, settings, None, keep, coarser)
    }

    /// [`Hermite::new`], on a grid whose added corners `cap` marks when capped
    /// (with the grid the caps close); with `keep`, reusing the crossings it
    /// holds that fit (see [`Hermite::reusing`]) and returning this build's;
    /// with `coarser`, as [`Hermite::for_chunk`].
    fn build(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
        capped: Option<(Cap, Grid)>,
        keep: Option<Option<&KeptCrossings>>,
        coarser: Option<&Coarser>,
    ) -> Result<(Self, Option<KeptCrossings>)> {
        let (cap, capped) = (capped.map(|c| c.0), capped.map(|c| c.1));
        let surface = Surface::of(field, capped.as_ref());
        let tables = CellTables::get();
        let (cells, patches) = active::active_cells(grid, values, tables);
        let lookup = active::CellLookup::new(&cells, grid.cells);
        let borders = settings.materials && settings.material_borders && field.has_materials();
        let iterations = settings.root_iterations;
        let reuse = keep
            .flatten()
            .filter(|k| cap.is_none() && k.fits(grid, settings, borders));
        let found =
            crossing::crossings(field, grid, values, &cells, cap, iterations, borders, reuse);
        let outside = sign_bits(values, grid.corners());
        let kept =
            keep.map(|_| KeptCrossings::keep(grid, settings, borders, outside.clone(), &found));
        let p = patches::accumulate(
            found, &cells, &lookup, values, grid, patches, borders, coarser,
        )?;
        let (patch_vertex, patch_comp) = vertex::cell_vertices(
            &cells,
            &p.qef,
            &p.normal,
            &p.quads,
            &Facing::new(surface.field(), grid),
            &p.fixed,
            grid.cells,
        );
        drop(p.quads);
        let (cell_material, cell_border) =
            border_codes(&cells, &p.own_material, grid.cells, |c| lookup.get(c));
        drop(lookup);
        let h = Hermite {
            grid: *grid,
            outside,
            cells,
            patch_qef: p.qef,
            patch_normal: p.normal,
            patch_vertex,
            patch_comp,
            crossings: p.crossings,
            edges: p.edges,
            cell_material,
            cell_border,
            capped,
        };
        Ok((h, kept))
    }

    /// The surface this data's polygons are held to: `field`, the field it was
    /// sampled from, cut by the caps' box when capped (`Hermite::capped`).
    pub fn surface<'a>(&self, field: &'a dyn Field) -> Surface<'a> {
        Surface::of(field, self.capped.as_ref())
    }

    /// Whether corner `(x, y, z)` is outside.
    #[inline]
    pub fn is_outside(&self, c: [u32; 3]) -> bool {
        let i = self.grid.corner_index(c[0], c[1], c[2]);
        self.outside[i / 64] >> (i % 64) & 1 == 1
    }
}

/// Per active cell, from the material codes `own` (one per cell, empty when not
/// tracked; `index` gives a cell's active index or `u32::MAX`): its code for the
/// tree ([`Hermite::cell_material`]) and, for a cell of one pure material next to
/// a border, the unit direction toward the other side
/// ([`Hermite::cell_border`]).
///
/// A cell whose crossings hold two materials is [`material::MIXED`]; a cell of
/// one material keeps it, and when a cell of the 3x3x3 block around it holds
/// another (or is mixed) its direction is the mean of the offsets to those
/// cells (a block with such cells all round, whose offsets cancel, makes it
/// mixed). A cell with no pure crossing takes the block's combined code, mixed
/// where the block holds two materials.
fn border_codes(
    cells: &[ActiveCell],
    own: &[u16],
    n: UVec3,
    index: impl Fn([u32; 3]) -> u32 + Sync,
) -> (Vec<u16>, Vec<Vec3>) {
    if own.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let per_cell: Vec<(u16, Vec3)> = cells
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let mine = own[i];
            let (mut block, mut toward) = (mine, Vec3::ZERO);
            // For a cell a border passes through: the offsets to the pure
            // cells of the first material seen, less those to the second's
            // (a third material leaves it without a direction).
            let (mut sides, mut across, mut third) = ([material::UNSET; 2], Vec3::ZERO, false);
            for d in 0..27u32 {
                let off = [d % 3, d / 3 % 3, d / 9];
                let mut at = [0u32; 3];
                let mut inside = true;
                for a in 0..3 {
                    let v = c.coord[a] as u32 + off[a];
                    inside &= v >= 1 && v <= n[a];
                    at[a] = v.wrapping_sub(1);
                }
                if !inside {
                    continue;
                }
                let j = index(at);
                if j == u32::MAX {
                    continue;
                }
                let theirs = own[j as usize];
                block = material::combine(block, theirs);
                if mine == material::MIXED && theirs != material::UNSET && theirs != material::MIXED
                {
                    let off = Vec3::new(off[0] as f32, off[1] as f32, off[2] as f32) - 1.0;
                    if sides[0] == material::UNSET || sides[0] == theirs {
                        sides[0] = theirs;
                        across += off;
                    } else if sides[1] == material::UNSET || sides[1] == theirs {
                        sides[1] = theirs;
                        across -= off;
                    } else {
                        third = true;
                    }
                }
                if theirs != material::UNSET && theirs != mine {
                    toward += Vec3::new(off[0] as f32, off[1] as f32, off[2] as f32) - 1.0;
                }
            }
            match mine {
                material::MIXED if third || sides[1] == material::UNSET => {
                    (material::MIXED, Vec3::ZERO)
                }
                material::MIXED => (
                    material::MIXED,
                    across.try_normalize().unwrap_or(Vec3::ZERO),
                ),
                material::UNSET => (block, Vec3::ZERO),
                _ if block != material::MIXED => (mine, Vec3::ZERO),
                _ => match toward.try_normalize() {
                    Some(dir) => (mine, dir),
                    None => (material::MIXED, Vec3::ZERO),
                },
            }
        })
        .collect();
    per_cell.into_iter().unzip()
}

/// One bit per corner of `values`, 64 corners per word: set when outside.
fn sign_bits(values: &[f32], corners: UVec3) -> Vec<u64> {
    // In parallel (a serial 2 M-corner loop at res 128 kept two threads from
    // doubling the speed).
    let mut outside =
        vec![0u64; (corners.x as usize * corners.y as usize * corners.z as usize).div_ceil(64)];
    outside
        .par_chunks_mut(256)
        .zip(values.par_chunks(256 * 64))
        .for_each(|(words, vals)| {
            for (word, vals) in words.iter_mut().zip(vals.chunks(64)) {
                let mut w = 0u64;
                for (k, v) in vals.iter().enumerate() {
                    w |= ((*v >= 0.0) as u64) << k;
                }
                *word = w;
            }
        });
    outside
}
