//! Edits: brushes (any CSG shape, usually one transformed primitive) applied to a
//! base field in order. The log is serialisable, so an edited world can be saved
//! and replayed exactly; [`compact`] drops the brushes later ones provably erase;
//! [`EditHistory`] adds undo and redo, and [`Sequencer`] and [`Replica`] keep
//! peers' histories equal over an unreliable network.

mod compact;
mod history;
mod material;
mod sequence;

pub use compact::compact;
pub use history::{EditHistory, UndoSteps};
pub use sequence::{EditOp, Replica, Sequencer, Snapshot};

/// The field the history and sequence tests edit: a sphere of radius 10 at the
/// origin, with no brushes.
#[cfg(test)]
fn test_base() -> EditedField {
    let sphere = CsgNode::Sphere {
        radius: 10.0,
        center: Vec3::ZERO,
    };
    EditedField::new(Arc::new(sphere.compile().expect("a valid sphere")))
}

use crate::error::{Error, Result};
use crate::field::csg::{Csg, CsgNode};
use crate::field::Field;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// How a brush combines with the field.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum BrushOp {
    /// Union: add material.
    Add,
    /// Difference: dig.
    Subtract,
    /// Union blended over `radius`.
    SmoothAdd {
        /// Blend radius (> 0).
        radius: f32,
    },
    /// Difference blended over `radius`.
    SmoothSubtract {
        /// Blend radius (> 0).
        radius: f32,
    },
    /// Gives the surface inside the shape the brush's material, without moving
    /// it (the value is unchanged).
    Paint,
}

/// One edit: a shape and what to do with it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Brush {
    /// The brush's shape (world coordinates); must be bounded.
    pub shape: CsgNode,
    /// The operation.
    pub op: BrushOp,
    /// The material the brush leaves where it wins (adds, digs or paints);
    /// smooth brushes blend it in with their blend factor. 0 by default (logs
    /// saved before brushes had materials load as material 0).
    #[serde(default)]
    pub material: u8,
}

impl Brush {
    /// A sphere brush of material 0.
    pub fn sphere(center: Vec3, radius: f32, op: BrushOp) -> Brush {
        Brush {
            shape: CsgNode::Sphere { radius, center },
            op,
            material: 0,
        }
    }

    /// Checks the brush as applying it would (a bounded shape of finite
    /// values, a positive blend radius) and returns the region it can change
    /// (center and radius), without applying it.
    pub fn reach(&self) -> Result<(Vec3, f32)> {
        Ok(EditedField::compile(self.clone())?.reach)
    }

    /// This brush with material `id`.
    pub fn with_material(self, id: u8) -> Brush {
        Brush {
            material: id,
            ..self
        }
    }
}

struct Compiled {
    brush: Brush,
    field: Csg,
    /// Center and radius beyond which the brush cannot change the field.
    reach: (Vec3, f32),
    blend: f32,
}

/// A base field with a log of brushes applied in order.
#[derive(Clone)]
pub struct EditedField {
    base: Arc<dyn Field>,
    edits: Arc<Vec<Arc<Compiled>>>,
}

impl EditedField {
    /// A field with no edits yet.
    pub fn new(base: Arc<dyn Field>) -> Self {
        EditedField {
            base,
            edits: Arc::new(Vec::new()),
        }
    }

    /// This field with `brush` applied on top (the original is unchanged, so
    /// meshing tasks that hold it keep a consistent field).
    pub fn with_edit(&self, brush: Brush) -> Result<EditedField> {
        self.with_edits([brush])
    }

    /// This field with `brushes` applied on top, in order (one copy of the log
    /// however many there are: replaying 10,000 edits is linear).
    pub fn with_edits(&self, brushes: impl IntoIterator<Item = Brush>) -> Result<EditedField> {
        let mut edits: Vec<Arc<Compiled>> = (*self.edits).clone();
        for brush in brushes {
            edits.push(Arc::new(Self::compile(brush)?));
        }
        Ok(EditedField {
            base: self.base.clone(),
            edits: Arc::new(edits),
        })
    }

