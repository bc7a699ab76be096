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
