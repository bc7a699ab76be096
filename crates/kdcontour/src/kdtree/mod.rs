//! The discrete k-d tree (sections 4 to 6 of the paper): built once from Hermite
//! data, retained, and contoured at any error threshold without re-sampling.
//!
//! Which file holds which algorithm:
//! - `mod.rs` (here): the retained tree ([`KdTree`], `KdNode`) and its queries.
//! - `build.rs`: the build driver, the top-down recursion of section 4.3 over
//!   per-task node arenas (parallel near the root, the same tree on any thread
//!   count) and cell leaves; `arena.rs` what one build works in. [`KdTree::build`]
//!   (the one way to build a tree) runs the stages of [`crate::pipeline`].
//! - `split.rs`: the split search of section 4.3, the axis and the plane of
//!   equal-`E1` halves by binary search over probes of slab prefix sums, with the
//!   shortcut for flat nodes.
//! - `cluster.rs`: the bottom-up topology-preserving clustering of section 5, run on
//!   each node as the recursion returns.
//! - `fold.rs`: the geometric test a clustered node passes before it may be a
//!   leaf (its dual polygons must not fold against its finest neighbours).
//! - `contour.rs`: contouring at a threshold (section 6): a tree's inside edge by
//!   edge from its cells' leaves, seams between trees by `face_proc` and
//!   `edge_proc`.
//!
//! [`Comp`] (the packed dual vertex, [`crate::comp`]) and [`Partition`] (a setting,
//! [`crate::settings`]) live below this module and are re-exported here.

mod arena;
mod borders;
mod build;
mod cluster;
mod coarser;
mod contour;
mod fold;
mod paint;
mod split;

use crate::grid::Grid;
use glam::Vec3;

pub(crate) use crate::comp::Comp;
pub use crate::settings::Partition;
pub(crate) use build::build_in;
pub(crate) use coarser::Coarser;
pub(crate) use contour::{contour, Job, Part};
pub(crate) use paint::paint_tree;

/// Marks a missing child (an empty box pruned during construction).
pub(crate) const NONE: u32 = u32::MAX;
/// [`KdNode::axis`] of a 1x1x1 cell leaf.
pub(crate) const CELL: u8 = 3;

/// One node of the retained tree: a box of cells, split on `axis` at `split`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct KdNode {
    /// Lowest corner (cell coordinates).
    pub(crate) min: [u16; 3],
    /// Highest corner (exclusive cell coordinates = corner coordinates).
    pub(crate) max: [u16; 3],
    /// Low and high child, or [`NONE`].
    pub(crate) children: [u32; 2],
    /// Split axis 0..3, or [`CELL`] for a 1x1x1 leaf.
    pub(crate) axis: u8,
    /// Cell leaves: the corner signs (see [`crate::cell`]).
    pub(crate) config: u8,
    /// Cell leaves: the face resolution mask.
    pub(crate) mask: u8,
    /// Number of surface components (0 when not clusterable).
    pub(crate) comp_count: u8,
    /// Split plane position (absolute cell coordinate).
    pub(crate) split: u16,
    /// Whether the node may stand in for its subtree (section 5).
    pub(crate) clusterable: bool,
    /// Whether the partition lets the node be a leaf (the octree baseline only
    /// allows whole octree cells; the k-d tree allows every clusterable node).
    pub(crate) leaf_ok: bool,
    /// Index of the first component in [`KdTree::comps`].
    pub(crate) comp_start: u32,
    /// Largest QEF residual of any component at or below this node (squared grid
    /// units); infinite when not clusterable. Never smaller than a child's.
    pub(crate) error: f32,
}

/// Times and sizes of one build.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Sampling the field and finding crossings (ms).
    pub sample_ms: f64,
    /// Building and clustering the tree (ms).
    pub build_ms: f64,
    /// Active cells.
    pub active_cells: usize,
    /// Edges with a sign change.
    pub crossings: usize,
}

/// The retained discrete k-d tree of one grid.
#[derive(Clone)]
pub struct KdTree {
    /// The grid it was built on.
    pub(crate) grid: Grid,
    /// All nodes; children come before their parent.
    pub(crate) nodes: Vec<KdNode>,
    /// Components of all clusterable nodes.
    pub(crate) comps: Vec<Comp>,
    /// The root, or [`NONE`] when the volume has no surface.
    pub(crate) root: u32,
    /// One bit per grid corner: set when outside.
    pub(crate) outside: Vec<u64>,
    /// How the build went.
    pub(crate) stats: BuildStats,
    /// Per component, when the field has materials: the material at its vertex
    /// for every component some threshold makes a leaf (painted by the
    /// pipeline, [`crate::pipeline::tree`]), the default blend for the others;
    /// empty otherwise. Contouring gives each vertex its component's.
    pub(crate) materials: Vec<crate::material::MaterialBlend>,
    /// The largest threshold it is cut at ([`crate::Settings::max_threshold`]).
    pub(crate) max_threshold: f32,
    /// The smallest threshold it is cut at ([`crate::Settings::min_threshold`]).
    pub(crate) min_threshold: f32,
}

impl std::fmt::Debug for KdTree {
    /// The grid and the tree's size (not its nodes).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KdTree")
            .field("grid", &self.grid)
            .field("nodes", &self.nodes.len())
            .field("components", &self.comps.len())
            .finish_non_exhaustive()
    }
}

