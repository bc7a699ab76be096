//! Crisp material borders on creases in a drawn mesh: vertices split where
//! faces of different materials meet at a crease.
//!
//! A mesh carries one [`MaterialBlend`] per vertex, and a renderer blends them
//! across each face. Where a hard border on a crease (a CSG cut of another
//! material, a cave mouth) runs through a row of vertices, each of those
//! vertices can hold only one side's material, and the faces of the other side
//! that touch it take its colour for part of their width: the border is drawn as
//! a sawtooth one cell deep along what is a smooth crease in the geometry (the
//! "teeth" on the csg_editor cup's rim).
//!
//! [`split_borders`] reads the field's material at the centroids of the faces
//! whose corners hold two pure materials and, where the surface bends at
//! such a vertex, gives each side its own copy of it, with that side's material
//! and normal. The border then runs along the crease, shaded sharp. A border
//! across smooth surface (a snow line, a painted patch) has no edge to follow
//! and keeps its fade. Positions do not change, so welding the
//! copies back gives the mesh it was made from; only drawn meshes are split (the
//! core's checks, colliders and exported meshes stay welded).

use super::{MaterialBlend, PURE};
use crate::field::Field;
use crate::geometry::CREASE_DEGREES;
use crate::mesh::IndexedMesh;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// What [`split_borders`] did to a mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BorderSplit {
    /// Faces whose corners hold two pure materials, given the field's material
    /// at their centroid.
    pub faces_read: usize,
    /// Faces of one pure material that had a corner of another on a crease
    /// (drawn as the sawtooth) before the split; none have after it.
    pub toothed_faces: usize,
    /// Vertex copies added.
    pub vertices_added: usize,
}