    /// Checks and compiles one brush.
    fn compile(brush: Brush) -> Result<Compiled> {
        let field = brush.shape.compile()?;
        let blend = match brush.op {
            BrushOp::Add | BrushOp::Subtract | BrushOp::Paint => 0.0,
            BrushOp::SmoothAdd { radius } | BrushOp::SmoothSubtract { radius } => {
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(Error::InvalidSetting {
                        name: "brush radius",
                        reason: format!("blend radius {radius} must be a finite number > 0"),
                    });
                }
                radius
            }
        };
        let (c, r) = field
            .bounding_sphere()
            .ok_or_else(|| Error::InvalidSetting {
                name: "brush",
                reason: "a brush must be bounded (no planes or terrain)".into(),
            })?;
        Ok(Compiled {
            brush,
            field,
            reach: (c, r + blend),
            blend,
        })
    }

    /// How many brushes have been applied.
    pub fn edit_count(&self) -> usize {
        self.edits.len()
    }

    /// The brushes applied so far, oldest first.
    pub fn log(&self) -> Vec<Brush> {
        self.edits.iter().map(|c| c.brush.clone()).collect()
    }

    /// Replays a log onto a base field.
    pub fn replay(base: Arc<dyn Field>, log: &[Brush]) -> Result<EditedField> {
        EditedField::new(base).with_edits(log.iter().cloned())
    }

    /// Center and radius of the region the last edit can change.
    pub fn last_reach(&self) -> Option<(Vec3, f32)> {
        self.edits.last().map(|c| c.reach)
    }

    /// This field with only its first `n` brushes (all of them if it has fewer);
    /// the brushes are shared, not compiled again, so the result samples bit for
    /// bit as a replay of those `n` brushes would.
    pub fn prefix(&self, n: usize) -> EditedField {
        let n = n.min(self.edits.len());
        if n == self.edits.len() {
            return self.clone();
        }
        EditedField {
            base: self.base.clone(),
            edits: Arc::new(self.edits[..n].to_vec()),
        }
    }

    /// Center and radius of the region each brush in `range` can change.
    pub fn reaches(&self, range: std::ops::Range<usize>) -> Vec<(Vec3, f32)> {
        self.edits[range].iter().map(|c| c.reach).collect()
    }

    /// The brushes in `range`, oldest first.
    pub fn brushes(&self, range: std::ops::Range<usize>) -> Vec<Brush> {
        self.edits[range].iter().map(|c| c.brush.clone()).collect()
    }

    /// The same brushes on another base field (shared: a brush does not
    /// depend on what it is applied to).
    pub fn rebased(&self, base: Arc<dyn Field>) -> EditedField {
        EditedField {
            base,
            edits: self.edits.clone(),
        }
    }
}

fn smin(a: f32, b: f32, k: f32) -> f32 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b + (a - b) * h - k * h * (1.0 - h)
}

/// The polynomial smooth minimum's blend weight of `a` (its gradient is
/// `ga * h + gb * (1 - h)`, the blend terms cancel).
fn smin_weight(a: f32, b: f32, k: f32) -> f32 {
    (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0)
}

impl EditedField {
    /// Whether edit `e` can change a value `v` at `p` (a paint changes no value;
    /// it changes the material inside its reach).
    fn affects(e: &Compiled, p: Vec3, v: f32) -> bool {
        let lower = p.distance(e.reach.0) - e.reach.1;
        match e.brush.op {
            BrushOp::Add | BrushOp::SmoothAdd { .. } => lower < v + e.blend,
            BrushOp::Subtract | BrushOp::SmoothSubtract { .. } => -lower > v - e.blend,
            BrushOp::Paint => lower < 0.0,
        }
    }
}

