//! The `noise` crate's 3-D Perlin noise and its fBm, for [`super::Density`]: the
//! same lattice, hashes, gradients and quintic blend as `noise` 0.9's
//! `perlin_3d` and `Fbm::get`.
//!
//! - [`Perlin3`] computes the value bit for bit as `noise` does (the same
//!   operations in the same order; a test compares them), about twice as fast:
//!   the permutation is read from a plain table and nothing is generic.
//! - [`Perlin3::get_grad`] and [`Fbm3::get_grad`] differentiate it: one
//!   evaluation gives value and gradient, where central differences take six.
//! - [`Perlin2`] and [`Fbm2`] do the same for `perlin_2d` (the height field's
//!   noise): its values bit for bit, and the gradient with them, where central
//!   differences took four evaluations.

use glam::DVec3;
use noise::permutationtable::{NoiseHasher, PermutationTable};

/// `floor_to_isize` of `noise` 0.9: truncation, minus one at and below 0.
#[inline]
fn lattice(x: f64) -> isize {
    if x <= 0.0 {
        x as isize - 1
    } else {
        x as isize
    }
}

/// `noise`'s quintic blend (`map_quintic`).
#[inline]
fn quintic(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
}

/// `noise`'s `linear`.
#[inline]
fn linear(a: f64, b: f64, alpha: f64) -> f64 {
    b * alpha + a * (1.0 - alpha)
}

