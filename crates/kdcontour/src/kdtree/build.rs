//! The build driver: the top-down recursion of section 4.3 over a node arena, with
//! the bottom-up clustering of section 5 run on each node as the recursion returns
//! (one post-order pass), and the fold guard over the result ([`build_in`]).
//!
//! Each node partitions its list of active cells at the plane [`super::split`] picks
//! (or at the midpoint, for the octree baseline), builds its halves (in parallel
//! near the root, each into its own arena), then asks [`super::cluster`] whether it
//! may stand in for them. Cell leaves are made here.

use super::arena::{Arena, Ctx, NO_EDGE};
use super::borders;
use super::cluster::cluster;
use super::coarser::Coarser;
use super::fold::refuse_folding_leaves;
use super::split::{empty_cut, kd_split, EMPTY_CUT_CELLS};
use super::{KdNode, KdTree, CELL, NONE};
use crate::boundary::open_faces;
use crate::cell::{edge_corners, CellTables};
use crate::field::Field;
use crate::hermite::Hermite;
use crate::qef::Qef;
use crate::settings::Partition;
use glam::Vec3;
use rayon::prelude::*;

/// Nodes above this depth with at least [`PARALLEL_CELLS`] active cells build their
/// halves with `rayon::join`, each into its own arena that is appended afterwards
/// (one copy per parallel level, so the depth is kept small: 16 tasks feed 2 to 8
/// cores). Appending preserves the sequential layout, so every thread count gives
/// the same tree.
const PARALLEL_DEPTH: u32 = 4;
/// See [`PARALLEL_DEPTH`]; below this the join overhead exceeds the work.
const PARALLEL_CELLS: usize = 1024;

/// How far (cells) a leaf touching a chunk's face toward a chunk of its own
/// level may reach in from it. The seam across such a face joins the two
/// chunks' leaves, each cut on its own, and each chunk's fold guard stands the
/// other's cells there (it cannot know the other's tree): two merged leaves
/// reaching far in on both sides passed both guards and still folded their
/// seam polygons, a fan from one side's deep vertex to the other side's
/// vertices zigzagging between cells and deep leaves (on the box's faces,
/// triangles 30 cells long). With leaves held to a slab this thin, merged
/// along the face as freely as before, the `defects` example's level worlds
/// (8 analytic and CSG scenes) had 90 flipped faces on faces within one level
/// instead of 313, 112 overlapping instead of 917, for 1.9% more triangles;
/// a slab of 1 left 95 with 50 zero-area faces, one of 3 left 197, the slab on
/// one side of each face alone 215 and 278.
const SAME_SLAB: u16 = 2;

