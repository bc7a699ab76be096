//! The five terminal surface node classes (the paper's section 3.1) and the test
//! that decides whether a set of facets is a *codifiable* node.
//!
//! A node's surface is coded as `s(n) = {K, <V0, d0>, ..., <Vn, dn>}`: its class
//! `K` and one plane per polygon. Here each plane also keeps its polygon (the
//! union of the facets on it), which the reconstruction outputs. The class follows
//! from the number of planes and from which of their polygons share a fold (an
//! edge inside the node):
//!
//! | class | planes | folds |
//! |---|---|---|
//! | Face `F` | 1 | 0 |
//! | Edge `E` | 2 | 1 |
//! | DoubleEdge `DE` | 3 | 2 (a chain) |
//! | Band `B^n` | 2 to 4 | 0 |
//! | SpecialBand `B*` | 3 | 1 (an Edge and a Face) |
//!
//! Anything else (five planes or more, three planes folded pairwise, folds among
//! four planes, or the facets of one plane not making a single convex polygon) is
//! not codifiable.

use super::plane::{Facet, Point};

/// The class `K` of a terminal surface node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Class {
    /// `F`: one plane (Marching Cubes patterns 1, 2, 8, 9).
    Face,
    /// `E`: two planes meeting inside the node (pattern 5).
    Edge,
    /// `DE`: three planes, the middle one meeting the other two (patterns 11, 14).
    DoubleEdge,
    /// `B^n`: `n` (2 to 4) planes that do not meet inside the node (patterns 3, 4,
    /// 6, 7, 10, 13).
    Band(u8),
    /// `B*`: an Edge and a separate Face, three planes (pattern 12).
    SpecialBand,
}

impl Class {
    /// The paper's symbol (`F`, `E`, `DE`, `B2`..`B4`, `B*`).
    pub fn symbol(self) -> &'static str {
        match self {
            Class::Face => "F",
            Class::Edge => "E",
            Class::DoubleEdge => "DE",
            Class::Band(2) => "B2",
            Class::Band(3) => "B3",
            Class::Band(_) => "B4",
            Class::SpecialBand => "B*",
        }
    }

    /// Index in [`super::Stats::terminals`] (`F, E, DE, B^n, B*`).
    pub fn slot(self) -> usize {
        match self {
            Class::Face => 0,
            Class::Edge => 1,
            Class::DoubleEdge => 2,
            Class::Band(_) => 3,
            Class::SpecialBand => 4,
        }
    }
}

/// The surface of a codifiable node: its class and one convex polygon per plane,
/// in plane order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Code {
    /// `K`.
    pub class: Class,
    /// One facet per plane `<Vi, di>`.
    pub facets: Vec<Facet>,
}

/// The code of a node whose surface is `pieces` (facets of its children, or of
/// its own contour loops), or `None` when it is not codifiable.
pub(crate) fn codify(pieces: &[&Facet], pts: &[Point]) -> Option<Code> {
    let mut pieces = pieces.to_vec();
    pieces.sort_by_key(|f| f.plane);
    if pieces.chunk_by(|a, b| a.plane == b.plane).nth(4).is_some() {
        return None; // five planes or more
    }
    let mut facets: Vec<Facet> = Vec::new();
    for group in pieces.chunk_by(|a, b| a.plane == b.plane) {
        let plane = group[0].plane;
        let ring = match group {
            [one] => one.ring.clone(),
            _ => union(group)?,
        };
        if !plane.is_convex(&ring, pts) {
            return None;
        }
        facets.push(Facet { plane, ring });
    }
    // Folds: edges one plane's polygon runs one way and another's the other way.
    let mut owned: Vec<(u32, u32, usize)> = facets
        .iter()
        .enumerate()
        .flat_map(|(k, f)| ring_edges(&f.ring).map(move |(a, b)| (a, b, k)))
        .collect();
    owned.sort_unstable();
    let mut folded = [[false; 4]; 4];
    let mut folds = 0;
    for &(a, b, k) in &owned {
        let i = owned.partition_point(|&(x, y, _)| (x, y) < (b, a));
        if let Some(&(x, y, o)) = owned.get(i) {
            if (x, y) == (b, a) && o != k && !folded[o][k] {
                folded[o][k] = true;
                folded[k][o] = true;
                folds += 1;
            }
        }
    }
    let class = match (facets.len(), folds) {
        (1, 0) => Class::Face,
        (2, 1) => Class::Edge,
        (3, 2) => Class::DoubleEdge,
        (3, 1) => Class::SpecialBand,
        (n @ 2..=4, 0) => Class::Band(n as u8),
        _ => return None,
    };
    Some(Code { class, facets })
}

