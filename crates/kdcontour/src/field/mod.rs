//! Scalar fields: negative inside, positive outside, zero on the surface.
//!
//! [`Field`] is the one interface the mesher samples. [`sdf`] has exact signed
//! distance primitives, [`csg`] combines them into a serialisable scene tree, and
//! [`terrain`] builds height-field and 3-D density terrain from the `noise` crate.

pub mod csg;
pub mod layers;
pub mod mesh_sdf;
pub mod sdf;
pub mod terrain;
pub mod volume;

use crate::grid::Grid;
use crate::material::MaterialBlend;
use glam::Vec3;

/// Smallest step of the central differences used by [`Field::gradient`]'s default,
/// in world units. Small enough for features a few cells wide at cell sizes down to
/// 1e-3, large enough that f32 cancellation stays below 1e-3 relative on unit-scale
/// fields. Far from the origin the step grows with the coordinates
/// ([`gradient_step`]).
pub const GRADIENT_STEP: f32 = 1e-4;

/// Units in the last place of the largest coordinate that one step of
/// [`gradient_step`] spans at least.
const STEP_ULPS: f32 = 32.0;

/// The step [`Field::gradient`]'s default takes at `p`: [`GRADIENT_STEP`], or 32
/// units in the last place of `p`'s largest coordinate where that is more.
///
/// A fixed step fails far out: at `|x| >= 2048` an f32 step of 1e-4 is below the
/// spacing of representable coordinates, `x + h == x`, and the difference is 0.
/// With at least 32 ulps both sides are distinct points, the step actually taken
/// ([`central_difference`] divides by it) is exact, and a field rounded to its
/// coordinates' precision errs by at most about 1/64 of its slope. The step passes
/// `GRADIENT_STEP` beyond `|p| = 32`.
pub fn gradient_step(p: Vec3) -> f32 {
    let m = p.abs().max_element();
    if !m.is_finite() {
        return GRADIENT_STEP;
    }
    let ulp = f32::from_bits(m.to_bits() + 1) - m;
    GRADIENT_STEP.max(STEP_ULPS * ulp)
}

/// A scalar field sampled by the mesher. Negative is inside.
pub trait Field: Send + Sync {
    /// The field's value at `p` (world units).
    fn value(&self, p: Vec3) -> f32;

    /// The gradient at `p`. The default uses central differences of
    /// [`Field::value`] with step [`gradient_step`]`(p)`; analytic fields override
    /// it.
    fn gradient(&self, p: Vec3) -> Vec3 {
        central_difference(|q| self.value(q), p, gradient_step(p))
    }

    /// [`Field::value`] and [`Field::gradient`] at `p`, both bit for bit, from
    /// one evaluation that costs little more than the value alone (an analytic
    /// gradient computed alongside it), or `None` when the field has no such
    /// evaluation (the default). The Hermite stage's root search uses it so the
    /// evaluation that finds a crossing gives its normal too.
    fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
        let _ = p;
        None
    }

    /// Sound bounds `(lo, hi)` of the value over the box `[lo, hi]`: every point
    /// of the box has `lo <= value <= hi` (up to f32 rounding of the value itself,
    /// a few ulps), or `None` when the field cannot tell. Chunk builds skip
    /// sampling a box the bound proves to be of one sign
    /// ([`crate::hermite::one_sign`]).
    ///
    /// The default uses [`Field::lipschitz`]: the value at the box's center, plus
    /// or minus `L` times its half-diagonal.
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let l = self.lipschitz().filter(|l| l.is_finite() && *l > 0.0)?;
        let v = self.value((lo + hi) * 0.5);
        let r = l * (hi - lo).length() * 0.5;
        (v.is_finite() && r.is_finite()).then_some((v - r, v + r))
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
        sample_each(grid, z_range, out, |p| self.value(p));
    }

    /// [`Field::sample_grid`] for the build's sampling stage, which needs exact
    /// values only near the surface: a corner whose value is provably more than
    /// `far` from zero may hold `f32::MAX` with the value's sign instead
    /// (the build evaluates such a corner where it needs the value). By default
    /// [`Field::sample_grid`].
    fn sample_grid_far(
        &self,
        grid: &Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: f32,
    ) {
        let _ = far;
        self.sample_grid(grid, z_range, out)
    }

    /// Why the value at `p` is not finite, when the field can tell (a scene's
    /// noise node evaluated beyond its reach names its node path and what would
    /// be valid); the error of a non-finite sample carries it. `None` by default.
    fn explain_non_finite(&self, p: Vec3) -> Option<String> {
        let _ = p;
        None
    }

    /// The material at `p` ([`crate::material`]); material 0 by default.
    fn material(&self, p: Vec3) -> MaterialBlend {
        let _ = p;
        MaterialBlend::single(0)
    }

    /// [`Field::material`] at `p`, where the caller has the field's gradient
    /// ([`Field::gradient`] at `p`): fields whose material rule reads the
    /// gradient use it instead of computing it again, and give the same
    /// material to rounding. By default [`Field::material`].
    fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> MaterialBlend {
        let _ = gradient;
        self.material(p)
    }

    /// [`Field::gradient`] and [`Field::material`] at `p` together (the Hermite
    /// stage needs both at every crossing when it keeps material borders): fields
    /// whose material and gradient share work compute it once. By default the
    /// gradient, then [`Field::material_with_gradient`].
    fn gradient_and_material(&self, p: Vec3) -> (Vec3, MaterialBlend) {
        let g = self.gradient(p);
        (g, self.material_with_gradient(p, g))
    }

    /// Whether the field has materials: meshes then carry one blend per vertex
    /// and the tree keeps material borders crisp. `false` by default.
    fn has_materials(&self) -> bool {
        false
    }
}

