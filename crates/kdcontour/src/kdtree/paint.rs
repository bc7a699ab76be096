//! The pipeline's painting step: each component that can be a leaf takes the
//! field's material at its vertex, so every mesh cut from the tree carries them.
//!
//! A clustered node can be a leaf only at thresholds at or above its error and
//! below the error of the nearest ancestor that may be a leaf (the cut stops at
//! the first leaf on the way down, and errors never decrease going up). Where
//! the two errors are equal (a node whose box only cut empty space off its one
//! child, or a flat region merged level after level) no threshold reaches it,
//! and its components are not painted: on the plugin's terrain chunk that is a
//! third of them.

use super::{KdTree, CELL, NONE};
use crate::field::Field;
use crate::material::MaterialBlend;
use glam::Vec3;
use rayon::prelude::*;

/// Gives every component of `tree` that can be a leaf at some threshold its
/// vertex's material ([`KdTree::materials`]), so contouring the tree (alone, or
/// as a chunk of a world) gives each vertex the field's material at it; the
/// others keep the default blend. Empties them when the field has no materials,
/// or `settings` turn materials off ([`crate::Settings::materials`]).
pub(crate) fn paint_tree(tree: &mut KdTree, field: &dyn Field, settings: &crate::Settings) {
    tree.materials.clear();
    if !(settings.materials && field.has_materials()) {
        return;
    }
    let mut out = vec![MaterialBlend::default(); tree.comps.len()];
    let tree_ref: &KdTree = tree;
    let spans = leaf_spans(tree_ref);
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

/// The nodes whose components some threshold makes leaves (see the module
/// docs), as (node, first component, component count): every cell, and every
/// clustered node that may be a leaf with an error below the nearest such
/// ancestor's; of a tree with a smallest threshold
/// ([`crate::Settings::min_threshold`]), only those a cut at it or above
/// reaches.
fn leaf_spans(tree: &KdTree) -> Vec<(u32, u32, usize)> {
    let mut spans = Vec::new();
    if tree.root == NONE {
        return spans;
    }
    // (node, error of the nearest ancestor that may be a leaf)
    let mut stack = vec![(tree.root, f32::INFINITY)];
    while let Some((n, cap)) = stack.pop() {
        let node = &tree.nodes[n as usize];
        let may_be_leaf = node.clusterable && node.leaf_ok && node.comp_count > 0;
        // The lowest threshold it is a leaf at: a cell's is any, but no cut is
        // lower than the tree's smallest.
        let from = if node.axis == CELL {
            f32::NEG_INFINITY
        } else {
            node.error
        };
        let from = if from < tree.min_threshold {
            tree.min_threshold
        } else {
            from
        };
        if (node.axis == CELL || may_be_leaf) && from < cap {
            spans.push((n, node.comp_start, node.comp_count as usize));
        }
        let cap = if may_be_leaf {
            cap.min(node.error)
        } else {
            cap
        };
        for &c in node.children.iter().rev() {
            if c != NONE {
                stack.push((c, cap));
            }
        }
    }
    spans
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{scenes, validate, Grid, Settings};

    /// At every threshold where the cut changes (each distinct error of a node
    /// that may be a leaf, and just below it), every vertex carries the field's
    /// material: no component a cut reaches was left unpainted. A tree with a
    /// smallest threshold paints fewer (no cell a cut at it passes by).
    #[test]
    fn every_cut_reaches_only_painted_components() {
        for (name, min_threshold) in [
            ("terrain", f32::NEG_INFINITY),
            ("caves", f32::NEG_INFINITY),
            ("terrain", 0.01),
            ("caves", 0.003),
        ] {
            let scene = scenes::scene(name).unwrap();
            let grid = Grid::cube(1.0, 20);
            let settings = Settings {
                min_threshold,
                ..Settings::default()
            };
            let tree = KdTree::build(&*scene.field, &grid, &settings).unwrap();
            let spans = leaf_spans(&tree);
            let painted: usize = spans.iter().map(|s| s.2).sum();
            if min_threshold.is_finite() {
                let all = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
                let unlimited: usize = leaf_spans(&all).iter().map(|s| s.2).sum();
                assert!(painted < unlimited, "{name}: {painted} of {unlimited}");
            }
            let old_rule: usize = tree
                .nodes
                .iter()
                .filter(|n| n.comp_count > 0 && (n.axis == CELL || n.leaf_ok))
                .map(|n| n.comp_count as usize)
                .sum();
            assert!(painted < old_rule, "{name}: {painted} of {old_rule}");
            let mut errors: Vec<f32> = tree
                .nodes
                .iter()
                .filter(|n| n.clusterable && n.leaf_ok && n.axis != CELL && n.error.is_finite())
                .map(|n| n.error)
                .collect();
            errors.sort_by(f32::total_cmp);
            errors.dedup();
            let step = errors.len().div_ceil(60).max(1);
            let mut thresholds = vec![-1.0, f32::MAX];
            for e in errors.iter().step_by(step) {
                thresholds.extend([*e, e.next_down()]);
            }
            for t in thresholds {
                let mesh = tree.mesh(t);
                let m = validate(&mesh, Some((&*scene.field, grid.cell_size)))
                    .materials
                    .unwrap();
                assert_eq!(
                    m.mismatched_vertices,
                    Some(0),
                    "{name} (min {min_threshold}) at {t}: {m:?}"
                );
            }
        }
    }
}