/// Builds the tree over the cells in the box `core_min..core_max` only (a chunk
/// inside a grid with a halo: the halo's cells decide the face resolution of the
/// core's boundary cells but belong to the neighbouring chunk). `field` is the
/// field the data was sampled from: the fold guard holds the clustered polygons
/// to it (`kdtree::fold`). On the box's faces in `finer_faces` (bit `2 * axis +
/// side`: a chunk's faces toward finer chunks) every leaf is a cell
/// ([`face_cells`]); on those in `same_faces` (toward chunks of its own level)
/// no leaf reaches more than [`SAME_SLAB`] cells in. Across faces toward
/// coarser chunks the fold guard stands the coarse cells of `coarser` (module
/// `coarser`). The pipeline's tree stage ([`crate::pipeline::tree`]) is the way
/// in.
pub(crate) fn build_in(
    h: &Hermite,
    field: &dyn Field,
    (partition, (min_threshold, max_threshold)): (Partition, (f32, f32)),
    (core_min, core_max): ([u16; 3], [u16; 3]),
    (finer_faces, same_faces): (u8, u8),
    coarser: Option<&Coarser>,
) -> KdTree {
    let tables = CellTables::get();
    let cell_qef: Vec<Qef> = h
        .cells
        .par_iter()
        .map(|c| {
            let mut q = Qef::default();
            for k in 0..tables.cell(c.config, c.mask).count as usize {
                q += &h.patch_qef[c.patch_base as usize + k];
            }
            q
        })
        .collect();
    let open: Vec<u8> = h
        .cells
        .par_iter()
        .map(|c| open_faces(h.grid.cells, c.coord, c.config))
        .collect();
    let inside = |c: &[u16; 3]| (0..3).all(|a| c[a] >= core_min[a] && c[a] < core_max[a]);
    let mut ids: Vec<u32> = (0..h.cells.len() as u32)
        .filter(|&i| inside(&h.cells[i as usize].coord))
        .collect();
    let ctx = Ctx {
        h,
        partition,
        max_threshold,
        cell_qef,
        tables,
        any_open: ids.iter().any(|&i| open[i as usize] != 0),
        open,
        touched: face_cells(h, (core_min, core_max), (finer_faces, same_faces)),
        core_min,
        finer_faces,
        same_faces,
        kinds: borders::cell_kinds(h),
    };
    // At most about three nodes and components per active cell (measured: 2.3 on
    // disk_pole and terrain at 128, 3.1 on the sphere at 64, 3.2 on a 32³ terrain
    // chunk); reserving avoids regrowing the arena.
    let mut arena = Arena {
        nodes: Vec::with_capacity(h.cells.len() * 13 / 4),
        comps: Vec::with_capacity(h.cells.len() * 13 / 4),
        normals: Vec::with_capacity(h.cells.len() * 13 / 4),
        edges: Vec::with_capacity(h.cells.len() * 13 / 4),
        material: Vec::new(),
    };
    let root = if ids.is_empty() {
        NONE
    } else {
        let mut total = Qef::default();
        for &i in &ids {
            total += &ctx.cell_qef[i as usize];
        }
        let mut stack = Vec::new();
        build_node(
            &ctx, &mut arena, &mut stack, &mut ids, core_min, core_max, total, 0,
        )
        .0
    };
    let mut nodes = arena.nodes;
    nodes.shrink_to_fit();
    let mut comps = arena.comps;
    comps.shrink_to_fit();
    let mut tree = KdTree {
        grid: h.grid,
        nodes,
        comps,
        root,
        outside: h.outside.clone(),
        stats: Default::default(),
        materials: Vec::new(),
        max_threshold,
        min_threshold,
    };
    refuse_folding_leaves(&mut tree, h, h.surface(field).field(), coarser);
    tree
}

