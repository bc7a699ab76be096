//! Cell vertices (issue 13): where each patch of an active cell puts its vertex.
//!
//! Dual contouring puts a cell's vertex at its QEF's minimiser (section 4), held
//! in the cell. Where the surface bends within a cell or two sheets pass through
//! it (thin plates, a crease between three surfaces), the minimisers of the
//! cells around an edge can sit so that the edge's dual quad folds: as the mesh
//! splits it, a triangle does not face the way the edge crosses the surface, has
//! zero area, or is flipped against the field ([`Facing::polygon`]), and the mesh
//! has a flipped, zero-area or self-crossing face. The clustering's fold guard
//! (`kdtree::fold`) keeps merged leaves from folding; this keeps the cells from
//! it.
//!
//! Across a chunk's face toward a coarser chunk the seam joins the chunk's cells
//! to the coarse cells there, not to its halo's: a quad of a fine edge on such a
//! face takes the coarse corners the seam will take (`kdtree::coarser`), which
//! do not move (a coarse corner in two quadrants makes the quad a triangle, as
//! the seam meshes it). On the `defects` example's level worlds this took the
//! flipped faces on faces between levels from 967 to 800 and zero-area ones
//! from 12 to 0.
//!
//! Every patch starts at its minimiser. A minimiser held on a corner of its
//! cell (the unclamped one is outside the cell on all three axes) sits where
//! two surfaces meet at a sharp angle (the gyroid's shell cut by its sphere,
//! caves' walls against their box), its neighbours' minimisers held onto the
//! same faces, and the quads around it fold whichever way it steps from
//! there; so a first round moves every such patch to its mass point, folding
//! or not, and takes the move back (the patch then steps as any other) where
//! it makes more triangles cross among the quads around it. On the `defects`
//! example (summed over the five thresholds) the one-grid meshes of every
//! scene at 32 and 64 went from 943 flipped, 479 crossing and 20 overlapping
//! faces to 728, 275 and 0 (caves at 64: 358 flipped to 222), at 128 from 342
//! / 48 / 6 to 222 / 4 / 6 (the gyroid 240 flipped to 135, csg_mix 40 to 25),
//! the analytic and CSG scenes at 40, 48, 56 and 96 from 102 flipped and no
//! crossing face to 77 and 45 (csg_mix at 96: 45 flipped to 20, and 45
//! crossing where it had none, where its capsule passes under its box), and
//! the level worlds from 2,284 flipped and 925 crossing to 1,826 and 557;
//! triangle counts moved by less than 0.4% on every row. Moving them without
//! taking any move back gave fewer flipped and more crossing faces (667 and
//! 383 at 32 and 64, 197 and 34 at 128); moving only patches of quads that
//! fold, or only mass points nearer the surface than the corner, kept the
//! flips or traded them for crossing faces.
//!
//! A minimiser held on an edge of its cell (outside it on two axes) joins that
//! round where it does not fit its crossings' planes there ([`EDGE_MISFIT`]),
//! away from the grid's sides ([`EDGE_MARGIN`]); and the round also takes back
//! a move that leaves more quads around its patch folding. That took the
//! one-grid meshes at 32 and 64 to 663 flipped and 8 crossing faces, at 128 to
//! 197 and 4 (`csg_mix` 25 flipped to 0), `csg_mix` at 96 to none at all, and
//! the level worlds to 1,784 and 223. Without the fit test the box's edge
//! vertices, on creases that pass just outside their cells, moved too: its
//! meshes at threshold 1 grew by up to 15%. Without the margin the level
//! worlds of the analytic and CSG scenes gained flipped seam faces (155 to
//! 213): a chunk places its halo's vertices, and the seam joins its
//! neighbour's.
//!
//! Each crossing edge with four cells around
//! it tests its quad ([`quad_faces`]). The patches of a quad that folds step
//! half of the way from their minimiser toward their mass point (the mean of
//! their crossings, which lies on the surface's side of the cell), and the test
//! repeats on the moved vertices, up to [`MAX_ROUNDS`] rounds. A step is taken
//! back, and its patch moves no more, when it makes more triangles cross among
//! the quads of the cells around it (each quad split as the mesh will split it,
//! by the vertices and normals the tree stores): where the minimisers of
//! neighbouring cells were clamped onto a shared face, a move that unfolds one
//! quad can push it through another. Sharp features are kept everywhere the
//! quads around them do not fold.
//!
//! On the built-in scenes (`cargo run --release -p kdcontour --example
//! defects`, summed over five thresholds) the first version of this (quads held
//! to the crossing's normal, not the field at their centroids) took flipped faces
//! at res 32 and 64 from 3,717 to 1,840 and crossing faces from 1,379 to 827.
//! Held to the field with [`Facing`], flipped faces there went from 1,840 to 990
//! (none left on the analytic and CSG scenes), crossing ones from 827 to 612,
//! overlapping ones from 40 to 32 and zero-area ones from 10 to 0. Steps of
//! half the way instead of a quarter took flipped faces from 992 to 940 and
//! crossing ones from 612 to 489, in half the rounds. Counting crossings on
//! the diagonal the mesh takes instead of both took crossing faces from 489 to
//! 473 and overlapping ones from 40 to 20 (flipped 940 to 945), and the loop's
//! time on the demo's coarse chunks by 30-45%. What is left at other resolutions is where two
//! surfaces pass within a fraction of a cell (csg_mix's capsule under its box,
//! the gyroid's shell cut by its sphere) and the neighbours' vertices were
//! clamped onto a shared face: no step toward the mass points unfolds them.

