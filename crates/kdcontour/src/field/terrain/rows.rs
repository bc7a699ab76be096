//! [`Density`]'s batched sampling: a grid's corners row by row (one y and z, every
//! x), with the same values as [`Field::value`] bit for bit.
//!
//! Per row and octave the lattice cells, blends and hash bytes of y and z are
//! found once ([`super::perlin::Perlin3::get_row`]), and the cave noises run only
//! over the row's points that [`Density::value`] would evaluate them at (the same
//! tests, in the same order, on the same f32 values).

use super::Density;
use crate::field::Field;
use crate::grid::{Grid, FAR};
use glam::{UVec3, Vec3};

/// Buffers reused from row to row.
#[derive(Default)]
struct RowScratch {
    positions: Vec<Vec3>,
    /// The row's x in f64, and its fBm.
    xs: Vec<f64>,
    fbm: Vec<f64>,
    /// Scratch of [`super::perlin::Fbm3::get_row`] and of
    /// [`super::perlin::Fbm3::get_row_below`].
    octave: Vec<f64>,
    below: super::perlin::RowBelow,
    /// The row's points that need the first cave noise, and that noise.
    first: Vec<usize>,
    n1: Vec<f64>,
    /// The points that need the second cave noise too, their first noise, and
    /// the second.
    second: Vec<usize>,
    n1_kept: Vec<f64>,
    n2: Vec<f64>,
    /// Cave noise x coordinates.
    cave_xs: Vec<f64>,
}

impl Density {
    /// Samples the corners of `grid` with z in `z_range` into `out` (x fastest),
    /// row by row: [`Field::sample_grid`].
    /// With `far`, a corner whose surface term the fBm's first octaves prove to
    /// be more than `far` (the sky, well above the surface) gets
    /// [`crate::grid::FAR`] instead: the tunnel term cannot lower the value
    /// below the surface term, so its sign is exact.
    pub(super) fn sample_rows(
        &self,
        grid: &Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: Option<f32>,
    ) {
        let c = grid.corners();
        let mut s = RowScratch::default();
        let rows = z_range.flat_map(|z| (0..c.y).map(move |y| (y, z)));
        for ((y, z), out) in rows.zip(out.chunks_mut(c.x as usize)) {
            s.positions.clear();
            s.positions
                .extend((0..c.x).map(|x| grid.corner_pos(UVec3::new(x, y, z))));
            self.value_row(out, &mut s, far);
        }
    }