impl EditedField {
    /// Applies the brushes to the base value `v` at `p`.
    fn apply(&self, p: Vec3, mut v: f32) -> f32 {
        for e in self.edits.iter() {
            // Outside its reach the brush is at least this far away: skip it when
            // that proves it cannot change the value.
            if !Self::affects(e, p, v) {
                continue;
            }
            match e.brush.op {
                BrushOp::Add => v = v.min(e.field.value(p)),
                BrushOp::Subtract => v = v.max(-e.field.value(p)),
                BrushOp::SmoothAdd { radius } => v = smin(v, e.field.value(p), radius),
                BrushOp::SmoothSubtract { radius } => v = -smin(-v, e.field.value(p), radius),
                BrushOp::Paint => {}
            }
        }
        v
    }
}

impl Field for EditedField {
    fn value(&self, p: Vec3) -> f32 {
        self.apply(p, self.base.value(p))
    }

    /// The base field's explanation, or the first brush's that has one.
    fn explain_non_finite(&self, p: Vec3) -> Option<String> {
        self.base.explain_non_finite(p).or_else(|| {
            self.edits
                .iter()
                .find_map(|e| e.field.explain_non_finite(p))
        })
    }

    /// The base field's own batched sampling (one noise evaluation per column for a
    /// height field), then the brushes corner by corner.
    fn sample_grid(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
    ) {
        self.base.sample_grid(grid, z_range.clone(), out);
        if self.edits.is_empty() {
            return;
        }
        let c = grid.corners();
        let mut i = 0;
        for z in z_range {
            for y in 0..c.y {
                for x in 0..c.x {
                    out[i] = self.apply(grid.corner_pos(glam::UVec3::new(x, y, z)), out[i]);
                    i += 1;
                }
            }
        }
    }

    /// Unedited, the base field's; with brushes, [`Field::sample_grid`] (a
    /// brush can bring a corner the base proved far back near the surface).
    fn sample_grid_far(
        &self,
        grid: &crate::grid::Grid,
        z_range: std::ops::Range<u32>,
        out: &mut [f32],
        far: f32,
    ) {
        if self.edits.is_empty() {
            self.base.sample_grid_far(grid, z_range, out, far);
        } else {
            self.sample_grid(grid, z_range, out);
        }
    }

    /// The base field's, while there are no brushes.
    fn value_and_gradient(&self, p: Vec3) -> Option<(f32, Vec3)> {
        if self.edits.is_empty() {
            self.base.value_and_gradient(p)
        } else {
            None
        }
    }

    /// The base field's own gradient where no brush is active (analytic where the
    /// base has one), the active brush's where one is.
    fn gradient(&self, p: Vec3) -> Vec3 {
        if self.edits.is_empty() {
            return self.base.gradient(p);
        }
        let mut v = self.base.value(p);
        let mut g = None; // None: still the base's
        for e in self.edits.iter() {
            if !Self::affects(e, p, v) {
                continue;
            }
            let b = e.field.value(p);
            let gb = || e.field.gradient(p);
            let base_g = |g: Option<Vec3>| g.unwrap_or_else(|| self.base.gradient(p));
            match e.brush.op {
                BrushOp::Add => {
                    if b < v {
                        v = b;
                        g = Some(gb());
                    }
                }
                BrushOp::Subtract => {
                    if -b > v {
                        v = -b;
                        g = Some(-gb());
                    }
                }
                BrushOp::SmoothAdd { radius } => {
                    let h = smin_weight(v, b, radius);
                    if h < 1.0 {
                        g = Some(base_g(g) * h + gb() * (1.0 - h));
                    }
                    v = smin(v, b, radius);
                }
                BrushOp::SmoothSubtract { radius } => {
                    let h = smin_weight(-v, b, radius);
                    if h < 1.0 {
                        g = Some(-((-base_g(g)) * h + gb() * (1.0 - h)));
                    }
                    v = -smin(-v, b, radius);
                }
                BrushOp::Paint => {}
            }
        }
        g.unwrap_or_else(|| self.base.gradient(p))
    }

