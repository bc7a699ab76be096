//! The chunk world: chunks keyed by [`ChunkKey`] (a level and a position), each a
//! retained k-d tree over its own box of cells, cut at its own threshold, with the
//! seams between neighbours contoured by `face_proc` and `edge_proc` across the
//! chunk roots. The seam walk meets each tree at its own cut, so neighbours at
//! different thresholds and levels join with no cracks, skirts, transition cells or
//! shader tricks.
//!
//! One type serves every kind of volume; only its [`Layout`] differs:
//! - a **bounded** world ([`World::bounded`]) is a one-level layout that tiles an
//!   `X x Y x Z` block of chunks;
//! - an **unbounded** world ([`World::unbounded`]) has an open layout whose level-0
//!   chunks come and go ([`World::add_chunk`], [`World::remove_chunk`]): terrain
//!   streamed around a camera. A seam whose neighbour is missing is left open, so
//!   its mesh is open at the edge of what is loaded;
//! - a **level** world ([`World::new`] with a layout of several levels, or
//!   [`World::set_layout`]) has chunks whose cells double with distance: a chunk at
//!   level `k` has cells of side `cell_size * 2^k` and the same `chunk_res` cells
//!   per side, so it covers `2^k` level-0 chunks per axis.
//!
//! All levels sit on one lattice: a level-`k` sample is the level-0 lattice point
//! `2^k` times its index, computed in the same way at every level, so where two
//! chunks' samples coincide they are bitwise the same ([`Grid::offset`]). Chunks
//! sample one extra cell around their box on every side (the halo), whose cells decide
//! how the chunk's boundary cells resolve ambiguous faces, so both chunks that share
//! a face resolve it the same way.
//!
//! ## Seam ownership
//! - A **face seam** (two chunks whose faces overlap) belongs to the finer chunk;
//!   between equal levels to the lower one.
//! - An **edge seam** (the chunks around a stretch of a chunk edge, in quadrant
//!   order; a coarser chunk may fill two quadrants) belongs to its finest chunk, the
//!   first in quadrant order among equals: between equal levels, the lowest.
//!
//! A chunk's mesh is its interior plus the seams it owns ([`World::snapshot`],
//! [`World::extract_interior`], [`World::extract_seams`]). When chunk `c` changes
//! (new threshold, or rebuilt after an edit), re-extract `c` and the chunks in
//! [`World::seam_owners_touching`]`(c)`. A threshold change never re-samples the
//! field.
//!
//! ## Level seams
//! Where a chunk meets one a level coarser, the finer side sees lattice points the
//! coarse side does not: the midpoints of coarse edges and the centers of coarse
//! faces. Two rules make both sides see one contour on the shared boundary:
//!
//! 1. **The finer side conforms.** On the closed box of a coarser neighbour, a
//!    coarse edge's midpoint keeps the field's sign when the coarse edge has a
//!    crossing (the fine crossing then lies in the half that holds the field's
//!    root, so it is found on the field) and takes its ends' sign when it has
//!    none: a coarse edge has one fine crossing exactly when it has a crossing. A
//!    coarse face's center is inside when the face is ambiguous; otherwise it
//!    keeps the field's sign where that leaves no fine quarter of the face
//!    ambiguous and joins it to a midpoint, and takes a sign that does where
//!    the field's does not ([`conform`]): a center forced against the field
//!    pulls the fine contour, and the vertices of the four cells around it,
//!    off the surface. The fine contour on a coarse face then runs
//!    between the same coarse edges as the coarse contour: one segment stays one
//!    curve, and an ambiguous face joins its inside corners through the center.
//!    Every chunk of the finer level computes the same samples there, so fine
//!    neighbours agree too.
//! 2. **Both sides separate.** Across a face whose neighbours are at another
//!    level, a chunk's halo samples are inside, so every ambiguous face on a level
//!    seam, coarse or fine, separates its outside corners and joins its inside
//!    ones: the resolution rule 1 gives the coarse faces.
//!
//! And two rules keep merged leaves from folding those seams: **the coarser side
//! keeps cells.** A chunk's leaves on a face toward finer chunks are cells at every
//! threshold ([`crate::pipeline::Cells::Core`]): its fold guard sees the cells
//! across at its own cell size, which the finer chunk's are not, so merged
//! leaves there folded seam polygons that no guard saw. Its threshold then never
//! changes those seams. **The finer side's guard sees the coarse cells.** A chunk
//! samples the coarse cells across each face toward a coarser chunk from the
//! field (a slab along the face) and its fold guard holds the seam polygons to
//! them, each fine edge mapped to its coarse cell as the seam walk maps it
//! (`kdtree/coarser.rs`).
//!
//! The seam walk (`kdtree/contour.rs`) places every chunk on the level-0
//! lattice with its own shift: a coarse node's box is its cells times `2^level`. It
//! reads a seam line's signs from the finest tree around it, steps along it by that
//! tree's cells, and maps each fine crossing to each quadrant's leaf: on a coarse
//! edge to that edge; through the middle of a coarse face (a fine edge from a coarse
//! edge's midpoint to the face center) to the coarse edge through that midpoint
//! when it crosses, else to any crossing edge of the face (which then holds a
//! single segment).
//!
//! Chunks whose neighbourhood ([`Neighbourhood`]) changes with a new layout are
//! rebuilt: [`World::set_layout`] lists them. A level world keeps the field's
//! samples each chunk was built from and the crossings found on them
//! ([`World::keep_samples`]), so such a rebuild applies the rules above to its
//! kept samples instead of sampling the field again, and searches the field
//! only along the edges whose samples the rules changed (the others take their
//! kept crossing: [`crate::hermite::KeptCrossings`]), and a chunk where no
//! corner's sign and no crossing edge's samples changed keeps its tree; the tree
//! is the one a build from scratch gives. An edit drops the samples and crossings it reaches
//! ([`World::edited`]).
//!
//! A chunk whose field bound ([`crate::Field::bound`]) proves all of its samples to be of
//! one sign (sky far above a terrain, rock far below it) is not sampled: its tree
//! is built from the signs alone and is the tree sampling would build, with no
//! surface.

