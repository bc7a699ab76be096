//! Adaptive Skeleton Climbing (Poston, Wong and Heng, *Multiresolution Isosurface
//! Extraction with Adaptive Skeleton Climbing*, Eurographics 1998): a baseline
//! that groups voxels into size-maximal simple boxes and triangulates each box's
//! isosurface from the iso lines on its faces, so smooth regions get large
//! triangles without any post-process.
//!
//! The skeleton is climbed one dimension at a time, on the same [`Hermite`]
//! samples as Marching Cubes ([`crate::mc`]):
//! 1. **Dikes** (`dikes.rs`): each line of samples in a block is a binary tree
//!    of dikes with occupancies (not crossed, crossed up, down, or more than once);
//!    its simple dike array gives the length-maximal simple dike at each sample.
//! 2. **Plots and padis** (`boxes.rs`): plots (runs of unit squares whose dikes are
//!    simple) stacked into padis (simple rectangles).
//! 3. **Size-maximal simple boxes** (`boxes.rs`): padis stacked into bricks and
//!    boxes in which every line of samples crosses the surface at most once.
//! 4. **Sharing information** (`padis.rs`): each box face is tiled by its overlaps
//!    with the faces across it, so neighbouring boxes cut a face the same way.
//! 5. **Iso lines and triangles** (`padis.rs`, `triangulate.rs`): a marching
//!    squares case per padi, segments joined into loops, loops cut into ears.
//!
//! ## The box size limit
//! The paper's single coarseness parameter is the block size `2^n`: the volume is
//! tiled by blocks of `2^n` cells per side and no box grows past its block. Block
//! 1 makes every box a cell (Marching Cubes' topology and crossings, with loops
//! triangulated by ears instead of fans). [`meshers::run`](crate::meshers::run)
//! maps the shared error threshold onto it ([`block_for_threshold`]) so that a
//! larger threshold means a coarser mesh, as for the trees: below 0.01 (and the
//! crate's negative "uniform" convention) block 1, then the block doubles with
//! every tenfold threshold: 2 at 0.01 (the command line's default), 4 at 0.1, 8
//! at 1. The threshold is no error bound here: the box size is. Measured at
//! res 64 on the sphere, block 2 / 4 / 8 give 4 / 16 / 60 times fewer triangles
//! than Marching Cubes at max errors of 0.06 / 0.24 / 0.85 cells (the example
//! `skeleton_climbing` prints this per scene). Call [`skeleton_climbing`] for any
//! block size.
//!
//! ## Where this copy chooses (the paper's text is a keyword extract)
//! - Boxes are grown greedily from the lowest uncovered cell of a block (z
//!   slowest), along x, then y, then z, each as far as the box stays aligned,
//!   simple and over uncovered cells. The paper grows candidates in every strip
//!   and slab, then deletes enclosed ones and clips overlaps; growing only from
//!   uncovered cells gives a tiling directly and keeps every box aligned.
//! - Simple means every dike inside the box is simple, on all three axes (the
//!   extract names "simple plots inside" and "simple faces"; we take the
//!   strongest reading, which makes every padi of a face simple).
//! - Ambiguous padis (alternating corners) follow Marching Cubes' face rule on the
//!   unit faces inside them; the paper subsamples the padi's center, which our
//!   sign-only samples cannot do for a padi one cell wide.
//! - Ears: the least gradient deviation wins, after avoiding new edges that lie
//!   in a box face (see `triangulate.rs`).
//! - Vertices are the Hermite crossings, found on the field, as Marching Cubes'.
//!
//! ## What it guarantees, and what not
//! - Watertight and consistently oriented where Marching Cubes is: both boxes at
//!   a face use the same padis and the same crossings (`tests/skeleton_climbing.rs`
//!   checks every built-in scene at blocks 1 to 16).
//! - Deterministic on any number of threads (blocks in parallel, results in
//!   block order).
//! - Block 1 is Marching Cubes' topology exactly (same loops, same triangle
//!   count). Coarser blocks keep it on every built-in scene but `caves`, where a
//!   simple box (each sample line crossed at most once) can still hold a tunnel
//!   or thin wall that the unit cells resolve: the Euler characteristic changes
//!   and, at block 2, two boxes draw the same edge in a face they share (a
//!   non-manifold edge). Not manifold in general, then, but manifold on every
//!   other built-in scene.
//! - Error: vertices are exact crossings, but a box's triangles span it, so the
//!   surface between them sags up to about a box's width on curved or creased
//!   surfaces (max errors grow with the block; the example measures them).