    /// [`Field::value`] at every point of `s.positions` (one y and z) into `out`;
    /// with `far`, [`crate::grid::FAR`] where the surface term is provably above
    /// `far` ([`Density::sample_rows`]).
    fn value_row(&self, out: &mut [f32], s: &mut RowScratch, far: Option<f32>) {
        let ps = &s.positions;
        let Some(first) = ps.first() else {
            return;
        };
        let (y, z) = (first.y, first.z);
        let reach = |p: &Vec3| self.in_reach([p.x as f64, p.y as f64, p.z as f64]);
        if !ps.iter().all(|p| p.y == y && p.z == z && reach(p)) {
            // Not one row of points in reach: point by point (NaN out of reach).
            for (o, p) in out.iter_mut().zip(ps) {
                *o = self.value(*p);
            }
            return;
        }
        let (y64, z64) = (y as f64, z as f64);
        s.xs.clear();
        s.xs.extend(ps.iter().map(|p| p.x as f64));
        s.fbm.resize(ps.len(), 0.0);
        let amp = self.params.amplitude;
        match far {
            // `solid > far` where `amp * fbm < y - base - far`; the f32 rounding
            // of the surface term is far below the margin.
            Some(far) if amp > 0.0 => {
                let below = (y64 - self.params.base as f64 - far as f64) / amp as f64;
                self.noise
                    .get_row_below(&s.xs, y64, z64, below, &mut s.fbm, &mut s.below);
            }
            _ => self
                .noise
                .get_row(&s.xs, y64, z64, &mut s.fbm, &mut s.octave),
        }
        for (o, n) in out.iter_mut().zip(&s.fbm) {
            *o = if n.is_nan() { FAR } else { self.solid(y, *n) };
        }
        let (Some(c), Some((a, b))) = (&self.params.caves, &self.caves) else {
            return;
        };
        // The cave noises only where `value` evaluates them: the first where the
        // surface term does not decide, the second where the first does not.
        let f = c.frequency as f64;
        let (yc, zc) = (y64 * f, z64 * f);
        s.first.clear();
        s.first
            .extend((0..ps.len()).filter(|&i| out[i] != FAR && !self.solid_decides(out[i]).0));
        s.cave_xs.clear();
        s.cave_xs.extend(s.first.iter().map(|&i| s.xs[i] * f));
        s.n1.resize(s.first.len(), 0.0);
        a.get_row(&s.cave_xs, yc, zc, &mut s.n1);
        s.second.clear();
        s.n1_kept.clear();
        for (&i, &n1) in s.first.iter().zip(&s.n1) {
            if !self.first_cave_decides(out[i], n1 as f32) {
                s.second.push(i);
                s.n1_kept.push(n1);
            }
        }
        s.cave_xs.clear();
        s.cave_xs.extend(s.second.iter().map(|&i| s.xs[i] * f));
        s.n2.resize(s.second.len(), 0.0);
        b.get_row(&s.cave_xs, yc, zc, &mut s.n2);
        for ((&i, n1), n2) in s.second.iter().zip(&s.n1_kept).zip(&s.n2) {
            out[i] = self.with_tunnel(out[i], *n1 as f32, *n2 as f32);
        }
    }
}

/// The steps of [`Density::value`], shared with the rows.
impl Density {
    /// The surface term at height `y` where the fBm is `n`.
    #[inline]
    pub(super) fn solid(&self, y: f32, n: f64) -> f32 {
        y - self.params.base - self.params.amplitude * n as f32
    }

    /// `(true, _)` when the surface term `solid` is the value whatever the cave
    /// noises are (it reaches the tunnel term's largest value, less the fade);
    /// else `(false, fade)`.
    #[inline]
    pub(super) fn solid_decides(&self, solid: f32) -> (bool, f32) {
        let Some(c) = &self.params.caves else {
            return (true, 0.0);
        };
        // Without a depth band the fade is 0 and `tunnel - 0.0` is `tunnel`.
        let fade = c.fade(-solid as f64) as f32;
        // The tunnel term is at most `radius / frequency` in f32 too (the square
        // root is >= 0 and rounding is monotone).
        (solid >= c.radius / c.frequency - fade, fade)
    }

    /// Whether the first cave noise `n1` proves the surface term the value:
    /// `|(n1, n2)| >= |n1|` in f32 too (adding `n2 * n2 >= 0` and the square
    /// root are monotone under rounding), so the tunnel term is at most the one
    /// with `n2 = 0`, and `solid` above that is above the tunnel.
    #[inline]
    pub(super) fn first_cave_decides(&self, solid: f32, n1: f32) -> bool {
        let Some(c) = &self.params.caves else {
            return true;
        };
        let fade = self.solid_decides(solid).1;
        solid > (c.radius - (n1 * n1).sqrt()) / c.frequency - fade
    }

    /// The value from the surface term and both cave noises (f32).
    #[inline]
    pub(super) fn with_tunnel(&self, solid: f32, n1: f32, n2: f32) -> f32 {
        let Some(c) = &self.params.caves else {
            return solid;
        };
        let fade = self.solid_decides(solid).1;
        // Positive inside a tunnel (air); the terrain is air where either is.
        let tunnel = (c.radius - (n1 * n1 + n2 * n2).sqrt()) / c.frequency;
        solid.max(tunnel - fade)
    }
}