/// Fills `out` with `value` at every corner of `grid` with z in `z_range` (x
/// fastest, then y, then z): the per-corner [`Field::sample_grid`].
pub fn sample_each(
    grid: &Grid,
    z_range: std::ops::Range<u32>,
    out: &mut [f32],
    value: impl Fn(Vec3) -> f32,
) {
    let c = grid.corners();
    let mut i = 0;
    for z in z_range {
        for y in 0..c.y {
            for x in 0..c.x {
                out[i] = value(grid.corner_pos(glam::UVec3::new(x, y, z)));
                i += 1;
            }
        }
    }
}

/// Central differences of `f` at `p` with step `h`, each divided by the distance
/// between the two points actually evaluated (`p + h` and `p - h` rounded to f32),
/// so a step that is not a multiple of the coordinate's spacing costs no accuracy.
pub fn central_difference(f: impl Fn(Vec3) -> f32, p: Vec3, h: f32) -> Vec3 {
    let mut g = Vec3::ZERO;
    for a in 0..3 {
        let (mut hi, mut lo) = (p, p);
        hi[a] += h;
        lo[a] -= h;
        g[a] = (f(hi) - f(lo)) / (hi[a] - lo[a]);
    }
    g
}

/// A reference or smart pointer to a field is the field: every method forwards.
macro_rules! forward_field {
    ($($ptr:ty),*) => {$(
        impl<F: Field + ?Sized> Field for $ptr {
            fn value(&self, p: Vec3) -> f32 {
                (**self).value(p)
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                (**self).gradient(p)
            }
            fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
                (**self).value_and_gradient(p)
            }
            fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
                (**self).sample_grid(grid, z_range, out)
            }
            fn sample_grid_far(
                &self,
                grid: &Grid,
                z_range: std::ops::Range<u32>,
                out: &mut [f32],
                far: f32,
            ) {
                (**self).sample_grid_far(grid, z_range, out, far)
            }
            fn lipschitz(&self) -> Option<f32> {
                (**self).lipschitz()
            }
            fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
                (**self).bound(lo, hi)
            }
            fn explain_non_finite(&self, p: Vec3) -> Option<String> {
                (**self).explain_non_finite(p)
            }
            fn material(&self, p: Vec3) -> MaterialBlend {
                (**self).material(p)
            }
            fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> MaterialBlend {
                (**self).material_with_gradient(p, gradient)
            }
            fn gradient_and_material(&self, p: Vec3) -> (Vec3, MaterialBlend) {
                (**self).gradient_and_material(p)
            }
            fn has_materials(&self) -> bool {
                (**self).has_materials()
            }
        }
    )*};
}

forward_field!(&F, Box<F>, std::sync::Arc<F>);

/// `inner - iso`: moves the surface to the `iso` level set of `inner` (an iso-value
/// slider over a scan, or growing and shrinking a shape).
pub struct IsoShift {
    /// The field.
    pub inner: std::sync::Arc<dyn Field>,
    /// The level that becomes the surface.
    pub iso: f32,
}

