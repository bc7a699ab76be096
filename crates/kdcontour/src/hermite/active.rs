//! The build's first step: the active cells (a sign change among their corners)
//! with their face resolution masks and patch numbering, and a dense lookup from
//! a cell to its active index.

use super::ActiveCell;
use crate::cell::{opposite_face, CellTables};
use crate::grid::Grid;
use glam::UVec3;
use rayon::prelude::*;

/// The active cells of `values` on `grid`, ordered by linear index (x fastest),
/// each with its first patch; and the number of patches.
pub(super) fn active_cells(
    grid: &Grid,
    values: &[f32],
    tables: &CellTables,
) -> (Vec<ActiveCell>, u32) {
    let n = grid.cells;
    let corners = grid.corners();
    let cidx = |x: u32, y: u32, z: u32| grid.corner_index(x, y, z);
    let config_at = |x: u32, y: u32, z: u32| -> u8 {
        let mut cfg = 0u8;
        for i in 0..8u32 {
            let v = values[cidx(x + (i & 1), y + ((i >> 1) & 1), z + ((i >> 2) & 1))];
            if v >= 0.0 {
                cfg |= 1 << i;
            }
        }
        cfg
    };

    // Active cells, z slab by z slab.
    let slabs: Vec<Vec<ActiveCell>> = (0..n.z)
        .into_par_iter()
        .map(|z| {
            let mut out = Vec::new();
            let cx = corners.x as usize;
            let mut signs = vec![0u8; cx];
            let mut row_cfg = vec![0u8; cx];
            for y in 0..n.y {
                // Sign bits of the four corner rows around this row of cells,
                // combined column by column (vectorises; no index arithmetic).
                row_cfg.fill(0);
                for (k, (dy, dz)) in [(0u32, 0u32), (1, 0), (0, 1), (1, 1)]
                    .into_iter()
                    .enumerate()
                {
                    let start = cidx(0, y + dy, z + dz);
                    let row = &values[start..start + cx];
                    for (s, v) in signs.iter_mut().zip(row) {
                        *s = (*v >= 0.0) as u8;
                    }
                    // Corner bit: x offset 0 -> bit 2k', x offset 1 -> bit 2k'+1,
                    // with k' = dy + 2 dz = k.
                    for x in 0..cx - 1 {
                        row_cfg[x] |= (signs[x] | (signs[x + 1] << 1)) << (2 * k);
                    }
                }
                for x in 0..n.x {
                    let cfg = row_cfg[x as usize];
                    if cfg == 0 || cfg == 255 {
                        continue;
                    }
                    let mut mask = 0u8;
                    let joined = tables.skeleton_joined[cfg as usize];
                    for f in 0..6usize {
                        if joined & (1 << f) == 0 {
                            continue;
                        }
                        let a = f / 2;
                        let mut nc = [x as i64, y as i64, z as i64];
                        nc[a] += if f % 2 == 1 { 1 } else { -1 };
                        if nc[a] < 0 || nc[a] >= n[a] as i64 {
                            continue;
                        }
                        let ncfg = config_at(nc[0] as u32, nc[1] as u32, nc[2] as u32);
                        if tables.skeleton_joined[ncfg as usize] & (1 << opposite_face(f)) != 0 {
                            mask |= 1 << f;
                        }
                    }
                    out.push(ActiveCell {
                        coord: [x as u16, y as u16, z as u16],
                        config: cfg,
                        mask,
                        patch_base: 0,
                    });
                }
            }
            out
        })
        .collect();
    let mut cells: Vec<ActiveCell> = Vec::with_capacity(slabs.iter().map(Vec::len).sum());
    for l in slabs {
        cells.extend(l);
    }
    let mut patches = 0u32;
    for c in cells.iter_mut() {
        c.patch_base = patches;
        patches += tables.cell(c.config, c.mask).count as u32;
    }

    (cells, patches)
}

/// A cell's active index by its coordinates (`u32::MAX`: not active); dropped
/// after the build (uniform Dual Marching Cubes makes its own).
pub(crate) struct CellLookup {
    lookup: Vec<u32>,
    n: UVec3,
}

impl CellLookup {
    /// The lookup of `cells` on a grid of `n` cells.
    pub(crate) fn new(cells: &[ActiveCell], n: UVec3) -> Self {
        let count = n.x as usize * n.y as usize * n.z as usize;
        let mut lookup: Vec<u32> = Vec::with_capacity(count);
        lookup.par_extend(rayon::iter::repeat_n(u32::MAX, count));
        let mut me = CellLookup { lookup, n };
        for (i, c) in cells.iter().enumerate() {
            let at = me.lin([c.coord[0] as u32, c.coord[1] as u32, c.coord[2] as u32]);
            me.lookup[at] = i as u32;
        }
        me
    }

    fn lin(&self, c: [u32; 3]) -> usize {
        c[0] as usize + self.n.x as usize * (c[1] as usize + self.n.y as usize * c[2] as usize)
    }

    /// The active index of cell `c`, or `u32::MAX`.
    pub(crate) fn get(&self, c: [u32; 3]) -> u32 {
        self.lookup[self.lin(c)]
    }
}