mod boxes;
mod dikes;
mod padis;
mod triangulate;

use crate::error::{Error, Result};
use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use boxes::{SimpleBox, Tiling};
use dikes::Signs;
use rayon::prelude::*;
use std::collections::HashMap;

/// The largest block size accepted.
pub const MAX_BLOCK: u32 = 64;

/// The block size [`crate::meshers::run`] uses for `threshold`: 1 (every box a
/// cell) up to a threshold of 0.001, then doubling with every tenfold threshold
/// (2 at 0.01, the command line's default; 4 at 0.1; 8 at 1), at most
/// [`MAX_BLOCK`].
pub fn block_for_threshold(threshold: f32) -> u32 {
    if threshold.is_nan() || threshold < 0.01 {
        return 1;
    }
    // The small bias keeps 0.01f32 (a hair under 1/100) in its decade.
    let decades = (threshold.log10() + 1e-4).floor() as i32 + 3;
    1 << decades.clamp(1, MAX_BLOCK.trailing_zeros() as i32)
}

/// Everything the stages share: the samples, the tiled blocks and a lookup from
/// crossing keys to [`Hermite::edges`].
pub(crate) struct Climb<'a> {
    h: &'a Hermite,
    block_log: u32,
    /// Blocks per axis.
    blocks: [u32; 3],
    /// Per block (x fastest), its index in `tilings` or `u32::MAX` when it holds
    /// no crossing and was not tiled.
    slot: Vec<u32>,
    tilings: Vec<Tiling>,
    index: HashMap<u64, u32>,
}

impl Climb<'_> {
    /// The box holding grid cell `c`, if `c` is in the grid and its block is tiled.
    fn box_at(&self, c: [i64; 3]) -> Option<SimpleBox> {
        let n = self.h.grid.cells;
        if (0..3).any(|a| c[a] < 0 || c[a] >= n[a] as i64) {
            return None;
        }
        let c = c.map(|x| x as u32);
        let b = c.map(|x| x >> self.block_log);
        let s = self.slot[(b[0] + self.blocks[0] * (b[1] + self.blocks[1] * b[2])) as usize];
        (s != u32::MAX).then(|| self.tilings[s as usize].box_at(c))
    }
}

/// Meshes `h` by Adaptive Skeleton Climbing with boxes of at most `block` cells
/// per side (a power of two from 1 to [`MAX_BLOCK`]).
///
/// Runs on the calling thread pool (wrap in [`crate::Settings::run`] to honour
/// `threads`). Triangles face the outside (value >= 0), as Marching Cubes'.
pub fn skeleton_climbing(h: &Hermite, block: u32) -> Result<IndexedMesh> {
    if !block.is_power_of_two() || block > MAX_BLOCK {
        return Err(Error::InvalidSetting {
            name: "block",
            reason: format!("a power of two from 1 to {MAX_BLOCK}, got {block}"),
        });
    }
    Ok(climb(h, block.trailing_zeros()))
}

/// [`skeleton_climbing`] with the block size [`block_for_threshold`] gives
/// `threshold` (always valid, so infallible).
pub fn at_threshold(h: &Hermite, threshold: f32) -> IndexedMesh {
    climb(h, block_for_threshold(threshold).trailing_zeros())
}

