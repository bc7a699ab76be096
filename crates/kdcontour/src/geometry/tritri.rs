//! Triangle-triangle contact in f64: a crossing (the triangles pass through each
//! other) or a coplanar overlap (their interiors cover a common area), after
//! Möller's interval test. Touching (at a point, along an edge, a vertex resting
//! on a face) is neither.

use glam::DVec3;

/// How two triangles meet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Contact {
    /// Apart, or touching only.
    None,
    /// Crossing; `depth` is how far the shallower of the two pokes through the
    /// other's plane (world units).
    Cross {
        /// Penetration depth.
        depth: f64,
    },
    /// In one plane, interiors overlapping.
    Coplanar,
}

/// Tolerances of [`contact`], in world units.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tolerance {
    /// A vertex this close to the other triangle's plane is on it; two triangles
    /// whose vertices are all this close to each other's planes are coplanar; a
    /// crossing must be longer than this.
    pub length: f64,
    /// A coplanar overlap must cover more than this area.
    pub area: f64,
}

pub(crate) fn unit_normal(t: &[DVec3; 3]) -> Option<DVec3> {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let l = n.length();
    (l > 0.0 && l.is_finite()).then(|| n / l)
}

/// Signed distances of `a`'s vertices to the plane through `b0` with unit normal
/// `n`, snapped to zero within `tol`.
#[inline]
fn plane_distances(a: &[DVec3; 3], n: DVec3, b0: DVec3, tol: f64) -> [f64; 3] {
    let snap = |p: DVec3| {
        let d = n.dot(p - b0);
        if d.abs() <= tol {
            0.0
        } else {
            d
        }
    };
    [snap(a[0]), snap(a[1]), snap(a[2])]
}

/// Whether distances `d` put a triangle wholly on one side of a plane.
#[inline]
fn one_side(d: &[f64; 3]) -> bool {
    (d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0) || (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)
}