use super::ActiveCell;
use crate::cell::CellTables;
use crate::comp::Comp;
use crate::facing::Facing;
use crate::geometry::tritri::{
    apart_from_shared_corner, contact_with_normals, unit_normal, Contact, Tolerance,
};
use crate::qef::Qef;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Cells from the grid's sides within which a patch held on an edge of its
/// cell stays out of the first round: a chunk's halo and the cells beside it
/// are placed by its neighbour too, and the seam joins the neighbour's
/// placement to this one's (see the module docs).
const EDGE_MARGIN: u32 = 2;
/// The mean squared distance (cells²) from a patch held on an edge of its cell
/// to its crossings' planes above which it joins the first round (0.1 cells
/// RMS): a crease passing just outside the cell fits its planes there and
/// keeps its vertex.
const EDGE_MISFIT: f64 = 0.01;
/// The most rounds of stepping vertices toward their mass points.
const MAX_ROUNDS: usize = 8;
/// Steps from a patch's minimiser to its mass point.
const STEPS: u8 = 2;
/// The step of a patch that stays where it is.
const FROZEN: u8 = u8::MAX;

/// The dual quad of one crossing edge with four cells around it: their patches
/// in the contouring's order (counter-clockwise about the edge's axis), and the
/// axis pointing from the inside corner to the outside one.
#[derive(Clone, Copy)]
pub(super) struct DualQuad {
    pub patches: [u32; 4],
    pub facing: Vec3,
    /// The field's unit normal where the surface crosses the edge.
    pub normal: Vec3,
}