impl Field for IsoShift {
    fn value(&self, p: Vec3) -> f32 {
        self.inner.value(p) - self.iso
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.inner.gradient(p)
    }
    fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
        let (v, g) = self.inner.value_and_gradient(p)?;
        Some((v - self.iso, g))
    }
    fn sample_grid(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        self.inner.sample_grid(grid, z_range, out);
        for v in out.iter_mut() {
            *v -= self.iso;
        }
    }
    /// The inner field's, proved far by `|iso|` more, so a corner it skips is
    /// still more than `far` from the shifted surface.
    fn sample_grid_far(
        &self,
        grid: &Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: f32,
    ) {
        self.inner
            .sample_grid_far(grid, z_range, out, far + self.iso.abs());
        for v in out.iter_mut().filter(|v| v.abs() != crate::grid::FAR) {
            *v -= self.iso;
        }
    }
    fn lipschitz(&self) -> Option<f32> {
        self.inner.lipschitz()
    }
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (a, b) = self.inner.bound(lo, hi)?;
        Some((a - self.iso, b - self.iso))
    }
    fn explain_non_finite(&self, p: Vec3) -> Option<String> {
        self.inner.explain_non_finite(p)
    }
    fn material(&self, p: Vec3) -> MaterialBlend {
        self.inner.material(p)
    }
    fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> MaterialBlend {
        self.inner.material_with_gradient(p, gradient)
    }
    fn gradient_and_material(&self, p: Vec3) -> (Vec3, MaterialBlend) {
        self.inner.gradient_and_material(p)
    }
    fn has_materials(&self) -> bool {
        self.inner.has_materials()
    }
}

/// A field from a closure (gradient by central differences).
pub struct FnField<F>(pub F);

impl<F: Fn(Vec3) -> f32 + Send + Sync> Field for FnField<F> {
    fn value(&self, p: Vec3) -> f32 {
        (self.0)(p)
    }
}

