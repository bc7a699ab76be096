//! The uniform sampling grid a volume is meshed on.

use crate::error::{Error, Result};
use glam::{IVec3, UVec3, Vec3};

/// Largest number of cells along one axis (cell coordinates are stored as `u16`).
pub const MAX_CELLS_PER_AXIS: u32 = 65_000;

/// A box of `cells` cubic cells of side `cell_size` on a lattice anchored at `origin`
/// (world units). Corner `i` (for `i` in `0..=cells`) is at
/// `origin + (i + offset) * cell_size`, the sum taken in integers first, so two grids
/// on the same lattice (neighbouring chunks) sample a shared corner at bitwise the
/// same point and agree on its sign.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Grid {
    /// World position of corner (0, 0, 0).
    pub origin: Vec3,
    /// Side of one cubic cell, in world units.
    pub cell_size: f32,
    /// Cells along x, y, z.
    pub cells: UVec3,
    /// Lattice index of corner (0, 0, 0) (zero for a standalone grid).
    #[serde(default)]
    pub offset: IVec3,
}

impl Grid {
    /// The cube `[-half, half]^3` split into `res` cells per axis.
    pub fn cube(half: f32, res: u32) -> Self {
        Grid {
            origin: Vec3::splat(-half),
            cell_size: if res == 0 {
                0.0
            } else {
                2.0 * half / res as f32
            },
            cells: UVec3::splat(res),
            offset: IVec3::ZERO,
        }
    }

    /// The box `lo..hi` with `res` cubic cells along its longest side, corner
    /// (0, 0, 0) at `lo`, and enough cells along the other sides to cover it (at
    /// least one). With `res == 0` or an empty box the grid has no cells (and
    /// [`Grid::validate`] says so).
    pub fn covering(lo: Vec3, hi: Vec3, res: u32) -> Self {
        let ext = hi - lo;
        let cell = if res == 0 {
            0.0
        } else {
            ext.max_element() / res as f32
        };
        let cells = if cell > 0.0 {
            (ext / cell).ceil().as_uvec3().max(UVec3::ONE)
        } else {
            UVec3::ZERO
        };
        Grid {
            origin: lo,
            cell_size: cell,
            cells,
            offset: IVec3::ZERO,
        }
    }

    /// The grid for an input with bounds (a volume, a triangle mesh):
    /// [`Grid::covering`] the box `lo..hi` with `res` cells along its longest side,
    /// plus one cell of margin all round, so a surface inside the box closes inside
    /// the grid.
    pub fn fit(lo: Vec3, hi: Vec3, res: u32) -> Self {
        let mut g = Grid::covering(lo, hi, res);
        g.origin = lo - Vec3::splat(g.cell_size);
        if g.cell_size > 0.0 {
            g.cells += UVec3::splat(2);
        }
        g
    }

    /// Checks that the grid is usable; the error says which part is wrong.
    pub fn validate(&self) -> Result<()> {
        if self.cells.min_element() == 0 {
            return Err(Error::InvalidGrid(format!(
                "it has {}x{}x{} cells; every axis needs at least one cell (res must be >= 1)",
                self.cells.x, self.cells.y, self.cells.z
            )));
        }
        if self.cells.max_element() > MAX_CELLS_PER_AXIS {
            return Err(Error::InvalidGrid(format!(
                "{} cells along one axis is more than the {MAX_CELLS_PER_AXIS} supported",
                self.cells.max_element()
            )));
        }
        if !(self.cell_size.is_finite() && self.cell_size > 0.0) {
            return Err(Error::InvalidGrid(format!(
                "cell size {} must be a positive finite number",
                self.cell_size
            )));
        }
        if !self.origin.is_finite() {
            return Err(Error::InvalidGrid(format!(
                "origin {} must be finite",
                self.origin
            )));
        }
        Ok(())
    }

    /// Corners along x, y, z (`cells + 1`).
    pub fn corners(&self) -> UVec3 {
        self.cells + UVec3::ONE
    }

    /// Total number of cells.
    pub fn cell_count(&self) -> u64 {
        self.cells.x as u64 * self.cells.y as u64 * self.cells.z as u64
    }

    /// Total number of corners (samples).
    pub fn corner_count(&self) -> u64 {
        let c = self.corners();
        c.x as u64 * c.y as u64 * c.z as u64
    }

    /// World position of the corner with integer coordinates `c`.
    pub fn corner_pos(&self, c: UVec3) -> Vec3 {
        self.origin + (c.as_ivec3() + self.offset).as_vec3() * self.cell_size
    }

    /// World position of a point given in grid units (cell coordinates).
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        self.origin + (local + self.offset.as_vec3()) * self.cell_size
    }

    /// Grid units of a world position.
    pub fn to_local(&self, world: Vec3) -> Vec3 {
        (world - self.origin) / self.cell_size - self.offset.as_vec3()
    }

    /// Linear index of corner `(x, y, z)`, x fastest.
    #[inline]
    pub fn corner_index(&self, x: u32, y: u32, z: u32) -> usize {
        let c = self.corners();
        (x as usize) + c.x as usize * ((y as usize) + c.y as usize * z as usize)
    }
}

/// The magnitude sampling ([`crate::hermite::sample`]) gives corners it proved far
/// from the surface without evaluating them (their sign is exact, their value is
/// not); the padding of a capped grid ([`crate::boundary`]) takes it too.
pub(crate) const FAR: f32 = f32::MAX;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_puts_res_cells_along_the_longest_side_and_one_of_margin() {
        let g = Grid::fit(Vec3::new(1.0, 2.0, 3.0), Vec3::new(5.0, 3.0, 3.5), 8);
        assert_eq!(g.cell_size, 0.5);
        assert_eq!(g.cells, UVec3::new(8, 2, 1) + UVec3::splat(2));
        assert_eq!(g.origin, Vec3::new(0.5, 1.5, 2.5));
        assert_eq!(g.offset, IVec3::ZERO);
        // The box lies inside, a cell from the edge.
        assert_eq!(g.corner_pos(UVec3::ONE), Vec3::new(1.0, 2.0, 3.0));
        assert!(g.validate().is_ok());
    }

    #[test]
    fn covering_has_no_margin_and_a_cell_on_flat_axes() {
        let g = Grid::covering(Vec3::ZERO, Vec3::new(4.0, 1.5, 0.0), 4);
        assert_eq!((g.origin, g.cell_size), (Vec3::ZERO, 1.0));
        assert_eq!(g.cells, UVec3::new(4, 2, 1));
        assert_eq!(
            Grid::fit(Vec3::ZERO, Vec3::new(4.0, 1.5, 0.0), 4).cells,
            UVec3::new(6, 4, 3)
        );
    }

    #[test]
    fn fitting_nothing_gives_an_invalid_grid() {
        for g in [
            Grid::fit(Vec3::ZERO, Vec3::ONE, 0),
            Grid::fit(Vec3::ONE, Vec3::ONE, 16),
        ] {
            assert_eq!(g.cells, UVec3::ZERO);
            assert!(g.validate().is_err());
        }
    }
}