/// Each patch's vertex (grid units; tested where [`Comp::pack`] will round it):
/// its QEF's minimiser in its cell, moved toward its mass point where the
/// minimiser folds a quad of `quads` (see the module docs); and each vertex
/// with its normal as the tree stores them (packed in the patch's cell).
///
/// `fixed` are corners that do not move (a coarser chunk's cells across a
/// face between levels: their vertex and unit normal, as that chunk stores
/// them); a quad's patch `qef.len() + i` is `fixed[i]`. Each counts as a cell
/// of its own.
pub(super) fn cell_vertices(
    cells: &[ActiveCell],
    qef: &[Qef],
    normal: &[Vec3],
    quads: &[DualQuad],
    facing: &Facing,
    fixed: &[(Vec3, Vec3)],
    grid_cells: glam::UVec3,
) -> (Vec<Vec3>, Vec<Comp>) {
    let tables = CellTables::get();
    let own = qef.len();
    // Each patch's cell (a fixed corner's is past the cells).
    let mut cell_of = vec![0u32; own + fixed.len()];
    for (i, c) in cells.iter().enumerate() {
        let count = tables.cell(c.config, c.mask).count as usize;
        let base = c.patch_base as usize;
        cell_of[base..base + count].fill(i as u32);
    }
    for (i, c) in cell_of[own..].iter_mut().enumerate() {
        *c = (cells.len() + i) as u32;
    }
    let lo = |p: usize| Vec3::from_array(cells[cell_of[p] as usize].coord.map(|v| v as f32));
    // How the tree will store a vertex: the quads are tested as they will be
    // meshed.
    let pack = |v: Vec3, p: usize| Comp::pack(v, normal[p], lo(p), lo(p) + Vec3::ONE, 0);
    let at = |c: &Comp, p: usize| c.position(lo(p), lo(p) + Vec3::ONE);
    let mut vertex: Vec<Vec3> = (0..own)
        .into_par_iter()
        .map(|p| qef[p].solve(lo(p), lo(p) + Vec3::ONE).0)
        .collect();
    let mut packed: Vec<Comp> = vertex
        .par_iter()
        .enumerate()
        .map(|(p, &v)| pack(v, p))
        .collect();
    let mut rounded: Vec<Vec3> = packed
        .par_iter()
        .enumerate()
        .map(|(p, c)| at(c, p))
        .collect();
    vertex.extend(fixed.iter().map(|f| f.0));
    rounded.extend(fixed.iter().map(|f| f.0));
    // Each patch's normal as the tree stores it (the mesh splits quads by it;
    // a packed normal does not depend on the vertex or its box).
    let mut unit: Vec<Vec3> = packed.par_iter().map(Comp::normal).collect();
    unit.extend(fixed.iter().map(|f| f.1));
    // How far each patch has moved from its minimiser toward its mass point, in
    // steps of 1 / STEPS; a patch whose step would make a crossing stays put
    // and moves no more (FROZEN), as do the fixed corners.
    let mut step = vec![0u8; own];
    step.resize(own + fixed.len(), FROZEN);
    let minimiser = vertex.clone();
    let mut around: Option<Around> = None;
    // Per quad, its place in a round's placed triangles (`u32::MAX`: none).
    let mut slot = vec![u32::MAX; quads.len()];
    // Per quad, its place among a round's quads around moving patches
    // (`u32::MAX`: none), and a scratch mark for gathering the quads near them.
    let mut side_of = vec![u32::MAX; quads.len()];
    let mut mark = vec![u32::MAX; quads.len()];
    // The quads a round tests: every quad at first, then the quads around the
    // patches that stepped. A quad none of whose patches stepped has the
    // vertices it had when it was last tested: it faces as it did then, or it
    // folded and none of its patches can move (each froze, or took its last
    // step), so it moves nothing.
    let mut dirty: Option<Vec<u32>> = None;
    // The patches held on a corner of their cell, and those held on an edge
    // of it that do not fit their planes there, away from the grid's sides: a
    // first round moves them to their mass points (see the module docs).
    let mut held_round: Vec<u32> = (0..own as u32)
        .filter(|&p| {
            let (v, l) = (vertex[p as usize], lo(p as usize));
            let held = (0..3)
                .filter(|&k| v[k] == l[k] || v[k] == l[k] + 1.0)
                .count();
            held == 3
                || (held == 2 && {
                    let c = cells[cell_of[p as usize] as usize].coord;
                    let deep = (0..3).all(|k| {
                        let c = c[k] as u32;
                        c >= EDGE_MARGIN && c + EDGE_MARGIN < grid_cells[k]
                    });
                    let q = &qef[p as usize];
                    deep && q.error_at(v.as_dvec3()) > EDGE_MISFIT * q.count
                })
        })
        .collect();
    let first_round = !held_round.is_empty();
    for round in 0..MAX_ROUNDS + first_round as usize {
        // The first round: each held patch takes its last step at once; one
        // taken back starts over (it may still step as others do).
        let zero = first_round && round == 0;
        if zero {
            for &p in &held_round {
                step[p as usize] = STEPS - 1;
            }
        }
        let folds = |q: &DualQuad| !quad_faces(q, &rounded, &unit, facing);
        let mut moving: Vec<u32> = if zero {
            std::mem::take(&mut held_round)
        } else {
            match &dirty {
                None => quads
                    .par_iter()
                    .filter(|q| folds(q))
                    .flat_map_iter(|q| q.patches)
                    .filter(|&p| step[p as usize] < STEPS)
                    .collect(),
                Some(dirty) => dirty
                    .par_iter()
                    .map(|&q| &quads[q as usize])
                    .filter(|q| folds(q))
                    .flat_map_iter(|q| q.patches)
                    .filter(|&p| step[p as usize] < STEPS)
                    .collect(),
            }
        };
        if moving.is_empty() {
            break;
        }
        moving.sort_unstable();
        moving.dedup();
        let prev = rounded.clone();
        let place = |p: usize, k: u8| {
            minimiser[p].lerp(qef[p].mass_point().as_vec3(), k as f32 / STEPS as f32)
        };
        let before: Vec<Comp> = moving.iter().map(|&p| packed[p as usize]).collect();
        for &p in &moving {
            let p = p as usize;
            step[p] += 1;
            packed[p] = pack(place(p, step[p]), p);
            rounded[p] = at(&packed[p], p);
        }
        let around = around.get_or_insert_with(|| Around::new(quads, &cell_of, cells, own));
        // The quads around the moving patches, each with the quads that share
        // a cell with it (only those can cross it: a quad lies in its four
        // cells), and every quad a count reads placed once.
        let mut sides: Vec<u32> = moving.iter().flat_map(|&p| around.of(p)).copied().collect();
        sides.sort_unstable();
        sides.dedup();
        let near = around.near(&sides, quads, &mut mark);
        for (i, &q) in sides.iter().enumerate() {
            side_of[q as usize] = i as u32;
        }
        // Per quad around a moving patch, how many pairs of its triangles and
        // those of the quads near it cross, with the patches at `vertex`;
        // each patch's count is the sum of its quads'.
        let counts = |which: &[bool], vertex: &[Vec3], slot: &mut [u32]| {
            // Each quad once, in the order first met (a quad's slot marks it).
            let mut used: Vec<u32> = Vec::new();
            for i in (0..sides.len()).filter(|&i| which[i]) {
                for &q in near.of(i) {
                    if slot[q as usize] == u32::MAX {
                        slot[q as usize] = used.len() as u32;
                        used.push(q);
                    }
                }
            }
            let placed: Vec<PlacedQuad> = used
                .par_iter()
                .map(|&q| place_quad(&quads[q as usize], vertex, &unit, facing))
                .collect();
            let n = near.pair_counts(&sides, which, &side_of, |q, r| {
                pair_crossings(&placed, slot, q, r)
            });
            for &q in &used {
                slot[q as usize] = u32::MAX;
            }
            n
        };
        let patch_count = |p: u32, n: &[usize]| -> usize {
            around
                .of(p)
                .iter()
                .map(|&q| n[side_of[q as usize] as usize])
                .sum()
        };

        // Crossings after the step, and before it for the patches with any
        // after it.
        let after = counts(&vec![true; sides.len()], &rounded, &mut slot);
        let after_n: Vec<usize> = moving.iter().map(|&p| patch_count(p, &after)).collect();
        let mut crossing = vec![false; moving.len()];
        if after_n.iter().any(|&n| n > 0) {
            let mut which = vec![false; sides.len()];
            for (&p, _) in moving.iter().zip(&after_n).filter(|(_, &n)| n > 0) {
                for &q in around.of(p) {
                    which[side_of[q as usize] as usize] = true;
                }
            }
            let before = counts(&which, &prev, &mut slot);
            for (i, &p) in moving.iter().enumerate() {
                crossing[i] = after_n[i] > 0 && after_n[i] > patch_count(p, &before);
            }
        }
        if zero {
            // The first round also takes back a move that leaves more quads
            // around its patch folding than before it.
            let folding = |p: u32, vertex: &[Vec3]| {
                around
                    .of(p)
                    .iter()
                    .filter(|&&q| !quad_faces(&quads[q as usize], vertex, &unit, facing))
                    .count()
            };
            for (i, &p) in moving.iter().enumerate() {
                if !crossing[i] && folding(p, &rounded) > folding(p, &prev) {
                    crossing[i] = true;
                }
            }
        }
        let mut stepped: Vec<u32> = Vec::with_capacity(moving.len());
        for ((&p, cross), old) in moving.iter().zip(crossing).zip(before) {
            if cross {
                step[p as usize] = if zero { 0 } else { FROZEN };
                rounded[p as usize] = prev[p as usize];
                packed[p as usize] = old;
            } else {
                vertex[p as usize] = place(p as usize, step[p as usize]);
                stepped.extend_from_slice(around.of(p));
            }
        }
        for &q in &sides {
            side_of[q as usize] = u32::MAX;
        }
        stepped.sort_unstable();
        stepped.dedup();
        dirty = if zero { None } else { Some(stepped) };
    }
    vertex.truncate(own);
    (vertex, packed)
}