/// Where a ray first meets the surface of `field`: the distance `t` along `dir`
/// (normalised here) from `origin`, up to `max_dist`, or `None`.
///
/// Marches with steps of `|f| / L` (sphere tracing) where the field gives a
/// Lipschitz bound `L`, and of at most `max_step` otherwise (noise fields: a sign
/// change inside one step can be missed only for features thinner than
/// `max_step`), then refines the crossing by bisection to 1e-5 of `max_step`.
/// A ray that starts inside hits at `t = 0`. Non-finite samples end the march.
pub fn raycast(
    field: &dyn Field,
    origin: Vec3,
    dir: Vec3,
    max_dist: f32,
    max_step: f32,
) -> Option<f32> {
    let dir = dir.normalize_or_zero();
    if dir == Vec3::ZERO || !(max_step.is_finite() && max_step > 0.0) || !max_dist.is_finite() {
        return None;
    }
    let lip = field.lipschitz().filter(|l| l.is_finite() && *l > 0.0);
    let mut t = 0.0f32;
    let mut f = field.value(origin);
    if !f.is_finite() {
        return None;
    }
    if f <= 0.0 {
        return Some(0.0);
    }
    let min_step = max_step * 1e-3;
    while t < max_dist {
        let step = match lip {
            Some(l) => (f / l).clamp(min_step, max_step.max(min_step)),
            None => max_step,
        };
        let t1 = (t + step).min(max_dist);
        let f1 = field.value(origin + dir * t1);
        if !f1.is_finite() {
            return None;
        }
        if f1 <= 0.0 {
            // Bisect [t, t1]: outside at t, inside at t1.
            // (At most 64 halvings: far from the origin f32 cannot resolve
            // 1e-5 of a step, and the midpoint stops moving.)
            let (mut a, mut b) = (t, t1);
            for _ in 0..64 {
                let m = 0.5 * (a + b);
                if b - a <= max_step * 1e-5 || m <= a || m >= b {
                    break;
                }
                if field.value(origin + dir * m) > 0.0 {
                    a = m;
                } else {
                    b = m;
                }
            }
            return Some(b);
        }
        if t1 >= max_dist {
            break;
        }
        t = t1;
        f = f1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where a field gives [`Field::value_and_gradient`], both parts are
    /// [`Field::value`]'s and [`Field::gradient`]'s bit for bit (the root
    /// search takes its crossings' normals from it): every built-in scene, the
    /// plugin's terrain chunk, a field shifted to another level and an edited
    /// field with no brushes yet, at points on and off their surfaces.
    #[test]
    fn value_and_gradient_is_value_and_gradient_bit_for_bit() {
        let (chunk, _) = crate::scenes::terrain_chunk(16);
        let mut fields: Vec<(String, std::sync::Arc<dyn Field>)> = crate::scenes::SCENES
            .iter()
            .map(|name| {
                let field: std::sync::Arc<dyn Field> =
                    crate::scenes::scene(name).unwrap().field.into();
                (name.to_string(), field)
            })
            .collect();
        fields.push(("terrain chunk".into(), std::sync::Arc::new(chunk)));
        let terrain = fields.iter().find(|f| f.0 == "terrain").unwrap().1.clone();
        fields.push((
            "iso shift".into(),
            std::sync::Arc::new(IsoShift {
                inner: terrain.clone(),
                iso: 0.1,
            }),
        ));
        fields.push((
            "edited".into(),
            std::sync::Arc::new(crate::edit::EditedField::new(terrain)),
        ));
        let mut joint = 0;
        for (name, field) in &fields {
            for i in 0..2000u32 {
                // Points over the scenes' box and a little beyond, and a chunk's
                // 16 cells.
                let h =
                    |k: u32| ((i.wrapping_mul(2654435761) ^ (k * 40503)) % 10007) as f32 / 10007.0;
                let p = Vec3::new(h(1), h(2), h(3)) * 2.4 - Vec3::splat(1.2);
                let p = if name == "terrain chunk" { p * 8.0 } else { p };
                let Some((v, g)) = field.value_and_gradient(p) else {
                    continue;
                };
                joint += 1;
                assert_eq!(v.to_bits(), field.value(p).to_bits(), "{name} value at {p}");
                let g0 = field.gradient(p);
                assert_eq!(
                    g.to_array().map(f32::to_bits),
                    g0.to_array().map(f32::to_bits),
                    "{name} gradient at {p}"
                );
            }
        }
        // The CSG scenes (but caves, whose 3-D noise has no cheap gradient), the
        // height field and the wrappers around it give it.
        assert!(joint >= 2000 * (fields.len() - 3), "{joint}");
    }

    #[test]
    fn raycast_hits_a_sphere_where_it_should() {
        let sphere = csg::CsgNode::from_json(r#"{"type":"sphere","radius":1.0}"#)
            .unwrap()
            .compile()
            .unwrap();
        assert_eq!(sphere.lipschitz(), Some(1.0));
        let t = raycast(&sphere, Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 10.0, 0.5).unwrap();
        assert!((t - 4.0).abs() < 1e-4, "{t}");
        // Without a Lipschitz bound (fixed steps) the answer is the same.
        let plain = FnField(|p: Vec3| p.length() - 1.0);
        let t = raycast(&plain, Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 10.0, 0.1).unwrap();
        assert!((t - 4.0).abs() < 1e-4, "{t}");
        // Misses, too short, inside, degenerate.
        assert_eq!(
            raycast(&sphere, Vec3::new(0.0, 2.0, -5.0), Vec3::Z, 10.0, 0.5),
            None
        );
        assert_eq!(
            raycast(&sphere, Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 3.0, 0.5),
            None
        );
        assert_eq!(raycast(&sphere, Vec3::ZERO, Vec3::X, 3.0, 0.5), Some(0.0));
        assert_eq!(
            raycast(&sphere, Vec3::new(0.0, 0.0, -5.0), Vec3::ZERO, 9.0, 0.5),
            None
        );
        // Far from the origin f32 cannot resolve the bisection tolerance: it
        // still ends, on the surface to f32 precision.
        let far = FnField(|p: Vec3| 1000.3 - p.x);
        let t = raycast(&far, Vec3::ZERO, Vec3::X, 2000.0, 0.5).unwrap();
        assert!((t - 1000.3).abs() < 1e-3, "{t}");
        let nan = FnField(|_| f32::NAN);
        assert_eq!(raycast(&nan, Vec3::ZERO, Vec3::X, 3.0, 0.5), None);
    }

    #[test]
    fn lipschitz_bounds_and_iso_shifts_hold() {
        let sphere: std::sync::Arc<dyn Field> = std::sync::Arc::new(
            csg::CsgNode::from_json(r#"{"type":"sphere","radius":1.0}"#)
                .unwrap()
                .compile()
                .unwrap(),
        );
        let shifted = IsoShift {
            inner: sphere.clone(),
            iso: 0.25,
        };
        let mut rng = crate::world::layout::Rng(2);
        let mut unit3 = || Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32);
        for _ in 0..200 {
            let lo = unit3() * 6.0 - 3.0;
            let hi = lo + unit3() * 2.0;
            let (a, b) = sphere.bound(lo, hi).unwrap();
            let (sa, sb) = shifted.bound(lo, hi).unwrap();
            assert_eq!((sa, sb), (a - 0.25, b - 0.25));
            for _ in 0..20 {
                let p = lo + (hi - lo) * unit3();
                let (v, s) = (sphere.value(p), shifted.value(p));
                assert!(a <= v && v <= b && sa <= s && s <= sb);
            }
        }
        // No Lipschitz bound, no value bound.
        assert_eq!(FnField(|p: Vec3| p.x).bound(Vec3::ZERO, Vec3::ONE), None);
    }
}
