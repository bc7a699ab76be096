//! Vertex materials read from the field, for meshes that did not come from a
//! painted tree.

use crate::field::Field;
use crate::mesh::IndexedMesh;
use rayon::prelude::*;

/// Fills `mesh.materials` with `field`'s material at every vertex, or empties it
/// when the field has none. Meshers that do not go through a [`crate::KdTree`] built
/// from the field (the baselines of [`crate::meshers`]) are given materials this
/// way.
pub fn attach(mesh: &mut IndexedMesh, field: &dyn Field) {
    mesh.materials.clear();
    if field.has_materials() {
        mesh.materials
            .par_extend(mesh.positions.par_iter().map(|&p| field.material(p)));
    }
}
