//! The octree construction (the paper's section 4): cells coded at the finest
//! level, then a bottom-up pass over the octree in which the eight children of a
//! node are replaced by the node when their surfaces together are codifiable.
//! A node with a non-codifiable child, or whose children do not merge, stops:
//! its coded children become terminal surface nodes and no ancestor of it is
//! tried again.
//!
//! The paper's Merging Table answers "which codifiable node do these two make"
//! pair by pair, with a Plane Position test where the table has several
//! answers. Here the union of all eight children is classified at once by
//! [`codify`](super::classes): the same question asked of the same facets, so
//! the same nodes merge; the table is only a shortcut for it.

use super::classes::{codify, Code};
use super::output::Polygon;
use super::plane::Facet;
use super::Stats;
use rayon::prelude::*;

/// A node at the current level: its key (coordinates at that level) and its
/// code, or `None` once a child of it has stopped (its polygons are out).
type Node = ([u32; 3], Option<Code>);

/// Merges coded cells bottom up; returns the polygons of the terminal surface
/// nodes (and of non-codifiable cells), counting them in `stats`.
pub(crate) fn merge(
    cells: Vec<([u32; 3], super::coding::CellSurface)>,
    depth: u32,
    pts: &[super::plane::Point],
    stats: &mut Stats,
) -> Vec<Polygon> {
    let mut out = Vec::new();
    let mut level: Vec<Node> = Vec::with_capacity(cells.len());
    for (key, surface) in cells {
        match surface {
            Ok(code) => {
                stats.cell_polygons += code.facets.len();
                level.push((key, Some(code)));
            }
            Err(loops) => {
                stats.cell_polygons += loops.len();
                stats.polygons += loops.len();
                stats.terminals[5] += 1;
                out.extend(loops.into_iter().map(Polygon::loop_of));
                level.push((key, None));
            }
        }
    }
    for l in 0..depth {
        if level.is_empty() {
            break;
        }
        let parent = |k: &[u32; 3]| [k[0] >> 1, k[1] >> 1, k[2] >> 1];
        level.sort_by_key(|(k, _)| {
            let p = parent(k);
            [p[2], p[1], p[0]]
        });
        let mut groups: Vec<([u32; 3], Vec<Option<Code>>)> = Vec::new();
        for (k, code) in level {
            match groups.last_mut() {
                Some((p, g)) if *p == parent(&k) => g.push(code),
                _ => groups.push((parent(&k), vec![code])),
            }
        }
        let merged: Vec<(Node, Vec<Code>)> = groups
            .into_par_iter()
            .map(|(key, children)| merge_children(key, children, pts))
            .collect();
        level = Vec::with_capacity(merged.len());
        for (node, terminal) in merged {
            stats.add_terminals(l as usize, &terminal);
            out.extend(terminal.into_iter().flat_map(Polygon::of_code));
            level.push(node);
        }
    }
    let top: Vec<Code> = level.into_iter().filter_map(|(_, c)| c).collect();
    stats.add_terminals(depth as usize, &top);
    out.extend(top.into_iter().flat_map(Polygon::of_code));
    out
}

/// The parent `key` of `children`: coded when every child is and their facets
/// make a codifiable node; otherwise stopped, with its coded children returned
/// as terminal nodes.
fn merge_children(
    key: [u32; 3],
    children: Vec<Option<Code>>,
    pts: &[super::plane::Point],
) -> (Node, Vec<Code>) {
    if children.iter().all(Option::is_some) {
        let pieces: Vec<&Facet> = children.iter().flatten().flat_map(|c| &c.facets).collect();
        if let Some(code) = codify(&pieces, pts) {
            return ((key, Some(code)), Vec::new());
        }
    }
    ((key, None), children.into_iter().flatten().collect())
}
