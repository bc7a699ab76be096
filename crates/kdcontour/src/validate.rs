//! The mesh checker every test uses: watertight, edge- and vertex-manifold,
//! consistently oriented, Euler characteristic, components, and geometric error.

use crate::field::Field;
use crate::mesh::IndexedMesh;
use std::collections::HashMap;

/// What [`validate`] found.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MeshReport {
    /// Triangles.
    pub triangles: usize,
    /// Vertices referenced by a triangle.
    pub vertices: usize,
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Vertices whose triangles form more than one fan.
    pub nonmanifold_vertices: usize,
    /// Edges whose two triangles traverse it in the same direction.
    pub misoriented_edges: usize,
    /// Triangles with a repeated vertex index.
    pub degenerate_triangles: usize,
    /// Connected components (through shared vertices).
    pub components: usize,
    /// V - E + F over referenced vertices.
    pub euler: i64,
    /// No boundary edges.
    pub watertight: bool,
    /// No non-manifold edge or vertex and no degenerate triangle.
    pub manifold: bool,
    /// Every interior edge is traversed once each way.
    pub oriented: bool,
    /// Largest |f| / |∇f| over vertices and triangle centroids, in cells.
    pub max_error: f32,
    /// Mean of the same.
    pub mean_error: f32,
    /// Largest |f| / |∇f| over vertices only, in cells (sharp features put vertices
    /// on creases and corners, while centroids of triangles that bridge a crease lie
    /// off it).
    pub max_vertex_error: f32,
}

impl MeshReport {
    /// Watertight, manifold and consistently oriented.
    pub fn is_closed_manifold(&self) -> bool {
        self.watertight && self.manifold && self.oriented
    }
}

fn find(p: &mut [u32], mut x: u32) -> u32 {
    while p[x as usize] != x {
        p[x as usize] = p[p[x as usize] as usize];
        x = p[x as usize];
    }
    x
}

/// Checks `mesh`. With `field` (and the grid's cell size), also measures how far
/// vertices and triangle centroids are from the surface, in cells.
pub fn validate(mesh: &IndexedMesh, field: Option<(&dyn Field, f32)>) -> MeshReport {
    let nv = mesh.positions.len();
    let tris: Vec<[u32; 3]> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let mut r = MeshReport {
        triangles: tris.len(),
        ..Default::default()
    };
    // Directed edge counts keyed by (min, max) with a direction tally.
    let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::with_capacity(tris.len() * 2);
    let mut used = vec![false; nv];
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for (ti, t) in tris.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            r.degenerate_triangles += 1;
            continue;
        }
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            used[a as usize] = true;
            incident[a as usize].push(ti as u32);
            let key = (a.min(b), a.max(b));
            let e = edges.entry(key).or_insert((0, 0));
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
        }
    }
    for &(count, dir) in edges.values() {
        match count {
            1 => r.boundary_edges += 1,
            2 => {
                if dir != 0 {
                    r.misoriented_edges += 1
                }
            }
            _ => r.nonmanifold_edges += 1,
        }
    }
    // Vertex fans: triangles around a vertex joined through edges at the vertex.
    for (v, tri_ids) in incident.iter().enumerate() {
        if tri_ids.len() <= 1 {
            continue;
        }
        let mut parent: Vec<u32> = (0..tri_ids.len() as u32).collect();
        let mut by_other: HashMap<u32, u32> = HashMap::new();
        for (k, &ti) in tri_ids.iter().enumerate() {
            for &o in &tris[ti as usize] {
                if o as usize == v {
                    continue;
                }
                if let Some(&prev) = by_other.get(&o) {
                    let (ra, rb) = (find(&mut parent, prev), find(&mut parent, k as u32));
                    parent[ra as usize] = rb;
                } else {
                    by_other.insert(o, k as u32);
                }
            }
        }
        let fans = (0..tri_ids.len() as u32)
            .filter(|&k| find(&mut parent, k) == k)
            .count();
        if fans > 1 {
            r.nonmanifold_vertices += 1;
        }
    }
    // Components through shared vertices.
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    for t in &tris {
        for i in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[i]));
            parent[a as usize] = b;
        }
    }
    r.vertices = used.iter().filter(|&&u| u).count();
    r.components = (0..nv as u32)
        .filter(|&v| used[v as usize] && find(&mut parent, v) == v)
        .count();
    r.euler = r.vertices as i64 - edges.len() as i64 + (tris.len() - r.degenerate_triangles) as i64;
    r.watertight = r.boundary_edges == 0;
    r.manifold =
        r.nonmanifold_edges == 0 && r.nonmanifold_vertices == 0 && r.degenerate_triangles == 0;
    r.oriented = r.misoriented_edges == 0;

    if let Some((f, cell)) = field {
        let dist = |p: glam::Vec3| {
            let g = f.gradient(p).length().max(1e-6);
            f.value(p).abs() / g / cell
        };
        let mut sum = 0f64;
        let mut n = 0usize;
        let mut max = 0f32;
        for (v, p) in mesh.positions.iter().enumerate() {
            if used[v] {
                let d = dist(*p);
                max = max.max(d);
                sum += d as f64;
                n += 1;
            }
        }
        r.max_vertex_error = max;
        for t in &tris {
            let c = (mesh.positions[t[0] as usize]
                + mesh.positions[t[1] as usize]
                + mesh.positions[t[2] as usize])
                / 3.0;
            let d = dist(c);
            max = max.max(d);
            sum += d as f64;
            n += 1;
        }
        r.max_error = max;
        r.mean_error = if n > 0 { (sum / n as f64) as f32 } else { 0.0 };
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tetra() -> IndexedMesh {
        IndexedMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            normals: vec![Vec3::Z; 4],
            indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
        }
    }

    #[test]
    fn tetrahedron_is_a_closed_sphere() {
        let r = validate(&tetra(), None);
        assert!(r.is_closed_manifold(), "{r:?}");
        assert_eq!(r.euler, 2);
        assert_eq!(r.components, 1);
    }

    #[test]
    fn hole_flip_and_pinch_are_seen() {
        let mut m = tetra();
        m.indices.truncate(9);
        let r = validate(&m, None);
        assert!(!r.watertight && r.boundary_edges == 3);

        let mut m = tetra();
        m.indices[0..3].copy_from_slice(&[0, 1, 2]);
        assert!(!validate(&m, None).oriented);

        // Two tetrahedra sharing one vertex: a pinch.
        let mut m = tetra();
        let t2 = tetra();
        let base = m.positions.len() as u32;
        m.positions
            .extend(t2.positions.iter().map(|p| *p + Vec3::splat(-1.0)));
        m.normals.extend(&t2.normals);
        m.indices.extend(
            t2.indices
                .iter()
                .map(|&i| if i == 1 { 0 } else { i + base }),
        );
        let r = validate(&m, None);
        assert_eq!(r.nonmanifold_vertices, 1, "{r:?}");
        assert!(!r.manifold);
    }
}