/// Splits `mesh`'s vertices along hard material borders on creases (see the
/// module docs); `cell` is the grid's cell size, the scale at which a crease is
/// looked for. Does nothing to a mesh without one blend per vertex.
///
/// Faces whose corners hold two pure materials (dominant weight at least
/// [`PURE`]) read `field`'s material at their centroid; the other faces round
/// those corners count as the material their corners agree on. A read face
/// whose material is pure and that has a corner of another pure material gets a
/// copy of that vertex with its own material, if the vertex sits on a crease
/// between the two: each side's material holds [`SIDE_CELLS`] cells from the
/// vertex toward that side's faces, and the field's normals at those two points
/// differ by more than the crease angle `validate` uses
/// ([`CREASE_DEGREES`](crate::geometry::CREASE_DEGREES)), or no face of the
/// vertex's own material touches it. One copy per vertex and material, whose
/// blend is the mean of the faces that use it; every vertex that is split takes,
/// on each side, the field's normal just on that side (the crease is shaded
/// sharp). Blends, and borders across smooth surface (a snow line, a painted
/// patch), are left to the vertices' weights, so they still fade: a split there
/// would colour whole faces one material, patches as angular as the faces.
pub fn split_borders(mesh: &mut IndexedMesh, field: &dyn Field, cell: f32) -> BorderSplit {
    let mut out = BorderSplit::default();
    if mesh.materials.len() != mesh.positions.len() || mesh.is_empty() {
        return out;
    }
    let heaviest = &mesh.materials;
    let dominant = |v: u32| heaviest[v as usize].dominant();
    let faces = mesh.indices.len() / 3;
    let face = |t: usize| face_of(&mesh.indices, t);

    // Faces with corners of two pure materials are read (inside a blend,
    // vertices are not pure: nothing to read); their corners are the vertices
    // a border may run through.
    let mut near = vec![false; mesh.positions.len()];
    let mut read = Vec::new();
    for t in 0..faces {
        let corners = face(t);
        let mut pure = corners
            .iter()
            .filter(|&&v| is_pure(&heaviest[v as usize]))
            .map(|&v| dominant(v));
        let first = pure.next();
        if pure.any(|d| Some(d) != first) {
            read.push(t);
            for v in corners {
                near[v as usize] = true;
            }
        }
    }
    out.faces_read = read.len();
    // The other faces round those vertices are taken to be of the material
    // their corners agree on, when pure: they only say where each side lies
    // (no sample; the field is read only where corners disagree).
    let agreed: Vec<(usize, MaterialBlend)> = (0..faces)
        .filter_map(|t| {
            let corners = face(t);
            if !corners.iter().any(|&v| near[v as usize]) {
                return None;
            }
            let d = dominant(corners[0]);
            corners
                .iter()
                .all(|&v| dominant(v) == d && is_pure(&heaviest[v as usize]))
                .then(|| (t, heaviest[corners[0] as usize]))
        })
        .collect();
    // Each read face's material at its centroid, kept when pure.
    let positions = &mesh.positions;
    let indices = &mesh.indices;
    let centroid = |t: usize| {
        face_of(indices, t)
            .iter()
            .map(|&v| positions[v as usize])
            .sum::<Vec3>()
            / 3.0
    };
    let sides: Vec<(usize, MaterialBlend)> = read
        .par_iter()
        .filter_map(|&t| {
            let m = field.material(centroid(t));
            is_pure(&m).then_some((t, m))
        })
        .collect();
    // Around each vertex, where each material's faces lie.
    let mut around: HashMap<(u32, u8), Around> = HashMap::new();
    for &(t, m) in sides.iter().chain(&agreed) {
        let c = centroid(t);
        for v in face_of(indices, t) {
            let to = c - positions[v as usize];
            let e = around.entry((v, m.dominant())).or_default();
            e.direction += to.normalize_or_zero();
            e.distance += to.length();
            e.faces += 1;
        }
    }
    // A point just on one material's side of a vertex: toward the mean of
    // that side's centroids, SIDE_CELLS cells away (or halfway to them).
    let beside = |v: u32, side: u8| -> Option<Vec3> {
        let e = around.get(&(v, side))?;
        let step = (SIDE_CELLS * cell).min(0.5 * e.distance / e.faces as f32);
        Some(positions[v as usize] + e.direction.try_normalize()? * step)
    };
    // The field's normal there, when the side's own material holds there (the
    // border passes through the vertex, not across its faces farther off).
    let side_normal = |v: u32, side: u8| -> Option<Vec3> {
        let at = beside(v, side)?;
        let m = field.material(at);
        (is_pure(&m) && m.dominant() == side).then_some(())?;
        field.gradient(at).try_normalize()
    };
    // A corner of another pure material is cut from a face when the field
    // bends by more than CREASE_DEGREES between the two materials' sides of
    // the vertex (it sits on a crease), or no face of its own material
    // touches it. Each (vertex, side) that is cut keeps its side's normal.
    let cos_crease = CREASE_DEGREES.to_radians().cos();
    let mut asked: Vec<(u32, u8, u8)> = Vec::new();
    for &(t, m) in &sides {
        for v in face_of(indices, t) {
            let own = &heaviest[v as usize];
            if own.dominant() != m.dominant() && is_pure(own) {
                asked.push((v, m.dominant(), own.dominant()));
            }
        }
    }
    asked.sort_unstable();
    asked.dedup();
    let decided: HashMap<(u32, u8), (Vec3, Option<Vec3>)> = asked
        .par_iter()
        .filter_map(|&(v, side, own)| {
            let this = side_normal(v, side)?;
            if !around.contains_key(&(v, own)) {
                return Some(((v, side), (this, None)));
            }
            let that = side_normal(v, own)?;
            (this.dot(that) < cos_crease).then_some(((v, side), (this, Some(that))))
        })
        .collect();
    let teeth: Vec<(usize, MaterialBlend, [bool; 3])> = sides
        .iter()
        .filter_map(|&(t, m)| {
            let cut = face_of(indices, t).map(|v| decided.contains_key(&(v, m.dominant())));
            cut.contains(&true).then_some((t, m, cut))
        })
        .collect();

    // One copy per (vertex, material) that a pure face of that material needs.
    struct Copy {
        index: u32,
        weights: Vec<(u8, f32)>,
    }
    let mut copies: HashMap<(u32, u8), Copy> = HashMap::new();
    out.toothed_faces = teeth.len();
    for &(t, m, cut) in &teeth {
        let side = m.dominant();
        for k in (0..3).filter(|&k| cut[k]) {
            let v = mesh.indices[3 * t + k];
            let next = (mesh.positions.len() + copies.len()) as u32;
            let copy = copies.entry((v, side)).or_insert_with(|| Copy {
                index: next,
                weights: Vec::new(),
            });
            copy.weights
                .extend(m.ids.iter().copied().zip(m.weights.iter().copied()));
            mesh.indices[3 * t + k] = copy.index;
        }
    }
    if copies.is_empty() {
        return out;
    }
    out.vertices_added = copies.len();
    let base = mesh.positions.len();
    mesh.positions.resize(base + copies.len(), Vec3::ZERO);
    mesh.normals.resize(base + copies.len(), Vec3::ZERO);
    mesh.materials
        .resize(base + copies.len(), MaterialBlend::default());
    for ((v, side), copy) in &copies {
        let i = copy.index as usize;
        mesh.positions[i] = mesh.positions[*v as usize];
        mesh.materials[i] = MaterialBlend::weighted(&copy.weights);
        let (this, that) = decided[&(*v, *side)];
        mesh.normals[i] = this;
        if let Some(that) = that {
            mesh.normals[*v as usize] = that;
        }
    }
    out
}

