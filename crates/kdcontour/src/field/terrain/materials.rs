//! The noise terrain's materials ([`crate::material::terrain_ids`]): rock on
//! steep slopes, snow on flat ground above a snow line, dirt in a noise mask, on
//! low ground and on cave walls, grass elsewhere; blended over a band around each
//! threshold, so borders are soft in the weights and sharp in the dominant id.
//!
//! Every threshold scales with the terrain's `amplitude` and `frequency`, so the
//! rule needs no parameters of its own and old scene files keep their meaning.

use super::perlin::Perlin3;
use crate::material::terrain_ids::{DIRT, GRASS, ROCK, SNOW};
use crate::material::MaterialBlend;
use glam::Vec3;

/// Steepness (`1 - n.y` of the unit normal) where rock starts to show (a slope
/// of about 20 degrees; it covers all from about 28).
const ROCK_FROM: f32 = 0.06;
/// Steepness where rock covers all.
const ROCK_TO: f32 = 0.12;
/// The snow line, above `base`, in amplitudes.
const SNOW_LINE: f32 = 0.30;
/// Low ground (dirt) below `base` by this many amplitudes.
const LOW_LINE: f32 = 0.30;
/// Half the height band the snow and low-ground blends run over, in amplitudes.
const HEIGHT_BAND: f32 = 0.04;
/// The dirt mask's noise frequency, in multiples of the terrain's.
const MASK_FREQUENCY: f64 = 4.0;
/// The dirt mask's noise level where dirt starts, and where it covers all.
const MASK_FROM: f32 = 0.30;
/// See [`MASK_FROM`].
const MASK_TO: f32 = 0.45;

/// Hermite smoothstep of `x` from `a` (0) to `b` (1); `a > b` runs downwards.
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The material rule of one terrain: its heights and its dirt mask noise.
pub(super) struct Paint {
    base: f32,
    amplitude: f32,
    frequency: f64,
    mask: Perlin3,
}

impl Paint {
    /// The rule for a terrain of `seed`, mean height `base`, `amplitude` and
    /// first-octave `frequency`.
    pub(super) fn new(seed: u32, base: f32, amplitude: f32, frequency: f32) -> Paint {
        Paint {
            base,
            amplitude,
            frequency: frequency as f64 * MASK_FREQUENCY,
            mask: Perlin3::new(seed.wrapping_add(303)),
        }
    }

    /// The material at `p` of a surface with gradient `gradient` there, `cave`
    /// (0 to 1) of the way into a cave wall. Non-finite input gives grass.
    pub(super) fn at(&self, p: Vec3, gradient: Vec3, cave: f32) -> MaterialBlend {
        let n = gradient.normalize_or_zero();
        if !(n.is_finite() && p.is_finite()) || n == Vec3::ZERO {
            return MaterialBlend::single(GRASS);
        }
        let rock = smoothstep(ROCK_FROM, ROCK_TO, 1.0 - n.y);
        let flat = 1.0 - rock;
        let (amp, band) = (self.amplitude, HEIGHT_BAND * self.amplitude);
        let snow_line = self.base + SNOW_LINE * amp;
        let snow = flat * smoothstep(snow_line - band, snow_line + band, p.y);
        let low_line = self.base - LOW_LINE * amp;
        let low = smoothstep(low_line + band, low_line - band, p.y);
        // Dirt shares what rock and snow leave; where they leave nothing (steep
        // rock, deep snow) the mask's noise is not read (`0 * x` is 0).
        let open = flat - snow;
        let dirt = if open > 0.0 {
            let f = self.frequency;
            let q = [p.x as f64 * f, p.y as f64 * f, p.z as f64 * f];
            open * smoothstep(MASK_FROM, MASK_TO, self.mask.get(q) as f32).max(low)
        } else {
            0.0
        };
        let grass = flat - snow - dirt;
        let cave = cave.clamp(0.0, 1.0);
        let keep = 1.0 - cave;
        MaterialBlend::weighted(&[
            (GRASS, grass * keep),
            (ROCK, rock * keep),
            (DIRT, dirt * keep + cave),
            (SNOW, snow * keep),
        ])
    }
}

/// How far into a cave wall a point is (0 to 1): 0 where the surface term wins
/// by a world unit or more, 1 where the tunnel term does.
pub(super) fn cave_weight(solid: f32, tunnel: f32) -> f32 {
    smoothstep(-1.0, 1.0, tunnel - solid)
}