/// Builds the subtree of `ids` in the box `min..max`. Returns the node and the
/// number of component QEFs it pushed onto `stack` (its parent pops them).
#[allow(clippy::too_many_arguments)]
fn build_node(
    ctx: &Ctx,
    arena: &mut Arena,
    stack: &mut Vec<Qef>,
    ids: &mut [u32],
    min: [u16; 3],
    max: [u16; 3],
    total: Qef,
    depth: u32,
) -> (u32, usize) {
    let ext = [max[0] - min[0], max[1] - min[1], max[2] - min[2]];
    if ext == [1, 1, 1] {
        debug_assert_eq!(ids.len(), 1);
        return cell_leaf(ctx, arena, stack, ids[0], min, max);
    }

    // Faces of the grid the surface leaves through, where this node is more than
    // a cell thick: it may not be a leaf (its mesh would stop short of the
    // boundary cells'), and the k-d tree splits the boundary slab off first.
    let open = if ctx.any_open {
        ids.iter().fold(0u8, |acc, &id| acc | ctx.open[id as usize])
    } else {
        0
    };
    let thick = thick_open_faces(ctx, open, min, max);
    let straight = thick != 0 || open == 0 || trace_straight(ctx, ids, open);
    // The chunk faces this node's cells touch.
    let touched = if ctx.touched.is_empty() {
        0
    } else {
        ids.iter()
            .fold(0u8, |acc, &id| acc | ctx.touched[id as usize])
    };
    // Faces toward finer chunks: it may not be a leaf, and where it is more
    // than a cell thick across one, the k-d tree splits the one-cell slab along
    // it off first.
    let finer = touched & ctx.finer_faces;
    let thick = thick | (finer & thick_faces(min, max));
    // Faces toward chunks of this level, where it reaches more than
    // `SAME_SLAB` cells in: it may not be a leaf, and the k-d tree splits that
    // slab off first.
    let deep = touched & ctx.same_faces & faces_thicker_than(min, max, SAME_SLAB);
    // And where it runs across a tile boundary along such a face: it may not
    // be a leaf, and the k-d tree cuts it there.
    let tile = tile_cut(touched & ctx.same_faces, ctx.core_min, min, max);
    // A small node whose cells leave part of its box empty cuts the largest
    // empty slab off first (module `split`).
    let empty = (ctx.partition == Partition::KdTree && thick == 0 && ids.len() <= EMPTY_CUT_CELLS)
        .then(|| empty_cut(ctx, ids, min, max, &total))
        .flatten();
    // A node holding a material border splits to set the border's cells, the
    // strips beside it and the free regions apart (module `borders`).
    let kinds = borders::of_cells(ctx, ids);
    let by_material = (ctx.partition == Partition::KdTree && thick == 0 && empty.is_none())
        .then(|| kinds.and_then(|k| borders::split(ctx, ids, min, max, &total, k)))
        .flatten();
    let (axis, split, ltotal, rtotal) = match ctx.partition {
        _ if empty.is_some() => empty.expect("just tested"),
        _ if by_material.is_some() => by_material.expect("just tested"),
        Partition::KdTree if thick != 0 => slab_split(ctx, ids, min, max, thick, 1),
        Partition::KdTree if deep != 0 => slab_split(ctx, ids, min, max, deep, SAME_SLAB),
        Partition::KdTree if tile.is_some() => {
            let (axis, split) = tile.expect("just tested");
            let (l, r) = super::split::halves(ctx, ids, axis, split, &total);
            (axis, split, l, r)
        }
        Partition::KdTree => kd_split(ctx, ids, min, max, &total),
        Partition::Octree => {
            // Midpoint, cycling x, y, z (an axis one cell thick is skipped).
            let mut axis = depth as usize % 3;
            while ext[axis] <= 1 {
                axis = (axis + 1) % 3;
            }
            (axis, min[axis] + ext[axis] / 2, Qef::ZERO, Qef::ZERO)
        }
    };

    // Partition the cells.
    let mut i = 0;
    let mut j = ids.len();
    while i < j {
        if ctx.h.cells[ids[i] as usize].coord[axis] < split {
            i += 1;
        } else {
            j -= 1;
            ids.swap(i, j);
        }
    }
    let (left_ids, right_ids) = ids.split_at_mut(i);
    let mut lmax = max;
    lmax[axis] = split;
    let mut rmin = min;
    rmin[axis] = split;

    let none = (NONE, 0);
    let (l, r) = if depth < PARALLEL_DEPTH
        && left_ids.len() + right_ids.len() >= PARALLEL_CELLS
        && rayon::current_num_threads() > 1
        && !left_ids.is_empty()
        && !right_ids.is_empty()
    {
        let ((la, ls, l), (ra, rs, r)) = rayon::join(
            || {
                let (mut a, mut st) = (Arena::new(), Vec::new());
                let l = build_node(ctx, &mut a, &mut st, left_ids, min, lmax, ltotal, depth + 1);
                (a, st, l)
            },
            || {
                let (mut a, mut st) = (Arena::new(), Vec::new());
                let r = build_node(
                    ctx,
                    &mut a,
                    &mut st,
                    right_ids,
                    rmin,
                    max,
                    rtotal,
                    depth + 1,
                );
                (a, st, r)
            },
        );
        let lo = arena.append(la);
        let ro = arena.append(ra);
        stack.extend(ls);
        stack.extend(rs);
        ((l.0 + lo, l.1), (r.0 + ro, r.1))
    } else {
        let l = if left_ids.is_empty() {
            none
        } else {
            build_node(ctx, arena, stack, left_ids, min, lmax, ltotal, depth + 1)
        };
        let r = if right_ids.is_empty() {
            none
        } else {
            build_node(ctx, arena, stack, right_ids, rmin, max, rtotal, depth + 1)
        };
        (l, r)
    };
    let mut node = KdNode {
        min,
        max,
        children: [l.0, r.0],
        axis: axis as u8,
        config: 0,
        mask: 0,
        comp_count: 0,
        split,
        clusterable: false,
        leaf_ok: thick == 0
            && deep == 0
            && tile.is_none()
            && finer == 0
            && straight
            && (ctx.partition == Partition::KdTree || depth.is_multiple_of(3)),
        comp_start: arena.comps.len() as u32,
        error: f32::INFINITY,
    };
    let popped = l.1 + r.1;
    let base = stack.len() - popped;
    let (count, edges) = cluster(ctx, arena, &mut node, stack, base, left_ids);
    if count == 0 {
        stack.truncate(base);
    }
    borders::mark(ctx, arena, &mut node, ids, kinds);
    // No cut reaches a node above the largest threshold (errors never decrease
    // going up, so neither does any ancestor's).
    if node.error > ctx.max_threshold {
        node.leaf_ok = false;
    }
    arena.nodes.push(node);
    arena.edges.push(edges);
    ((arena.nodes.len() - 1) as u32, count)
}

