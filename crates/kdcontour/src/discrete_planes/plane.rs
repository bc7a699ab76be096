//! The discrete planes: Discretized Marching Cubes puts every vertex at the
//! midpoint of its cube edge, so in half-cell units ([`Point`]) every vertex is an
//! integer point and every facet lies on a plane `V . p = d` with a small integer
//! normal `V` and integer `d` (the paper's `<V, d>`). Comparing planes is comparing
//! integers: no tolerance anywhere.

/// A point in half-cell units (twice the grid coordinates): edge midpoints are
/// integers.
pub type Point = [i64; 3];

/// A plane `<V, d>` of the discrete set: `normal . p = d` for its points.
///
/// The normal is reduced (its components have no common factor) and faces the
/// outside of the surface, so the plane also records which side is inside.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Plane {
    /// `V`, the reduced integer normal, facing outside.
    pub normal: [i64; 3],
    /// `d`, the distance term in half-cell units (`normal . p`).
    pub d: i64,
}

/// `a - b`.
pub(crate) fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a x b`.
pub(crate) fn cross(a: Point, b: Point) -> Point {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a . b`.
pub(crate) fn dot(a: Point, b: Point) -> i64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The turn at `b` going `a -> b -> c`: zero when the three are collinear.
pub(crate) fn turn(a: Point, b: Point, c: Point) -> Point {
    cross(sub(b, a), sub(c, b))
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 {
        a.abs()
    } else {
        gcd(b, a % b)
    }
}

impl Plane {
    /// The plane of the ring `ring` (indices into `pts`), facing the way the ring
    /// turns counter-clockwise, or `None` when the ring is not planar or has no
    /// area.
    pub fn of_ring(ring: &[u32], pts: &[Point]) -> Option<Plane> {
        let p = |i: usize| pts[ring[i % ring.len()] as usize];
        // Newell's normal: twice the vector area, exact in integers.
        let mut n = [0i64; 3];
        for i in 0..ring.len() {
            let c = cross(p(i), p(i + 1));
            n = [n[0] + c[0], n[1] + c[1], n[2] + c[2]];
        }
        let g = gcd(gcd(n[0], n[1]), n[2]);
        if g == 0 {
            return None;
        }
        let normal = n.map(|x| x / g);
        let d = dot(normal, p(0));
        ring.iter()
            .all(|&v| dot(normal, pts[v as usize]) == d)
            .then_some(Plane { normal, d })
    }

    /// Whether the ring, which lies on this plane, is convex: it never turns
    /// clockwise about the normal (collinear vertices allowed) and has at least
    /// three corners.
    pub fn is_convex(&self, ring: &[u32], pts: &[Point]) -> bool {
        let m = ring.len();
        let mut corners = 0;
        for i in 0..m {
            let t = turn(
                pts[ring[(i + m - 1) % m] as usize],
                pts[ring[i] as usize],
                pts[ring[(i + 1) % m] as usize],
            );
            match dot(t, self.normal) {
                x if x < 0 => return false,
                0 => {}
                _ => corners += 1,
            }
        }
        corners >= 3
    }
}

/// A planar convex polygon of the surface: its plane and its ring of vertex ids,
/// counter-clockwise seen from outside.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Facet {
    /// The plane it lies on.
    pub plane: Plane,
    /// Its vertices (ids of grid-edge crossings), counter-clockwise from outside.
    pub ring: Vec<u32>,
}

impl Facet {
    /// The facet spanned by `ring` when it is planar and convex.
    pub fn new(ring: Vec<u32>, pts: &[Point]) -> Option<Facet> {
        let plane = Plane::of_ring(&ring, pts)?;
        plane.is_convex(&ring, pts).then_some(Facet { plane, ring })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hexagon_of_edge_midpoints_is_one_convex_plane() {
        // Pattern 9-like hexagon on x + y + z = 3 (half-cell units).
        let pts = vec![
            [1, 2, 0],
            [0, 2, 1],
            [0, 1, 2],
            [1, 0, 2],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let ring: Vec<u32> = (0..6).collect();
        let f = Facet::new(ring.clone(), &pts).expect("planar and convex");
        assert_eq!(f.plane.d, 3 * f.plane.normal[0]);
        assert_eq!(f.plane.normal.map(i64::abs), [1, 1, 1]);
        // Reversed, it faces the other way: a different plane of the set.
        let back: Vec<u32> = ring.into_iter().rev().collect();
        let b = Facet::new(back, &pts).unwrap();
        assert_eq!(b.plane.normal, f.plane.normal.map(|x| -x));
    }

    #[test]
    fn a_folded_pentagon_is_not_one_plane() {
        // Pattern 5: a quad on x + y + z = 3 and a triangle on z = 1.
        let pts = vec![[2, 1, 0], [1, 2, 0], [0, 2, 1], [0, 0, 1], [2, 0, 1]];
        assert!(Plane::of_ring(&[0, 1, 2, 3, 4], &pts).is_none());
        assert!(Facet::new(vec![0, 1, 2, 4], &pts).is_some());
        assert!(Facet::new(vec![2, 3, 4], &pts).is_some());
    }
}
