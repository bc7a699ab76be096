//! The material check of [`super::validate`]: one well-formed blend per vertex,
//! each equal to the field's material at the vertex, how many triangles span a
//! border between dominant materials, and how many are drawn with a tooth.

use crate::field::Field;
use crate::material::PURE;
use crate::mesh::IndexedMesh;
use glam::Vec3;

/// The materials of a mesh ([`super::MeshReport::materials`]).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Materials {
    /// The mesh has exactly one blend per vertex.
    pub per_vertex: bool,
    /// Blends with a negative weight, weights out of order, or weights not
    /// summing to 1 (within 1e-4).
    pub bad_blends: usize,
    /// Referenced vertices whose blend is not the field's material at the
    /// vertex (`None` without a field).
    pub mismatched_vertices: Option<usize>,
    /// Triangles whose three vertices do not share one dominant material.
    pub border_triangles: usize,
    /// Triangles whose centroid holds one pure material (the field's, weight at
    /// least [`crate::material::PURE`]) and that have a vertex of another
    /// dominant material: each is drawn with a wedge of that vertex's colour
    /// (the sawtooth [`crate::material::split_borders`] removes on creases).
    /// `None` without a field.
    pub toothed_triangles: Option<usize>,
}

/// Checks the materials of `mesh` against `field`'s; `None` when neither the
/// mesh nor the field has materials.
pub(super) fn check(
    mesh: &IndexedMesh,
    field: Option<&dyn Field>,
    used: &[bool],
) -> Option<Materials> {
    let field_has = field.is_some_and(|f| f.has_materials());
    if mesh.materials.is_empty() && !field_has {
        return None;
    }
    let m = &mesh.materials;
    let mut r = Materials {
        per_vertex: m.len() == mesh.positions.len(),
        ..Default::default()
    };
    r.bad_blends = m
        .iter()
        .filter(|b| {
            let sum: f32 = b.weights.iter().sum();
            (sum - 1.0).abs() > 1e-4
                || b.weights.iter().any(|w| w.is_nan() || *w < 0.0)
                || b.weights.windows(2).any(|w| w[0] < w[1])
        })
        .count();
    if !r.per_vertex {
        return Some(r);
    }
    r.mismatched_vertices = field.map(|f| {
        (0..m.len())
            .filter(|&i| used[i] && f.material(mesh.positions[i]) != m[i])
            .count()
    });
    r.border_triangles = mesh
        .indices
        .chunks_exact(3)
        .filter(|t| {
            let d = t.iter().map(|&i| m[i as usize].dominant());
            let first = m[t[0] as usize].dominant();
            d.into_iter().any(|x| x != first)
        })
        .count();
    r.toothed_triangles = field.map(|f| {
        mesh.indices
            .chunks_exact(3)
            .filter(|t| {
                let c = t.iter().map(|&i| mesh.positions[i as usize]).sum::<Vec3>() / 3.0;
                let at = f.material(c);
                at.weights[0] >= PURE
                    && t.iter().any(|&i| m[i as usize].dominant() != at.dominant())
            })
            .count()
    });
    Some(r)
}