/// Whether the quad faces its edge's way as the mesh will split it
/// ([`Facing::polygon`]: each triangle faces the edge, has more than zero area and
/// is not flipped against the field) and no triangle opposes the field's normal where the surface crosses
/// the edge.
fn quad_faces(q: &DualQuad, vertex: &[Vec3], unit: &[Vec3], facing: &Facing) -> bool {
    let (corner, n) = distinct(&q.patches);
    if n < 3 {
        return true;
    }
    let corners = corner.map(|k| {
        let i = q.patches[k] as usize;
        (vertex[i], unit[i])
    });
    facing.polygon(&corners[..n], q.facing, |t| {
        crate::geometry::face_normal(t).dot(q.normal.as_dvec3()) >= 0.0
    })
}

/// The corners of a quad whose patches differ from the corner before them
/// (going round), in order, and how many: a quad with one fixed corner in
/// two quadrants is a triangle, as the seam meshes it.
fn distinct(patches: &[u32; 4]) -> ([usize; 4], usize) {
    let mut out = [0usize; 4];
    let mut n = 0;
    for k in 0..4 {
        if patches[k] != patches[(k + 3) % 4] {
            out[n] = k;
            n += 1;
        }
    }
    (out, n)
}

/// The quads around each patch (built once a quad folds).
struct Around {
    start: Vec<u32>,
    quads: Vec<u32>,
    /// Each patch's cell, and each cell's first patch.
    cell: Vec<u32>,
    cell_start: Vec<u32>,
}

