//! The agent a navmesh is built for, and what can go wrong building it.

use thiserror::Error;

/// The agent the navmesh is built for, and the grid Recast rasterizes at
/// (volume-local units, as the chunk meshes).
#[derive(Clone, Debug, PartialEq)]
pub struct NavSettings {
    /// The agent's radius: floors are kept this far from walls and ledges.
    pub agent_radius: f32,
    /// The agent's height: floors with less room above are left out.
    pub agent_height: f32,
    /// The steepest walkable slope, in degrees (0 to 89).
    pub max_slope_degrees: f32,
    /// The highest step the agent climbs (and the largest height gap a link
    /// between tiles bridges).
    pub max_climb: f32,
    /// Recast's cell on the ground plane (a chunk's side is rounded to a whole
    /// number of them); its cell height is half of it.
    pub cell_size: f32,
    /// How far apart (across, on the ground plane) two tiles' open edges may
    /// lie and still be linked, in cells: Recast simplifies each tile's
    /// outline on its own (by up to 1.3 cells).
    pub link_tolerance: f32,
    /// The most ground-plane columns a tile may have (a chunk of a coarse level
    /// is large): a bigger tile is refused, not built.
    pub max_tile_columns: u32,
}

impl Default for NavSettings {
    fn default() -> Self {
        NavSettings {
            agent_radius: 0.4,
            agent_height: 1.8,
            max_slope_degrees: 40.0,
            max_climb: 0.5,
            cell_size: 0.2,
            link_tolerance: 3.0,
            max_tile_columns: 1024 * 1024,
        }
    }
}

impl NavSettings {
    /// Checks every value is in range; the error names the setting and says
    /// what it may be.
    pub fn check(&self) -> Result<(), NavError> {
        let positive = [
            ("agent_radius", self.agent_radius),
            ("agent_height", self.agent_height),
            ("cell_size", self.cell_size),
            ("link_tolerance", self.link_tolerance),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(NavError::Settings(format!(
                    "{name} is {v}: it must be a finite number above 0"
                )));
            }
        }
        if !(self.max_climb.is_finite() && self.max_climb >= 0.0) {
            return Err(NavError::Settings(format!(
                "max_climb is {}: it must be a finite number, 0 or more",
                self.max_climb
            )));
        }
        if !(self.max_slope_degrees > 0.0 && self.max_slope_degrees < 90.0) {
            return Err(NavError::Settings(format!(
                "max_slope_degrees is {}: it must be above 0 and below 90",
                self.max_slope_degrees
            )));
        }
        if self.cell_size > self.agent_radius * 4.0 {
            return Err(NavError::Settings(format!(
                "cell_size {} is coarser than the agent (radius {}): at most 4 times the radius",
                self.cell_size, self.agent_radius
            )));
        }
        if self.max_tile_columns == 0 {
            return Err(NavError::Settings("max_tile_columns is 0".into()));
        }
        Ok(())
    }
}

/// Why a tile was not built.
#[derive(Debug, Error)]
pub enum NavError {
    /// A setting out of range.
    #[error("navmesh settings: {0}")]
    Settings(String),
    /// The chunk is larger than [`NavSettings::max_tile_columns`] allows.
    #[error("a navmesh tile of {columns} columns ({width} x {depth}) is more than the {max} allowed (a chunk of a coarse level? raise max_tile_columns or keep navmesh to near chunks)")]
    TileTooLarge {
        /// Columns the tile would have.
        columns: u64,
        /// Along x.
        width: u64,
        /// Along z.
        depth: u64,
        /// The limit.
        max: u32,
    },
    /// A step of Recast failed.
    #[error("navmesh tile: Recast's {step} failed: {message}")]
    Recast {
        /// Which step.
        step: &'static str,
        /// Its error.
        message: String,
    },
}
