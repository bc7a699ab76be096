//! Noise terrain from the `noise` crate: an fBm height field, and a 3-D density with
//! overhangs and caves. Y is up (Bevy's convention).

use super::Field;
use glam::Vec3;
use noise::{Fbm, MultiFractal, NoiseFn, Perlin};
use serde::{Deserialize, Serialize};

/// Parameters of an fBm height field `y = base + amplitude * fbm(x, z)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightfieldParams {
    /// Noise seed.
    #[serde(default)]
    pub seed: u32,
    /// Height of the mean surface.
    #[serde(default)]
    pub base: f32,
    /// Peak deviation from `base` (world units).
    pub amplitude: f32,
    /// Features per world unit of the first octave.
    pub frequency: f32,
    /// fBm octaves (1 to 16).
    #[serde(default = "default_octaves")]
    pub octaves: u32,
}

/// Parameters of a 3-D density terrain: a height gradient disturbed by 3-D fBm (which
/// makes overhangs and arches), optionally carved by worm-like caves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensityParams {
    /// Noise seed.
    #[serde(default)]
    pub seed: u32,
    /// Height of the mean surface.
    #[serde(default)]
    pub base: f32,
    /// Strength of the 3-D noise, in world units of displacement.
    pub amplitude: f32,
    /// Features per world unit of the first octave.
    pub frequency: f32,
    /// fBm octaves (1 to 16).
    #[serde(default = "default_octaves")]
    pub octaves: u32,
    /// Caves, if any.
    #[serde(default)]
    pub caves: Option<CaveParams>,
}

impl DensityParams {
    /// The terrain the main demo streams, at a cell size of 1: hills about 22
    /// cells high with overhangs and arches, carved by worm-like caves.
    pub fn demo(seed: u32) -> Self {
        DensityParams {
            seed,
            base: 0.0,
            amplitude: 22.0,
            frequency: 0.011,
            octaves: 5,
            caves: Some(CaveParams {
                frequency: 0.018,
                radius: 0.11,
            }),
        }
    }
}

/// Tunnels where two independent noises are both near zero.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaveParams {
    /// Tunnel features per world unit.
    pub frequency: f32,
    /// Tunnel radius, in noise units (0.05 to 0.3 is sensible).
    pub radius: f32,
}

fn default_octaves() -> u32 {
    5
}

fn fbm(seed: u32, frequency: f32, octaves: u32) -> Fbm<Perlin> {
    Fbm::<Perlin>::new(seed)
        .set_octaves(octaves as usize)
        .set_frequency(frequency as f64)
        .set_persistence(0.5)
        .set_lacunarity(2.0)
}

/// The most features per world unit a noise `frequency` may ask for.
pub const MAX_FREQUENCY: f32 = 1e6;

/// The farthest noise-space coordinate evaluated (frequency times position,
/// times 2 per extra octave). The `noise` crate floors coordinates into `isize`
/// and panics past about 9.2e18, and past 2^53 an `f64` has no fraction left to
/// make noise of; beyond this the terrain's value is NaN, which meshing reports
/// as a non-finite sample at that point.
pub const NOISE_REACH: f64 = 1e15;

/// `noise` at `p`, or NaN when `p` scaled by `reach` leaves [`NOISE_REACH`].
fn guarded<const N: usize>(noise: &impl NoiseFn<f64, N>, p: [f64; N], reach: f64) -> f64 {
    if p.iter().all(|c| (c * reach).abs() <= NOISE_REACH) {
        noise.get(p)
    } else {
        f64::NAN
    }
}

/// How much the last of `octaves` octaves scales the first octave's coordinates
/// (lacunarity 2).
fn octave_reach(octaves: u32) -> f64 {
    2f64.powi(octaves.saturating_sub(1).min(64) as i32)
}

