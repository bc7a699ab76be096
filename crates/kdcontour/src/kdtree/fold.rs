//! What keeps geometry when nodes cluster (issue 13). The paper's conditions
//! (section 5) keep topology: a clustered node stands for its subtree with the same
//! signs and components. They say nothing of where its vertex lands, and a vertex
//! at its QEF's minimiser can sit far along a flat face (a k-d box is often long
//! and thin, and on a plane the minimiser is the mass point), so the triangles
//! between it and its neighbours fold back over each other in the plane, some
//! facing inward.
//!
//! Every polygon the contouring emits is the dual of one crossing edge of the grid:
//! its corners are the vertices of the leaves (at the threshold) that hold the four
//! cells around the edge. On each cell's root-to-cell path the leaf at threshold
//! `e` is the highest node that may be a leaf and whose error is at most `e`
//! (errors never decrease going up), so as `e` grows each corner climbs its path
//! and an edge has only as many distinct polygons as its four paths have such
//! nodes. [`refuse_folding_leaves`] visits them all, for every crossing edge, once
//! the tree is built: a polygon must face the way its edge crosses the surface
//! (from the inside corner to the outside one). A triangle faces that way when its
//! normal has a positive component along the edge and does not oppose its
//! vertices' normals ([`crate::mesh::triangle_faces`]), has more than zero area and is not
//! flipped against the field's gradient at its centroid; a quad when the two
//! triangles [`crate::IndexedMesh::push_polygon_facing`] splits it into do
//! ([`Facing::polygon`], the test `validate` counts flipped and zero-area faces
//! by). Where a polygon does not, the largest clustered leaf in it may no longer
//! be a leaf (`leaf_ok`): it
//! stays clusterable, so its ancestors may still cluster and are tested in turn,
//! and the cut passes through its children instead. Refusals change other edges'
//! polygons, so the pass repeats until none is refused. A tree with a largest
//! threshold ([`crate::Settings::max_threshold`]) has no leaf above it, so the
//! climb stops there (a limit of 0.2 takes the build of the terrain demo's
//! level-3 and level-6 chunks, borders off, from 5.7 and 6.3 ms to 4.3 ms).
//! Seen along its edge, a polygon of vertices inside their boxes winds once
//! around the edge, so the cells
//! alone never need refusing for this reason; at the finest level the cells'
//! vertices are already placed so their quads do not fold (`hermite::vertex`).
//!
//! A chunk's seams are contoured against its neighbours' trees, whose cuts the
//! build cannot know: on an edge with cells outside the tree (in the chunk's halo)
//! those cells stand at their finest, their Dual Marching Cubes vertices. Across
//! a face toward finer chunks they are not even that (the cells there are
//! smaller), so the chunk keeps cells along such a face (`build::finer_cells`).
//! Across a face toward a coarser chunk the coarse cells the seam takes stand
//! there instead of the halo's ([`Coarser`]). A seam polygon between cells of
//! two levels can still fold, and so can one between merged leaves of two
//! chunks of one level.

use super::coarser::Coarser;
use super::{KdNode, KdTree, CELL, NONE};
use crate::cell::{edge_index, CellTables, NO_COMP};
use crate::facing::Facing;
use crate::field::Field;
use crate::hermite::Hermite;
use glam::Vec3;
use rayon::prelude::*;

/// How many times the smallest area `validate` allows a triangle (per cell)
/// the guard asks of a merged leaf's polygons. Checked without a cell size,
/// `validate` measures areas against the mesh's mean edge, and an adaptive
/// mesh's edges are longer than a cell: with four-cell tiles along faces
/// within one level (`build::SAME_TILE`), a seam triangle along a box's crease
/// of 3.9e-5 cells² passed the guard and was zero-area in a level world of
/// `tests/levels.rs`. Four times (a mean edge of two cells) refuses it; the
/// `defects` example's tables keep their counts, and of the one-grid meshes
/// only `box` at 48 changes.
const AREA_MARGIN: f64 = 4.0;

/// The guard reads the field for a merged leaf's triangle more than this
/// many degrees from one of its vertices' normals (cells: 60). Where a box
/// cuts a height field, a merged wall leaf's triangle 42 degrees from its two
/// crease vertices' normals (their planes average the wall's and the top's)
/// lies where the top is nearer than the wall, and is flipped against the
/// field's gradient there: at 45 degrees the guard did not look and the
/// `terrain` scene at 32 kept one flipped face at thresholds 0.001 to 0.1.
/// At 30 it has none; the `defects` example's other counts are unchanged, the
/// plugin's terrain chunk (`stages chunk 32`) builds the same mesh in the same
/// time, and crease-heavy scenes build a little longer (`csg_mix` at 32 +8%,
/// the demo's level-3 chunk +4%).
const GUARD_CHECK_DEGREES: f32 = 30.0;

