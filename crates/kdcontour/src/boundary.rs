//! The grid's boundary ([`Boundary`]): which surface crosses it, and the caps that
//! close a surface there.
//!
//! - **Open** (the default): the dual mesh ends at the vertices of the cells along
//!   the grid's faces, half a cell inside. An adaptive tree keeps that: a node
//!   whose face on the grid's boundary the surface crosses may only be a leaf
//!   while it is one cell thick across that face ([`open_faces`]; the k-d tree
//!   splits such a slab off first), and, where the surface's trace on the face
//!   turns, only while it is one cell (a leaf long along the face would cut the
//!   trace into chords: a torus larger than the grid kept 89% of the uniform
//!   mesh's area at threshold 0.01). A plane's trace is straight, so its slab
//!   stays large along the face. Without the first rule a bare plane clustered
//!   into one node whose every sign-changing edge lay on the boundary, and its
//!   mesh was empty.
//! - **Capped**: when the solid reaches a face of the grid, the grid grows by one
//!   cell on every side ([`padded`]). The new corners are outside, and each edge
//!   from a grid corner that is inside to a new corner crosses the surface exactly
//!   at that grid corner, with the outward axis as its normal ([`Cap`]). The mesh
//!   is then the surface of the solid cut by the grid's box, closed like any
//!   surface inside a grid: the caps lie in the box's faces and meet the surface
//!   at sharp creases (the QEF places those vertices, as at a box's edges).
//!   [`CappedField`] is the field of that solid, to check such a mesh against.

use crate::field::Field;
use crate::grid::Grid;
use crate::grid::FAR;
use glam::{IVec3, UVec3, Vec3};

pub use crate::settings::Boundary;

/// The faces of the grid (bit `2 * axis + side`, side 1 = high) that cell `coord`
/// with corner signs `config` lies on and that the surface crosses there (the
/// cell's four corners on that face do not all share one sign).
pub fn open_faces(cells: UVec3, coord: [u16; 3], config: u8) -> u8 {
    let mut bits = 0u8;
    for f in 0..6 {
        let (a, side) = (f / 2, f % 2);
        let on = if side == 0 {
            coord[a] == 0
        } else {
            coord[a] as u32 + 1 == cells[a]
        };
        if !on {
            continue;
        }
        let signs = crate::cell::face_corners(f).map(|c| (config >> c) & 1);
        if signs.iter().any(|&s| s != signs[0]) {
            bits |= 1 << f;
        }
    }
    bits
}

/// Whether any corner on the faces of `grid` is inside (`values` are its samples):
/// the solid reaches the boundary, and capping changes the mesh.
pub fn reaches_faces(grid: &Grid, values: &[f32]) -> bool {
    let c = grid.corners();
    (0..c.z).any(|z| {
        (0..c.y).any(|y| {
            let row = &values[grid.corner_index(0, y, z)..][..c.x as usize];
            if y == 0 || z == 0 || y + 1 == c.y || z + 1 == c.z {
                row.iter().any(|v| *v < 0.0)
            } else {
                row[0] < 0.0 || row[row.len() - 1] < 0.0
            }
        })
    })
}

/// `grid` grown by one cell on every side, on the same lattice (its corner
/// `(1, 1, 1)` is `grid`'s corner `(0, 0, 0)`, at bitwise the same position).
pub fn padded(grid: &Grid) -> Grid {
    Grid {
        cells: grid.cells + UVec3::splat(2),
        offset: grid.offset - IVec3::ONE,
        ..*grid
    }
}

/// The samples of [`padded`]`(grid)`: `values` inside, `FAR` (outside, never
/// evaluated) on the new corners. Errors when the system cannot give their
/// memory.
pub fn pad_values(grid: &Grid, values: &[f32]) -> crate::Result<Vec<f32>> {
    let big = padded(grid);
    let mut out = crate::budget::filled(
        || format!("the capped samples of {} corners", big.corner_count()),
        big.corner_count(),
        FAR,
    )?;
    let c = grid.corners();
    for z in 0..c.z {
        for y in 0..c.y {
            let from = grid.corner_index(0, y, z);
            let to = big.corner_index(1, y + 1, z + 1);
            out[to..to + c.x as usize].copy_from_slice(&values[from..from + c.x as usize]);
        }
    }
    Ok(out)
}

/// The caps of a [`padded`] grid: which corners are the added ones, and the
/// crossing of an edge from a grid corner to one of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cap {
    /// Cells of the padded grid.
    pub cells: UVec3,
}

