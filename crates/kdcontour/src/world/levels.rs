//! A world of chunks at several levels of detail: a chunk at level `k` has cells
//! of side `cell_size * 2^k` and the same `chunk_res` cells per side, so it covers
//! `2^k` level-0 chunks per axis. A [`Layout`] says which chunk covers what; it
//! is balanced (touching chunks differ by at most one level). Each chunk keeps its
//! own retained tree and threshold, and seams join across levels with no skirts,
//! transition cells or overlap.
//!
//! All levels sit on one lattice: a level-`k` sample is the level-0 lattice point
//! `2^k` times its index, computed in the same way at every level, so where two
//! levels' samples coincide they are bitwise the same.
//!
//! ## Level seams
//! Where a chunk meets one a level coarser, the finer side sees lattice points the
//! coarse side does not: the midpoints of coarse edges and the centres of coarse
//! faces. Two rules make both sides see one contour on the shared boundary:
//!
//! 1. **The finer side conforms.** On the closed box of a coarser neighbour, a
//!    coarse edge's midpoint keeps the field's sign when the coarse edge has a
//!    crossing (the fine crossing then lies in the half that holds the field's
//!    root, so it is found on the field) and takes its ends' sign when it has
//!    none: a coarse edge has one fine crossing exactly when it has a crossing. A
//!    coarse face's centre is inside when the face is ambiguous; otherwise it
//!    takes the sign that leaves no fine quarter of the face ambiguous and joins
//!    it to a midpoint ([`super::conform`]). The fine contour on a coarse face
//!    then runs between the same coarse edges as the coarse contour: one segment
//!    stays one curve, and an ambiguous face joins its inside corners through the
//!    centre. Every chunk of the finer level computes the same samples there, so
//!    fine neighbours agree too.
//! 2. **Both sides separate.** Across a face whose neighbours are at another
//!    level, a chunk's halo samples are inside, so every ambiguous face on a level
//!    seam, coarse or fine, separates its outside corners and joins its inside
//!    ones: the resolution rule 1 gives the coarse faces.
//!
//! The seam walk ([`crate::kdtree::contour`]) places every chunk on the level-0
//! lattice with its own [`Part::shift`]: a coarse node's box is its cells times
//! `2^level`. It reads a seam line's signs from the finest tree around it, steps
//! along it by that tree's cells, and maps each fine crossing to each quadrant's
//! leaf: on a coarse edge to that edge; through the middle of a coarse face (a
//! fine edge from a coarse edge's midpoint to the face centre) to the coarse edge
//! through that midpoint when it crosses (the fine curve there cuts off the same
//! corner as that edge's coarse segment), else to any crossing edge of the face
//! (which then holds a single segment).
//!
//! Chunks whose neighbourhood ([`Neighbourhood`]) changes with a new layout are
//! rebuilt: [`LevelWorld::set_layout`] lists them. Each chunk keeps the field's
//! samples it was built from ([`LevelWorld::keep_samples`]), so such a rebuild
//! applies the rules above to its kept samples instead of sampling the field
//! again (the rules still read the field past the chunk's grid, and the crossings
//! are found again); an edit drops the samples it reaches ([`LevelWorld::edited`]).
//!
//! ## Seam ownership
//! - A **face seam** (two chunks whose faces overlap) belongs to the finer chunk;
//!   between equal levels to the lower one, as in [`super::ChunkWorld`].
//! - An **edge seam** (the chunks around a stretch of a chunk edge, in quadrant
//!   order; a coarser chunk may fill two quadrants) belongs to its finest chunk,
//!   the first in quadrant order among equals: between equal levels, the lowest.
//!
//! A chunk's mesh is its interior plus the seams it owns; when chunk `c` changes,
//! re-extract `c` and the chunks in [`LevelWorld::seam_owners_touching`]`(c)`.

mod seams;

pub use seams::{LevelSnapshot, Seam};

use super::conform::{level_grid, BuiltChunk, LevelBuild, Neighbourhood};
use super::layout::{ChunkKey, ChunkMap, Layout};
use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::Grid;
use crate::kdtree::{contour, Job, KdTree, Part};
use crate::mesh::IndexedMesh;
use crate::Settings;
use glam::{IVec3, Vec3};
use std::collections::HashMap;
use std::sync::Arc;

/// One chunk: its tree (once built), the neighbourhood it was built for, its
/// threshold, and the field's samples it was built from (when kept).
struct Slot {
    tree: Option<Arc<KdTree>>,
    built_for: Neighbourhood,
    threshold: f32,
    samples: Option<Arc<[f32]>>,
}

/// A layout with every chunk's neighbourhood worked out, checked and ready to
/// install with [`LevelWorld::set_prepared`]: the costly part of a layout change,
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