/// Quadrants around an edge, as in `contour.rs` (counter-clockwise about +d).
const QUADRANT: [(u32, u32); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];

/// One crossing edge: its low corner and axis.
#[derive(Clone, Copy)]
struct Edge {
    line: [u32; 3],
    d: usize,
}

/// One node a corner of an edge's polygon can be: the node (or, for a cell outside
/// the tree, [`NONE`] less its quadrant), the component the edge belongs to in it,
/// its error, and the component's vertex and normal.
#[derive(Clone, Copy)]
struct Rung {
    node: u32,
    local: u8,
    error: f32,
    pos: Vec3,
    normal: Vec3,
}

impl Rung {
    /// The rung of component `local` of tree node `node`, its vertex not yet
    /// looked up ([`Rung::place`]): most edges never test a polygon.
    fn bare(node: u32, local: u8, error: f32) -> Rung {
        Rung {
            node,
            local,
            error,
            pos: Vec3::ZERO,
            normal: Vec3::ZERO,
        }
    }

    /// Looks up the vertex and normal of a tree node's rung.
    fn place(&mut self, tree: &KdTree, links: &Links) {
        let n = &tree.nodes[self.node as usize];
        (self.pos, self.normal) = links.placed[(n.comp_start + self.local as u32) as usize];
    }
}

/// Clears `leaf_ok` on every clustered node whose polygons would fold at some
/// threshold (see the module docs). Returns how many nodes it refused.
pub(super) fn refuse_folding_leaves(
    tree: &mut KdTree,
    h: &Hermite,
    surface: &dyn Field,
    coarser: Option<&Coarser>,
) -> usize {
    if tree.root == NONE {
        return 0;
    }
    let test = &Facing::new(surface, &tree.grid)
        .with_area_margin(AREA_MARGIN)
        .with_field_check_degrees(GUARD_CHECK_DEGREES);
    let edges = crossing_edges(tree);
    let h = &Links::new(tree, h, coarser);
    // The first pass visits every edge and learns its four cells; later ones only
    // the edges below a node the pass before refused. Refusals are rare: the few
    // edges that refuse share one list.
    let t: &KdTree = tree;
    let found = std::sync::Mutex::new(Vec::new());
    let cells: Vec<[u32; 4]> = edges
        .par_iter()
        .map_init(Scratch::default, |s, e| {
            let cells = check_edge(t, h, *e, s, test);
            if !s.refused.is_empty() {
                found
                    .lock()
                    .expect("no thread panics holding it")
                    .append(&mut s.refused);
            }
            cells
        })
        .collect();
    let mut marks = found.into_inner().expect("no thread panicked holding it");
    let mut refused = 0;
    // Per cell, the deepest node refused in the last pass above it.
    let mut under = vec![NONE; tree.nodes.len()];
    loop {
        marks.sort_unstable();
        marks.dedup();
        if marks.is_empty() {
            return refused;
        }
        refused += marks.len();
        under.fill(NONE);
        // Outer nodes first (a child's box is smaller), so the deepest one wins.
        marks.sort_by_key(|&m| std::cmp::Reverse(volume(&tree.nodes[m as usize])));
        for &m in &marks {
            tree.nodes[m as usize].leaf_ok = false;
            mark_cells(tree, m, &mut under);
        }
        let t: &KdTree = tree;
        let under = &under;
        marks = (0..edges.len())
            .into_par_iter()
            .filter(|&i| touches_refused(&cells[i], under))
            .map_init(Scratch::default, |s, i| {
                check_edge(t, h, edges[i], s, test);
                std::mem::take(&mut s.refused)
            })
            .flatten_iter()
            .collect();
    }
}

/// Whether a node refused in the last pass can be a corner of the polygons of the
/// edge around `cells`: a refused node above all four cells is above the node
/// they share, where the polygon has collapsed, so only an edge across a refused
/// node's side (or with a cell outside the tree) sees it.
fn touches_refused(cells: &[u32; 4], under: &[u32]) -> bool {
    let deepest = cells.map(|c| (c != NONE).then(|| under[c as usize]));
    deepest.iter().any(|m| m.is_some_and(|m| m != NONE)) && deepest.iter().any(|m| *m != deepest[0])
}

