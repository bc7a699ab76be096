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
use super::plane::{dot, Facet, Plane, Point};
use crate::cell::{corner_offset, edge_corners, CellTables};
use crate::hermite::{ActiveCell, Hermite};
use crate::mc::{edge_key, forward};
use std::collections::HashMap;
use std::sync::OnceLock;

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

/// The contour loops of a cell configuration under a face resolution, as rings
/// of cell edge numbers oriented to face outside.
fn unit_loops(config: u8, mask: u8) -> Vec<Vec<u32>> {
    let l = &CellTables::get().loops[config as usize * 64 + mask as usize];
    (0..l.count as usize)
        .map(|k| {
            let edges = l.edges_of(k);
            let mut ring: Vec<u32> = edges.iter().map(|&e| e as u32).collect();
            if !forward(config, edges) {
                ring.reverse();
            }
            ring
        })
        .collect()
}

/// The 12 edge midpoints of the cell at the origin, in half-cell units.
fn unit_midpoints() -> Vec<Point> {
    (0..12)
        .map(|e| {
            let (lo, hi) = edge_corners(e);
            let (a, b) = (corner_offset(lo), corner_offset(hi));
            [0, 1, 2].map(|k| (a[k] + b[k]) as i64)
        })
        .collect()
}

/// The code of a configuration on the cell at the origin (rings of edge
/// numbers), or `None` when it is not codifiable.
fn unit_code(config: u8, mask: u8, pts: &[Point]) -> Option<Code> {
    let mut facets = Vec::new();
    for ring in unit_loops(config, mask) {
        facets.extend((1..=MAX_FACETS_PER_LOOP).find_map(|k| split(&ring, pts, k))?);
    }
    codify(&facets.iter().collect::<Vec<_>>(), pts)
}

/// The paper's look-up table: the code of every configuration under every
/// resolution of its ambiguous faces, on the cell at the origin, built once.
fn table() -> &'static [Option<Code>] {
    static TABLE: OnceLock<Vec<Option<Code>>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let ambiguous = &CellTables::get().ambiguous;
        let pts = unit_midpoints();
        (0..256 * 64)
            .map(|i| {
                let (config, mask) = ((i / 64) as u8, (i % 64) as u8);
                let valid = mask & !ambiguous[config as usize] == 0;
                valid.then(|| unit_code(config, mask, &pts)).flatten()
            })
            .collect()
    })
}

/// Codes the surface of `cell` (its terminal surface node at the finest level):
/// the table's code moved to the cell, its planes' `d` shifted by `V . offset`.
pub(crate) fn code_cell(h: &Hermite, cell: &ActiveCell, index: &HashMap<u64, u32>) -> CellSurface {
    let id = |e: u32| index[&edge_key(&h.grid, cell.coord, e as u8)];
    let slot = cell.config as usize * 64 + cell.mask as usize;
    let Some(code) = &table()[slot] else {
        return Err(unit_loops(cell.config, cell.mask)
            .into_iter()
            .map(|r| r.into_iter().map(id).collect())
            .collect());
    };
    let offset = cell.coord.map(|c| 2 * c as i64);
    let facets = code
        .facets
        .iter()
        .map(|f| Facet {
            plane: Plane {
                normal: f.plane.normal,
                d: f.plane.d + dot(f.plane.normal, offset),
            },
            ring: f.ring.iter().map(|&e| id(e)).collect(),
        })
        .collect();
    Ok(Code {
        class: code.class,
        facets,
    })
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

#[cfg(test)]
mod table {
    use super::*;

    /// Codes every configuration under the face resolutions `which` picks;
    /// returns (configurations, codifiable ones, class counts).
    fn survey(which: impl Fn(u8, u8) -> bool) -> (usize, usize, HashMap<&'static str, usize>) {
        let ambiguous = &CellTables::get().ambiguous;
        let (mut all, mut ok) = (0, 0);
        let mut classes = HashMap::new();
        for config in 1..255u8 {
            let amb = ambiguous[config as usize];
            for mask in (0..64u8).filter(|&m| m & !amb == 0 && which(m, amb)) {
                all += 1;
                if let Some(c) = &table()[config as usize * 64 + mask as usize] {
                    ok += 1;
                    *classes.entry(c.class.symbol()).or_insert(0) += 1;
                }
            }
        }
        (all, ok, classes)
    }

    #[test]
    fn every_marching_cubes_pattern_is_one_of_the_five_classes() {
        // The paper's Table 1: the 15 patterns of the original Marching Cubes,
        // which resolves every ambiguous face the same way, are all codifiable.
        // Both uniform resolutions (all faces separated, all joined) are.
        for (name, rule) in [
            ("separated", (|m: u8, _a: u8| m == 0) as fn(u8, u8) -> bool),
            ("joined", |m, a| m == a),
        ] {
            let (all, ok, classes) = survey(rule);
            assert_eq!((all, ok), (254, 254), "{name}: {classes:?}");
            // Patterns 1, 2, 8, 9 and their rotations and complements are Faces.
            assert_eq!(classes["F"], 54, "{name}");
            for k in ["E", "DE", "B2", "B3", "B4", "B*"] {
                assert!(classes[k] > 0, "{name}: no {k}");
            }
        }
        // Mixed resolutions (what the face rule picks next to other cells) can
        // make loops of seven or more edges, which may not be: those cells are
        // kept as Marching Cubes polygons.
        let (all, ok, _) = survey(|_, _| true);
        assert!(ok < all);
    }
}