/// The interval that triangle `t` (signed distances `d` to the other plane) covers
/// on the line of the two planes, measured along `dir`.
fn interval(t: &[DVec3; 3], d: &[f64; 3], dir: DVec3) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut add = |p: DVec3| {
        let s = dir.dot(p);
        lo = lo.min(s);
        hi = hi.max(s);
    };
    for i in 0..3 {
        let j = (i + 1) % 3;
        if d[i] == 0.0 {
            add(t[i]);
        }
        if d[i] * d[j] < 0.0 {
            add(t[i] + (t[j] - t[i]) * (d[i] / (d[i] - d[j])));
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// How far `d` pokes through its plane on its thinner side.
fn penetration(d: &[f64; 3]) -> f64 {
    let above = d.iter().fold(0f64, |m, &x| m.max(x));
    let below = d.iter().fold(0f64, |m, &x| m.max(-x));
    above.min(below)
}

/// Area of `a` clipped to `b`, both seen along the unit normal `n` of their plane.
fn overlap_area(a: &[DVec3; 3], b: &[DVec3; 3], n: DVec3) -> f64 {
    // Orient b counter-clockwise about n.
    let b = if (b[1] - b[0]).cross(b[2] - b[0]).dot(n) >= 0.0 {
        *b
    } else {
        [b[0], b[2], b[1]]
    };
    let mut poly: Vec<DVec3> = a.to_vec();
    for i in 0..3 {
        let (e0, e1) = (b[i], b[(i + 1) % 3]);
        let inward = n.cross(e1 - e0);
        let side = |p: DVec3| inward.dot(p - e0);
        let mut next = Vec::with_capacity(poly.len() + 1);
        for k in 0..poly.len() {
            let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                next.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                next.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        poly = next;
        if poly.len() < 3 {
            return 0.0;
        }
    }
    let mut area = DVec3::ZERO;
    for k in 1..poly.len() - 1 {
        area += (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]);
    }
    0.5 * area.dot(n).abs()
}

/// Whether triangles `a` and `b` (unit normals `na`, `nb`), which share the
/// corner `a[shared_a]` = `b[shared_b]` and no other, are certainly apart or only
/// touching: [`contact_with_normals`] gives [`Contact::None`] for them. Two
/// triangles from one corner cross only when each one's two other corners lie
/// strictly on both sides of the other's plane (the shared corner lies on both
/// planes); both other corners on a plane is the coplanar case, left to
/// [`contact_with_normals`]. Half the work of the full test, for the most
/// common pair of neighbouring triangles.
pub(crate) fn apart_from_shared_corner(
    a: &[DVec3; 3],
    na: Option<DVec3>,
    shared_a: usize,
    b: &[DVec3; 3],
    nb: Option<DVec3>,
    shared_b: usize,
    tol: Tolerance,
) -> bool {
    let (Some(na), Some(nb)) = (na, nb) else {
        return true;
    };
    // As `plane_distances` measures them, from the same plane points.
    let side = |p: DVec3, n: DVec3, o: DVec3| {
        let d = n.dot(p - o);
        if d.abs() <= tol.length {
            0.0
        } else {
            d
        }
    };
    let others = |k: usize| [(k + 1) % 3, (k + 2) % 3];
    let [a1, a2] = others(shared_a).map(|i| side(a[i], nb, b[0]));
    let [b1, b2] = others(shared_b).map(|i| side(b[i], na, a[0]));
    let flat = (a1 == 0.0 && a2 == 0.0) || (b1 == 0.0 && b2 == 0.0);
    !flat && (a1 * a2 >= 0.0 || b1 * b2 >= 0.0)
}

/// How triangles `a` and `b` meet. Triangles of zero area meet nothing (they are
/// counted elsewhere).
#[cfg(test)]
pub(crate) fn contact(a: &[DVec3; 3], b: &[DVec3; 3], tol: Tolerance) -> Contact {
    contact_with_normals(a, unit_normal(a), b, unit_normal(b), tol)
}

/// [`contact`] of `a` and `b` whose unit normals ([`unit_normal`]) the caller
/// has: a triangle tested against many others finds its normal once.
pub(crate) fn contact_with_normals(
    a: &[DVec3; 3],
    na: Option<DVec3>,
    b: &[DVec3; 3],
    nb: Option<DVec3>,
    tol: Tolerance,
) -> Contact {
    let (Some(na), Some(nb)) = (na, nb) else {
        return Contact::None;
    };
    let da = plane_distances(a, nb, b[0], tol.length);
    if one_side(&da) {
        return Contact::None;
    }
    let db = plane_distances(b, na, a[0], tol.length);
    if one_side(&db) {
        return Contact::None;
    }
    // One lying in the other's plane makes the pair coplanar (a small triangle's
    // normal is the less certain, so its plane may miss the other's far corners).
    let in_b = da.iter().all(|&x| x == 0.0);
    if in_b || db.iter().all(|&x| x == 0.0) {
        let n = if in_b { nb } else { na };
        return if overlap_area(a, b, n) > tol.area {
            Contact::Coplanar
        } else {
            Contact::None
        };
    }
    // Interiors that cross put each triangle on both sides of the other's plane;
    // one resting on the other (a vertex or an edge in its plane, as two triangles
    // sharing an edge do) only touches.
    let depth = penetration(&da).min(penetration(&db));
    if depth == 0.0 {
        return Contact::None;
    }
    let dir = na.cross(nb);
    let l = dir.length();
    if l == 0.0 {
        return Contact::None;
    }
    let dir = dir / l;
    let (Some((a0, a1)), Some((b0, b1))) = (interval(a, &da, dir), interval(b, &db, dir)) else {
        return Contact::None;
    };
    if a1.min(b1) - a0.max(b0) > tol.length {
        Contact::Cross { depth }
    } else {
        Contact::None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: Tolerance = Tolerance {
        length: 1e-9,
        area: 1e-12,
    };

    fn t(p: [[f64; 3]; 3]) -> [DVec3; 3] {
        p.map(DVec3::from)
    }

    #[test]
    fn crossing_touching_and_apart() {
        let a = t([[0., 0., 0.], [2., 0., 0.], [0., 2., 0.]]);
        // Pierces a's interior.
        let b = t([[0.5, 0.5, -1.], [0.5, 0.5, 1.], [1.5, 0.2, 0.3]]);
        assert!(matches!(contact(&a, &b, TOL), Contact::Cross { .. }));
        // Rests a vertex on a's interior: touching.
        let c = t([[0.5, 0.5, 0.], [0.5, 0.6, 1.], [0.7, 0.5, 1.]]);
        assert_eq!(contact(&a, &c, TOL), Contact::None);
        // Rests an edge on a's interior (as triangles meeting at a crease do).
        let g = t([[0.2, 0.2, 0.], [0.8, 0.2, 0.], [0.5, 0.2, 1.]]);
        assert_eq!(contact(&a, &g, TOL), Contact::None);
        // Above it.
        let d = t([[0., 0., 1.], [1., 0., 1.], [0., 1., 2.]]);
        assert_eq!(contact(&a, &d, TOL), Contact::None);
        // Shares vertex 0 and bends away: touching.
        let e = t([[0., 0., 0.], [0., -1., 1.], [-1., 0., 1.]]);
        assert_eq!(contact(&a, &e, TOL), Contact::None);
        // Shares vertex 0 and cuts through a's interior.
        let f = t([[0., 0., 0.], [1., 1., -1.], [1., 1., 1.]]);
        match contact(&a, &f, TOL) {
            Contact::Cross { depth } => assert!((depth - 1.0).abs() < 1e-12, "{depth}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn coplanar_overlap_and_shared_edges() {
        let a = t([[0., 0., 0.], [2., 0., 0.], [0., 2., 0.]]);
        let inside = t([[0.2, 0.2, 0.], [0.6, 0.2, 0.], [0.2, 0.6, 0.]]);
        assert_eq!(contact(&a, &inside, TOL), Contact::Coplanar);
        // Shares the edge 0-1, folded back over a.
        let fold = t([[2., 0., 0.], [0., 0., 0.], [1., 0.5, 0.]]);
        assert_eq!(contact(&a, &fold, TOL), Contact::Coplanar);
        // Shares the edge on the other side: a flat neighbour.
        let flat = t([[2., 0., 0.], [0., 0., 0.], [1., -0.5, 0.]]);
        assert_eq!(contact(&a, &flat, TOL), Contact::None);
        // Shares the edge at an angle.
        let bent = t([[2., 0., 0.], [0., 0., 0.], [1., -0.5, 0.7]]);
        assert_eq!(contact(&a, &bent, TOL), Contact::None);
        // Coplanar, sharing a vertex only.
        let corner = t([[0., 0., 0.], [-1., 0., 0.], [0., -1., 0.]]);
        assert_eq!(contact(&a, &corner, TOL), Contact::None);
    }

    /// The quick test for triangles from one corner never calls apart a pair
    /// the full test finds crossing or overlapping, and calls most of the
    /// others apart: random pairs around a shared corner, some nearly in one
    /// plane, with the corner at every position of both triangles.
    #[test]
    fn apart_from_a_shared_corner_agrees_with_the_full_test() {
        let tol = Tolerance {
            length: 1e-3,
            area: 1e-6,
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut apart, mut crossing, mut full_none) = (0, 0, 0);
        for i in 0..20_000 {
            let flat = if i % 4 == 0 { 1e-4 } else { 1.0 };
            let corner = DVec3::new(next(), next(), next());
            let mut p = || corner + DVec3::new(next(), next(), next() * flat);
            let (a1, a2, b1, b2) = (p(), p(), p(), p());
            let (sa, sb) = (i % 3, (i / 3) % 3);
            let mut a = [a1, a2, a1];
            a[sa] = corner;
            a[(sa + 1) % 3] = a1;
            a[(sa + 2) % 3] = a2;
            let mut b = [b1, b2, b1];
            b[sb] = corner;
            b[(sb + 1) % 3] = b1;
            b[(sb + 2) % 3] = b2;
            let (na, nb) = (unit_normal(&a), unit_normal(&b));
            let full = contact_with_normals(&a, na, &b, nb, tol);
            let quick = apart_from_shared_corner(&a, na, sa, &b, nb, sb, tol);
            if quick {
                assert_eq!(full, Contact::None, "{a:?} {b:?}");
                apart += 1;
            }
            match full {
                Contact::None => full_none += 1,
                _ => crossing += 1,
            }
        }
        assert!(crossing > 100, "{crossing} crossing pairs");
        // (72% of them here: the rest straddle each other's planes apart.)
        assert!(
            apart * 3 > full_none * 2,
            "{apart} of {full_none} apart pairs"
        );
    }
}