impl Around {
    /// `own`: the cells' patches (those after them are fixed corners).
    fn new(quads: &[DualQuad], cell_of: &[u32], cells: &[ActiveCell], own: usize) -> Self {
        let patches = cell_of.len();
        let mut cell_start: Vec<u32> = cells.iter().map(|c| c.patch_base).collect();
        // A fixed corner's cell is itself (see `cell_vertices`).
        cell_start.extend(own as u32..patches as u32);
        cell_start.push(patches as u32);
        let mut start = vec![0u32; patches + 1];
        for q in quads {
            for p in q.patches {
                start[p as usize + 1] += 1;
            }
        }
        for i in 0..patches {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; quads.len() * 4];
        for (i, q) in quads.iter().enumerate() {
            for p in q.patches {
                list[fill[p as usize] as usize] = i as u32;
                fill[p as usize] += 1;
            }
        }
        Around {
            start,
            quads: list,
            cell: cell_of.to_vec(),
            cell_start,
        }
    }

    /// The patches of patch `p`'s cell.
    fn cell_of(&self, p: u32) -> std::ops::Range<u32> {
        let c = self.cell[p as usize];
        self.cell_start[c as usize]..self.cell_start[c as usize + 1]
    }

    fn of(&self, p: u32) -> &[u32] {
        &self.quads[self.start[p as usize] as usize..self.start[p as usize + 1] as usize]
    }