impl PartialEq for KdTree {
    /// The same tree: grid, nodes, components, signs and materials (build times
    /// aside).
    fn eq(&self, other: &Self) -> bool {
        self.grid == other.grid
            && self.nodes == other.nodes
            && self.comps == other.comps
            && self.root == other.root
            && self.outside == other.outside
            && self.materials == other.materials
    }
}

impl KdTree {
    /// The grid it was built on.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Nodes in the tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Surface components (dual vertices) of all clusterable nodes.
    pub fn component_count(&self) -> usize {
        self.comps.len()
    }

    /// Whether the grid holds any surface (the tree has a root).
    pub fn has_surface(&self) -> bool {
        self.root != NONE
    }

    /// The largest threshold it is cut at: no node whose error is above it is a
    /// leaf, so a cut at any higher threshold is the cut at this one
    /// ([`crate::Settings::max_threshold`]).
    pub fn max_threshold(&self) -> f32 {
        self.max_threshold
    }

    /// The smallest threshold it is cut at: a cut at any lower threshold is the
    /// cut at this one ([`crate::Settings::min_threshold`]).
    pub fn min_threshold(&self) -> f32 {
        self.min_threshold
    }

    /// How the build went (times and sizes).
    pub fn stats(&self) -> BuildStats {
        self.stats
    }

    /// Per component, when the field has materials: the material at its vertex
    /// for every component some threshold makes a leaf (the default blend for
    /// components no threshold reaches); empty otherwise.
    pub fn materials(&self) -> &[crate::material::MaterialBlend] {
        &self.materials
    }

    /// Whether corner `c` is outside.
    #[inline]
    pub(crate) fn is_outside(&self, c: [u32; 3]) -> bool {
        let i = self.grid.corner_index(c[0], c[1], c[2]);
        self.outside[i / 64] >> (i % 64) & 1 == 1
    }

    /// Bytes held by the retained tree (nodes, components and sign bits).
    pub fn retained_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<KdNode>()
            + self.comps.capacity() * std::mem::size_of::<Comp>()
            + self.materials.capacity() * std::mem::size_of::<crate::material::MaterialBlend>()
            + self.outside.capacity() * 8
    }

    /// Whether node `n` is a leaf at threshold `e` (no lower than the tree's
    /// smallest, [`KdTree::min_threshold`]): a cell, or clusterable with error
    /// at most `e`.
    #[inline]
    pub(crate) fn is_leaf(&self, n: u32, e: f32) -> bool {
        let node = &self.nodes[n as usize];
        let e = e.max(self.min_threshold);
        node.axis == CELL || (node.clusterable && node.leaf_ok && node.error <= e)
    }

    /// Component (index within node `x`) of the patch of fine cell `cell` that edge
    /// `edge` of the cell belongs to. `x` must be clusterable and contain `cell`.
    pub(crate) fn comp_of(&self, x: u32, cell: [u32; 3], edge: usize) -> u8 {
        comp_in(&self.nodes, |i| self.comps[i].parent, x, cell, edge)
    }

    /// The box `[lo, hi]` (grid units) of node `n`.
    #[inline]
    pub(crate) fn node_box(&self, n: u32) -> (Vec3, Vec3) {
        let node = &self.nodes[n as usize];
        (
            Vec3::new(node.min[0] as f32, node.min[1] as f32, node.min[2] as f32),
            Vec3::new(node.max[0] as f32, node.max[1] as f32, node.max[2] as f32),
        )
    }

    /// Vertex (grid units) of component `local` of node `n`.
    pub(crate) fn comp_position(&self, n: u32, local: u8) -> Vec3 {
        let (lo, hi) = self.node_box(n);
        self.comps[(self.nodes[n as usize].comp_start + local as u32) as usize].position(lo, hi)
    }
}

/// Walks from clusterable node `x` down to `cell`, then back up through the
/// components' `parent` links.
pub(crate) fn comp_in(
    nodes: &[KdNode],
    parent_of: impl Fn(usize) -> u8,
    x: u32,
    cell: [u32; 3],
    edge: usize,
) -> u8 {
    // Most clustered nodes have one component: nothing to look up.
    if nodes[x as usize].comp_count == 1 {
        return 0;
    }
    thread_local! {
        // The descent path, reused across calls (no allocation on this hot path,
        // and no fixed depth limit: a k-d tree has no hard bound on its depth).
        static PATH: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    PATH.with(|path| {
        let mut path = path.borrow_mut();
        path.clear();
        let mut n = x;
        loop {
            let node = &nodes[n as usize];
            if node.axis == CELL {
                break;
            }
            let a = node.axis as usize;
            let side = (cell[a] >= node.split as u32) as usize;
            path.push(n);
            n = node.children[side];
            debug_assert!(n != NONE, "cell {cell:?} is not in the subtree");
        }
        let node = &nodes[n as usize];
        let mut local = crate::cell::CellTables::get()
            .cell(node.config, node.mask)
            .edge_comp[edge];
        debug_assert!(local != crate::cell::NO_COMP);
        // Walk up from the cell to just below x.
        let mut child = n;
        while let Some(parent) = path.pop() {
            local = parent_of((nodes[child as usize].comp_start + local as u32) as usize);
            child = parent;
        }
        local
    })
}
