//! Whether a dual polygon faces the way the surface does (issue 13): the one test
//! the cells' vertices (`hermite::vertex`) and the fold guard
//! (`kdtree::fold`) hold every polygon to, on the triangles the mesh will emit.
//!
//! A polygon faces its way when the mesh's split of it
//! ([`crate::mesh::quad_split`]) gives triangles that each face the polygon's grid
//! edge ([`triangle_faces`]), none has zero area and none is flipped against the
//! field: its normal does not point more than 90 degrees from the field's
//! gradient at its centroid. Both are judged as [`validate`](mod@crate::validate)
//! counts zero-area and flipped faces, on the world coordinates the mesh will
//! have. The gradient is read only for triangles whose normal is more than
//! [`FIELD_CHECK_DEGREES`] from one of their vertices' normals (the field's
//! gradients where the vertices' planes were measured): a triangle that close to
//! all three of them would need the gradient to turn by more than 30 degrees
//! between its corners and its centroid to be flipped.

use crate::field::Field;
use crate::geometry;
use crate::grid::Grid;
use crate::mesh::{triangle_faces, QuadSplit};
use glam::{DVec3, Vec3};

/// A triangle whose normal is more than this many degrees from one of its
/// vertices' normals is checked against the field's gradient at its centroid.
pub const FIELD_CHECK_DEGREES: f32 = 60.0;

/// The polygon test of one grid (see the module docs).
#[derive(Clone, Copy)]
pub(crate) struct Facing<'a> {
    field: &'a dyn Field,
    grid: Grid,
    /// `cos²` of [`FIELD_CHECK_DEGREES`].
    check_cos2: f64,
    /// Twice the smallest area a triangle may have (world units).
    min_twice_area: f64,
}

impl<'a> Facing<'a> {
    /// The test for polygons whose vertices are in `grid`'s units over `field`.
    pub fn new(field: &'a dyn Field, grid: &Grid) -> Self {
        Facing {
            field,
            grid: *grid,
            check_cos2: (FIELD_CHECK_DEGREES as f64).to_radians().cos().powi(2),
            min_twice_area: 2.0 * geometry::ZERO_AREA_CELLS2 * (grid.cell_size as f64).powi(2),
        }
    }

    /// The same test reading the field for triangles more than `degrees` from
    /// one of their vertices' normals (instead of [`FIELD_CHECK_DEGREES`]).
    pub fn with_field_check_degrees(mut self, degrees: f32) -> Self {
        self.check_cos2 = (degrees as f64).to_radians().cos().powi(2);
        self
    }

    /// The same test with the smallest area a triangle may have `factor` times
    /// larger.
    pub fn with_area_margin(mut self, factor: f64) -> Self {
        self.min_twice_area *= factor;
        self
    }

    /// Whether the polygon of `corners` (three or four distinct vertices in the
    /// contouring's order, grid units, each with its normal) faces `facing` (its
    /// edge from the inside corner to the outside one), and each of its triangles
    /// passes `also` too (on world positions).
    pub fn polygon(
        &self,
        corners: &[(Vec3, Vec3)],
        facing: Vec3,
        also: impl Fn([Vec3; 3]) -> bool,
    ) -> bool {
        let world = |i: usize| self.grid.to_world(corners[i].0);
        match corners.len() {
            3 => {
                let p = [0, 1, 2].map(world);
                let n = [0, 1, 2].map(|i| corners[i].1);
                triangle_faces(p, n, facing) && self.holds(p, n, geometry::face_normal(p), &also)
            }
            4 => {
                let p = [0, 1, 2, 3].map(world);
                let n = [0, 1, 2, 3].map(|i| corners[i].1);
                let s = QuadSplit::new(p, n, facing);
                let (ok02, ok13) = (s.faces[0] && s.faces[1], s.faces[2] && s.faces[3]);
                if !(ok02 || ok13) {
                    return false;
                }
                // Either split faces its edge: when all four triangles also pass
                // the tests that read no field, the one the mesh takes does.
                if ok02
                    && ok13
                    && (0..4).all(|k| {
                        let t = QuadSplit::TRIS[k];
                        self.sized(s.cross[k])
                            && !self.strays(s.cross[k], t.map(|i| n[i]))
                            && also(t.map(|i| p[i]))
                    })
                {
                    return true;
                }
                let pair = if s.takes_02(&p) { [0, 1] } else { [2, 3] };
                pair.into_iter().all(|k| {
                    let t = QuadSplit::TRIS[k];
                    s.faces[k] && self.holds(t.map(|i| p[i]), t.map(|i| n[i]), s.cross[k], &also)
                })
            }
            _ => true,
        }
    }

    /// Whether the mesh splits the quad of `p` (grid units, the contouring's
    /// order) with vertex normals `n` along 0-2 ([`crate::mesh::quad_split`], on
    /// the world coordinates the mesh will have).
    pub fn takes_02(&self, p: [Vec3; 4], n: [Vec3; 4], facing: Vec3) -> bool {
        let p = p.map(|x| self.grid.to_world(x));
        QuadSplit::new(p, n, facing).takes_02(&p)
    }

    /// The tests past facing its edge, on triangle `p` (world units) with
    /// vertex normals `n` and normal `cross` (unnormalised): it has more than
    /// zero area ([`Facing::sized`]), passes `also`, and is not flipped against
    /// the field.
    fn holds(
        &self,
        p: [Vec3; 3],
        n: [Vec3; 3],
        cross: DVec3,
        also: &impl Fn([Vec3; 3]) -> bool,
    ) -> bool {
        self.sized(cross) && also(p) && !(self.strays(cross, n) && geometry::flipped(self.field, p))
    }

    /// Whether a triangle of normal `cross` (unnormalised) has at least the area
    /// [`validate`](mod@crate::validate) counts as more than zero.
    fn sized(&self, cross: DVec3) -> bool {
        cross.length_squared() >= self.min_twice_area * self.min_twice_area
    }

    /// Whether a triangle of normal `cross` points more than
    /// [`FIELD_CHECK_DEGREES`] from one of its vertices' normals `n` (unit, or
    /// zero where the field had no gradient: that strays too).
    fn strays(&self, cross: DVec3, n: [Vec3; 3]) -> bool {
        let limit = self.check_cos2 * cross.length_squared();
        n.iter().any(|v| {
            let d = cross.dot(v.as_dvec3());
            d <= 0.0 || d * d < limit
        })
    }
}
