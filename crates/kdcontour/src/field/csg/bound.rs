//! Bounds: the sphere around each compiled node that lets unions and differences
//! skip children which cannot change the result (compilation gives each node
//! its own, [`super::compile`]).

use glam::Vec3;

/// A sphere with `value(p) >= |p - center| - radius` everywhere: for an exact SDF any
/// sphere enclosing the shape (inside, the distance to the shape's boundary is at
/// most the distance to the sphere's).
#[derive(Clone, Copy, Debug)]
pub(super) struct Bound {
    /// Center.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl Bound {
    /// A lower bound of the value at `p`: its distance to the sphere.
    pub(super) fn lower(&self, p: Vec3) -> f32 {
        p.distance(self.center) - self.radius
    }
    /// The sphere with its radius grown by `by`.
    pub(super) fn grow(self, by: f32) -> Bound {
        Bound {
            center: self.center,
            radius: self.radius + by,
        }
    }
}

/// A sphere enclosing all of `bounds`, or `None` if one of them is unbounded.
pub(super) fn enclose(bounds: &[Option<Bound>]) -> Option<Bound> {
    let b: Option<Vec<Bound>> = bounds.iter().cloned().collect();
    let b = b?;
    let (lo, hi) = b
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x.center - x.radius), hi.max(x.center + x.radius))
        });
    let center = (lo + hi) * 0.5;
    let radius = b
        .iter()
        .map(|x| x.center.distance(center) + x.radius)
        .fold(0.0, f32::max);
    Some(Bound { center, radius })
}
