//! A sampled scalar volume (CT, MRI, simulation output) as a field: trilinear
//! interpolation of voxel values around an iso value, closed at the volume's edge.

use super::Field;
use glam::{UVec3, Vec3};

/// Which side of the iso value is inside the surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Inside {
    /// Values above the iso value are inside (CT: bone is dense).
    #[default]
    Above,
    /// Values below the iso value are inside (distance fields, some MRI).
    Below,
}

/// Voxel values on a regular grid. Voxel `(i, j, k)` sits at
/// `origin + (i, j, k) * spacing`; x varies fastest in `data`.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledVolume {
    /// Voxels along x, y, z (each at least 2).
    pub dims: UVec3,
    /// Distance between voxel centres along x, y, z (world units, positive).
    pub spacing: Vec3,
    /// World position of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Voxel values, x fastest.
    pub data: Vec<f32>,
    /// The iso value the surface is extracted at.
    pub iso: f32,
    /// Which side is inside.
    pub inside: Inside,
}

impl SampledVolume {
    /// The world-space box the voxels span.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (
            self.origin,
            self.origin + (self.dims - UVec3::ONE).as_vec3() * self.spacing,
        )
    }

    /// Smallest and largest voxel value.
    pub fn range(&self) -> (f32, f32) {
        self.data
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// Checks that a surface at `iso` can exist: `iso` lies strictly between the
    /// smallest and largest voxel value. Otherwise every voxel is on one side and
    /// the mesh would be empty (or, at the volume's faces, a box); the message
    /// gives the range to choose from.
    pub fn check_iso(&self, iso: f32) -> Result<(), String> {
        let (lo, hi) = self.range();
        if lo < iso && iso < hi {
            return Ok(());
        }
        Err(if lo == hi {
            format!("every voxel is {lo}: the volume holds no surface")
        } else {
            format!(
                "iso {iso} is outside the voxel values ({lo} to {hi}), so there is no surface; give an iso strictly between them"
            )
        })
    }

    fn voxel(&self, x: u32, y: u32, z: u32) -> f32 {
        self.data[(x + self.dims.x * (y + self.dims.y * z)) as usize]
    }

    /// Trilinear interpolation at `p` (clamped into the volume).
    pub fn interpolate(&self, p: Vec3) -> f32 {
        let max = (self.dims - UVec3::ONE).as_vec3();
        let g = ((p - self.origin) / self.spacing).clamp(Vec3::ZERO, max);
        let i = g.floor().as_uvec3().min(self.dims - UVec3::splat(2));
        let f = g - i.as_vec3();
        let v = |dx: u32, dy: u32, dz: u32| self.voxel(i.x + dx, i.y + dy, i.z + dz);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(v(0, 0, 0), v(1, 0, 0), f.x);
        let x10 = lerp(v(0, 1, 0), v(1, 1, 0), f.x);
        let x01 = lerp(v(0, 0, 1), v(1, 0, 1), f.x);
        let x11 = lerp(v(0, 1, 1), v(1, 1, 1), f.x);
        lerp(lerp(x00, x10, f.y), lerp(x01, x11, f.y), f.z)
    }
}

impl Field for SampledVolume {
    /// `iso - value` (inside above) or `value - iso`, intersected with the volume's
    /// box so surfaces that reach the edge of the scan are closed there.
    fn value(&self, p: Vec3) -> f32 {
        let v = self.interpolate(p);
        let d = match self.inside {
            Inside::Above => self.iso - v,
            Inside::Below => v - self.iso,
        };
        let (lo, hi) = self.bounds();
        let c = (lo + hi) * 0.5;
        let half = (hi - lo) * 0.5;
        let q = (p - c).abs() - half;
        let outside_box = q.max(Vec3::ZERO).length() + q.max_element().min(0.0);
        d.max(outside_box)
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        // A quarter voxel: inside one trilinear cell on either side of most points.
        let h = 0.25 * self.spacing.min_element();
        super::central_difference(|q| self.value(q), p, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_is_exact_at_voxels_and_linear_between() {
        let vol = SampledVolume {
            dims: UVec3::new(2, 2, 2),
            spacing: Vec3::new(1.0, 2.0, 4.0),
            origin: Vec3::ZERO,
            data: vec![0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
            iso: 0.5,
            inside: Inside::Above,
        };
        assert_eq!(vol.interpolate(Vec3::new(1.0, 2.0, 4.0)), 1.0);
        assert!((vol.interpolate(Vec3::new(0.25, 1.0, 2.0)) - 0.25).abs() < 1e-6);
        // Inside above the iso value, outside beyond the box.
        assert!(vol.value(Vec3::new(0.9, 1.0, 2.0)) < 0.0);
        assert!(vol.value(Vec3::new(0.1, 1.0, 2.0)) > 0.0);
        assert!(vol.value(Vec3::new(3.0, 1.0, 2.0)) > 0.0);
    }
}