impl Cap {
    /// Whether corner `c` of the padded grid is one of the added ones.
    #[inline]
    pub fn is_added(&self, c: [u32; 3]) -> bool {
        (0..3).any(|a| c[a] == 0 || c[a] == self.cells[a])
    }

    /// The crossing (grid units) and unit normal of the edge from `p0` along axis
    /// `axis` to the next corner, when one end is an added corner: the other end
    /// (a grid corner, inside), facing the added one. `None` for other edges.
    #[inline]
    pub fn crossing(&self, p0: [u32; 3], axis: usize) -> Option<(Vec3, Vec3)> {
        let mut p1 = p0;
        p1[axis] += 1;
        let (a0, a1) = (self.is_added(p0), self.is_added(p1));
        let dir = Vec3::AXES[axis];
        match (a0, a1) {
            (true, false) => Some((UVec3::from(p1).as_vec3(), -dir)),
            (false, true) => Some((UVec3::from(p0).as_vec3(), dir)),
            _ => None,
        }
    }
}

/// The solid of a field cut by a box: `max(f, box)`, where `box` is the box's
/// signed distance. The surface a capped mesh approximates, so the checks of
/// [`validate`](mod@crate::validate) measure caps against the box's faces.
pub struct CappedField<'a> {
    field: &'a dyn Field,
    lo: Vec3,
    hi: Vec3,
}

impl<'a> CappedField<'a> {
    /// `field` cut by the box of `grid` (its corners' span).
    pub fn new(field: &'a dyn Field, grid: &Grid) -> Self {
        CappedField {
            field,
            lo: grid.corner_pos(UVec3::ZERO),
            hi: grid.corner_pos(grid.cells),
        }
    }

    /// Signed distance to the box and its gradient.
    fn box_distance(&self, p: Vec3) -> (f32, Vec3) {
        let c = (self.lo + self.hi) * 0.5;
        let half = (self.hi - self.lo) * 0.5;
        let q = (p - c).abs() - half;
        let outside = q.max(Vec3::ZERO);
        if outside.length_squared() > 0.0 {
            let g = outside.normalize() * (p - c).signum();
            (outside.length(), g)
        } else {
            // Inside: the nearest face.
            let a = q.max_position();
            let mut g = Vec3::ZERO;
            g[a] = (p - c)[a].signum();
            (q[a], g)
        }
    }
}

impl Field for CappedField<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.field.value(p).max(self.box_distance(p).0)
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let (d, g) = self.box_distance(p);
        if d >= self.field.value(p) {
            g
        } else {
            self.field.gradient(p)
        }
    }

    fn material(&self, p: Vec3) -> crate::material::MaterialBlend {
        self.field.material(p)
    }

    fn has_materials(&self) -> bool {
        self.field.has_materials()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padding_keeps_the_lattice_and_adds_outside_corners() {
        let g = Grid::cube(1.0, 4);
        let values: Vec<f32> = (0..g.corner_count()).map(|i| i as f32 - 60.0).collect();
        let big = padded(&g);
        let v = pad_values(&g, &values).unwrap();
        assert_eq!(big.cells, UVec3::splat(6));
        assert_eq!(big.corner_pos(UVec3::ONE), g.corner_pos(UVec3::ZERO));
        assert_eq!(
            v[big.corner_index(3, 2, 4)],
            values[g.corner_index(2, 1, 3)]
        );
        assert_eq!(v[big.corner_index(0, 2, 4)], FAR);
        let cap = Cap { cells: big.cells };
        assert!(cap.is_added([6, 1, 1]) && !cap.is_added([5, 1, 5]));
        let (p, n) = cap.crossing([0, 2, 3], 0).unwrap();
        assert_eq!((p, n), (Vec3::new(1.0, 2.0, 3.0), -Vec3::X));
        assert_eq!(cap.crossing([1, 2, 3], 0), None);
        assert!(reaches_faces(&g, &values));
        assert!(!reaches_faces(&g, &vec![1.0; values.len()]));
    }

    #[test]
    fn a_face_is_open_only_where_the_surface_crosses_it() {
        let cells = UVec3::splat(4);
        // Corner 0 (the low x, y, z corner) inside only.
        assert_eq!(open_faces(cells, [0, 0, 0], 0b1111_1110), 0b01_0101);
        assert_eq!(open_faces(cells, [1, 0, 2], 0b1111_1110), 0b00_0100);
        assert_eq!(open_faces(cells, [3, 3, 3], 0b0111_1111), 0b10_1010);
        // A face whose corners are all inside is not crossed.
        assert_eq!(open_faces(cells, [0, 1, 1], 0b1010_1010), 0);
    }
}