/// The side (cells) of the tiles that cut a chunk's faces toward chunks of
/// its own level: a leaf touching such a face lies within one tile along it
/// ([`tile_cut`]). Tiles start at the chunk's corner, so the two chunks on a
/// face tile it alike, and the seam polygons between their leaves join leaves
/// of one tile, not a leaf running along the face to ones cut elsewhere (what
/// [`SAME_SLAB`] left: flat faces folding in their plane). On the `defects`
/// example's level worlds (8 analytic and CSG scenes, 16-cell chunks), from
/// the slab alone to tiles of 8 to tiles of 4: flipped faces on faces within
/// one level 90 -> 62 -> 9, overlapping 112 -> 45 -> 2, for 1.0% and then
/// 2.4% more triangles (anisotropic +6.5%, box +5.8%, `disk_pole` +5.0%; the
/// plugin's terrain chunk +0.1%). Tiles of 2 left 4 such flips for 9.3%.
const SAME_TILE: u16 = 4;

/// For a node touching the faces `faces` toward chunks of its own level: the
/// axis along one of those faces on which it crosses a tile boundary
/// ([`SAME_TILE`], from `origin`, the chunk's low corner) and the boundary
/// nearest its middle, on its longest such axis; `None` when it lies within
/// one tile along every such face.
fn tile_cut(faces: u8, origin: [u16; 3], min: [u16; 3], max: [u16; 3]) -> Option<(usize, u16)> {
    if faces == 0 {
        return None;
    }
    let mut best: Option<(u16, usize, u16)> = None;
    for a in 0..3 {
        // Along a face whose normal is another axis.
        if !(0..3).any(|b| b != a && faces & (0b11 << (2 * b)) != 0) {
            continue;
        }
        let (o, t) = (origin[a], SAME_TILE);
        // The boundaries strictly inside the node: `first..=last`.
        let first = ((min[a] - o) / t + 1) * t + o;
        if first >= max[a] {
            continue;
        }
        let last = ((max[a] - 1 - o) / t) * t + o;
        let mid = (min[a] + max[a]) / 2;
        let at = (((mid - o) + t / 2) / t * t + o).clamp(first, last);
        let ext = max[a] - min[a];
        if best.is_none_or(|b| ext > b.0) {
            best = Some((ext, a, at));
        }
    }
    best.map(|(_, a, at)| (a, at))
}

/// The faces of the grid (bits as [`open_faces`]) that the node `min..max` lies
/// on, that the surface of its cells crosses (`open`: their bits together), and
/// across which it is more than one cell thick.
fn thick_open_faces(ctx: &Ctx, open: u8, min: [u16; 3], max: [u16; 3]) -> u8 {
    let n = ctx.h.grid.cells;
    let mut faces = 0u8;
    for a in 0..3 {
        if max[a] - min[a] > 1 {
            faces |= ((min[a] == 0) as u8) << (2 * a);
            faces |= ((max[a] as u32 == n[a]) as u8) << (2 * a + 1);
        }
    }
    open & faces & thick_faces(min, max)
}