/// `perlin_3d`'s gradient vectors, by the hash's low four bits.
const GRADS: [[f64; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [0.0, -1.0, -1.0],
];

/// `perlin_3d`'s gradient terms by the hash's low four bits: `sa * p[a] + sb * p[b]`
/// (`0 | 12 => x + y`, `1 | 13 => -x + y`, ..., `11 | 15 => -y - z`).
const TERMS: [(usize, f64, usize, f64); 16] = [
    (0, 1.0, 1, 1.0),
    (0, -1.0, 1, 1.0),
    (0, 1.0, 1, -1.0),
    (0, -1.0, 1, -1.0),
    (0, 1.0, 2, 1.0),
    (0, -1.0, 2, 1.0),
    (0, 1.0, 2, -1.0),
    (0, -1.0, 2, -1.0),
    (1, 1.0, 2, 1.0),
    (1, -1.0, 2, 1.0),
    (1, 1.0, 2, -1.0),
    (1, -1.0, 2, -1.0),
    (0, 1.0, 1, 1.0),
    (0, -1.0, 1, 1.0),
    (1, -1.0, 2, 1.0),
    (1, -1.0, 2, -1.0),
];

/// The spacing of a row's points (lattice cells) from which [`Perlin3::get_row`]
/// looks each point's terms up instead of setting up runs of points in one cell:
/// at half a cell, runs are about two points long (the demo's level-3 chunks
/// sample their finest octave 1.4 cells apart).
const SPARSE_STEP: f64 = 0.5;

/// `perlin_3d`'s scale, `2 / sqrt 3`.
const SCALE_FACTOR: f64 = 1.154_700_538_379_251_5;

/// 3-D Perlin noise of one seed: `noise::Perlin::new(seed)`'s values, bit for bit.
#[derive(Clone)]
pub(super) struct Perlin3 {
    /// The permutation of `PermutationTable::new(seed)`.
    perm: [u8; 256],
}

impl Perlin3 {
    /// The noise `noise::Perlin::new(seed)` computes.
    pub(super) fn new(seed: u32) -> Self {
        let table = PermutationTable::new(seed);
        // Hashing one coordinate reads the permutation at it.
        Perlin3 {
            perm: std::array::from_fn(|i| table.hash(&[i as isize]) as u8),
        }
    }

    /// `PermutationTable::hash` of the eight corners `c + [ox, oy, oz]` of a
    /// lattice cell, by corner `ox + 2 oy + 4 oz`: the hash reads the permutation
    /// at x, then at that xor y, then at that xor z, so the corners share their
    /// first two reads (14 reads instead of 24).
    #[inline]
    fn corner_hashes(&self, c: [isize; 3]) -> [usize; 8] {
        let p = |i: usize| self.perm[i & 0xff] as usize;
        let b = |a: usize, o: isize| (c[a] + o) as usize & 0xff;
        let px = [p(b(0, 0)), p(b(0, 1))];
        let (y, z) = ([b(1, 0), b(1, 1)], [b(2, 0), b(2, 1)]);
        let pxy = [
            p(px[0] ^ y[0]),
            p(px[1] ^ y[0]),
            p(px[0] ^ y[1]),
            p(px[1] ^ y[1]),
        ];
        std::array::from_fn(|i| p(pxy[i & 3] ^ z[i >> 2]))
    }

    /// The value at `q` (noise units), as `perlin_3d` computes it.
    #[inline]
    pub(super) fn get(&self, q: [f64; 3]) -> f64 {
        let c = [lattice(q[0]), lattice(q[1]), lattice(q[2])];
        let d = [q[0] - c[0] as f64, q[1] - c[1] as f64, q[2] - c[2] as f64];
        let h = self.corner_hashes(c);
        let g = |ox: isize, oy: isize, oz: isize| {
            let p = [d[0] - ox as f64, d[1] - oy as f64, d[2] - oz as f64];
            // `perlin_3d` matches on the hash; the table picks the same terms
            // without a branch (`-a` is `-1 * a`, and `a - b` is `a + -b`, bit for
            // bit).
            let (a, sa, b, sb) = TERMS[h[(ox + 2 * oy + 4 * oz) as usize] & 0b1111];
            sa * p[a] + sb * p[b]
        };
        let (g000, g100, g010, g110) = (g(0, 0, 0), g(1, 0, 0), g(0, 1, 0), g(1, 1, 0));
        let (g001, g101, g011, g111) = (g(0, 0, 1), g(1, 0, 1), g(0, 1, 1), g(1, 1, 1));
        let (cx, cy, cz) = (quintic(d[0]), quintic(d[1]), quintic(d[2]));
        let result = linear(
            linear(linear(g000, g001, cz), linear(g010, g011, cz), cy),
            linear(linear(g100, g101, cz), linear(g110, g111, cz), cy),
            cx,
        ) * SCALE_FACTOR;
        result.clamp(-1.0, 1.0)
    }

    /// [`Perlin3::get`] at `[x, y, z]` for every `x` of `xs`, into `out`: bit for
    /// bit the same values, with the work of `y` and `z` (their lattice cells,
    /// blends and hash bytes) done once for the row and the eight gradient
    /// terms of a lattice cell reused while consecutive `x` stay in it.
    pub(super) fn get_row(&self, xs: &[f64], y: f64, z: f64, out: &mut [f64]) {
        // Points a cell or more apart make runs of one: look terms up per point.
        if xs.len() >= 2 && (xs[1] - xs[0]).abs() >= SPARSE_STEP {
            return self.get_row_sparse(xs, y, z, out);
        }
        let (cy, cz) = (lattice(y), lattice(z));
        let (dy, dz) = (y - cy as f64, z - cz as f64);
        // `d - 0 as f64` is `d`, bit for bit.
        let (py, pz) = ([dy, dy - 1.0], [dz, dz - 1.0]);
        let (sy, sz) = (quintic(dy), quintic(dz));
        // The terms of the cell `cx`, by corner `ox + 2 oy + 4 oz`, with y and z
        // put in: a term `sa * p[a] + sb * p[b]` has `a < b`, so it is
        // `sa * px + rest` when `a` is x (`rest = sb * p[b]`, the same products
        // and sum), and the constant `rest` when it is not.
        // Run by run of points in one lattice cell along x (the loop over a run
        // is the same operations on every point, which the compiler vectorises).
        let mut first = 0;
        while first < xs.len() {
            let cx = lattice(xs[first]);
            let mut end = first + 1;
            while end < xs.len() && lattice(xs[end]) == cx {
                end += 1;
            }
            let mut with_x = [false; 8];
            let mut slope = [0.0f64; 8];
            let mut rest = [0.0f64; 8];
            let h = self.corner_hashes([cx, cy, cz]);
            for i in 0..8 {
                let (a, sa, b, sb) = TERMS[h[i] & 0b1111];
                let d = [0.0, py[(i >> 1) & 1], pz[i >> 2]];
                with_x[i] = a == 0;
                slope[i] = sa;
                rest[i] = if a == 0 {
                    sb * d[b]
                } else {
                    sa * d[a] + sb * d[b]
                };
            }
            let lattice_x = cx as f64;
            for (&x, out) in xs[first..end].iter().zip(&mut out[first..end]) {
                let dx = x - lattice_x;
                let px = [dx, dx - 1.0];
                let g = |i: usize| {
                    if with_x[i] {
                        slope[i] * px[i & 1] + rest[i]
                    } else {
                        rest[i]
                    }
                };
                let (g000, g100, g010, g110) = (g(0), g(1), g(2), g(3));
                let (g001, g101, g011, g111) = (g(4), g(5), g(6), g(7));
                let cx = quintic(dx);
                let result = linear(
                    linear(linear(g000, g001, sz), linear(g010, g011, sz), sy),
                    linear(linear(g100, g101, sz), linear(g110, g111, sz), sy),
                    cx,
                ) * SCALE_FACTOR;
                *out = result.clamp(-1.0, 1.0);
            }
            first = end;
        }
    }

    /// [`Perlin3::get_row`] for points about a lattice cell or more apart (a
    /// coarse chunk's finer octaves): each point looks its cell's terms up,
    /// as [`Perlin3::get`] does, without setting up a run.
    fn get_row_sparse(&self, xs: &[f64], y: f64, z: f64, out: &mut [f64]) {
        let (cy, cz) = (lattice(y), lattice(z));
        let (dy, dz) = (y - cy as f64, z - cz as f64);
        // `d - 0 as f64` is `d`, bit for bit.
        let (py, pz) = ([dy, dy - 1.0], [dz, dz - 1.0]);
        let (sy, sz) = (quintic(dy), quintic(dz));
        // The terms of the cell `cx`, by corner `ox + 2 oy + 4 oz`.
        let mut cell: Option<isize> = None;
        let mut terms = [TERMS[0]; 8];
        for (&x, out) in xs.iter().zip(out.iter_mut()) {
            let cx = lattice(x);
            if cell != Some(cx) {
                cell = Some(cx);
                let h = self.corner_hashes([cx, cy, cz]);
                for (t, h) in terms.iter_mut().zip(h) {
                    *t = TERMS[h & 0b1111];
                }
            }
            let dx = x - cx as f64;
            let px = [dx, dx - 1.0];
            let g = |i: usize| {
                let d = [px[i & 1], py[(i >> 1) & 1], pz[i >> 2]];
                let (a, sa, b, sb) = terms[i];
                sa * d[a] + sb * d[b]
            };
            let (g000, g100, g010, g110) = (g(0), g(1), g(2), g(3));
            let (g001, g101, g011, g111) = (g(4), g(5), g(6), g(7));
            let cx = quintic(dx);
            let result = linear(
                linear(linear(g000, g001, sz), linear(g010, g011, sz), sy),
                linear(linear(g100, g101, sz), linear(g110, g111, sz), sy),
                cx,
            ) * SCALE_FACTOR;
            *out = result.clamp(-1.0, 1.0);
        }
    }

    /// Value and gradient at `q` (noise units): `v = sum_i W_i n_i` over the
    /// cell's eight corners (blend weights `W_i`, gradient terms `n_i = k_i . p_i`),
    /// so `grad v = sum_i W_i k_i` plus, along each axis, the blend's slope times
    /// the difference of the corner terms across that axis, blended over the
    /// other two (the value to within rounding of [`Perlin3::get`]).
    pub(super) fn get_grad(&self, q: DVec3) -> (f64, DVec3) {
        let c = [lattice(q.x), lattice(q.y), lattice(q.z)];
        let d = [q.x - c[0] as f64, q.y - c[1] as f64, q.z - c[2] as f64];
        let s = d.map(quintic);
        let ds = d.map(|t| {
            let t = t.clamp(0.0, 1.0);
            30.0 * t * t * (t - 1.0) * (t - 1.0)
        });
        let h = self.corner_hashes(c);
        // Corner `i = ox + 2 oy + 4 oz`: its gradient and its term.
        let mut k = [[0.0f64; 3]; 8];
        let mut n = [0.0f64; 8];
        for i in 0..8usize {
            let o = [i & 1, (i >> 1) & 1, i >> 2];
            let g = GRADS[h[i] & 15];
            n[i] = g[0] * (d[0] - o[0] as f64)
                + g[1] * (d[1] - o[1] as f64)
                + g[2] * (d[2] - o[2] as f64);
            k[i] = g;
        }
        let w = [0, 1, 2].map(|a| [1.0 - s[a], s[a]]);
        let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
        // `f` blended over two axes with blends `t` and `u`, `f(j, l)` the value
        // at offsets `j` (along the first) and `l`.
        let bilerp = |f: &dyn Fn(usize, usize) -> f64, t: f64, u: f64| {
            lerp(lerp(f(0, 0), f(1, 0), t), lerp(f(0, 1), f(1, 1), t), u)
        };
        let (mut v, mut g) = (0.0, [0.0f64; 3]);
        for i in 0..8usize {
            let weight = w[0][i & 1] * w[1][(i >> 1) & 1] * w[2][i >> 2];
            v += weight * n[i];
            for a in 0..3 {
                g[a] += weight * k[i][a];
            }
        }
        let v = v * SCALE_FACTOR;
        if v.abs() > 1.0 {
            // `perlin_3d` clamps to [-1, 1]: flat where it clamps.
            return (v.clamp(-1.0, 1.0), DVec3::ZERO);
        }
        g[0] += ds[0] * bilerp(&|j, l| n[1 + 2 * j + 4 * l] - n[2 * j + 4 * l], s[1], s[2]);
        g[1] += ds[1] * bilerp(&|j, l| n[j + 2 + 4 * l] - n[j + 4 * l], s[0], s[2]);
        g[2] += ds[2] * bilerp(&|j, l| n[j + 2 * l + 4] - n[j + 2 * l], s[0], s[1]);
        (v, DVec3::from_array(g) * SCALE_FACTOR)
    }
}

/// Buffers of [`Fbm3::get_row_below`], reused from row to row: the points still
/// in (their index in the row, their x in noise units, their sum so far) and one
/// octave's signal.
#[derive(Default)]
pub(super) struct RowBelow {
    index: Vec<u32>,
    point: Vec<f64>,
    sum: Vec<f64>,
    signal: Vec<f64>,
}

/// `Fbm<Perlin>` with persistence 0.5 and lacunarity 2 (as [`super::fbm`] builds
/// it): its values, bit for bit.
#[derive(Clone)]
pub(super) struct Fbm3 {
    octaves: Vec<Perlin3>,
    frequency: f64,
    scale: f64,
}

impl Fbm3 {
    /// The fBm `super::fbm(seed, frequency, octaves)` computes.
    pub(super) fn new(seed: u32, frequency: f32, octaves: u32) -> Self {
        Fbm3 {
            // `Fbm` seeds octave `i` with `seed + i`.
            octaves: (0..octaves)
                .map(|i| Perlin3::new(seed.wrapping_add(i)))
                .collect(),
            frequency: frequency as f64,
            // `calc_scale_factor`, the same fold.
            scale: 1.0 / (1..=octaves).fold(0.0, |acc, x| acc + 0.5f64.powi(x as i32)),
        }
    }

    /// The value at `q` (world units), as `Fbm::get` computes it.
    #[inline]
    pub(super) fn get(&self, q: [f64; 3]) -> f64 {
        let mut point = q.map(|x| x * self.frequency);
        let (mut result, mut attenuation) = (0.0, 0.5);
        for octave in &self.octaves {
            let mut signal = octave.get(point);
            signal *= attenuation;
            attenuation *= 0.5;
            result += signal;
            point = point.map(|x| x * 2.0);
        }
        result * self.scale
    }

    /// [`Fbm3::get`] at `[x, y, z]` for every `x` of `xs`, into `out`: bit for
    /// bit, through [`Perlin3::get_row`] (`scratch` holds the row's points and
    /// one octave's signal).
    pub(super) fn get_row(
        &self,
        xs: &[f64],
        y: f64,
        z: f64,
        out: &mut [f64],
        scratch: &mut Vec<f64>,
    ) {
        let n = xs.len();
        scratch.clear();
        scratch.extend(xs.iter().map(|x| x * self.frequency));
        scratch.resize(2 * n, 0.0);
        let (point, signal) = scratch.split_at_mut(n);
        let (mut y, mut z) = (y * self.frequency, z * self.frequency);
        let out = &mut out[..n];
        out.fill(0.0);
        let mut attenuation = 0.5;
        // The operations of `get`, octave by octave for the whole row.
        for octave in &self.octaves {
            octave.get_row(point, y, z, signal);
            for (r, s) in out.iter_mut().zip(signal.iter()) {
                *r += s * attenuation;
            }
            attenuation *= 0.5;
            for x in point.iter_mut() {
                *x *= 2.0;
            }
            (y, z) = (y * 2.0, z * 2.0);
        }
        for r in out.iter_mut() {
            *r *= self.scale;
        }
    }

    /// [`Fbm3::get_row`], except that a point whose value the octaves summed so
    /// far prove to be below `below` (each octave still to come adds at most its
    /// weight: Perlin noise is within `[-1, 1]`) is dropped after that octave and
    /// gets NaN in `out`. The others get [`Fbm3::get`]'s value bit for bit.
    pub(super) fn get_row_below(
        &self,
        xs: &[f64],
        y: f64,
        z: f64,
        below: f64,
        out: &mut [f64],
        s: &mut RowBelow,
    ) {
        let n = xs.len();
        s.index.clear();
        s.index.extend(0..n as u32);
        s.point.clear();
        s.point.extend(xs.iter().map(|x| x * self.frequency));
        s.sum.clear();
        s.sum.resize(n, 0.0);
        s.signal.resize(n, 0.0);
        let (mut y, mut z) = (y * self.frequency, z * self.frequency);
        let mut attenuation = 0.5;
        let last = self.octaves.len().saturating_sub(1);
        for (i, octave) in self.octaves.iter().enumerate() {
            let m = s.index.len();
            octave.get_row(&s.point[..m], y, z, &mut s.signal[..m]);
            // The operations of `get`, on the points still in.
            for (r, g) in s.sum.iter_mut().zip(&s.signal[..m]) {
                *r += g * attenuation;
            }
            attenuation *= 0.5;
            for x in s.point.iter_mut() {
                *x *= 2.0;
            }
            (y, z) = (y * 2.0, z * 2.0);
            if i == last {
                break;
            }
            // The most the octaves after this one add, widened far past rounding.
            let rest: f64 = (0..last - i)
                .map(|j| attenuation * 0.5f64.powi(j as i32))
                .sum();
            let slack = 1e-9 * (1.0 + below.abs());
            let lowest = s.sum.iter().fold(f64::INFINITY, |a, &b| a.min(b));
            if (lowest + rest) * self.scale + slack >= below {
                continue;
            }
            let mut kept = 0;
            for r in 0..m {
                if (s.sum[r] + rest) * self.scale + slack < below {
                    out[s.index[r] as usize] = f64::NAN;
                    continue;
                }
                s.index[kept] = s.index[r];
                s.sum[kept] = s.sum[r];
                s.point[kept] = s.point[r];
                kept += 1;
            }
            s.index.truncate(kept);
            s.sum.truncate(kept);
            s.point.truncate(kept);
        }
        for (r, &i) in s.sum.iter().zip(&s.index) {
            out[i as usize] = r * self.scale;
        }
    }

    /// Value and gradient at `q` (world units).
    pub(super) fn get_grad(&self, q: DVec3) -> (f64, DVec3) {
        let (mut point, mut f) = (q * self.frequency, self.frequency);
        let (mut v, mut g, mut attenuation) = (0.0, DVec3::ZERO, 0.5);
        for octave in &self.octaves {
            let (ov, og) = octave.get_grad(point);
            v += ov * attenuation;
            g += og * (attenuation * f);
            attenuation *= 0.5;
            point *= 2.0;
            f *= 2.0;
        }
        (v * self.scale, g * self.scale)
    }
}

/// `perlin_2d`'s scale, `2 / sqrt 2` (computed as `noise` computes it).
const SCALE_FACTOR_2D: f64 = 2.0 / std::f64::consts::SQRT_2;

/// `perlin_2d`'s gradient vectors, by the hash's low two bits.
const GRADS_2D: [[f64; 2]; 4] = [[1.0, 1.0], [-1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]];

/// 2-D Perlin noise of one seed: `noise::Perlin::new(seed)`'s 2-D values, bit
/// for bit.
#[derive(Clone)]
pub(super) struct Perlin2 {
    /// The permutation of `PermutationTable::new(seed)`.
    perm: [u8; 256],
}

impl Perlin2 {
    /// The noise `noise::Perlin::new(seed)` computes in 2-D.
    pub(super) fn new(seed: u32) -> Self {
        Perlin2 {
            perm: Perlin3::new(seed).perm,
        }
    }

    /// `PermutationTable::hash` of the four corners `c + [ox, oy]` of a lattice
    /// cell, by corner `ox + 2 oy` (the corners share their reads at x: 6
    /// reads instead of 8).
    #[inline]
    fn corner_hashes(&self, c: [isize; 2]) -> [usize; 4] {
        let p = |i: usize| self.perm[i & 0xff] as usize;
        let b = |a: usize, o: isize| (c[a] + o) as usize & 0xff;
        let px = [p(b(0, 0)), p(b(0, 1))];
        let y = [b(1, 0), b(1, 1)];
        std::array::from_fn(|i| p(px[i & 1] ^ y[i >> 1]))
    }

    /// The value at `q` (noise units), as `perlin_2d` computes it.
    #[inline]
    pub(super) fn get(&self, q: [f64; 2]) -> f64 {
        let c = [lattice(q[0]), lattice(q[1])];
        let d = [q[0] - c[0] as f64, q[1] - c[1] as f64];
        let h = self.corner_hashes(c);
        let g = |ox: isize, oy: isize| {
            let p = [d[0] - ox as f64, d[1] - oy as f64];
            // `x + y`, `-x + y`, `x - y`, `-x - y` by the hash, bit for bit
            // (`-a` is `-1 * a`, and `a - b` is `a + -b`).
            let [sa, sb] = GRADS_2D[h[(ox + 2 * oy) as usize] & 0b11];
            sa * p[0] + sb * p[1]
        };
        let (g00, g10, g01, g11) = (g(0, 0), g(1, 0), g(0, 1), g(1, 1));
        let (cx, cy) = (quintic(d[0]), quintic(d[1]));
        let result = linear(linear(g00, g01, cy), linear(g10, g11, cy), cx) * SCALE_FACTOR_2D;
        result.clamp(-1.0, 1.0)
    }

    /// Value (as [`Perlin2::get`], bit for bit) and gradient at `q` (noise
    /// units), from the same four corner terms.
    #[inline]
    pub(super) fn get_grad(&self, q: [f64; 2]) -> (f64, [f64; 2]) {
        let c = [lattice(q[0]), lattice(q[1])];
        let d = [q[0] - c[0] as f64, q[1] - c[1] as f64];
        let h = self.corner_hashes(c);
        // Per corner `ox + 2 oy`: the gradient vector and its term.
        let corner = |ox: isize, oy: isize| {
            let p = [d[0] - ox as f64, d[1] - oy as f64];
            let k = GRADS_2D[h[(ox + 2 * oy) as usize] & 0b11];
            (k, k[0] * p[0] + k[1] * p[1])
        };
        let ((k00, g00), (k10, g10)) = (corner(0, 0), corner(1, 0));
        let ((k01, g01), (k11, g11)) = (corner(0, 1), corner(1, 1));
        let (cx, cy) = (quintic(d[0]), quintic(d[1]));
        let (a, b) = (linear(g00, g01, cy), linear(g10, g11, cy));
        let result = linear(a, b, cx) * SCALE_FACTOR_2D;
        if result.abs() > 1.0 {
            // `perlin_2d` clamps to [-1, 1]: flat where it clamps.
            return (result.clamp(-1.0, 1.0), [0.0, 0.0]);
        }
        // The quintic's slope (zero outside [0, 1], where it clamps).
        let slope = |t: f64| {
            let t = t.clamp(0.0, 1.0);
            30.0 * t * t * (t - 1.0) * (t - 1.0)
        };
        let (sx, sy) = (slope(d[0]), slope(d[1]));
        let dx = sx * (b - a) + linear(linear(k00[0], k01[0], cy), linear(k10[0], k11[0], cy), cx);
        let dy = linear(
            sy * (g01 - g00) + linear(k00[1], k01[1], cy),
            sy * (g11 - g10) + linear(k10[1], k11[1], cy),
            cx,
        );
        (result, [dx * SCALE_FACTOR_2D, dy * SCALE_FACTOR_2D])
    }
}

/// `Fbm<Perlin>` in 2-D with persistence 0.5 and lacunarity 2 (as [`super::fbm`]
/// builds it): its values, bit for bit, and its gradient.
#[derive(Clone)]
pub(super) struct Fbm2 {
    octaves: Vec<Perlin2>,
    frequency: f64,
    scale: f64,
    /// Per octave: the most the octaves from it on add to the sum (each
    /// octave's signal is within `[-1, 1]`, times its attenuation).
    rest: Vec<f64>,
    /// `1 / scale`.
    sum_per_value: f64,
}

impl Fbm2 {
    /// The fBm `super::fbm(seed, frequency, octaves)` computes in 2-D.
    pub(super) fn new(seed: u32, frequency: f32, octaves: u32) -> Self {
        let sum = (1..=octaves).fold(0.0, |acc, x| acc + 0.5f64.powi(x as i32));
        Fbm2 {
            octaves: (0..octaves)
                .map(|i| Perlin2::new(seed.wrapping_add(i)))
                .collect(),
            frequency: frequency as f64,
            scale: 1.0 / sum,
            sum_per_value: sum,
            rest: (0..octaves)
                .map(|i| (i..octaves).map(|j| 0.5f64.powi(j as i32 + 1)).sum())
                .collect(),
        }
    }

    /// The bar the octaves' running sum must pass, with the octaves still to
    /// come at their lowest, for the value to be surely above `bar`: widened
    /// far past the rounding of the sum (at most 16 terms within 1) and of
    /// the scaling. Infinite (never passed) when `bar` is NaN.
    fn sum_bar(&self, bar: f64) -> f64 {
        // `scale` is within [1, 2]: the sum is the value divided by it (a
        // product by its inverse errs by an ulp, far below the slack).
        let t = (bar + 1e-9) * self.sum_per_value;
        if t.is_nan() {
            f64::INFINITY
        } else {
            t
        }
    }

    /// [`Fbm2::get`], bit for bit, unless the octaves summed so far prove the
    /// value above `bar` (`None`): where another part of a CSG tree decides,
    /// most points stop after an octave or two.
    pub(super) fn get_unless_above(&self, q: [f64; 2], bar: f64) -> Option<f64> {
        let t = self.sum_bar(bar);
        let mut point = q.map(|x| x * self.frequency);
        let (mut result, mut attenuation) = (0.0, 0.5);
        for (octave, rest) in self.octaves.iter().zip(&self.rest) {
            if result - rest > t {
                return None;
            }
            let mut signal = octave.get(point);
            signal *= attenuation;
            attenuation *= 0.5;
            result += signal;
            point = point.map(|x| x * 2.0);
        }
        Some(result * self.scale)
    }

    /// [`Fbm2::get_grad`], bit for bit, unless the value is surely above
    /// `bar` (as [`Fbm2::get_unless_above`]).
    pub(super) fn get_grad_unless_above(&self, q: [f64; 2], bar: f64) -> Option<(f64, [f64; 2])> {
        let t = self.sum_bar(bar);
        let mut point = q.map(|x| x * self.frequency);
        let (mut result, mut attenuation, mut f) = (0.0, 0.5, self.frequency);
        let mut g = [0.0f64; 2];
        for (octave, rest) in self.octaves.iter().zip(&self.rest) {
            if result - rest > t {
                return None;
            }
            let (mut signal, og) = octave.get_grad(point);
            g[0] += og[0] * (attenuation * f);
            g[1] += og[1] * (attenuation * f);
            signal *= attenuation;
            attenuation *= 0.5;
            result += signal;
            point = point.map(|x| x * 2.0);
            f *= 2.0;
        }
        Some((result * self.scale, g.map(|x| x * self.scale)))
    }

    /// The value at `q` (world units), as `Fbm::get` computes it.
    #[inline]
    pub(super) fn get(&self, q: [f64; 2]) -> f64 {
        // One octave loop for both (a second copy measured slower: the
        // octave's noise was no longer inlined into either).
        self.get_unless_above(q, f64::INFINITY)
            .expect("no value is above infinity")
    }

    /// Value (as [`Fbm2::get`], bit for bit) and gradient at `q` (world units).
    #[inline]
    pub(super) fn get_grad(&self, q: [f64; 2]) -> (f64, [f64; 2]) {
        // One octave loop for both, as in `get`.
        self.get_grad_unless_above(q, f64::INFINITY)
            .expect("no value is above infinity")
    }
}
