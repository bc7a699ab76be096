//! Noise terrain from the `noise` crate: an fBm height field, and a 3-D density with
//! overhangs and caves. Y is up (Bevy's convention).

mod materials;
mod perlin;
mod rows;

use super::Field;
use glam::{DVec3, Vec3};
#[cfg(test)]
use noise::{Fbm, MultiFractal, Perlin};
use perlin::{Fbm2, Fbm3, Perlin3};
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
                depth: Some(DEMO_CAVE_DEPTH),
            }),
        }
    }
}

/// How deep below the surface the demo's caves reach (world units), before they
/// close over the next `1.5 * radius / frequency` (about 9): tunnels open in hill
/// sides and under the valleys, and the rock below them is provably solid, so a
/// far horizon does not mesh kilometres of caves no one can see.
pub const DEMO_CAVE_DEPTH: f32 = 24.0;

/// Tunnels where two independent noises are both near zero.
///
/// The tunnel term is `t = (radius - |(n1, n2)|) / frequency` (world units, at
/// most `radius / frequency`), and the terrain is air where `t` or the surface
/// term says so. With a `depth`, tunnels exist only from the surface down to
/// about that depth: at a point `d` world units below the surface (`d` is minus
/// the surface term), `t` is lowered by `ramp(d - depth)`, where `ramp` is 0 for
/// negative arguments, `x^2 / (2w)` up to `w = radius / frequency` and `x - w/2`
/// beyond (continuous with its slope). Tunnels narrow from `depth` on and are
/// closed everywhere below `depth + 1.5 w`; the field stays continuous.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaveParams {
    /// Tunnel features per world unit.
    pub frequency: f32,
    /// Tunnel radius, in noise units (0.05 to 0.3 is sensible).
    pub radius: f32,
    /// Depth below the surface (world units, >= 0) where tunnels start to close;
    /// `None` (the default): caves at every depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<f32>,
}

impl CaveParams {
    /// How much the tunnel term is lowered `below` world units under the surface
    /// (0 everywhere without a depth band; never decreasing in `below`).
    pub fn fade(&self, below: f64) -> f64 {
        let Some(depth) = self.depth else {
            return 0.0;
        };
        let w = self.radius as f64 / self.frequency as f64;
        let x = below - depth as f64;
        if x <= 0.0 {
            0.0
        } else if x < w {
            x * x / (2.0 * w)
        } else {
            x - 0.5 * w
        }
    }

    /// The slope of [`CaveParams::fade`] at `below` (0 to 1).
    fn fade_slope(&self, below: f64) -> f64 {
        let Some(depth) = self.depth else {
            return 0.0;
        };
        let w = self.radius as f64 / self.frequency as f64;
        ((below - depth as f64) / w).clamp(0.0, 1.0)
    }
}

fn default_octaves() -> u32 {
    5
}

/// The `noise` crate's fBm with our parameters: the reference the copies in
/// module `perlin` are tested against.
#[cfg(test)]
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

/// Why noise scaled by `reach` gives no value at `q` (its own coordinates), or
/// `None` when every coordinate is within [`NOISE_REACH`]: how far it reached and
/// what would be valid.
fn reach_fault(q: &[f64], reach: f64) -> Option<String> {
    let far = q.iter().fold(0f64, |m, c| m.max(c.abs()));
    if far * reach <= NOISE_REACH {
        return None;
    }
    Some(format!(
        "noise evaluated too far from its origin: {far:.3e} units out in the node's own \
         coordinates (after the transforms above it), times {reach} (frequency times \
         2 per extra octave) is past {NOISE_REACH:e}, the farthest the noise can be \
         evaluated; keep the node within {:.3e} units of where it is evaluated (a \
         smaller translate, a larger scale) or lower its frequency",
        NOISE_REACH / reach
    ))
}

/// How much the last of `octaves` octaves scales the first octave's coordinates
/// (lacunarity 2).
fn octave_reach(octaves: u32) -> f64 {
    2f64.powi(octaves.saturating_sub(1).min(64) as i32)
}