/// How far from a vertex (in cells) each side of a crease is read: near enough
/// that a border crossing a large face away from its corners (a coarse level
/// over a snow line) is not taken for one through the vertex, far enough to
/// clear a crease vertex placed a little off the crease.
pub const SIDE_CELLS: f32 = 0.5;

/// Whether one material holds at least [`PURE`] of `m`.
fn is_pure(m: &MaterialBlend) -> bool {
    m.weights[0] >= PURE
}

/// Where one material's faces lie around a vertex.
#[derive(Default)]
struct Around {
    /// Sum of the unit directions from the vertex to their centroids.
    direction: Vec3,
    /// Sum of the distances to them.
    distance: f32,
    /// How many.
    faces: u32,
}

fn face_of(indices: &[u32], t: usize) -> [u32; 3] {
    [indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CsgNode, Grid, KdTree, Settings};

    /// A block of material 1 with a bore of material 2 cut from its top: the
    /// bore's rim is a curved crease and a hard border.
    fn cup() -> CsgNode {
        let block = CsgNode::Material {
            id: 1,
            child: Box::new(CsgNode::Box {
                half_extents: Vec3::splat(0.6),
                center: Vec3::ZERO,
            }),
        };
        let bore = CsgNode::Material {
            id: 2,
            child: Box::new(CsgNode::Cylinder {
                radius: 0.35,
                half_height: 0.5,
                center: Vec3::new(0.0, 0.5, 0.0),
            }),
        };
        CsgNode::Difference {
            a: Box::new(block),
            b: Box::new(bore),
        }
    }

    /// A ball, material 1 for x < 0 and 2 for x >= 0: a hard border across
    /// smooth surface.
    struct Halves;

    impl Field for Halves {
        fn value(&self, p: Vec3) -> f32 {
            p.length() - 0.6
        }
        fn has_materials(&self) -> bool {
            true
        }
        fn material(&self, p: Vec3) -> MaterialBlend {
            MaterialBlend::single(if p.x < 0.0 { 1 } else { 2 })
        }
    }

    #[test]
    fn a_border_across_smooth_surface_is_left_to_the_weights() {
        let tree = KdTree::build(&Halves, &Grid::cube(1.0, 32), &Settings::default()).unwrap();
        for threshold in [-1.0, 0.01] {
            let mut mesh = tree.mesh(threshold);
            let before = mesh.clone();
            let report = split_borders(&mut mesh, &Halves, 2.0 / 32.0);
            assert!(report.faces_read > 0, "{threshold}: {report:?}");
            assert_eq!(report.vertices_added, 0, "{threshold}: {report:?}");
            assert_eq!(mesh, before);
        }
    }

    #[test]
    fn the_border_runs_along_edges_and_the_geometry_stays() {
        let field = cup().compile().expect("a valid scene");
        let tree = KdTree::build(&field, &Grid::cube(1.0, 48), &Settings::default()).unwrap();
        for threshold in [-1.0, 0.01, 0.1] {
            let mut mesh = tree.mesh(threshold);
            let before = mesh.clone();
            let report = split_borders(&mut mesh, &field, 2.0 / 48.0);
            assert!(
                report.toothed_faces > 0,
                "{threshold}: the rim had no sawtooth to remove ({report:?})"
            );
            assert!(report.vertices_added > 0);
            // After: no pure face has a corner of another material (every
            // border here is a crease), and a second pass finds nothing.
            let teeth = |m: &IndexedMesh| {
                crate::validate(m, Some((&field, 2.0 / 48.0)))
                    .materials
                    .and_then(|r| r.toothed_triangles)
                    .expect("a field with materials")
            };
            assert!(teeth(&before) >= report.toothed_faces, "{threshold}");
            assert_eq!(teeth(&mesh), 0, "{threshold}: {report:?}");
            let again = split_borders(&mut mesh.clone(), &field, 2.0 / 48.0);
            assert_eq!(again.vertices_added, 0, "{threshold}: {again:?}");
            // The same triangles at the same places.
            assert_eq!(mesh.indices.len(), before.indices.len());
            for (i, (&a, &b)) in mesh.indices.iter().zip(&before.indices).enumerate() {
                assert_eq!(
                    mesh.positions[a as usize], before.positions[b as usize],
                    "corner {i}"
                );
            }
            assert!(mesh.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
            assert_eq!(mesh.materials.len(), mesh.positions.len());
        }
    }
}