/// Sets `under` to `n` on every cell leaf below node `n`.
fn mark_cells(tree: &KdTree, n: u32, under: &mut [u32]) {
    let mut stack = vec![n];
    while let Some(m) = stack.pop() {
        let node = &tree.nodes[m as usize];
        if node.axis == CELL {
            under[m as usize] = n;
        } else {
            stack.extend(node.children.iter().filter(|&&c| c != NONE));
        }
    }
}

/// Every crossing edge with a cell in the tree, each once: from the first of its
/// cells in the tree, in the order of [`OWNER`].
fn crossing_edges(tree: &KdTree) -> Vec<Edge> {
    let tables = CellTables::get();
    let root = &tree.nodes[tree.root as usize];
    let (lo, hi) = (root.min.map(|v| v as i64), root.max.map(|v| v as i64));
    let in_tree = |c: [i64; 3]| (0..3).all(|a| c[a] >= lo[a] && c[a] < hi[a]);
    let mut edges = Vec::new();
    for n in &tree.nodes {
        if n.axis != CELL {
            continue;
        }
        let cc = tables.cell(n.config, n.mask);
        let coord = n.min.map(|v| v as i64);
        for d in 0..3 {
            let (u, v) = ((d + 1) % 3, (d + 2) % 3);
            for (k, &q) in OWNER.iter().enumerate() {
                // This cell is in quadrant q of the edge; its edge is the one at
                // the far side of the quadrant.
                let (qu, qv) = QUADRANT[q];
                if cc.edge_comp[edge_index(d, 1 - qu, 1 - qv)] == NO_COMP {
                    continue;
                }
                let mut line = coord;
                line[u] += 1 - qu as i64;
                line[v] += 1 - qv as i64;
                let cell_of = |q: usize| {
                    let mut c = line;
                    c[u] += QUADRANT[q].0 as i64 - 1;
                    c[v] += QUADRANT[q].1 as i64 - 1;
                    c
                };
                if OWNER[..k].iter().all(|&p| !in_tree(cell_of(p))) {
                    edges.push(Edge {
                        line: line.map(|x| x as u32),
                        d,
                    });
                }
            }
        }
    }
    edges
}

/// The order in which the cells around an edge own it.
const OWNER: [usize; 4] = [2, 1, 3, 0];

/// Marks a cell of the build's Hermite data outside the tree (a chunk's halo) in
/// [`Links::node_of`]: the rest of the word is its index in the data.
const HALO: u32 = 1 << 31;

/// What the guard looks up: each cell of the grid (a tree's cell leaf, or a cell
/// of the build's Hermite data outside the tree, whose vertex stands in for the
/// neighbouring chunk's at its finest) and each node's parent.
struct Links<'a> {
    h: &'a Hermite,
    /// The coarse cells across faces toward coarser chunks, which stand in for
    /// the halo's cells there.
    coarser: Option<&'a Coarser>,
    /// Per row of the grid along x (`y + cells.y * z`): its first cell in the
    /// data's cells (ordered by linear index), and one past the last row's.
    rows: Vec<u32>,
    /// Per cell of the data: its leaf node, or [`HALO`] with its own index.
    node_of: Vec<u32>,
    /// Per node: its parent, or [`NONE`] for the root.
    up: Vec<u32>,
    /// Per node: its depth (the root's is 0).
    depth: Vec<u16>,
    /// Per node: whether it or one of its ancestors may be a leaf, climbing
    /// clusterable nodes only (as [`climb`] does): a cell whose parent has
    /// none is its own polygon corner at every threshold.
    reach: Vec<bool>,
    /// Per component of the tree: its vertex and unit normal, decoded once
    /// (a big node's components are corners of many edges' polygons).
    placed: Vec<(Vec3, Vec3)>,
}