/// Both faces' bits (as [`open_faces`]) of each axis across which the node
/// `min..max` is more than one cell thick.
fn thick_faces(min: [u16; 3], max: [u16; 3]) -> u8 {
    faces_thicker_than(min, max, 1)
}

/// Both faces of each axis along which the box `min..max` is more than `d`
/// cells thick.
fn faces_thicker_than(min: [u16; 3], max: [u16; 3], d: u16) -> u8 {
    (0..3)
        .filter(|&a| max[a] - min[a] > d)
        .fold(0u8, |acc, a| acc | (0b11 << (2 * a)))
}

/// Per active cell of `h`: the faces in `faces` of the box `core` that it
/// touches (bits as [`open_faces`]); empty when there are none.
///
/// On a chunk's faces toward finer chunks every leaf is a cell. The seam
/// across a level face is contoured from both chunks' trees, each cut on its own, and each chunk's
/// fold guard stands the cells across at its own cell size (`kdtree::fold`).
/// For the finer chunk that is close to the coarse cells there; for the coarser
/// one it is not (the finer chunk's cells are half its size), so its merged
/// leaves on such a face folded seam polygons that no guard saw. Every leaf
/// touching one is therefore a cell on the coarser side. Measured on the
/// `defects` example's level worlds (8 scenes at 32 and 64): flipped seam
/// faces 5,482 -> 1,839 for 4% more triangles; the same rule on the finer side
/// as well gave 1,907 for 11% more, on the finer side alone 5,635.
fn face_cells(h: &Hermite, (lo, hi): ([u16; 3], [u16; 3]), (finer, same): (u8, u8)) -> Vec<u8> {
    if finer | same == 0 {
        return Vec::new();
    }
    h.cells
        .par_iter()
        .map(|c| {
            let on = (0..3).fold(0u8, |acc, a| {
                acc | ((c.coord[a] == lo[a]) as u8) << (2 * a)
                    | ((c.coord[a] + 1 == hi[a]) as u8) << (2 * a + 1)
            });
            // On a face toward a chunk of its own level, only a cell the
            // surface crosses the face in: the seam's polygons are those of
            // crossing edges in the face.
            let crossed = (0..6).fold(0u8, |acc, f| {
                let corners = FACE_CORNERS[f];
                let signs = c.config & corners;
                acc | ((signs != 0 && signs != corners) as u8) << f
            });
            on & (finer | (same & crossed))
        })
        .collect()
}

/// Per face of a cell (`2 * axis + side`): its corners as bits of a cell's
/// sign configuration.
const FACE_CORNERS: [u8; 6] = {
    let mut m = [0u8; 6];
    let mut f = 0;
    while f < 6 {
        let (a, s) = (f / 2, f % 2);
        let mut i = 0;
        while i < 8 {
            if (i >> a) & 1 == s {
                m[f] |= 1 << i;
            }
            i += 1;
        }
        f += 1;
    }
    m
};

/// The most the surface's normals may turn (radians) across a leaf's cells on
/// an open face ([`trace_straight`]): rounding, no more.
const TRACE_TURN: f32 = 1e-3;