    /// Per quad of `sides`, the quads of every patch of the cells of its
    /// patches (a cell's other patches are other sheets through it), itself
    /// among them. `mark` is a scratch of one `u32::MAX` per quad, left so.
    fn near(&self, sides: &[u32], quads: &[DualQuad], mark: &mut [u32]) -> Near {
        let mut start = Vec::with_capacity(sides.len() + 1);
        let mut list: Vec<u32> = Vec::with_capacity(sides.len() * 12);
        start.push(0);
        for (i, &q) in sides.iter().enumerate() {
            let from = list.len();
            for r in quads[q as usize].patches {
                for c in self.cell_of(r) {
                    for &x in self.of(c) {
                        if mark[x as usize] != i as u32 {
                            mark[x as usize] = i as u32;
                            list.push(x);
                        }
                    }
                }
            }
            for &x in &list[from..] {
                mark[x as usize] = u32::MAX;
            }
            start.push(list.len() as u32);
        }
        Near { start, quads: list }
    }
}

/// The quads near each quad of a round's `sides` ([`Around::near`]), in one list.
struct Near {
    start: Vec<u32>,
    quads: Vec<u32>,
}

impl Near {
    /// The quads near side `i`.
    fn of(&self, i: usize) -> &[u32] {
        &self.quads[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// Per side `i` with `which[i]`, the sum of `crossings(q, r)` over the
    /// quads `r` near its quad `q` but `q` itself (0 for the others). The count
    /// is symmetric, so a pair of two sides both counted is tested once
    /// (`side_of`: each quad's index in `sides`, or `u32::MAX`).
    fn pair_counts(
        &self,
        sides: &[u32],
        which: &[bool],
        side_of: &[u32],
        crossings: impl Fn(u32, u32) -> usize + Sync,
    ) -> Vec<usize> {
        const LATER: u32 = u32::MAX;
        let both = |q: u32, r: u32| {
            let j = side_of[r as usize];
            j != u32::MAX && which[j as usize] && r < q
        };
        let mut pairs = vec![0u32; self.quads.len()];
        let mut parts: Vec<(usize, &mut [u32])> = Vec::with_capacity(sides.len());
        let mut rest: &mut [u32] = &mut pairs;
        for i in 0..sides.len() {
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(self.of(i).len());
            rest = tail;
            if which[i] {
                parts.push((i, part));
            }
        }
        parts.into_par_iter().for_each(|(i, part)| {
            let q = sides[i];
            for (n, &r) in part.iter_mut().zip(self.of(i)) {
                *n = if r == q {
                    0
                } else if both(q, r) {
                    LATER
                } else {
                    crossings(q, r) as u32
                };
            }
        });
        // The pairs left for the other side of them: its count, tested there.
        (0..sides.len())
            .map(|i| {
                if !which[i] {
                    return 0;
                }
                let q = sides[i];
                let from = self.start[i] as usize;
                self.of(i)
                    .iter()
                    .enumerate()
                    .map(|(k, &r)| {
                        let n = pairs[from + k];
                        if n != LATER {
                            return n as usize;
                        }
                        let j = side_of[r as usize] as usize;
                        let at = self
                            .of(j)
                            .iter()
                            .position(|&x| x == q)
                            .expect("nearness is mutual");
                        pairs[self.start[j] as usize + at] as usize
                    })
                    .sum()
            })
            .collect()
    }
}

/// The two triangles of a quad split along 0-2, and along 1-3, as corners of it.
const SPLITS: [[[usize; 3]; 2]; 2] = [[[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]];

/// How many pairs of triangles cross, one of quad `q` and one of quad `r`,
/// placed at `placed[slot[quad]]`. Two triangles with two corners in common
/// (an edge) never do: their planes meet along that edge, which both only
/// touch.
fn pair_crossings(placed: &[PlacedQuad], slot: &[u32], q: u32, r: u32) -> usize {
    let (a, b) = (
        &placed[slot[q as usize] as usize],
        &placed[slot[r as usize] as usize],
    );
    if !a.bounds.meets(&b.bounds) {
        return 0;
    }
    // Per corner of `a`: the bits of the corners of `b` that are the same
    // patch (two where a fixed corner takes two quadrants of `b`).
    let same = a.patches.map(|p| {
        (0..4)
            .filter(|&k| b.patches[k] == p)
            .fold(0u8, |m, k| m | 1 << k)
    });
    let tol = Tolerance {
        length: crate::geometry::INTERSECTION_TOL_CELLS,
        area: crate::geometry::ZERO_AREA_CELLS2,
    };
    let mut n = 0;
    for (ta, ca) in a.triangles[..a.count].iter().enumerate() {
        if !a.triangle_bounds[ta].meets(&b.bounds) {
            continue;
        }
        let shared_with = same[ca[0]] | same[ca[1]] | same[ca[2]];
        let pa = [a.corners[ca[0]], a.corners[ca[1]], a.corners[ca[2]]];
        for (tb, cb) in b.triangles[..b.count].iter().enumerate() {
            if !a.triangle_bounds[ta].meets(&b.triangle_bounds[tb]) {
                continue;
            }
            let shared = shared_with & cb.iter().fold(0u8, |m, &c| m | 1 << c);
            if shared.count_ones() >= 2 {
                continue;
            }
            let pb = [b.corners[cb[0]], b.corners[cb[1]], b.corners[cb[2]]];
            if shared != 0 {
                // One corner in common: the quick test first.
                let k = shared.trailing_zeros() as usize;
                let sb = cb
                    .iter()
                    .position(|&c| c == k)
                    .expect("a corner of b's triangle");
                let sa = ca
                    .iter()
                    .position(|&c| same[c] & shared != 0)
                    .expect("a corner of a's triangle");
                let (na, nb) = (a.normals[ta], b.normals[tb]);
                if apart_from_shared_corner(&pa, na, sa, &pb, nb, sb, tol) {
                    continue;
                }
            }
            let contact = contact_with_normals(&pa, a.normals[ta], &pb, b.normals[tb], tol);
            n += matches!(contact, Contact::Cross { .. }) as usize;
        }
    }
    n
}

/// A quad's two triangles as the mesh will split it ([`Facing::takes_02`]):
/// its corners and patches, each triangle's corners, unit normal and box, and
/// the box around them.
struct PlacedQuad {
    corners: [DVec3; 4],
    patches: [u32; 4],
    triangles: [[usize; 3]; 2],
    /// How many of `triangles` it has: one where a fixed corner takes two
    /// quadrants.
    count: usize,
    normals: [Option<DVec3>; 2],
    triangle_bounds: [Bounds; 2],
    bounds: Bounds,
}

/// The two triangles of `quad` with its patches at `vertex` (normals `unit`),
/// split as the mesh will split it.
fn place_quad(quad: &DualQuad, vertex: &[Vec3], unit: &[Vec3], facing: &Facing) -> PlacedQuad {
    let p = quad.patches.map(|i| vertex[i as usize]);
    let n = quad.patches.map(|i| unit[i as usize]);
    let (corner, distinct) = distinct(&quad.patches);
    let (triangles, count) = match distinct {
        4 => (SPLITS[!facing.takes_02(p, n, quad.facing) as usize], 2),
        3 => {
            let t = [corner[0], corner[1], corner[2]];
            ([t, t], 1)
        }
        _ => ([[0, 0, 0]; 2], 0),
    };
    let v = p.map(|x| x.as_dvec3());
    let tri = |t: [usize; 3]| t.map(|k| v[k]);
    PlacedQuad {
        corners: v,
        patches: quad.patches,
        triangles,
        count,
        normals: triangles.map(|t| unit_normal(&tri(t))),
        triangle_bounds: triangles.map(|t| {
            let t = tri(t);
            Bounds {
                lo: t[0].min(t[1]).min(t[2]),
                hi: t[0].max(t[1]).max(t[2]),
            }
        }),
        bounds: Bounds {
            lo: v[0].min(v[1]).min(v[2]).min(v[3]),
            hi: v[0].max(v[1]).max(v[2]).max(v[3]),
        },
    }
}

/// An axis-aligned box (grid units).
struct Bounds {
    lo: DVec3,
    hi: DVec3,
}

impl Bounds {
    /// Whether the boxes overlap or touch.
    fn meets(&self, o: &Bounds) -> bool {
        !(self.lo.cmpgt(o.hi).any() || o.lo.cmpgt(self.hi).any())
    }
}
