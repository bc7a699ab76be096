//! Surface reconstruction (the paper's section 5): one polygon per plane of
//! every terminal surface node, triangulated for an [`IndexedMesh`].
//!
//! The paper intersects each plane with the node's edges and keeps the points on
//! the right side of the other planes. Because a merge never adds error, that
//! polygon is exactly the union of the merged children's facets on the plane,
//! which [`codify`](super::classes) already holds as a ring of edge-crossing
//! vertices; so it is output directly.
//!
//! **Cracks and T-junctions.** A polygon of a large node has, along a face of the
//! node, the same straight boundary as the smaller polygons across that face
//! (the surface is the same Discretized Marching Cubes surface on both sides),
//! but those have corners at midpoints that lie on it. Geometrically there is no
//! crack; topologically such a midpoint is a T-junction unless the large polygon
//! has it too. So a vertex is kept in every polygon that runs through it when it
//! is a corner of at least one polygon, and dropped from all of them when it is
//! a straight point of every polygon (then exactly two polygons share it, both
//! straight there). The triangles therefore pair edge to edge: the mesh is a
//! re-triangulation of the Discretized Marching Cubes surface and has its
//! topology, which is Marching Cubes' topology.
//!
//! **Triangulation.** Each polygon is convex. It is cut by ear clipping at strict
//! corners only, never at a corner whose removal would leave all remaining
//! vertices on one line; so no triangle has zero area. A polygon of `k` kept
//! vertices gives `k - 2` triangles. The loops of non-codifiable cells are not
//! planar and are fanned as Marching Cubes fans them.

use super::classes::Code;
use super::plane::{dot, turn, Point};
use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use glam::Vec3;

/// A polygon to output: a ring of vertex ids, counter-clockwise from outside.
pub(crate) struct Polygon {
    /// Its vertices.
    ring: Vec<u32>,
    /// Its plane's normal, or `None` for a non-planar loop of a cell that is not
    /// codifiable.
    normal: Option<Point>,
}

impl Polygon {
    /// The polygons of a terminal node, one per plane.
    pub(crate) fn of_code(code: Code) -> impl Iterator<Item = Polygon> {
        code.facets.into_iter().map(|f| Polygon {
            ring: f.ring,
            normal: Some(f.plane.normal),
        })
    }

    /// A contour loop of a non-codifiable cell.
    pub(crate) fn loop_of(ring: Vec<u32>) -> Polygon {
        Polygon { ring, normal: None }
    }
}

/// The mesh of `polygons` over the edge midpoints `pts` of `h`.
pub(crate) fn to_mesh(h: &Hermite, pts: &[Point], polygons: &[Polygon]) -> IndexedMesh {
    let at = |ring: &[u32], i: usize| pts[ring[i % ring.len()] as usize];
    let mut corner = vec![false; pts.len()];
    for p in polygons {
        let m = p.ring.len();
        for i in 0..m {
            if turn(at(&p.ring, i + m - 1), at(&p.ring, i), at(&p.ring, i + 1)) != [0; 3] {
                corner[p.ring[i] as usize] = true;
            }
        }
    }
    let mut mesh = IndexedMesh::default();
    let mut id = vec![u32::MAX; pts.len()];
    for (v, p) in pts.iter().enumerate() {
        if corner[v] {
            id[v] = mesh.positions.len() as u32;
            let half = Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * 0.5;
            mesh.positions.push(h.grid.to_world(half));
            mesh.normals.push(h.edges[v].normal);
        }
    }
    let mut tris = Vec::new();
    for p in polygons {
        let ring: Vec<u32> = p
            .ring
            .iter()
            .copied()
            .filter(|&v| corner[v as usize])
            .collect();
        match p.normal {
            Some(n) => clip_ears(ring, n, pts, &mut tris),
            None => tris.extend((1..ring.len() - 1).map(|i| [ring[0], ring[i], ring[i + 1]])),
        }
    }
    mesh.indices = tris.into_iter().flatten().map(|v| id[v as usize]).collect();
    mesh
}

/// Triangulates the convex polygon `ring` (normal `n`) by ear clipping without
/// zero-area triangles.
fn clip_ears(mut ring: Vec<u32>, n: Point, pts: &[Point], tris: &mut Vec<[u32; 3]>) {
    let strict = |r: &[u32], i: usize| {
        let m = r.len();
        let p = |j: usize| pts[r[j % m] as usize];
        dot(turn(p(i + m - 1), p(i), p(i + 1)), n) > 0
    };
    while ring.len() > 3 {
        let m = ring.len();
        let s: Vec<bool> = (0..m).map(|i| strict(&ring, i)).collect();
        let corners = s.iter().filter(|&&c| c).count();
        // Clipping a strict corner keeps every other strict corner strict and
        // makes a straight neighbour strict; with only three corners, clip one
        // that has a straight neighbour.
        let i = (0..m)
            .find(|&i| s[i] && (corners > 3 || !s[(i + m - 1) % m] || !s[(i + 1) % m]))
            .expect("a convex polygon with area has an ear");
        tris.push([ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m]]);
        ring.remove(i);
    }
    tris.push([ring[0], ring[1], ring[2]]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_with_points_on_its_sides_clips_without_slivers_of_zero_area() {
        // Corners 0, 3, 5; 1, 2 on side 0-3 and 4 on side 3-5.
        let pts = vec![
            [0, 0, 0],
            [1, 0, 0],
            [2, 0, 0],
            [3, 0, 0],
            [2, 1, 0],
            [1, 2, 0],
        ];
        let mut tris = Vec::new();
        clip_ears((0..6).collect(), [0, 0, 1], &pts, &mut tris);
        assert_eq!(tris.len(), 4);
        for t in &tris {
            let [a, b, c] = t.map(|v| pts[v as usize]);
            assert!(dot(turn(a, b, c), [0, 0, 1]) > 0, "{t:?}");
        }
    }
}