/// The directed edges of a ring.
fn ring_edges(ring: &[u32]) -> impl Iterator<Item = (u32, u32)> + '_ {
    (0..ring.len()).map(|i| (ring[i], ring[(i + 1) % ring.len()]))
}

/// The boundary of the union of coplanar facets that share edges: their edges
/// less those run both ways, walked from the smallest vertex id. `None` unless
/// that boundary is one simple ring (the facets are one disk).
fn union(group: &[&Facet]) -> Option<Vec<u32>> {
    let mut all: Vec<(u32, u32)> = group.iter().flat_map(|f| ring_edges(&f.ring)).collect();
    all.sort_unstable();
    if all.windows(2).any(|w| w[0] == w[1]) {
        return None; // an edge run twice the same way: not one oriented surface
    }
    let has = |e: (u32, u32)| all.binary_search(&e).is_ok();
    // The boundary, sorted by first vertex: at most one edge may leave a vertex.
    let next: Vec<(u32, u32)> = all.iter().copied().filter(|&(a, b)| !has((b, a))).collect();
    if next.is_empty() || next.windows(2).any(|w| w[0].0 == w[1].0) {
        return None; // no boundary, or a pinch
    }
    let after = |v: u32| {
        let i = next.partition_point(|&(a, _)| a < v);
        next.get(i).filter(|&&(a, _)| a == v).map(|&(_, b)| b)
    };
    let start = next[0].0;
    let mut ring = vec![start];
    let mut v = after(start)?;
    while v != start {
        if ring.len() >= next.len() {
            return None;
        }
        ring.push(v);
        v = after(v)?;
    }
    (ring.len() == next.len()).then_some(ring)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points of a unit square grid on z = 0 (ids `x + 3 y`, x, y in 0..3).
    fn square() -> Vec<Point> {
        (0..9).map(|i| [i % 3, i / 3, 0]).collect()
    }

    #[test]
    fn four_coplanar_squares_merge_into_one_face() {
        let pts = square();
        let quads = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]];
        let pieces: Vec<Facet> = quads
            .iter()
            .map(|q| Facet::new(q.to_vec(), &pts).unwrap())
            .collect();
        let code = codify(&pieces.iter().collect::<Vec<_>>(), &pts).expect("one convex face");
        assert_eq!(code.class, Class::Face);
        assert_eq!(code.facets.len(), 1);
        // The boundary keeps the collinear midpoints 1, 5, 7, 3: neighbours may
        // need them.
        assert_eq!(code.facets[0].ring, vec![0, 1, 2, 5, 8, 7, 6, 3]);
    }

    #[test]
    fn an_l_shape_is_not_convex_and_not_codifiable() {
        let pts = square();
        let quads = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6]];
        let pieces: Vec<Facet> = quads
            .iter()
            .map(|q| Facet::new(q.to_vec(), &pts).unwrap())
            .collect();
        assert!(codify(&pieces.iter().collect::<Vec<_>>(), &pts).is_none());
    }

    #[test]
    fn two_planes_folded_once_are_an_edge_and_apart_a_band() {
        // A roof: two quads meeting along the ridge 1-4.
        let pts = vec![
            [0, 0, 0],
            [1, 0, 1],
            [2, 0, 0],
            [0, 1, 0],
            [1, 1, 1],
            [2, 1, 0],
        ];
        let roof = |a: Vec<u32>, b: Vec<u32>| {
            codify(
                &[&Facet::new(a, &pts).unwrap(), &Facet::new(b, &pts).unwrap()],
                &pts,
            )
        };
        let e = roof(vec![0, 1, 4, 3], vec![1, 2, 5, 4]).unwrap();
        assert_eq!(e.class, Class::Edge);
        // Without the shared ridge (the second quad shifted off it) they are a
        // band of two.
        let pts2: Vec<Point> = pts.iter().chain(&[[1, 0, 1], [1, 1, 1]]).copied().collect();
        let b = codify(
            &[
                &Facet::new(vec![0, 1, 4, 3], &pts2).unwrap(),
                &Facet::new(vec![6, 2, 5, 7], &pts2).unwrap(),
            ],
            &pts2,
        )
        .unwrap();
        assert_eq!(b.class, Class::Band(2));
    }
}