mod build;
pub mod conform;
pub mod layout;
mod lod;
mod seams;

pub use conform::{BuiltChunk, ChunkBuild, Neighbourhood};
pub use layout::{ChunkKey, ChunkMap, ChunkSet, KeyHasher, Layout};
pub use lod::Lod;
pub use seams::{ChunkSnapshot, Seam};

use crate::error::{Error, Result};

use crate::grid::Grid;
use crate::hermite::KeptCrossings;
use crate::kdtree::KdTree;
use crate::settings::Settings;
use conform::level_grid;
use glam::{IVec3, UVec3, Vec3};
use std::sync::Arc;

/// Largest `|chunk coordinate| * chunk_res` on any axis: lattice coordinates stay
/// well inside `i32`.
const MAX_LATTICE: i64 = 1 << 30;

/// One chunk: its tree (once built), the neighbourhood it was built for, its
/// threshold, and the field's samples it was built from (when kept).
struct Slot {
    tree: Option<Arc<KdTree>>,
    built_for: Neighbourhood,
    threshold: f32,
    samples: Option<Arc<[f32]>>,
    /// The crossings found on `samples`.
    crossings: Option<Arc<KeptCrossings>>,
}

impl Slot {
    /// Bytes held by the chunk's tree, kept samples and crossings.
    fn retained_bytes(&self) -> usize {
        self.tree.as_ref().map_or(0, |t| t.retained_bytes())
            + self
                .samples
                .as_ref()
                .map_or(0, |v| std::mem::size_of_val(&**v))
            + self.crossings.as_ref().map_or(0, |c| c.retained_bytes())
    }
}

/// A layout with every chunk's neighbourhood worked out, checked and ready to
/// install with [`World::set_prepared`]: the costly part of a layout change,
/// which can run on another thread.
#[derive(Clone, Debug)]
pub struct PreparedLayout {
    layout: Layout,
    neighbourhoods: ChunkMap<Neighbourhood>,
}

