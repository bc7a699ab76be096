//! Camera-driven thresholds: [`Lod`], a chunk's error threshold from its distance
//! to the camera, and [`World::apply_lod`].

use super::{ChunkKey, Layout, World};
use crate::error::{Error, Result};
use glam::Vec3;

/// A chunk's threshold from its distance to the camera:
/// `base * max(1, d / near)^growth`, capped at `max`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lod {
    /// Threshold within `near` of the camera.
    pub base: f32,
    /// Distance (world units) up to which chunks stay at `base`.
    pub near: f32,
    /// How fast the threshold grows with distance (2: quadratic).
    pub growth: f32,
    /// Largest threshold.
    pub max: f32,
}

impl Default for Lod {
    fn default() -> Self {
        Lod {
            base: 0.001,
            near: 0.25,
            growth: 2.0,
            max: 10.0,
        }
    }
}

impl Lod {
    /// The threshold at distance `d`.
    pub fn threshold(&self, d: f32) -> f32 {
        (self.base * (d / self.near).max(1.0).powf(self.growth)).min(self.max)
    }

    /// The largest threshold the curve gives a chunk of an [`Layout::around`]
    /// layout of ring `ring` (`chunk_res`-cell chunks, level-0 cells of side
    /// `cell_size`) when each chunk takes the curve at its distance in its own
    /// level's cells (as a horizon's chunks do) and the camera is at most
    /// `slack` of the chunk's widths from where the layout was made for: the
    /// curve at [`Layout::around_reach`]` + slack` chunk widths. A world whose
    /// chunks are cut so builds with it as [`crate::Settings::max_threshold`];
    /// a chunk farther (a camera far ahead of its layout, or above the region)
    /// is cut at it, finer than the curve asks.
    pub fn around_limit(&self, ring: f32, chunk_res: u32, cell_size: f32, slack: f32) -> f32 {
        let widths = Layout::around_reach(ring) + slack.max(0.0);
        self.threshold(widths * chunk_res as f32 * cell_size)
    }

    /// Checks the curve's values.
    pub fn check(&self) -> Result<()> {
        let ok = self.base.is_finite()
            && self.near.is_finite()
            && self.near > 0.0
            && self.growth.is_finite()
            && self.growth >= 0.0
            && self.max.is_finite()
            && self.max >= self.base;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidSetting {
                name: "lod",
                reason: format!("{self:?}: near must be > 0, growth >= 0, max >= base, all finite"),
            })
        }
    }
}

impl World {
    /// Sets every chunk's threshold from its distance to `camera` (the nearest point
    /// of its box). Returns the chunks whose threshold changed.
    pub fn apply_lod(&mut self, camera: Vec3, lod: &Lod) -> Vec<ChunkKey> {
        let mut changed = Vec::new();
        for k in self.chunks() {
            let (lo, hi) = self.chunk_bounds(&k);
            let e = lod.threshold(camera.clamp(lo, hi).distance(camera));
            if e != self.threshold(&k) {
                self.set_threshold(&k, e);
                changed.push(k);
            }
        }
        changed
    }
}
