//! The pipeline's painting step: each component that can be a leaf takes the
//! field's material at its vertex, so every mesh cut from the tree carries them.

use super::{KdTree, CELL};
use crate::field::Field;
use crate::material::MaterialBlend;
use glam::Vec3;
use rayon::prelude::*;

/// Gives every component of `tree` that can be a leaf its vertex's material
/// ([`KdTree::materials`]), so contouring the tree (alone, or as a chunk of a
/// world) gives each vertex the field's material at it. Empties them when the
/// field has no materials, or `settings` turn materials off
/// ([`crate::Settings::materials`]).
pub(crate) fn paint_tree(tree: &mut KdTree, field: &dyn Field, settings: &crate::Settings) {
    tree.materials.clear();
    if !(settings.materials && field.has_materials()) {
        return;
    }
    let mut out = vec![MaterialBlend::default(); tree.comps.len()];
    let tree_ref: &KdTree = tree;
    let spans: Vec<(u32, u32, usize)> = tree_ref
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.comp_count > 0 && (n.axis == CELL || n.leaf_ok))
        .map(|(i, n)| (i as u32, n.comp_start, n.comp_count as usize))
        .collect();
    let painted: Vec<(usize, MaterialBlend)> = spans
        .par_iter()
        .flat_map_iter(|&(n, start, count)| {
            (0..count).map(move |k| {
                let at: Vec3 = tree_ref.grid.to_world(tree_ref.comp_position(n, k as u8));
                (start as usize + k, field.material(at))
            })
        })
        .collect();
    for (i, m) in painted {
        out[i] = m;
    }
    tree.materials = out;
}