impl PreparedLayout {
    /// Checks `layout` ([`Layout::check`]) and works out its neighbourhoods.
    pub fn new(layout: Layout) -> Result<Self> {
        layout.check()?;
        let neighbourhoods = layout
            .chunks()
            .into_iter()
            .map(|k| (k, Neighbourhood::of(&layout, &k)))
            .collect();
        Ok(PreparedLayout {
            layout,
            neighbourhoods,
        })
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
}

/// A world of chunks with retained trees and per-chunk thresholds (see the
/// module docs).
pub struct World {
    /// World position of lattice corner (0, 0, 0).
    pub origin: Vec3,
    /// Side of a level-0 cell (world units).
    pub cell_size: f32,
    /// Cells per chunk along each axis, at every level (even in a layout of
    /// several levels).
    pub chunk_res: u32,
    /// Build settings used for every chunk.
    pub settings: Settings,
    /// Keep each chunk's field samples and the crossings found on them, so a
    /// chunk rebuilt because a neighbour changed level is conformed again
    /// without sampling the field and searches only the edges whose samples
    /// changed, or keeps its tree when none did (true for [`World::new`],
    /// false for one-level worlds, whose neighbours never change level). Costs
    /// `(chunk_res + 3)^3` floats and bits and 32 bytes per crossing per
    /// sampled chunk (counted in
    /// [`World::retained_bytes`]). After the field changes, drop them with
    /// [`World::edited`] or [`World::forget_samples`].
    pub keep_samples: bool,
    layout: Layout,
    neighbourhoods: ChunkMap<Neighbourhood>,
    default_threshold: f32,
    slots: ChunkMap<Slot>,
}

impl World {
    /// A world over `layout` (of one level or several), no chunk built yet; every
    /// chunk starts at `threshold`, and chunks keep their samples
    /// ([`World::keep_samples`]).
    pub fn new(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        layout: Layout,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        let mut world = Self::empty(origin, cell_size, chunk_res, threshold, settings)?;
        world.keep_samples = true;
        world.set_layout(layout)?;
        Ok(world)
    }

    /// A bounded one-level world of `chunks` (X x Y x Z) chunks from chunk
    /// `(0, 0, 0)`, none built yet. Every chunk starts at `threshold`. A world over
    /// `settings.memory_budget` ([`World::check_budget`]) is refused here.
    pub fn bounded(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        chunks: UVec3,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        if chunks.min_element() == 0
            || chunks.x as u64 * chunks.y as u64 * chunks.z as u64 > 1 << 24
        {
            return Err(Error::InvalidSetting {
                name: "chunks",
                reason: format!(
                    "{chunks}: each axis needs at least one chunk, at most 2^24 in all"
                ),
            });
        }
        let mut world = Self::empty(origin, cell_size, chunk_res, threshold, settings)?;
        if chunks.max_element() as i64 * chunk_res as i64 > MAX_LATTICE {
            return Err(Error::InvalidSetting {
                name: "chunks",
                reason: format!("{chunks} chunks of {chunk_res} cells exceed 2^30 cells"),
            });
        }
        // Before the layout is made: a refused world allocates nothing.
        Self::check_region(chunks, chunk_res, &world.settings)?;
        let layout = Layout::uniform(IVec3::ZERO, chunks.as_ivec3(), 0)?;
        world.set_layout(layout)?;
        Ok(world)
    }

    /// An unbounded one-level world with no chunks (an open layout); add them
    /// with [`World::add_chunk`]. New chunks start at `threshold`.
    pub fn unbounded(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        Self::empty(origin, cell_size, chunk_res, threshold, settings)
    }