/// A bounded world of chunks at several levels (see the module docs).
pub struct LevelWorld {
    /// World position of lattice corner (0, 0, 0).
    pub origin: Vec3,
    /// Side of a level-0 cell (world units).
    pub cell_size: f32,
    /// Cells per chunk along each axis, at every level (even).
    pub chunk_res: u32,
    /// Build settings used for every chunk.
    pub settings: Settings,
    /// Keep each chunk's field samples (default true), so a chunk rebuilt
    /// because a neighbour changed level is conformed again without sampling
    /// the field. Costs `(chunk_res + 3)^3` floats per sampled chunk (counted in
    /// [`LevelWorld::retained_bytes`]). After the field changes, drop them with
    /// [`LevelWorld::edited`] or [`LevelWorld::forget_samples`].
    pub keep_samples: bool,
    layout: Layout,
    neighbourhoods: ChunkMap<Neighbourhood>,
    default_threshold: f32,
    slots: ChunkMap<Slot>,
}

impl LevelWorld {
    /// A world over `layout`, no chunk built yet; every chunk starts at
    /// `threshold`.
    pub fn new(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        layout: Layout,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        if !(2..=4096).contains(&chunk_res) || !chunk_res.is_multiple_of(2) {
            return Err(Error::InvalidSetting {
                name: "chunk_res",
                reason: format!("{chunk_res} cells per chunk; allowed even, 2 to 4096"),
            });
        }
        super::check_threshold(threshold)?;
        let mut world = LevelWorld {
            origin,
            cell_size,
            chunk_res,
            settings,
            keep_samples: true,
            layout: Layout::uniform(IVec3::ZERO, IVec3::ONE, 0)?,
            neighbourhoods: ChunkMap::default(),
            default_threshold: threshold,
            slots: ChunkMap::default(),
        };
        world.set_layout(layout)?;
        Ok(world)
    }