/// [`skeleton_climbing`] with blocks of `2^block_log` cells per side.
fn climb(h: &Hermite, block_log: u32) -> IndexedMesh {
    let block = 1u32 << block_log;
    let n = h.grid.cells;
    let blocks = [n.x, n.y, n.z].map(|c| c.div_ceil(block));
    let block_of = |c: [u16; 3]| {
        let b = c.map(|x| x as u32 >> block_log);
        (b[0] + blocks[0] * (b[1] + blocks[1] * b[2])) as usize
    };
    // Blocks with a crossing; the others are skipped, as the paper skips empty
    // blocks by their occupancy.
    let mut busy = vec![false; (blocks[0] * blocks[1] * blocks[2]) as usize];
    for c in &h.cells {
        busy[block_of(c.coord)] = true;
    }
    let ids: Vec<u32> = (0..busy.len() as u32)
        .filter(|&i| busy[i as usize])
        .collect();
    let tilings: Vec<Tiling> = ids
        .par_iter()
        .map(|&i| {
            let b = [
                i % blocks[0],
                (i / blocks[0]) % blocks[1],
                i / (blocks[0] * blocks[1]),
            ];
            let origin = b.map(|x| x << block_log);
            let ext = [0, 1, 2].map(|a| block.min(n[a] - origin[a]));
            Tiling::new(origin, &block_signs(h, origin, ext), block_log)
        })
        .collect();
    let mut slot = vec![u32::MAX; busy.len()];
    for (k, &i) in ids.iter().enumerate() {
        slot[i as usize] = k as u32;
    }
    let index = h
        .edges
        .iter()
        .enumerate()
        .map(|(i, x)| (x.key, i as u32))
        .collect();
    let climb = Climb {
        h,
        block_log,
        blocks,
        slot,
        tilings,
        index,
    };
    let triangles: Vec<Vec<[u64; 3]>> = climb
        .tilings
        .par_iter()
        .map(|t| {
            let mut out = Vec::new();
            let mut segs = Vec::new();
            for b in &t.boxes {
                // A simple box whose corners share a sign has that sign at every
                // sample (each dike from a corner is crossed at most once, so not
                // at all), and no surface.
                if uniform_corners(h, b) {
                    continue;
                }
                segs.clear();
                for axis in 0..3 {
                    for side in 0..2 {
                        for p in padis::face_padis(&climb, b, axis, side) {
                            padis::iso_lines(&climb, &p, side, &mut segs);
                        }
                    }
                }
                if !segs.is_empty() {
                    triangulate::triangulate_box(&climb, b, &mut segs, &mut out);
                }
            }
            out
        })
        .collect();
    output(&climb, &triangles)
}

/// Whether the eight corners of `b` share a sign.
fn uniform_corners(h: &Hermite, b: &SimpleBox) -> bool {
    let first = h.is_outside(b.lo);
    (1..8).all(|i| {
        let p = [0, 1, 2].map(|a| if i >> a & 1 == 1 { b.hi(a) } else { b.lo[a] });
        h.is_outside(p) == first
    })
}

/// The signs of the samples of the block at `origin` with `ext` cells per axis.
fn block_signs(h: &Hermite, origin: [u32; 3], ext: [u32; 3]) -> Signs {
    let mut outside = Vec::with_capacity(((ext[0] + 1) * (ext[1] + 1) * (ext[2] + 1)) as usize);
    for z in 0..=ext[2] {
        for y in 0..=ext[1] {
            for x in 0..=ext[0] {
                outside.push(h.is_outside([origin[0] + x, origin[1] + y, origin[2] + z]));
            }
        }
    }
    Signs { ext, outside }
}

/// The mesh of the triangles (edge keys), vertices numbered in order of first use.
fn output(c: &Climb, triangles: &[Vec<[u64; 3]>]) -> IndexedMesh {
    let mut mesh = IndexedMesh::default();
    let mut ids: HashMap<u64, u32> = HashMap::new();
    for tri in triangles.iter().flatten() {
        for &key in tri {
            let id = *ids.entry(key).or_insert_with(|| {
                let x = &c.h.edges[c.index[&key] as usize];
                mesh.positions.push(c.h.grid.to_world(x.point));
                mesh.normals.push(x.normal);
                mesh.positions.len() as u32 - 1
            });
            mesh.indices.push(id);
        }
    }
    mesh
}