    /// A world with an open layout and no chunk, its settings checked.
    fn empty(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        if !(1..=4096).contains(&chunk_res) {
            return Err(Error::InvalidSetting {
                name: "chunk_res",
                reason: format!("{chunk_res} cells per chunk; allowed 1 to 4096"),
            });
        }
        check_threshold(threshold)?;
        let world = World {
            origin,
            cell_size,
            chunk_res,
            settings,
            keep_samples: false,
            layout: Layout::open(),
            neighbourhoods: ChunkMap::default(),
            default_threshold: threshold,
            slots: ChunkMap::default(),
        };
        world
            .chunk_grid(&ChunkKey::new(0, IVec3::ZERO))
            .validate()?;
        Ok(world)
    }

    /// Checks a world of `layout`'s chunks against `settings.memory_budget`
    /// before any is built: one slot per chunk, one chunk build per worker thread
    /// (each build checks its own grid again before sampling), and for a layout
    /// of one level that tiles a region, the trees of a surface as large as the
    /// faces of that region. [`World::set_layout`] calls it; call
    /// [`World::check_chunk_count`] before making a large layout.
    pub fn check_budget(layout: &Layout, chunk_res: u32, settings: &Settings) -> Result<()> {
        if layout.max_level() == 0 && !layout.is_open() {
            let extent = (layout.hi() - layout.lo()).as_uvec3();
            return Self::check_region(extent, chunk_res, settings);
        }
        Self::check_chunk_count(layout.len() as u64, chunk_res, settings)
    }

    /// [`World::check_budget`] for a one-level region of `extent` chunks.
    fn check_region(extent: UVec3, chunk_res: u32, settings: &Settings) -> Result<()> {
        let what = format!(
            "a world of {}x{}x{} chunks of {chunk_res}^3 cells",
            extent.x, extent.y, extent.z
        );
        let surface = crate::hermite::surface_bytes(extent.as_u64vec3() * chunk_res as u64);
        let chunks = extent.as_u64vec3().element_product();
        Self::check_needed(what, chunks, surface, chunk_res, settings)
    }

    /// [`World::check_budget`] for `chunks` chunks of several levels, before
    /// their layout is made (the level-0 chunk count of a region bounds any
    /// layout over it). Every chunk has `chunk_res`^3 cells whatever its level,
    /// so such a world's memory is per chunk, not per level-0 cell of its region
    /// (a 4,096-cell view's region is 12,288 cells wide but holds ~1,500 chunks).
    pub fn check_chunk_count(chunks: u64, chunk_res: u32, settings: &Settings) -> Result<()> {
        let what = format!("a world of {chunks} chunks of {chunk_res}^3 cells");
        Self::check_needed(what, chunks, 0, chunk_res, settings)
    }