/// Whether the surface's trace on the grid's open faces through the node's
/// cells is straight, so the node may be a leaf there: the normals of the
/// crossing cells on each open face, projected onto it, agree within
/// [`TRACE_TURN`] (a plane crossing the face). A leaf gives the mesh one vertex
/// per component along the face, and a curved trace cut that way loses area the
/// uniform mesh has (a torus larger than the grid kept 89% of it at threshold
/// 0.01 when long leaves were allowed on every trace, and 95% when only traces
/// turning by less than a twentieth of a cell per leaf were), so there every
/// leaf is a cell, as in the uniform mesh. A node with one crossing cell on a
/// face says nothing of the turn and is not a leaf either.
/// `open` is the cells' open faces together: only those are looked at.
fn trace_straight(ctx: &Ctx, ids: &[u32], open: u8) -> bool {
    for f in (0..6).filter(|f| open & (1 << f) != 0) {
        let a = f / 2;
        let mut normals = Vec::new();
        for &id in ids {
            if ctx.open[id as usize] & (1 << f) == 0 {
                continue;
            }
            let c = ctx.h.cells[id as usize];
            let count = ctx.tables.cell(c.config, c.mask).count as usize;
            for k in 0..count {
                let mut n = ctx.h.patch_normal[c.patch_base as usize + k];
                n[a] = 0.0;
                normals.push(n.normalize_or_zero());
            }
        }
        match normals.len() {
            0 => continue,
            1 => return false,
            _ => {}
        }
        let mean = normals.iter().sum::<Vec3>().normalize_or_zero();
        let least = normals
            .iter()
            .map(|n| n.dot(mean))
            .fold(1.0f32, f32::min)
            .clamp(-1.0, 1.0);
        if 2.0 * least.acos() > TRACE_TURN {
            return false;
        }
    }
    true
}

/// The split of a node more than `depth` cells thick across faces `thick`: the
/// slab `depth` cells thick along the first of them, and the QEFs of the two
/// halves.
fn slab_split(
    ctx: &Ctx,
    ids: &[u32],
    min: [u16; 3],
    max: [u16; 3],
    thick: u8,
    depth: u16,
) -> (usize, u16, Qef, Qef) {
    let f = thick.trailing_zeros() as usize;
    let axis = f / 2;
    let split = if f.is_multiple_of(2) {
        min[axis] + depth
    } else {
        max[axis] - depth
    };
    let (mut left, mut right) = (Qef::ZERO, Qef::ZERO);
    for &id in ids {
        if ctx.h.cells[id as usize].coord[axis] < split {
            left += &ctx.cell_qef[id as usize];
        } else {
            right += &ctx.cell_qef[id as usize];
        }
    }
    (axis, split, left, right)
}

/// Makes the leaf of active cell `id`: one component per patch, each at its
/// patch QEF's minimiser; pushes the patch QEFs onto `stack`.
fn cell_leaf(
    ctx: &Ctx,
    arena: &mut Arena,
    stack: &mut Vec<Qef>,
    id: u32,
    min: [u16; 3],
    max: [u16; 3],
) -> (u32, usize) {
    let c = ctx.h.cells[id as usize];
    let cc = ctx.tables.cell(c.config, c.mask);
    let comp_start = arena.comps.len() as u32;
    let mut error = 0f64;
    for k in 0..cc.count as usize {
        let p = c.patch_base as usize + k;
        let q = ctx.h.patch_qef[p];
        let vertex = ctx.h.patch_vertex[p];
        let e = q.error_at(vertex.as_dvec3());
        error = error.max(e);
        let normal = ctx.h.patch_normal[p];
        // Packed in the cell (this box) by the Hermite stage.
        arena.comps.push(ctx.h.patch_comp[p]);
        arena.normals.push(normal);
        stack.push(q);
    }
    let mut edges = [NO_EDGE; 12];
    for (e, at) in edges.iter_mut().enumerate() {
        let (c0, c1) = edge_corners(e);
        if (c.config >> c0) & 1 != (c.config >> c1) & 1 {
            *at = min[e / 4];
        }
    }
    arena.edges.push(edges);
    if let Some(&m) = ctx.h.cell_material.get(id as usize) {
        arena.material.push(m);
    }
    arena.nodes.push(KdNode {
        min,
        max,
        children: [NONE, NONE],
        axis: CELL,
        config: c.config,
        mask: c.mask,
        comp_count: cc.count,
        split: 0,
        clusterable: true,
        leaf_ok: true,
        comp_start,
        error: error as f32,
    });
    ((arena.nodes.len() - 1) as u32, cc.count as usize)
}