impl<'a> Links<'a> {
    fn new(tree: &KdTree, h: &'a Hermite, coarser: Option<&'a Coarser>) -> Self {
        let n = h.grid.cells;
        let row = |c: [u16; 3]| c[1] as usize + n.y as usize * c[2] as usize;
        let mut rows = vec![0u32; n.y as usize * n.z as usize + 1];
        for c in &h.cells {
            rows[row(c.coord) + 1] += 1;
        }
        for i in 1..rows.len() {
            rows[i] += rows[i - 1];
        }
        let mut node_of: Vec<u32> = (0..h.cells.len() as u32).map(|i| HALO | i).collect();
        let mut up = vec![NONE; tree.nodes.len()];
        let mut links = Links {
            h,
            coarser,
            rows,
            node_of: Vec::new(),
            up: Vec::new(),
            depth: Vec::new(),
            reach: Vec::new(),
            placed: Vec::new(),
        };
        for (i, node) in tree.nodes.iter().enumerate() {
            if node.axis == CELL {
                let at = links
                    .index(node.min.map(u32::from))
                    .expect("a cell of the data");
                node_of[at] = i as u32;
            }
            for &c in &node.children {
                if c != NONE {
                    up[c as usize] = i as u32;
                }
            }
        }
        // Parents come after their children: top down is back to front.
        let mut reach = vec![false; tree.nodes.len()];
        let mut depth = vec![0u16; tree.nodes.len()];
        for i in (0..tree.nodes.len()).rev() {
            let node = &tree.nodes[i];
            let above = up[i] != NONE && reach[up[i] as usize];
            reach[i] = node.clusterable && (node.leaf_ok || above);
            if up[i] != NONE {
                depth[i] = depth[up[i] as usize] + 1;
            }
        }
        let mut placed = vec![(Vec3::ZERO, Vec3::ZERO); tree.comps.len()];
        for (i, node) in tree.nodes.iter().enumerate() {
            let (lo, hi) = tree.node_box(i as u32);
            let start = node.comp_start as usize;
            for (k, c) in tree.comps[start..start + node.comp_count as usize]
                .iter()
                .enumerate()
            {
                placed[start + k] = (c.position(lo, hi), c.normal());
            }
        }
        links.placed = placed;
        links.node_of = node_of;
        links.up = up;
        links.depth = depth;
        links.reach = reach;
        links
    }

    /// The index of cell `c` in the data's cells (wrapped coordinates below the
    /// grid are past it), `None` when it is not active or not in the grid.
    fn index(&self, c: [u32; 3]) -> Option<usize> {
        let n = self.h.grid.cells;
        if c[0] >= n.x || c[1] >= n.y || c[2] >= n.z {
            return None;
        }
        let row = c[1] as usize + n.y as usize * c[2] as usize;
        let (start, end) = (self.rows[row] as usize, self.rows[row + 1] as usize);
        let x = c[0] as u16;
        self.h.cells[start..end]
            .binary_search_by_key(&x, |a| a.coord[0])
            .ok()
            .map(|k| start + k)
    }

    /// What is at cell `c`: its leaf node, [`HALO`] with its index in the data,
    /// or [`NONE`].
    fn at(&self, c: [u32; 3]) -> u32 {
        self.index(c).map_or(NONE, |i| self.node_of[i])
    }

    /// The depth of the deepest node above all of `cells` (tree nodes).
    fn shared_depth(&self, cells: [u32; 4]) -> u16 {
        let mut at = cells;
        let target = at
            .iter()
            .map(|&n| self.depth[n as usize])
            .min()
            .expect("four");
        for n in &mut at {
            while self.depth[*n as usize] > target {
                *n = self.up[*n as usize];
            }
        }
        while at.iter().any(|&n| n != at[0]) {
            for n in &mut at {
                *n = self.up[*n as usize];
            }
        }
        self.depth[at[0] as usize]
    }

    /// The patch of halo cell `i` (its index in the data) that edge `edge`
    /// belongs to; `None` when the edge does not cross in it.
    fn halo(&self, i: usize, edge: usize) -> Option<(usize, u8)> {
        let cell = self.h.cells[i];
        let local = CellTables::get().cell(cell.config, cell.mask).edge_comp[edge];
        (local != NO_COMP).then_some((i, local))
    }

    /// The rung of patch `local` of halo cell `i` (from [`Links::halo`]),
    /// standing in quadrant `q`.
    fn rung(&self, (i, local): (usize, u8), q: usize) -> Rung {
        let cell = self.h.cells[i];
        let p = cell.patch_base as usize + local as usize;
        Rung {
            node: NONE - q as u32,
            local,
            error: f32::NEG_INFINITY,
            pos: self.h.patch_vertex[p],
            normal: self.h.patch_normal[p].normalize_or_zero(),
        }
    }
}

/// Buffers one thread reuses from edge to edge.
#[derive(Default)]
struct Scratch {
    ladders: [Vec<Rung>; 4],
    /// The nodes this edge refused.
    refused: Vec<u32>,
}