    fn material(&self, p: Vec3) -> crate::material::MaterialBlend {
        self.material_at(p)
    }

    /// The base's, with the gradient, where no brush reaches `p` (the gradient
    /// is the base's there); the edited blend of brushes and base elsewhere.
    fn material_with_gradient(&self, p: Vec3, gradient: Vec3) -> crate::material::MaterialBlend {
        if self.edits.is_empty() {
            return self.base.material_with_gradient(p, gradient);
        }
        let v = self.base.value(p);
        if self.edits.iter().all(|e| !Self::affects(e, p, v)) {
            return self.base.material_with_gradient(p, gradient);
        }
        self.material_at(p)
    }

    /// The base's materials, or any brush of a material other than 0, or a
    /// paint.
    fn has_materials(&self) -> bool {
        self.base.has_materials()
            || self
                .edits
                .iter()
                .any(|e| e.brush.material != 0 || e.brush.op == BrushOp::Paint)
    }

    fn lipschitz(&self) -> Option<f32> {
        // Brushes are exact distances (bound 1); min, max and the smooth blends
        // keep the larger bound.
        self.base.lipschitz().map(|l| l.max(1.0))
    }

    /// The base's bound, moved by the brushes: a brush whose reach (bounding
    /// sphere grown by its blend) stays a distance `gap > 0` from the box is at
    /// least `d = gap + blend` there, so adding it lowers the value to no less
    /// than `min(lo, d) - blend / 4` (the polynomial smooth minimum is at most
    /// `k / 4` below the plain one) and digging raises it to no more than
    /// `max(hi, -d) + blend / 4`. `None` where a brush's reach meets the box.
    fn bound(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (mut a, mut b) = self.base.bound(lo, hi)?;
        for e in self.edits.iter() {
            if e.brush.op == BrushOp::Paint {
                continue; // changes no value
            }
            let (c, reach) = e.reach;
            let gap = c.clamp(lo, hi).distance(c) - reach;
            if gap.is_nan() || gap <= 0.0 {
                return None;
            }
            let d = gap + e.blend;
            match e.brush.op {
                BrushOp::Add | BrushOp::SmoothAdd { .. } => a = a.min(d) - 0.25 * e.blend,
                BrushOp::Subtract | BrushOp::SmoothSubtract { .. } => {
                    b = b.max(-d) + 0.25 * e.blend
                }
                BrushOp::Paint => {}
            }
        }
        Some((a, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradients_match_differences_and_the_base_where_untouched() {
        let base: Arc<dyn Field> = Arc::new(
            CsgNode::Torus {
                major_radius: 0.5,
                minor_radius: 0.2,
                center: Vec3::ZERO,
            }
            .compile()
            .unwrap(),
        );
        let mut f = EditedField::new(base.clone());
        for (i, op) in [
            BrushOp::Add,
            BrushOp::Subtract,
            BrushOp::SmoothAdd { radius: 0.1 },
            BrushOp::SmoothSubtract { radius: 0.1 },
        ]
        .into_iter()
        .enumerate()
        {
            let a = i as f32 * 1.3;
            f = f
                .with_edit(Brush::sphere(
                    Vec3::new(0.5 * a.cos(), 0.1, 0.5 * a.sin()),
                    0.2,
                    op,
                ))
                .unwrap();
        }
        for i in 0..400 {
            let p = Vec3::new(
                (i as f32 * 0.37).sin(),
                (i as f32 * 0.61).cos() * 0.4,
                (i as f32 * 0.23).sin(),
            ) * 0.8;
            let fd = crate::field::central_difference(|q| f.value(q), p, 1e-3);
            let g = f.gradient(p);
            if fd.length() > 0.5 {
                assert!((g - fd).length() < 0.05, "{p}: {g} vs {fd}");
            }
        }
        // Far from every brush the gradient is the base's, bit for bit.
        let p = Vec3::new(0.0, 0.0, -0.9);
        assert_eq!(f.gradient(p), base.gradient(p));
    }

    #[test]
    fn batched_sampling_equals_point_evaluation() {
        use crate::field::terrain::{Heightfield, HeightfieldParams};
        let base: Arc<dyn Field> = Arc::new(Heightfield::new(HeightfieldParams {
            seed: 1,
            base: 8.0,
            amplitude: 4.0,
            frequency: 0.05,
            octaves: 4,
        }));
        let f = EditedField::new(base)
            .with_edit(Brush::sphere(
                Vec3::new(8.0, 8.0, 8.0),
                3.0,
                BrushOp::Subtract,
            ))
            .unwrap()
            .with_edit(Brush::sphere(
                Vec3::new(4.0, 9.0, 5.0),
                2.0,
                BrushOp::SmoothAdd { radius: 1.0 },
            ))
            .unwrap();
        let grid = crate::grid::Grid {
            origin: Vec3::ZERO,
            cell_size: 1.0,
            cells: glam::UVec3::splat(16),
            offset: glam::IVec3::new(-1, -1, -1),
        };
        let c = grid.corners();
        let mut out = vec![0f32; (c.x * c.y * c.z) as usize];
        f.sample_grid(&grid, 0..c.z, &mut out);
        let mut i = 0;
        for z in 0..c.z {
            for y in 0..c.y {
                for x in 0..c.x {
                    let p = grid.corner_pos(glam::UVec3::new(x, y, z));
                    assert_eq!(out[i].to_bits(), f.value(p).to_bits(), "{p}");
                    i += 1;
                }
            }
        }
    }

    #[test]
    fn bounds_hold_around_brushes_and_none_where_they_reach() {
        use crate::field::terrain::{Density, DensityParams};
        let base: Arc<dyn Field> = Arc::new(Density::new(DensityParams::demo(4)));
        let mut f = EditedField::new(base);
        for (c, op) in [
            (Vec3::new(0.0, 10.0, 0.0), BrushOp::Add),
            (Vec3::new(40.0, -5.0, 0.0), BrushOp::Subtract),
            (
                Vec3::new(-40.0, 30.0, 10.0),
                BrushOp::SmoothAdd { radius: 4.0 },
            ),
            (
                Vec3::new(0.0, -30.0, 40.0),
                BrushOp::SmoothSubtract { radius: 3.0 },
            ),
        ] {
            f = f.with_edit(Brush::sphere(c, 8.0, op)).unwrap();
        }
        let mut rng = crate::world::layout::Rng(17);
        let mut unit3 = || Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32);
        let (mut bounded, mut reached) = (0, 0);
        for _ in 0..400 {
            let lo = Vec3::new(-80.0, -60.0, -80.0) + unit3() * Vec3::new(160.0, 120.0, 160.0);
            let hi = lo + Vec3::splat(2.0) + unit3() * 20.0;
            let Some((a, b)) = f.bound(lo, hi) else {
                reached += 1;
                continue;
            };
            bounded += 1;
            for _ in 0..50 {
                let v = f.value(lo + (hi - lo) * unit3());
                assert!(a <= v && v <= b, "{v} outside [{a}, {b}] in {lo}..{hi}");
            }
        }
        assert!(
            bounded > 100 && reached > 0,
            "{bounded} bounded, {reached} reached"
        );
        // A box around a brush has no bound; far above everything, air is proven.
        let around = f.bound(Vec3::new(-1.0, 9.0, -1.0), Vec3::new(1.0, 11.0, 1.0));
        assert!(around.is_none());
        let sky = f.bound(Vec3::new(-50.0, 60.0, -50.0), Vec3::new(50.0, 90.0, 50.0));
        assert!(sky.unwrap().0 > 0.0, "{sky:?}");
    }
}