    fn check_needed(
        what: String,
        chunks: u64,
        surface: u64,
        chunk_res: u32,
        settings: &Settings,
    ) -> Result<()> {
        let grid = level_grid(Vec3::ZERO, 1.0, chunk_res, &ChunkKey::new(0, IVec3::ZERO));
        let threads = match settings.threads {
            0 => rayon::current_num_threads(),
            n => n,
        } as u64;
        let entry = (std::mem::size_of::<(ChunkKey, Slot)>()
            + std::mem::size_of::<(ChunkKey, Neighbourhood)>()
            + 2) as u64;
        let needed = chunks
            .saturating_mul(entry)
            .saturating_add(surface)
            .saturating_add(threads.saturating_mul(crate::hermite::estimate_bytes(&grid)));
        crate::settings::check_budget(what, needed, settings.memory_budget)
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Replaces the layout. Chunks that leave it are dropped, new ones start
    /// unbuilt at the default threshold, kept ones keep their tree and threshold.
    /// Returns the chunks to (re)build: the new ones and the kept ones whose
    /// neighbourhood changed (see [`World::stale`]).
    pub fn set_layout(&mut self, layout: Layout) -> Result<Vec<ChunkKey>> {
        self.set_prepared(PreparedLayout::new(layout)?)
    }

    /// [`World::set_layout`] with the layout prepared beforehand (perhaps on
    /// another thread): only the bookkeeping is left.
    pub fn set_prepared(&mut self, prepared: PreparedLayout) -> Result<Vec<ChunkKey>> {
        let PreparedLayout {
            layout,
            neighbourhoods,
        } = prepared;
        if layout.max_level() > 0 && !self.chunk_res.is_multiple_of(2) {
            return Err(Error::InvalidSetting {
                name: "chunk_res",
                reason: format!(
                    "{} cells per chunk; a layout of several levels needs an even count",
                    self.chunk_res
                ),
            });
        }
        let far =
            layout.lo().abs().max(layout.hi().abs()).max_element() as i64 * self.chunk_res as i64;
        if far >= MAX_LATTICE {
            return Err(Error::InvalidSetting {
                name: "layout",
                reason: format!(
                    "{}..{} is more than 2^30 cells out",
                    layout.lo(),
                    layout.hi()
                ),
            });
        }
        Self::check_budget(&layout, self.chunk_res, &self.settings)?;
        // Trees and samples of the chunks that leave, and the old neighbourhoods,
        // are freed on a rayon thread: thousands of buffers are a few ms.
        let removed: Vec<Slot> = self
            .slots
            .extract_if(|k, _| !layout.contains(k))
            .map(|(_, s)| s)
            .collect();
        for &k in neighbourhoods.keys() {
            self.slots.entry(k).or_insert(Slot {
                tree: None,
                built_for: Neighbourhood::default(),
                threshold: self.default_threshold,
                samples: None,
                crossings: None,
            });
        }
        self.layout = layout;
        let old = std::mem::replace(&mut self.neighbourhoods, neighbourhoods);
        drop_elsewhere((removed, old));
        Ok(self.stale())
    }

    /// Makes level-0 chunk `c` a member of an open layout (unbuilt, at the default
    /// threshold). Returns whether it is new. Errors when the layout is not open
    /// and `c` is not already one of its chunks, or when `c` is so far out that
    /// its lattice coordinates would overflow.
    pub fn add_chunk(&mut self, c: IVec3) -> Result<bool> {
        let k = ChunkKey::new(0, c);
        if !self.layout.is_open() {
            if self.layout.contains(&k) {
                return Ok(false);
            }
            return Err(Error::InvalidSetting {
                name: "chunk",
                reason: format!(
                    "{c} is outside the bounded world's {}..{} chunks",
                    self.layout.lo(),
                    self.layout.hi()
                ),
            });
        }
        let far = c.abs().max_element() as i64 * self.chunk_res as i64;
        if far >= MAX_LATTICE {
            return Err(Error::InvalidSetting {
                name: "chunk",
                reason: format!("{c} is more than 2^30 cells from the origin"),
            });
        }
        if !self.layout.insert(k) {
            return Ok(false);
        }
        self.neighbourhoods.insert(k, Neighbourhood::default());
        self.slots.insert(
            k,
            Slot {
                tree: None,
                built_for: Neighbourhood::default(),
                threshold: self.default_threshold,
                samples: None,
                crossings: None,
            },
        );
        Ok(true)
    }

    /// Drops chunk `k` of an open layout and its tree. Returns whether it was a
    /// member. The seams of [`World::seam_owners_touching`]`(k)`, computed before
    /// the call, need re-extracting: they lose the triangles that joined `k`.
    pub fn remove_chunk(&mut self, k: &ChunkKey) -> bool {
        if !self.layout.is_open() || !self.layout.remove(k) {
            return false;
        }
        self.neighbourhoods.remove(k);
        if let Some(s) = self.slots.remove(k) {
            drop_elsewhere(s);
        }
        true
    }

    /// The chunks without a tree, or whose tree was built for another
    /// neighbourhood than the layout now gives them, in layout order.
    pub fn stale(&self) -> Vec<ChunkKey> {
        self.layout
            .chunks()
            .into_iter()
            .filter(|k| {
                let s = &self.slots[k];
                s.tree.is_none() || s.built_for != self.neighbourhoods[k]
            })
            .collect()
    }

    /// Every chunk, in layout order ([`ChunkKey::order`]: z, then y, then x).
    pub fn chunks(&self) -> Vec<ChunkKey> {
        self.layout.chunks()
    }

    /// Number of chunks (built or not).
    pub fn len(&self) -> usize {
        self.layout.len()
    }

    /// Whether the world has no chunk.
    pub fn is_empty(&self) -> bool {
        self.layout.is_empty()
    }

    /// Whether `k` is one of the world's chunks.
    pub fn contains(&self, k: &ChunkKey) -> bool {
        self.layout.contains(k)
    }

    fn slot(&self, k: &ChunkKey) -> &Slot {
        self.slots
            .get(k)
            .unwrap_or_else(|| panic!("chunk {k:?} is not in the world"))
    }

    fn slot_mut(&mut self, k: &ChunkKey) -> &mut Slot {
        self.slots
            .get_mut(k)
            .unwrap_or_else(|| panic!("chunk {k:?} is not in the world"))
    }

    /// The grid chunk `k` samples: its cells plus one cell of halo on every side.
    pub fn chunk_grid(&self, k: &ChunkKey) -> Grid {
        level_grid(self.origin, self.cell_size, self.chunk_res, k)
    }

    /// The world box of chunk `k` (min, max).
    pub fn chunk_bounds(&self, k: &ChunkKey) -> (Vec3, Vec3) {
        let side = self.chunk_side();
        (
            self.origin + k.lo().as_vec3() * side,
            self.origin + k.hi().as_vec3() * side,
        )
    }

    /// Side of a level-0 chunk (world units).
    pub fn chunk_side(&self) -> f32 {
        self.chunk_res as f32 * self.cell_size
    }

    /// World point `p` in level-0 chunk units (for [`Layout::around`]).
    pub fn to_chunk_units(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.chunk_side()
    }

    /// The level-0 chunk position whose box holds world point `p`.
    pub fn chunk_at(&self, p: Vec3) -> IVec3 {
        self.to_chunk_units(p).floor().as_ivec3()
    }

    /// Every level-0 chunk position (in the world or not) whose box comes within
    /// `radius` of `center`, nearest first.
    pub fn chunks_near(&self, center: Vec3, radius: f32) -> Vec<IVec3> {
        let lo = self.chunk_at(center - Vec3::splat(radius));
        let hi = self.chunk_at(center + Vec3::splat(radius));
        let mut out = Vec::new();
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let k = ChunkKey::new(0, IVec3::new(x, y, z));
                    let (a, b) = self.chunk_bounds(&k);
                    let d = center.clamp(a, b).distance(center);
                    if d <= radius {
                        out.push((d, k));
                    }
                }
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.order().cmp(&b.1.order())));
        out.into_iter().map(|(_, k)| k.coord).collect()
    }

    /// The tree of chunk `k`, if built.
    pub fn tree(&self, k: &ChunkKey) -> Option<&KdTree> {
        self.slot(k).tree.as_deref()
    }

    /// The threshold chunk `k` is cut at (squared cells of its own level).
    pub fn threshold(&self, k: &ChunkKey) -> f32 {
        self.slot(k).threshold
    }

    /// Sets chunk `k`'s threshold. Re-extract `k` and the seams of
    /// [`World::seam_owners_touching`]`(k)` to show it.
    pub fn set_threshold(&mut self, k: &ChunkKey, threshold: f32) {
        self.slot_mut(k).threshold = threshold;
    }

    /// Bytes held by all retained trees and kept samples.
    pub fn retained_bytes(&self) -> usize {
        self.slots.values().map(Slot::retained_bytes).sum()
    }
}

/// A chunk threshold must be finite.
pub(crate) fn check_threshold(threshold: f32) -> Result<()> {
    if threshold.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidSetting {
            name: "threshold",
            reason: format!("{threshold} must be finite"),
        })
    }
}

/// Drops `garbage` on a rayon thread, so the thread that changes the world (a
/// game's main thread) does not free its buffers.
fn drop_elsewhere<T: Send + 'static>(garbage: T) {
    rayon::spawn(move || drop(garbage));
}