/// Fills `rungs` with the nodes the corner of the edge in cell `n` can be at some
/// threshold, bottom up: the cell, then each ancestor that may be a leaf, up to
/// the first that is not clusterable or the first at depth `stop` or above
/// (where the edge's four cells all meet, its polygon has collapsed; -1 climbs
/// to the root). `false` when the edge does not cross in the cell.
fn climb(
    tree: &KdTree,
    links: &Links,
    n: u32,
    stop: i32,
    edge: usize,
    rungs: &mut Vec<Rung>,
) -> bool {
    rungs.clear();
    let leaf = &tree.nodes[n as usize];
    let mut local = CellTables::get().cell(leaf.config, leaf.mask).edge_comp[edge];
    if local == NO_COMP {
        return false;
    }
    rungs.push(Rung::bare(n, local, f32::NEG_INFINITY));
    let mut child = n;
    let mut p = links.up[n as usize];
    while p != NONE && links.depth[p as usize] as i32 > stop {
        let node = &tree.nodes[p as usize];
        // Above the tree's largest threshold no node is a leaf (errors never
        // decrease going up).
        if !node.clusterable || node.error > tree.max_threshold {
            break;
        }
        local = tree.comps[(tree.nodes[child as usize].comp_start + local as u32) as usize].parent;
        if node.leaf_ok {
            rungs.push(Rung::bare(p, local, node.error));
        }
        child = p;
        p = links.up[p as usize];
    }
    true
}

/// Sweeps the thresholds at which the polygon of `edge` changes, pushing onto
/// `s.refused` the nodes refused to keep every one of them facing the right way.
/// Returns the edge's four cells, or all [`NONE`] when one is not in the tree or
/// when no corner can ever be a clustered node (refusals only take rungs away, so
/// such an edge never needs looking at again).
fn check_edge(
    tree: &KdTree,
    links: &Links,
    edge: Edge,
    s: &mut Scratch,
    test: &Facing,
) -> [u32; 4] {
    let Edge { line, d } = edge;
    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
    let mut cells = [NONE; 4];
    // Corners outside the tree: a halo cell's, or across a face toward a
    // coarser chunk the coarse cell's the seam takes.
    let mut halo_rungs: [Option<Rung>; 4] = [None; 4];
    let mut reach = false;
    for (q, &(qu, qv)) in QUADRANT.iter().enumerate() {
        let mut c = line;
        // Wrapping: a cell below the grid's side is no cell at all.
        c[u] = (line[u] + qu).wrapping_sub(1);
        c[v] = (line[v] + qv).wrapping_sub(1);
        match links.at(c) {
            NONE => return [NONE; 4],
            x if x & HALO != 0 => {
                let found = links.halo((x & !HALO) as usize, edge_index(d, 1 - qu, 1 - qv));
                let Some(found) = found else {
                    return [NONE; 4];
                };
                let coarse = links.coarser.and_then(|k| k.corner(c, line, d, q));
                halo_rungs[q] = Some(match coarse {
                    Some(k) => Rung {
                        node: k.id,
                        local: 0,
                        error: f32::NEG_INFINITY,
                        pos: k.pos,
                        normal: k.normal,
                    },
                    None => links.rung(found, q),
                });
            }
            n => {
                cells[q] = n;
                let up = links.up[n as usize];
                reach |= up != NONE && links.reach[up as usize];
            }
        }
    }
    // No cell has an ancestor that may be a leaf: no clustered node at any
    // corner, ever.
    if !reach {
        return [NONE; 4];
    }
    // Where the four cells meet (above it the polygon has collapsed); with a
    // cell outside the tree, nowhere: climb to the root.
    let stop = if cells.contains(&NONE) {
        -1
    } else {
        links.shared_depth(cells) as i32
    };
    for (q, &(qu, qv)) in QUADRANT.iter().enumerate() {
        if halo_rungs[q].is_some() {
            s.ladders[q].clear();
        } else if !climb(
            tree,
            links,
            cells[q],
            stop,
            edge_index(d, 1 - qu, 1 - qv),
            &mut s.ladders[q],
        ) {
            return [NONE; 4];
        }
    }
    // No clustered node at any corner: the polygon is Dual Marching Cubes' at
    // every threshold, nothing to refuse.
    if s.ladders.iter().all(|l| l.len() <= 1) {
        return [NONE; 4];
    }
    for (q, l) in s.ladders.iter_mut().enumerate() {
        match halo_rungs[q] {
            Some(r) => l.push(r),
            None => l.iter_mut().for_each(|r| r.place(tree, links)),
        }
    }
    let inside_low = !tree.is_outside(line);
    // Per corner, its current rung: the highest within the threshold. Each
    // ladder's errors grow going up, so the thresholds at which the polygon
    // changes are those of the corners' next rungs, lowest first: the four
    // ladders are merged as the sweep goes. It starts at the tree's smallest
    // threshold: no cut is lower, so the polygons below it are never shown.
    let mut at = [0usize; 4];
    let mut t = tree.min_threshold;
    let climb_to = |at: &mut [usize; 4], t: f32, ladders: &[Vec<Rung>; 4]| {
        for (q, l) in ladders.iter().enumerate() {
            while at[q] + 1 < l.len() && l[at[q] + 1].error <= t {
                at[q] += 1;
            }
        }
    };
    climb_to(&mut at, t, &s.ladders);
    // The polygon at the smallest threshold, when a corner already climbed to
    // it, is checked first (as if each corner climbed there at once).
    let mut start = at != [0; 4];
    loop {
        let before = if start {
            [0; 4]
        } else {
            let next = (0..4).filter_map(|q| s.ladders[q].get(at[q] + 1).map(|r| r.error));
            let Some(next) = next.min_by(f32::total_cmp) else {
                break;
            };
            t = next;
            let before = at;
            climb_to(&mut at, t, &s.ladders);
            // No corner can climb (the errors left are not numbers).
            if at == before {
                break;
            }
            before
        };
        start = false;
        // Two corners in one leaf stay in one leaf as the threshold grows (their
        // paths above it are the same): once the polygon has collapsed to fewer
        // than three corners, it never comes back.
        if collapsed([0, 1, 2, 3].map(|q| s.ladders[q][at[q]])) {
            break;
        }
        // The corners that climbed at this threshold (to the merge that may fold).
        let mut climbed = [0, 1, 2, 3].map(|q| at[q] != before[q]);
        loop {
            let leaves = [0, 1, 2, 3].map(|q| s.ladders[q][at[q]]);
            if faces(leaves, d, inside_low, test) {
                break;
            }
            // Refuse the largest clustered leaf among the corners that just
            // climbed (else among all), and look again.
            let clustered = |q: &usize| {
                tree.nodes
                    .get(leaves[*q].node as usize)
                    .is_some_and(|n| n.axis != CELL)
            };
            let largest = |q: &usize| {
                let r = leaves[*q];
                (volume(&tree.nodes[r.node as usize]), r.node)
            };
            let pick = (0..4)
                .filter(|q| climbed[*q])
                .filter(clustered)
                .max_by_key(largest)
                .or_else(|| (0..4).filter(clustered).max_by_key(largest));
            let Some(q) = pick else {
                break;
            };
            climbed = [false; 4];
            let big = leaves[q];
            let big = big.node;
            s.refused.push(big);
            for (q, l) in s.ladders.iter_mut().enumerate() {
                if l.iter().any(|r| r.node == big) {
                    l.retain(|r| r.node != big);
                    at[q] = l.iter().rposition(|r| r.error <= t).unwrap_or(0);
                }
            }
        }
    }
    cells
}

