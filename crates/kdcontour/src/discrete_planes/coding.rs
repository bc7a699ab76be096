//! The surface of one cell in discrete planes (the paper's section 3): the
//! Discretized Marching Cubes polygons of the cell, each contour loop cut along
//! its diagonals into the fewest planar convex facets.
//!
//! The loops are the ones Marching Cubes uses ([`crate::cell::CellTables`], with
//! the same rule for ambiguous faces), so the cells' polygons meet edge to edge
//! across every face. With vertices at edge midpoints a loop of pattern 1, 2, 8
//! or 9 is one plane, pattern 5's pentagon folds once along a diagonal (two
//! planes) and the hexagons of patterns 11 and 14 fold twice (three planes). A
//! loop that needs more than three facets, which the paper's Table 1 does not
//! have but other ambiguity rules can make, leaves its cell non-codifiable.

use super::classes::{codify, Code};
use super::plane::{Facet, Point};
use crate::cell::CellTables;
use crate::hermite::{ActiveCell, Hermite};
use crate::mc::{edge_key, forward};
use std::collections::HashMap;

/// What one cell holds: its code, or (when it is not codifiable) its contour
/// loops, oriented to face outside.
pub(crate) type CellSurface = Result<Code, Vec<Vec<u32>>>;

/// The most facets one loop is cut into (a DoubleEdge).
const MAX_FACETS_PER_LOOP: usize = 3;

/// The vertex of every edge crossing, in [`Hermite::edges`] order, at its edge's
/// midpoint in half-cell units; and the map from edge key to vertex id.
pub(crate) fn midpoints(h: &Hermite) -> (Vec<Point>, HashMap<u64, u32>) {
    let c = h.grid.corners();
    let (cx, cy) = (c.x as u64, c.y as u64);
    let mut index = HashMap::with_capacity(h.edges.len());
    let pts = h
        .edges
        .iter()
        .enumerate()
        .map(|(i, x)| {
            index.insert(x.key, i as u32);
            let (corner, axis) = (x.key / 3, (x.key % 3) as usize);
            let g = [corner % cx, (corner / cx) % cy, corner / (cx * cy)];
            let mut p = g.map(|v| 2 * v as i64);
            p[axis] += 1;
            p
        })
        .collect();
    (pts, index)
}

/// The oriented contour loops of `cell` as vertex ids.
fn loops(h: &Hermite, cell: &ActiveCell, index: &HashMap<u64, u32>) -> Vec<Vec<u32>> {
    let l = &CellTables::get().loops[cell.config as usize * 64 + cell.mask as usize];
    (0..l.count as usize)
        .map(|k| {
            let edges = l.edges_of(k);
            let mut ids: Vec<u32> = edges
                .iter()
                .map(|&e| index[&edge_key(&h.grid, cell.coord, e)])
                .collect();
            if !forward(cell.config, edges) {
                ids.reverse();
            }
            ids
        })
        .collect()
}

/// Codes the surface of `cell` (its terminal surface node at the finest level).
pub(crate) fn code_cell(
    h: &Hermite,
    cell: &ActiveCell,
    index: &HashMap<u64, u32>,
    pts: &[Point],
) -> CellSurface {
    let rings = loops(h, cell, index);
    let mut facets = Vec::new();
    for ring in &rings {
        match (1..=MAX_FACETS_PER_LOOP).find_map(|k| split(ring, pts, k)) {
            Some(f) => facets.extend(f),
            None => return Err(rings),
        }
    }
    codify(facets, pts).ok_or(rings)
}

/// `ring` cut along diagonals into exactly `pieces` planar convex facets.
///
/// Two diagonals that do not cross cut a ring into three pieces, one of which
/// is cut off by one diagonal alone; so trying every diagonal with one side a
/// single facet finds every cut.
pub(crate) fn split(ring: &[u32], pts: &[Point], pieces: usize) -> Option<Vec<Facet>> {
    if pieces <= 1 {
        return Facet::new(ring.to_vec(), pts).map(|f| vec![f]);
    }
    let m = ring.len();
    for i in 0..m {
        for j in i + 2..m {
            if i == 0 && j == m - 1 {
                continue; // a side, not a diagonal
            }
            let a: Vec<u32> = ring[i..=j].to_vec();
            let b: Vec<u32> = ring[j..].iter().chain(&ring[..=i]).copied().collect();
            for (one, rest) in [(&a, &b), (&b, &a)] {
                if let Some(f) = Facet::new(one.clone(), pts) {
                    if let Some(mut r) = split(rest, pts, pieces - 1) {
                        r.push(f);
                        return Some(r);
                    }
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_five_splits_into_two_facets() {
        let pentagon = vec![[2, 1, 0], [1, 2, 0], [0, 2, 1], [0, 0, 1], [2, 0, 1]];
        let ring = [0, 1, 2, 3, 4];
        assert!(split(&ring, &pentagon, 1).is_none());
        let two = split(&ring, &pentagon, 2).expect("one fold");
        assert_eq!(two.len(), 2);
        assert_ne!(two[0].plane, two[1].plane);
    }
}
