//! 2-D and 3-D: plots, padis and size-maximal simple boxes.
//!
//! A *strip* is a row of unit squares between two neighbouring lines of a farm; a
//! *plot* is an aligned run of `2^k` of its squares, simple when the two dikes
//! along it are (the paper's max over the two simple dike arrays, a min over our
//! levels). A *padi* stacks plots of one extent over aligned strips; a *brick*
//! stacks matching padis of two neighbouring farms; a *box* stacks bricks over
//! aligned slabs. A box is *simple* when every dike in it, along all three axes,
//! is simple: each line of samples through it crosses the isosurface at most once.
//!
//! Growing a box from its lowest corner cell follows the paper's order: the
//! length-maximal simple plot along x, stacked along y into the largest padi
//! (then cut down to an aligned height, the binary edge constraint), stacked
//! along z into the largest box (cut the same way).

use super::dikes::{Dikes, Signs};

/// A box of cells: lowest cell `lo` (grid coords) and `2^size_log` cells per axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SimpleBox {
    /// Its lowest cell, in grid cell coordinates.
    pub lo: [u32; 3],
    /// Log2 of its size along each axis.
    pub size_log: [u8; 3],
}

impl SimpleBox {
    /// Cells along `axis`.
    #[inline]
    pub fn size(&self, axis: usize) -> u32 {
        1 << self.size_log[axis]
    }

    /// One past its highest cell along `axis`.
    #[inline]
    pub fn hi(&self, axis: usize) -> u32 {
        self.lo[axis] + self.size(axis)
    }
}

/// The size-maximal simple boxes tiling one block.
pub(super) struct Tiling {
    /// The block's lowest cell (grid coords).
    pub origin: [u32; 3],
    /// Cells per axis of the block.
    pub ext: [u32; 3],
    /// The boxes, in the order they were grown (lowest uncovered cell first, z
    /// slowest).
    pub boxes: Vec<SimpleBox>,
    /// For every cell of the block (x fastest), the index of its box.
    owner: Vec<u32>,
}

const UNCOVERED: u32 = u32::MAX;

impl Tiling {
    /// Tiles the block at `origin` whose samples are `signs` with size-maximal
    /// simple boxes of at most `2^block_log` cells per side.
    pub fn new(origin: [u32; 3], signs: &Signs, block_log: u32) -> Self {
        let ext = signs.ext;
        let dikes = Dikes::new(signs, block_log);
        let mut t = Tiling {
            origin,
            ext,
            boxes: Vec::new(),
            owner: vec![UNCOVERED; (ext[0] * ext[1] * ext[2]) as usize],
        };
        for z in 0..ext[2] {
            for y in 0..ext[1] {
                for x in 0..ext[0] {
                    if t.owner[t.cell_index([x, y, z])] != UNCOVERED {
                        continue;
                    }
                    let mut size = [0u8; 3];
                    // x: the length-maximal simple plot; y: stacked into a padi;
                    // z: padis (bricks) stacked into a box.
                    for axis in 0..3 {
                        loop {
                            let mut bigger = size;
                            bigger[axis] += 1;
                            if !t.fits([x, y, z], bigger, &dikes) {
                                break;
                            }
                            size = bigger;
                        }
                    }
                    t.cover([x, y, z], size);
                }
            }
        }
        t
    }

    /// Index of local cell `c` in [`Tiling::owner`].
    #[inline]
    fn cell_index(&self, c: [u32; 3]) -> usize {
        (c[0] + self.ext[0] * (c[1] + self.ext[1] * c[2])) as usize
    }