/// Checks the shared noise parameters.
pub(crate) fn check_noise(amplitude: f32, frequency: f32, octaves: u32) -> Result<(), String> {
    if !(amplitude.is_finite() && amplitude >= 0.0) {
        return Err(format!(
            "amplitude must be finite and >= 0, got {amplitude}"
        ));
    }
    if !(frequency.is_finite() && frequency > 0.0 && frequency <= MAX_FREQUENCY) {
        return Err(format!(
            "frequency must be > 0 and at most {MAX_FREQUENCY} (features per world unit), got {frequency}"
        ));
    }
    if !(1..=16).contains(&octaves) {
        return Err(format!("octaves must be 1 to 16, got {octaves}"));
    }
    Ok(())
}

/// An fBm height field (see [`HeightfieldParams`]).
pub struct Heightfield {
    params: HeightfieldParams,
    noise: Fbm<Perlin>,
}

impl Heightfield {
    /// Builds the noise generator.
    pub fn new(params: HeightfieldParams) -> Self {
        let noise = fbm(params.seed, params.frequency, params.octaves);
        Heightfield { params, noise }
    }

    /// The terrain height at `(x, z)`.
    pub fn height(&self, x: f32, z: f32) -> f32 {
        let reach = self.params.frequency as f64 * octave_reach(self.params.octaves);
        self.params.base
            + self.params.amplitude * guarded(&self.noise, [x as f64, z as f64], reach) as f32
    }
}

impl Field for Heightfield {
    fn value(&self, p: Vec3) -> f32 {
        p.y - self.height(p.x, p.z)
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let h = 1e-3 / self.params.frequency;
        let dx = (self.height(p.x + h, p.z) - self.height(p.x - h, p.z)) / (2.0 * h);
        let dz = (self.height(p.x, p.z + h) - self.height(p.x, p.z - h)) / (2.0 * h);
        Vec3::new(-dx, 1.0, -dz)
    }

    fn sample_grid(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
    ) {
        // One noise evaluation per (x, z) column instead of one per corner.
        let c = grid.corners();
        let mut i = 0;
        for z in z_range {
            let heights: Vec<f32> = (0..c.x)
                .map(|x| {
                    let p = grid.corner_pos(glam::UVec3::new(x, 0, z));
                    self.height(p.x, p.z)
                })
                .collect();
            for y in 0..c.y {
                let py = grid.corner_pos(glam::UVec3::new(0, y, z)).y;
                for &h in &heights {
                    out[i] = py - h;
                    i += 1;
                }
            }
        }
    }
}

/// A 3-D density terrain (see [`DensityParams`]).
pub struct Density {
    params: DensityParams,
    noise: Fbm<Perlin>,
    caves: Option<(Perlin, Perlin)>,
}

impl Density {
    /// Builds the noise generators.
    pub fn new(params: DensityParams) -> Self {
        let noise = fbm(params.seed, params.frequency, params.octaves);
        let caves = params.caves.as_ref().map(|_| {
            (
                Perlin::new(params.seed.wrapping_add(101)),
                Perlin::new(params.seed.wrapping_add(202)),
            )
        });
        Density {
            params,
            noise,
            caves,
        }
    }
}

impl Field for Density {
    fn value(&self, p: Vec3) -> f32 {
        let q = [p.x as f64, p.y as f64, p.z as f64];
        let reach = self.params.frequency as f64 * octave_reach(self.params.octaves);
        let solid =
            p.y - self.params.base - self.params.amplitude * guarded(&self.noise, q, reach) as f32;
        match (&self.caves, &self.params.caves) {
            (Some((a, b)), Some(c)) => {
                let f = c.frequency as f64;
                let qc = [q[0] * f, q[1] * f, q[2] * f];
                let n1 = guarded(a, qc, 1.0) as f32;
                let n2 = guarded(b, qc, 1.0) as f32;
                // Positive inside a tunnel (air); the terrain is air where either is.
                let tunnel = (c.radius - (n1 * n1 + n2 * n2).sqrt()) / c.frequency;
                solid.max(tunnel)
            }
            _ => solid,
        }
    }
}