    /// Checks a level world of `chunks` chunks of `chunk_res`^3 cells against
    /// `settings.memory_budget`: every chunk's bookkeeping and the builds running
    /// at once (each build checks its own grid again before sampling). Call it
    /// with the most chunks a layout can have (its level-0 chunks) before building
    /// a large [`Layout`]; [`LevelWorld::set_layout`] checks the real count.
    pub fn check_budget(chunks: u64, chunk_res: u32, settings: &Settings) -> Result<()> {
        // Every chunk has `chunk_res`^3 cells whatever its level, so the world's
        // surface memory is per chunk, not per level-0 cell of the region (a
        // 4,096-cell view's region is 12,288 cells wide but holds ~1,500 chunks).
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
            .saturating_add(threads.saturating_mul(crate::hermite::estimate_bytes(&grid)));
        crate::settings::check_budget(
            format!("a level world of {chunks} chunks of {chunk_res}^3 cells"),
            needed,
            settings.memory_budget,
        )
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Replaces the layout. Chunks that leave it are dropped, new ones start
    /// unbuilt at the default threshold, kept ones keep their tree and threshold.
    /// Returns the chunks to (re)build: the new ones and the kept ones whose
    /// neighbourhood changed (see [`LevelWorld::stale`]).
    pub fn set_layout(&mut self, layout: Layout) -> Result<Vec<ChunkKey>> {
        self.set_prepared(PreparedLayout::new(layout)?)
    }

    /// [`LevelWorld::set_layout`] with the layout prepared beforehand (perhaps on
    /// another thread): only the bookkeeping is left.
    pub fn set_prepared(&mut self, prepared: PreparedLayout) -> Result<Vec<ChunkKey>> {
        let PreparedLayout {
            layout,
            neighbourhoods,
        } = prepared;
        let far =
            layout.lo().abs().max(layout.hi().abs()).max_element() as i64 * self.chunk_res as i64;
        if far >= 1 << 30 {
            return Err(Error::InvalidSetting {
                name: "layout",
                reason: format!(
                    "{}..{} is more than 2^30 cells out",
                    layout.lo(),
                    layout.hi()
                ),
            });
        }
        Self::check_budget(layout.len() as u64, self.chunk_res, &self.settings)?;
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
            });
        }
        self.layout = layout;
        let old = std::mem::replace(&mut self.neighbourhoods, neighbourhoods);
        drop_elsewhere((removed, old));
        Ok(self.stale())
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

    /// Every chunk, in layout order ([`ChunkKey::order`]).
    pub fn chunks(&self) -> Vec<ChunkKey> {
        self.layout.chunks()
    }

    fn slot(&self, k: &ChunkKey) -> &Slot {
        self.slots
            .get(k)
            .unwrap_or_else(|| panic!("chunk {k:?} is not in the layout"))
    }

    fn slot_mut(&mut self, k: &ChunkKey) -> &mut Slot {
        self.slots
            .get_mut(k)
            .unwrap_or_else(|| panic!("chunk {k:?} is not in the layout"))
    }

    /// The grid chunk `k` samples: its cells plus one cell of halo on every side.
    pub fn chunk_grid(&self, k: &ChunkKey) -> Grid {
        level_grid(self.origin, self.cell_size, self.chunk_res, k)
    }

    /// The world box of chunk `k` (min, max).
    pub fn chunk_bounds(&self, k: &ChunkKey) -> (Vec3, Vec3) {
        let side = self.chunk_res as f32 * self.cell_size;
        (
            self.origin + k.lo().as_vec3() * side,
            self.origin + k.hi().as_vec3() * side,
        )
    }

    /// World point `p` in level-0 chunk units (for [`Layout::around`]).
    pub fn to_chunk_units(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / (self.chunk_res as f32 * self.cell_size)
    }

    /// Everything needed to build chunk `k` elsewhere (a task, another thread).
    pub fn chunk_build(&self, k: &ChunkKey) -> LevelBuild {
        LevelBuild {
            key: *k,
            grid: self.chunk_grid(k),
            res: self.chunk_res,
            neighbourhood: self
                .neighbourhoods
                .get(k)
                .cloned()
                .unwrap_or_else(|| Neighbourhood::of(&self.layout, k)),
            settings: self.settings.clone(),
            kept: self.slots.get(k).and_then(|s| s.samples.clone()),
        }
    }

    /// Installs a tree built by [`LevelBuild::run`] for chunk `build.key` (the
    /// chunk's kept samples are dropped: they may not be the tree's).
    pub fn insert_tree(&mut self, build: &LevelBuild, tree: KdTree) {
        self.insert_built(
            build,
            BuiltChunk {
                tree,
                samples: None,
            },
        );
    }

    /// Installs a chunk built by [`LevelBuild::build`], keeping its samples
    /// when [`LevelWorld::keep_samples`] is set.
    pub fn insert_built(&mut self, build: &LevelBuild, built: BuiltChunk) {
        let keep = self.keep_samples;
        let s = self.slot_mut(&build.key);
        let old = (
            s.tree.replace(Arc::new(built.tree)),
            std::mem::replace(&mut s.samples, built.samples.filter(|_| keep)),
        );
        s.built_for = build.neighbourhood.clone();
        drop_elsewhere(old);
    }

    /// Drops the kept samples of `keys` (chunks not in the layout are
    /// ignored): the field changed there, so their next build samples it.
    pub fn forget_samples(&mut self, keys: &[ChunkKey]) {
        for k in keys {
            if let Some(s) = self.slots.get_mut(k) {
                drop_elsewhere(s.samples.take());
            }
        }
    }

    /// The field changed within `radius` of `center` (an edit): drops the kept
    /// samples of the chunks it reaches and returns them
    /// ([`LevelWorld::chunks_near_edit`]), to rebuild.
    pub fn edited(&mut self, center: Vec3, radius: f32) -> Vec<ChunkKey> {
        let keys = self.chunks_near_edit(center, radius);
        self.forget_samples(&keys);
        keys
    }

    /// Forgets chunk `k`'s tree (a failed build): its mesh and the seams it owns
    /// become empty, and [`LevelWorld::stale`] lists it again.
    pub fn remove_tree(&mut self, k: &ChunkKey) {
        let s = self.slot_mut(k);
        drop_elsewhere((s.tree.take(), s.samples.take()));
    }

    /// Samples `field` for chunk `k` (or conforms its kept samples) and builds
    /// its tree (replacing an old one).
    pub fn build_chunk(&mut self, k: &ChunkKey, field: &dyn Field) -> Result<()> {
        let b = self.chunk_build(k);
        let built = b.build(field)?;
        self.insert_built(&b, built);
        Ok(())
    }

    /// Builds the chunks in `keys` (in parallel over chunks).
    pub fn build(&mut self, keys: &[ChunkKey], field: &dyn Field) -> Result<()> {
        use rayon::prelude::*;
        let inner = Settings {
            threads: 0,
            ..self.settings.clone()
        };
        let builds: Vec<LevelBuild> = keys
            .iter()
            .map(|k| LevelBuild {
                settings: inner.clone(),
                ..self.chunk_build(k)
            })
            .collect();
        let built: Vec<Result<BuiltChunk>> = self
            .settings
            .run(|| builds.par_iter().map(|b| b.build(field)).collect())?;
        for (b, t) in builds.iter().zip(built) {
            self.insert_built(b, t?);
        }
        Ok(())
    }

    /// Builds every chunk.
    pub fn build_all(&mut self, field: &dyn Field) -> Result<()> {
        self.build(&self.chunks(), field)
    }

    /// Builds the chunks [`LevelWorld::stale`] lists; returns them.
    pub fn build_stale(&mut self, field: &dyn Field) -> Result<Vec<ChunkKey>> {
        let stale = self.stale();
        self.build(&stale, field)?;
        Ok(stale)
    }

    /// The chunks an edit within `radius` of `center` (world units) reaches: those
    /// whose box, grown by two of their own cells, meets that ball (a chunk samples
    /// one cell of halo, and one more where it conforms to a coarser neighbour).
    /// Rebuild them with [`LevelWorld::build`]; every level that covers the edit
    /// is among them. (When the field changed there, [`LevelWorld::edited`]
    /// also drops their kept samples.)
    pub fn chunks_near_edit(&self, center: Vec3, radius: f32) -> Vec<ChunkKey> {
        self.chunks()
            .into_iter()
            .filter(|k| {
                let (lo, hi) = self.chunk_bounds(k);
                let grow = 2.0 * self.chunk_grid(k).cell_size;
                center.clamp(lo - grow, hi + grow).distance(center) <= radius
            })
            .collect()
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
    /// [`LevelWorld::seam_owners_touching`]`(k)` to show it.
    pub fn set_threshold(&mut self, k: &ChunkKey, threshold: f32) {
        self.slot_mut(k).threshold = threshold;
    }

    /// Bytes held by all retained trees and kept samples.
    pub fn retained_bytes(&self) -> usize {
        self.slots
            .values()
            .map(|s| {
                s.tree.as_ref().map_or(0, |t| t.retained_bytes())
                    + s.samples
                        .as_ref()
                        .map_or(0, |v| std::mem::size_of_val(&**v))
            })
            .sum()
    }

    fn part(&self, k: &ChunkKey) -> Option<Part<'_>> {
        let slot = self.slots.get(k)?;
        slot.tree.as_deref().map(|tree| Part {
            tree,
            offset: (k.coord * self.chunk_res as i32 - IVec3::ONE) << k.level as i32,
            threshold: slot.threshold,
            shift: k.level,
        })
    }

    /// Contours `seams` (and the insides of `cells`) over the built chunks they
    /// need, into `out` (appended).
    fn contour_seams(&self, cells: &[ChunkKey], seams: &[Seam], out: &mut IndexedMesh) {
        let mut keys: Vec<ChunkKey> = Vec::new();
        let mut parts: Vec<Part> = Vec::new();
        let mut index = |k: ChunkKey| -> Option<usize> {
            if let Some(i) = keys.iter().position(|x| *x == k) {
                return Some(i);
            }
            parts.push(self.part(&k)?);
            keys.push(k);
            Some(keys.len() - 1)
        };
        let mut jobs = Vec::new();
        for c in cells {
            if let Some(i) = index(*c) {
                jobs.push(Job::Cell(i));
            }
        }
        for s in seams {
            if let Some(j) = self.job(s, &mut index) {
                jobs.push(j);
            }
        }
        contour(&parts, &jobs, out);
    }

    /// Contours the inside of chunk `k` at its threshold into `out` (cleared).
    pub fn extract_interior(&self, k: &ChunkKey, out: &mut IndexedMesh) {
        out.reset();
        self.contour_seams(&[*k], &[], out);
    }

    /// Contours the seams chunk `k` owns into `out` (cleared), each chunk at its
    /// own threshold and level.
    pub fn extract_seams(&self, k: &ChunkKey, out: &mut IndexedMesh) {
        out.reset();
        if self.part(k).is_some() {
            self.contour_seams(&[], &self.owned_seams(k), out);
        }
    }

    /// The whole world as one welded mesh: every built chunk's interior and every
    /// seam between built chunks, vertices shared.
    pub fn extract_all(&self) -> IndexedMesh {
        let chunks: Vec<ChunkKey> = self
            .chunks()
            .into_iter()
            .filter(|k| self.part(k).is_some())
            .collect();
        let index_of: HashMap<ChunkKey, usize> =
            chunks.iter().enumerate().map(|(i, &k)| (k, i)).collect();
        let parts: Vec<Part> = chunks.iter().filter_map(|k| self.part(k)).collect();
        let mut index = |k: ChunkKey| index_of.get(&k).copied();
        let mut jobs = Vec::new();
        for (i, k) in chunks.iter().enumerate() {
            jobs.push(Job::Cell(i));
            for s in self.owned_seams(k) {
                if let Some(j) = self.job(&s, &mut index) {
                    jobs.push(j);
                }
            }
        }
        let mut out = IndexedMesh::default();
        contour(&parts, &jobs, &mut out);
        out
    }
}

/// Drops `garbage` on a rayon thread, so the thread that changes the world (a
/// game's main thread) does not free its buffers.
fn drop_elsewhere<T: Send + 'static>(garbage: T) {
    rayon::spawn(move || drop(garbage));
}