/// Checks the shared noise parameters; the error names the bad field and says
/// what is valid.
pub(crate) fn check_noise(
    amplitude: f32,
    frequency: f32,
    octaves: u32,
) -> Result<(), (&'static str, String)> {
    if !(amplitude.is_finite() && amplitude >= 0.0) {
        return Err((
            "amplitude",
            format!("must be finite and >= 0, got {amplitude}"),
        ));
    }
    if !(frequency.is_finite() && frequency > 0.0 && frequency <= MAX_FREQUENCY) {
        return Err((
            "frequency",
            format!(
                "must be > 0 and at most {MAX_FREQUENCY} (features per world unit), got {frequency}"
            ),
        ));
    }
    if !(1..=16).contains(&octaves) {
        return Err(("octaves", format!("must be 1 to 16, got {octaves}")));
    }
    Ok(())
}

/// An fBm height field (see [`HeightfieldParams`]).
///
/// Its noise is the `noise` crate's 2-D `Fbm<Perlin>`, computed bit for bit by a
/// copy (module `perlin`) that also differentiates it: the gradient is analytic.
pub struct Heightfield {
    params: HeightfieldParams,
    noise: Fbm2,
    paint: materials::Paint,
    /// `1 / amplitude` (f64).
    per_amplitude: f64,
}

impl Heightfield {
    /// Builds the noise generator.
    pub fn new(params: HeightfieldParams) -> Self {
        let noise = Fbm2::new(params.seed, params.frequency, params.octaves);
        let paint =
            materials::Paint::new(params.seed, params.base, params.amplitude, params.frequency);
        Heightfield {
            per_amplitude: 1.0 / params.amplitude as f64,
            params,
            noise,
            paint,
        }
    }

    /// The terrain height at `(x, z)`.
    pub fn height(&self, x: f32, z: f32) -> f32 {
        let q = [x as f64, z as f64];
        let n = if self.in_reach(q) {
            self.noise.get(q)
        } else {
            f64::NAN
        };
        self.params.base + self.params.amplitude * n as f32
    }

    /// Whether the noise at `q` stays within [`NOISE_REACH`].
    fn in_reach(&self, q: [f64; 2]) -> bool {
        q.iter().all(|c| (c * self.reach()).abs() <= NOISE_REACH)
    }

    /// How far a unit step moves the finest octave's noise coordinates.
    fn reach(&self) -> f64 {
        self.params.frequency as f64 * octave_reach(self.params.octaves)
    }

    /// Why the value at `p` is not finite: the noise is out of its reach there
    /// (see [`NOISE_REACH`]); `None` where it is finite.
    pub fn reach_fault(&self, p: Vec3) -> Option<String> {
        reach_fault(&[p.x as f64, p.z as f64], self.reach())
    }

    /// [`Field::value`] and [`Field::gradient`] at `p`, bit for bit, from one
    /// evaluation of the noise with its gradient (the value alone is a second
    /// one): what a CSG tree asks of a height field for a normal.
    pub(crate) fn value_gradient(&self, p: Vec3) -> (f32, Vec3) {
        let q = [p.x as f64, p.z as f64];
        if !self.in_reach(q) {
            return (self.value(p), self.gradient(p));
        }
        let (n, [dx, dz]) = self.noise.get_grad(q);
        let height = self.params.base + self.params.amplitude * n as f32;
        let amp = self.params.amplitude as f64;
        let gradient = Vec3::new((-amp * dx) as f32, 1.0, (-amp * dz) as f32);
        (p.y - height, gradient)
    }

    /// Bounds on [`Field::value`] at `p` without evaluating the noise, `None`
    /// where the value may be NaN (out of the noise's reach): what lets a CSG
    /// tree skip the height field where another child decides.
    pub(crate) fn range_at(&self, p: Vec3) -> Option<(f32, f32)> {
        self.in_reach([p.x as f64, p.z as f64])
            .then(|| self.bound(p, p))
            .flatten()
    }

    /// A noise value above which the value at `p` is surely below `v` (the
    /// value's f32 operations err far less than the slack); infinite where
    /// none is (a flat field).
    fn noise_bar(&self, p: Vec3, v: f32) -> f64 {
        let (base, amp) = (self.params.base as f64, self.params.amplitude as f64);
        if amp <= 0.0 {
            return f64::INFINITY;
        }
        let (y, v) = (p.y as f64, v as f64);
        let slack = 1e-5 * (y.abs() + base.abs() + amp + v.abs()) + 1e-6;
        // A product by the inverse errs by an ulp, far below the slack.
        (y - base - v + slack) * self.per_amplitude
    }

