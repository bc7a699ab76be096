//! Scalar fields: negative inside, positive outside, zero on the surface.
//!
//! [`Field`] is the one interface the mesher samples. [`sdf`] has exact signed
//! distance primitives, [`csg`] combines them into a serialisable scene tree, and
//! [`terrain`] builds height-field and 3-D density terrain from the `noise` crate.

pub mod csg;
pub mod mesh_sdf;
pub mod sdf;
pub mod terrain;
pub mod volume;

use crate::grid::Grid;
use glam::Vec3;

/// Step of the central differences used by [`Field::gradient`]'s default, in world
/// units. Small enough for features a few cells wide at cell sizes down to 1e-3,
/// large enough that f32 cancellation stays below 1e-3 relative on unit-scale fields.
pub const GRADIENT_STEP: f32 = 1e-4;

/// A scalar field sampled by the mesher. Negative is inside.
pub trait Field: Send + Sync {
    /// The field's value at `p` (world units).
    fn value(&self, p: Vec3) -> f32;

    /// The gradient at `p`. The default uses central differences of
    /// [`Field::value`] with step [`GRADIENT_STEP`]; analytic fields override it.
    fn gradient(&self, p: Vec3) -> Vec3 {
        central_difference(|q| self.value(q), p, GRADIENT_STEP)
    }

    /// A Lipschitz bound `L` (|f(a) - f(b)| <= L |a - b|), if the field has one.
    /// Exact signed distances have `L = 1`. With a bound, sampling skips blocks of
    /// the grid that are provably far from the surface; without one every corner is
    /// evaluated.
    fn lipschitz(&self) -> Option<f32> {
        None
    }

    /// Samples the corners of `grid` with z in `z_range` into `out` (x fastest, then
    /// y, then z).
    /// `out.len()` must equal `grid.corner_count()`. Fields with a faster batched
    /// evaluator override this; the default calls [`Field::value`] per corner.
    fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        let c = grid.corners();
        let mut i = 0;
        for z in z_range {
            for y in 0..c.y {
                for x in 0..c.x {
                    out[i] = self.value(grid.corner_pos(glam::UVec3::new(x, y, z)));
                    i += 1;
                }
            }
        }
    }
}

/// Central differences of `f` at `p` with step `h`.
pub fn central_difference(f: impl Fn(Vec3) -> f32, p: Vec3, h: f32) -> Vec3 {
    let dx = f(p + Vec3::X * h) - f(p - Vec3::X * h);
    let dy = f(p + Vec3::Y * h) - f(p - Vec3::Y * h);
    let dz = f(p + Vec3::Z * h) - f(p - Vec3::Z * h);
    Vec3::new(dx, dy, dz) / (2.0 * h)
}

impl<F: Field + ?Sized> Field for &F {
    fn value(&self, p: Vec3) -> f32 {
        (**self).value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        (**self).gradient(p)
    }
    fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        (**self).sample_grid(grid, z_range, out)
    }
    fn lipschitz(&self) -> Option<f32> {
        (**self).lipschitz()
    }
}

impl<F: Field + ?Sized> Field for Box<F> {
    fn value(&self, p: Vec3) -> f32 {
        (**self).value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        (**self).gradient(p)
    }
    fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        (**self).sample_grid(grid, z_range, out)
    }
    fn lipschitz(&self) -> Option<f32> {
        (**self).lipschitz()
    }
}

impl<F: Field + ?Sized> Field for std::sync::Arc<F> {
    fn value(&self, p: Vec3) -> f32 {
        (**self).value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        (**self).gradient(p)
    }
    fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        (**self).sample_grid(grid, z_range, out)
    }
    fn lipschitz(&self) -> Option<f32> {
        (**self).lipschitz()
    }
}

/// A field from a closure (gradient by central differences).
pub struct FnField<F>(pub F);

impl<F: Fn(Vec3) -> f32 + Send + Sync> Field for FnField<F> {
    fn value(&self, p: Vec3) -> f32 {
        (self.0)(p)
    }
}