/// Whether the corners `at` (in quadrant order) are fewer than three distinct
/// leaves: the edge has no polygon.
fn collapsed(at: [Rung; 4]) -> bool {
    (0..4)
        .filter(|&i| (at[i].node, at[i].local) != (at[(i + 3) % 4].node, at[(i + 3) % 4].local))
        .count()
        < 3
}

/// Cells in a node's box.
fn volume(n: &KdNode) -> u64 {
    (0..3).map(|a| (n.max[a] - n.min[a]) as u64).product()
}

/// Whether the polygon of the leaves `at` (in quadrant order) faces the way its
/// edge along `d` crosses the surface ([`Facing::polygon`]).
fn faces(at: [Rung; 4], d: usize, inside_low: bool, test: &Facing) -> bool {
    let mut poly = at;
    let mut facing = Vec3::ZERO;
    facing[d] = 1.0;
    if !inside_low {
        poly.reverse();
        facing = -facing;
    }
    let mut pts = [(Vec3::ZERO, Vec3::ZERO); 4];
    let mut k = 0;
    for i in 0..4 {
        let (a, b) = (poly[i], poly[(i + 3) % 4]);
        if (a.node, a.local) != (b.node, b.local) {
            pts[k] = (a.pos, a.normal);
            k += 1;
        }
    }
    k < 3 || test.polygon(&pts[..k], facing, |_| true)
}