    /// Whether the box at local cell `lo` with `size` (log2) is aligned, inside the
    /// block, simple, and over uncovered cells only.
    fn fits(&self, lo: [u32; 3], size: [u8; 3], dikes: &Dikes) -> bool {
        let len = size.map(|s| 1u32 << s);
        for a in 0..3 {
            if !lo[a].is_multiple_of(len[a]) || lo[a] + len[a] > self.ext[a] {
                return false;
            }
        }
        // Every dike along each axis, on every line through the box's samples.
        for a in 0..3 {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for pv in lo[v]..=lo[v] + len[v] {
                for pu in lo[u]..=lo[u] + len[u] {
                    let mut p = [0; 3];
                    p[a] = lo[a];
                    p[u] = pu;
                    p[v] = pv;
                    if dikes.level(a, p) < size[a] {
                        return false;
                    }
                }
            }
        }
        for z in lo[2]..lo[2] + len[2] {
            for y in lo[1]..lo[1] + len[1] {
                for x in lo[0]..lo[0] + len[0] {
                    if self.owner[self.cell_index([x, y, z])] != UNCOVERED {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Adds the box at local cell `lo` with `size` (log2) and marks its cells.
    fn cover(&mut self, lo: [u32; 3], size: [u8; 3]) {
        let id = self.boxes.len() as u32;
        let len = size.map(|s| 1u32 << s);
        for z in lo[2]..lo[2] + len[2] {
            for y in lo[1]..lo[1] + len[1] {
                for x in lo[0]..lo[0] + len[0] {
                    let i = self.cell_index([x, y, z]);
                    self.owner[i] = id;
                }
            }
        }
        self.boxes.push(SimpleBox {
            lo: [0, 1, 2].map(|a| self.origin[a] + lo[a]),
            size_log: size,
        });
    }

    /// The box holding grid cell `c`, which must lie in this block.
    #[inline]
    pub fn box_at(&self, c: [u32; 3]) -> SimpleBox {
        let local = [0, 1, 2].map(|a| c[a] - self.origin[a]);
        self.boxes[self.owner[self.cell_index(local)] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiling(ext: [u32; 3], outside: impl Fn([u32; 3]) -> bool) -> Tiling {
        let mut s = Vec::new();
        for z in 0..=ext[2] {
            for y in 0..=ext[1] {
                for x in 0..=ext[0] {
                    s.push(outside([x, y, z]));
                }
            }
        }
        let signs = Signs { ext, outside: s };
        Tiling::new([0; 3], &signs, 3)
    }

    #[test]
    fn a_block_with_one_sign_is_one_box() {
        let t = tiling([8; 3], |_| true);
        assert_eq!(t.boxes.len(), 1);
        assert_eq!(t.boxes[0].size_log, [3, 3, 3]);
    }

    #[test]
    fn a_plane_is_crossed_once_by_every_line_so_one_box_holds_it() {
        let t = tiling([8; 3], |p| p[0] + p[1] + p[2] >= 11);
        assert_eq!(t.boxes.len(), 1);
    }

    #[test]
    fn boxes_tile_the_block_and_every_box_is_simple() {
        // A sphere of radius 3 around (4, 4, 4): lines through it cross twice.
        let inside = |p: [u32; 3]| {
            let d = p.map(|c| c as f32 - 4.0);
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 9.0
        };
        let t = tiling([8; 3], |p| !inside(p));
        let volume: u32 = t
            .boxes
            .iter()
            .map(|b| b.size(0) * b.size(1) * b.size(2))
            .sum();
        assert_eq!(volume, 512, "the boxes cover each cell once");
        assert!(t.boxes.len() > 1 && t.boxes.len() < 512);
        for b in &t.boxes {
            // Along each axis each line of samples changes sign at most once.
            for a in 0..3 {
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                for pv in b.lo[v]..=b.hi(v) {
                    for pu in b.lo[u]..=b.hi(u) {
                        let mut changes = 0;
                        for i in b.lo[a]..b.hi(a) {
                            let (mut p, mut q) = ([0; 3], [0; 3]);
                            (p[a], p[u], p[v]) = (i, pu, pv);
                            (q[a], q[u], q[v]) = (i + 1, pu, pv);
                            changes += (inside(p) != inside(q)) as u32;
                        }
                        assert!(changes <= 1, "{b:?} is not simple");
                    }
                }
            }
        }
    }
}