    /// [`Field::value`] at `p`, bit for bit, unless it is surely below `v`
    /// (then `None`, after as few octaves of the noise as prove it): what an
    /// intersection already at `v` asks of a height field.
    pub(crate) fn value_unless_below(&self, p: Vec3, v: f32) -> Option<f32> {
        let q = [p.x as f64, p.z as f64];
        if !self.in_reach(q) {
            return Some(self.value(p));
        }
        let n = self.noise.get_unless_above(q, self.noise_bar(p, v))?;
        Some(p.y - (self.params.base + self.params.amplitude * n as f32))
    }

    /// [`Heightfield::value_gradient`], bit for bit, unless the value is
    /// surely below `v` (see [`Heightfield::value_unless_below`]).
    pub(crate) fn value_gradient_unless_below(&self, p: Vec3, v: f32) -> Option<(f32, Vec3)> {
        let q = [p.x as f64, p.z as f64];
        if !self.in_reach(q) {
            return Some(self.value_gradient(p));
        }
        let (n, [dx, dz]) = self.noise.get_grad_unless_above(q, self.noise_bar(p, v))?;
        let height = self.params.base + self.params.amplitude * n as f32;
        let amp = self.params.amplitude as f64;
        let gradient = Vec3::new((-amp * dx) as f32, 1.0, (-amp * dz) as f32);
        Some((p.y - height, gradient))
    }

    /// [`Field::value`] and [`Field::material`] at `p`, bit for bit, from one
    /// evaluation of the noise ([`Heightfield::value_gradient`]): what a CSG
    /// tree asks of a height field when it reads materials.
    pub(crate) fn value_and_material(&self, p: Vec3) -> (f32, crate::material::MaterialBlend) {
        let (value, gradient) = self.value_gradient(p);
        (value, self.paint.at(p, gradient, 0.0))
    }

    /// [`Heightfield::value_and_material`], bit for bit, unless the value is
    /// surely below `v` (see [`Heightfield::value_unless_below`]).
    pub(crate) fn value_and_material_unless_below(
        &self,
        p: Vec3,
        v: f32,
    ) -> Option<(f32, crate::material::MaterialBlend)> {
        let (value, gradient) = self.value_gradient_unless_below(p, v)?;
        Some((value, self.paint.at(p, gradient, 0.0)))
    }
}

/// Bounds `lo` and `hi` of a value computed in f32, widened by far more than the
/// f32 rounding of the few operations that computed it from terms of magnitude up
/// to `scale`.
fn widen(lo: f64, hi: f64, scale: f64) -> (f32, f32) {
    let slack = 1e-5 * (scale + lo.abs() + hi.abs()) + 1e-6;
    ((lo - slack) as f32, (hi + slack) as f32)
}

/// The largest magnitude [`Fbm`]`<`[`Perlin`]`>` returns: 1.
///
/// Proof from the `noise` 0.9 source: `perlin_3d` and `perlin_2d` end in
/// `result.clamp(-1.0, 1.0)`, so every octave's signal `s_i` is in `[-1, 1]`.
/// `Fbm::get` returns `scale * sum_{i=0}^{n-1} p^(i+1) s_i` with
/// `scale = 1 / sum_{i=1}^{n} p^i` (`calc_scale_factor`), a weighted mean of the
/// `s_i` with positive weights summing to 1 (here `p = 0.5`; the sum of `n` f64
/// terms errs by a few ulps, which [`widen`] covers). So `|fbm| <= 1` at every
/// point, for every seed, octave count and frequency.
const FBM_MAX: f64 = 1.0;

impl Field for Heightfield {
    fn value(&self, p: Vec3) -> f32 {
        p.y - self.height(p.x, p.z)
    }

    /// Analytic, in f64: as exact 65,536 units out as at the origin.
    fn gradient(&self, p: Vec3) -> Vec3 {
        let q = [p.x as f64, p.z as f64];
        // Out of the noise's reach the value is NaN, and so is the gradient.
        if !self.in_reach(q) {
            return Vec3::NAN;
        }
        let (_, [dx, dz]) = self.noise.get_grad(q);
        let amp = self.params.amplitude as f64;
        Vec3::new((-amp * dx) as f32, 1.0, (-amp * dz) as f32)
    }

    /// One evaluation of the noise with its gradient.
    fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
        Some(self.value_gradient(p))
    }

    /// `y - height` with the height within `base +- amplitude` (`FBM_MAX`, proven in the source).
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (base, amp) = (self.params.base as f64, self.params.amplitude as f64);
        let scale = lo.y.abs().max(hi.y.abs()) as f64 + base.abs() + amp;
        Some(widen(
            lo.y as f64 - base - amp * FBM_MAX,
            hi.y as f64 - base + amp * FBM_MAX,
            scale,
        ))
    }

    /// By slope, height and a noise mask (see `terrain/materials.rs`).
    fn material(&self, p: Vec3) -> crate::material::MaterialBlend {
        self.paint.at(p, self.gradient(p), 0.0)
    }

    fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> crate::material::MaterialBlend {
        self.paint.at(p, gradient, 0.0)
    }

    fn has_materials(&self) -> bool {
        true
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
///
/// Its noises are the `noise` crate's `Fbm<Perlin>` and `Perlin`, computed bit
/// for bit by a faster copy (module `perlin`) that also differentiates them.
/// [`Field::sample_grid`] samples a grid row by row (module `rows`), with the
/// values of [`Field::value`] bit for bit.
pub struct Density {
    params: DensityParams,
    noise: Fbm3,
    caves: Option<(Perlin3, Perlin3)>,
    /// [`Density::reach`], found once (every value tests it).
    reach: f64,
    paint: materials::Paint,
}

impl Density {
    /// Builds the noise generators.
    pub fn new(params: DensityParams) -> Self {
        let noise = Fbm3::new(params.seed, params.frequency, params.octaves);
        let caves = params.caves.as_ref().map(|_| {
            (
                Perlin3::new(params.seed.wrapping_add(101)),
                Perlin3::new(params.seed.wrapping_add(202)),
            )
        });
        let paint =
            materials::Paint::new(params.seed, params.base, params.amplitude, params.frequency);
        let mut density = Density {
            params,
            noise,
            caves,
            reach: 0.0,
            paint,
        };
        density.reach = density.reach();
        density
    }
}

impl Density {
    /// Bounds on [`Field::value`] at `p` without evaluating a noise, `None`
    /// where the value may be NaN (see [`Heightfield::range_at`]).
    pub(crate) fn range_at(&self, p: Vec3) -> Option<(f32, f32)> {
        self.in_reach([p.x as f64, p.y as f64, p.z as f64])
            .then(|| self.bound(p, p))
            .flatten()
    }

    /// Whether every noise this field evaluates at `q` stays within
    /// [`NOISE_REACH`] (beyond it the value is NaN, reported as a non-finite
    /// sample, instead of a panic inside the noise).
    fn in_reach(&self, q: [f64; 3]) -> bool {
        q.iter().all(|c| (c * self.reach).abs() <= NOISE_REACH)
    }

    /// How far a unit step moves the finest noise's coordinates (the surface's
    /// last octave or the caves).
    fn reach(&self) -> f64 {
        let reach = self.params.frequency as f64 * octave_reach(self.params.octaves);
        match &self.params.caves {
            Some(c) => reach.max(c.frequency as f64),
            None => reach,
        }
    }

    /// Why the value at `p` is not finite: a noise is out of its reach there
    /// (see [`NOISE_REACH`]); `None` where it is finite.
    pub fn reach_fault(&self, p: Vec3) -> Option<String> {
        reach_fault(&p.as_dvec3().to_array(), self.reach())
    }

    /// The gradient at `p` ([`Field::gradient`], bit for bit) and how far into a
    /// cave wall `p` is (0 to 1, see `terrain/materials.rs`), from one
    /// evaluation of each noise's value and gradient: the material rule needs
    /// both, and the cave weight is zero wherever the tunnel term is a world
    /// unit or more below the surface term (the second cave noise is skipped
    /// there, as the gradient skips it).
    fn gradient_and_cave(&self, p: Vec3) -> (Vec3, f32) {
        if !self.in_reach(p.as_dvec3().to_array()) {
            return (Vec3::NAN, 0.0);
        }
        let q = p.as_dvec3();
        let amp = self.params.amplitude as f64;
        let (n, gn) = self.noise.get_grad(q);
        let solid = q.y - self.params.base as f64 - amp * n;
        let g_solid = DVec3::Y - gn * amp;
        let (Some(c), Some((a, b))) = (&self.params.caves, &self.caves) else {
            return (g_solid.as_vec3(), 0.0);
        };
        let f = c.frequency as f64;
        let (n1, g1) = a.get_grad(q * f);
        // As in `gradient`: with `n2 = 0` the tunnel term is at its largest.
        if solid > (c.radius as f64 - n1.abs()) / f - c.fade(-solid) + 1.0 {
            return (g_solid.as_vec3(), 0.0);
        }
        let (n2, g2) = b.get_grad(q * f);
        let len = n1.hypot(n2);
        let tunnel = (c.radius as f64 - len) / f - c.fade(-solid);
        let cave = materials::cave_weight(solid as f32, tunnel as f32);
        if solid >= tunnel {
            return (g_solid.as_vec3(), cave);
        }
        let g_len = if len > 0.0 {
            (g1 * n1 + g2 * n2) / len
        } else {
            DVec3::ZERO
        };
        ((g_solid * c.fade_slope(-solid) - g_len).as_vec3(), cave)
    }

    /// How far into a cave wall `p` is (0 to 1), as [`Density::gradient_and_cave`]
    /// finds it (to rounding) from the noises' values alone.
    fn cave_weight(&self, p: Vec3) -> f32 {
        let q = [p.x as f64, p.y as f64, p.z as f64];
        if !self.in_reach(q) {
            return 0.0;
        }
        let solid =
            q[1] - self.params.base as f64 - self.params.amplitude as f64 * self.noise.get(q);
        let (Some(c), Some((a, b))) = (&self.params.caves, &self.caves) else {
            return 0.0;
        };
        let f = c.frequency as f64;
        let qc = [q[0] * f, q[1] * f, q[2] * f];
        let n1 = a.get(qc);
        if solid > (c.radius as f64 - n1.abs()) / f - c.fade(-solid) + 1.0 {
            return 0.0;
        }
        let tunnel = (c.radius as f64 - n1.hypot(b.get(qc))) / f - c.fade(-solid);
        materials::cave_weight(solid as f32, tunnel as f32)
    }

    /// The two cave noises at `q`, if there are caves (cave walls' material,
    /// and the tests' reference).
    #[cfg(test)]
    fn cave_noise(&self, q: [f64; 3]) -> Option<(&CaveParams, f64, f64)> {
        match (&self.caves, &self.params.caves) {
            (Some((a, b)), Some(c)) => {
                let f = c.frequency as f64;
                let qc = [q[0] * f, q[1] * f, q[2] * f];
                Some((c, a.get(qc), b.get(qc)))
            }
            _ => None,
        }
    }
}

impl Field for Density {
    fn value(&self, p: Vec3) -> f32 {
        let q = [p.x as f64, p.y as f64, p.z as f64];
        if !self.in_reach(q) {
            return f32::NAN;
        }
        let solid = self.solid(p.y, self.noise.get(q));
        // Where the surface term decides the value, the cave noises cannot change
        // it: skip them (in the sky and in rock below the band); where the first
        // cave noise decides it, skip the second.
        if self.solid_decides(solid).0 {
            return solid;
        }
        let (Some(c), Some((a, b))) = (&self.params.caves, &self.caves) else {
            return solid;
        };
        let f = c.frequency as f64;
        let qc = [q[0] * f, q[1] * f, q[2] * f];
        let n1 = a.get(qc) as f32;
        if self.first_cave_decides(solid, n1) {
            return solid;
        }
        self.with_tunnel(solid, n1, b.get(qc) as f32)
    }

    /// Row by row, bit for bit [`Field::value`] (module `rows`).
    fn sample_grid(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
    ) {
        self.sample_rows(grid, z_range, out, None);
    }

    /// Row by row: in the sky more than `far` above the surface the fBm's
    /// octaves stop once the ones summed prove it (module `rows`).
    fn sample_grid_far(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: f32,
    ) {
        self.sample_rows(grid, z_range, out, Some(far));
    }

    /// By slope, height, a noise mask and cave walls (see
    /// `terrain/materials.rs`).
    fn material(&self, p: Vec3) -> crate::material::MaterialBlend {
        let (gradient, cave) = self.gradient_and_cave(p);
        self.paint.at(p, gradient, cave)
    }

    /// [`Field::material`] to rounding (the cave weight from the noises'
    /// values instead of their values with gradients).
    fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> crate::material::MaterialBlend {
        self.paint.at(p, gradient, self.cave_weight(p))
    }

    /// One evaluation of each noise's value and gradient for both: the
    /// material is [`Field::material`]'s.
    fn gradient_and_material(&self, p: Vec3) -> (Vec3, crate::material::MaterialBlend) {
        let (gradient, cave) = self.gradient_and_cave(p);
        (gradient, self.paint.at(p, gradient, cave))
    }

    fn has_materials(&self) -> bool {
        true
    }

    /// Analytic, in f64 (the noises differentiated): as exact 65,536
    /// units out as at the origin, and one noise evaluation where central
    /// differences take six. Where the two terms are equal, the surface's.
    fn gradient(&self, p: Vec3) -> Vec3 {
        if !self.in_reach(p.as_dvec3().to_array()) {
            return Vec3::NAN;
        }
        let q = p.as_dvec3();
        let amp = self.params.amplitude as f64;
        let (n, gn) = self.noise.get_grad(q);
        let solid = q.y - self.params.base as f64 - amp * n;
        let g_solid = DVec3::Y - gn * amp;
        let (Some(c), Some((a, b))) = (&self.params.caves, &self.caves) else {
            return g_solid.as_vec3();
        };
        let f = c.frequency as f64;
        let (n1, g1) = a.get_grad(q * f);
        // `|(n1, n2)| >= |n1|` (`hypot` errs by less than an ulp, and `|n1|` is a
        // float below the exact length), so above the tunnel term with `n2 = 0`
        // the test below returns the surface's too: skip the second noise.
        if solid > (c.radius as f64 - n1.abs()) / f - c.fade(-solid) + 1e-9 {
            return g_solid.as_vec3();
        }
        let (n2, g2) = b.get_grad(q * f);
        let len = n1.hypot(n2);
        let tunnel = (c.radius as f64 - len) / f - c.fade(-solid);
        if solid >= tunnel {
            return g_solid.as_vec3();
        }
        // d/dp of -|n(p f)| / f, and of -fade(-solid).
        let g_len = if len > 0.0 {
            (g1 * n1 + g2 * n2) / len
        } else {
            DVec3::ZERO
        };
        (g_solid * c.fade_slope(-solid) - g_len).as_vec3()
    }

    /// The surface term `y - base - amplitude * fbm` is bounded through the
    /// box's y range and `|fbm| <= 1` (`FBM_MAX`, proven in the source); the tunnel term
    /// `(radius - |(n1, n2)|) / frequency` lies in
    /// `[(radius - sqrt 2) / frequency, radius / frequency]` (each Perlin noise is
    /// clamped to `[-1, 1]`), lowered by the depth fade, which never decreases with
    /// depth: at least `fade(-surface_hi)`, at most `fade(-surface_lo)`. The value
    /// is the larger term, so its bounds are the larger bounds.
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (base, amp) = (self.params.base as f64, self.params.amplitude as f64);
        let s_lo = lo.y as f64 - base - amp * FBM_MAX;
        let s_hi = hi.y as f64 - base + amp * FBM_MAX;
        let mut scale = lo.y.abs().max(hi.y.abs()) as f64 + base.abs() + amp;
        let (v_lo, v_hi) = match &self.params.caves {
            None => (s_lo, s_hi),
            Some(c) => {
                let (r, f) = (c.radius as f64, c.frequency as f64);
                scale += (r + std::f64::consts::SQRT_2) / f;
                let t_lo = (r - std::f64::consts::SQRT_2) / f - c.fade(-s_lo);
                let t_hi = r / f - c.fade(-s_hi);
                (s_lo.max(t_lo), s_hi.max(t_hi))
            }
        };
        Some(widen(v_lo, v_hi, scale))
    }
}

#[cfg(test)]
mod tests;
