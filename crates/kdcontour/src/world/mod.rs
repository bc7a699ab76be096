//! A world of chunks: each chunk is a retained k-d tree over its own box of cells,
//! the chunk grid is an implicit level above them, and seams between neighbours are
//! contoured by `face_proc` and `edge_proc` across the chunk roots. Every chunk is
//! cut at its own threshold, and the seam walk meets each tree at its own cut, so
//! neighbours at different levels of detail join with no cracks, skirts,
//! transition cells or shader tricks.
//!
//! ## Seam ownership
//! - The **face seam** between chunk `c` and `c + e_a` (for each axis `a`) belongs
//!   to `c`, the lower chunk.
//! - The **edge seam** along axis `a` where chunks `c`, `c + e_u`, `c + e_u + e_v`
//!   and `c + e_v` meet (`u`, `v` the other two axes) belongs to `c`, the lowest.
//!
//! A chunk's mesh is its interior ([`ChunkWorld::extract_interior`]) plus the seams it
//! owns ([`ChunkWorld::extract_seams`]). When chunk `c` changes (new threshold, or
//! rebuilt after an edit), re-extract the interior of `c` and the seams of every
//! chunk in [`ChunkWorld::seam_owners_touching`]`(c)`: `c` and its up-to-six lower
//! neighbours. A threshold change never re-samples the field.
//!
//! Chunks sample one extra layer of cells around their box (the halo). The halo's
//! cells decide how the chunk's boundary cells resolve ambiguous faces, so both
//! chunks that share a face resolve it the same way; samples sit on one lattice
//! ([`Grid::offset`]), so a corner shared by two chunks has bitwise the same value
//! in both.
//!
//! A chunk whose field bound ([`Field::bound`]) proves all of its samples to be of
//! one sign (sky far above a terrain, rock far below it) is not sampled: its tree
//! is built from the signs alone and is the tree sampling would build, with no
//! surface. Inside a sampled chunk, whole layers the bound proves one-signed are
//! skipped the same way ([`crate::hermite::sample`]).

pub mod conform;
pub mod layout;
pub mod levels;
mod lod;

pub use conform::{BuiltChunk, LevelBuild, Neighbourhood};
pub use layout::{ChunkKey, ChunkMap, ChunkSet, KeyHasher, Layout};
pub use levels::{LevelSnapshot, LevelWorld, PreparedLayout, Seam};
pub use lod::Lod;

use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::Hermite;
use crate::kdtree::{self, contour, Job, KdTree, Part};
use crate::mesh::IndexedMesh;
use crate::settings::Settings;
use glam::{IVec3, UVec3, Vec3};
use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::sync::Arc;

/// Largest `|chunk coordinate| * chunk_res` on any axis: lattice coordinates stay
/// well inside `i32`.
const MAX_LATTICE: i64 = 1 << 30;

/// One member chunk: its tree (once built) and its threshold.
struct Slot {
    tree: Option<Arc<KdTree>>,
    threshold: f32,
}

/// A set of chunks on one lattice, with retained trees and per-chunk thresholds.
///
/// A world is either **bounded** ([`ChunkWorld::new`]: every chunk of an
/// `X x Y x Z` block starting at chunk `(0, 0, 0)`) or **unbounded**
/// ([`ChunkWorld::unbounded`]: no chunk until [`ChunkWorld::add_chunk`]; chunk
/// coordinates may be negative, for terrain that streams around a camera). Seams
/// are contoured only between member chunks that have trees; a seam whose
/// neighbour is missing is left open, so an unbounded world's mesh is open at the
/// edge of what is loaded.
pub struct ChunkWorld {
    /// World position of lattice corner (0, 0, 0).
    pub origin: Vec3,
    /// Side of one cell (world units).
    pub cell_size: f32,
    /// Cells per chunk along each axis.
    pub chunk_res: u32,
    /// Build settings used for every chunk.
    pub settings: Settings,
    bounds: Option<UVec3>,
    default_threshold: f32,
    // Looked up by the thousand per frame in the plugin: the fast chunk hasher.
    slots: HashMap<IVec3, Slot, BuildHasherDefault<KeyHasher>>,
}

impl ChunkWorld {
    /// A bounded world of `chunks` (X x Y x Z) chunks, none built yet. Every chunk
    /// starts at `threshold`. A world over `settings.memory_budget` (its trees,
    /// the samples of one chunk per thread, its slots) is refused here.
    pub fn new(
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
        let mut world = Self::unbounded(origin, cell_size, chunk_res, threshold, settings)?;
        if chunks.max_element() as i64 * chunk_res as i64 > MAX_LATTICE {
            return Err(Error::InvalidSetting {
                name: "chunks",
                reason: format!("{chunks} chunks of {chunk_res} cells exceed 2^30 cells"),
            });
        }
        check_world_budget::<(IVec3, Slot)>(
            chunks,
            chunks.as_u64vec3().element_product(),
            &world.chunk_grid(IVec3::ZERO),
            &world.settings,
        )?;
        world.bounds = Some(chunks);
        for z in 0..chunks.z as i32 {
            for y in 0..chunks.y as i32 {
                for x in 0..chunks.x as i32 {
                    world.slots.insert(
                        IVec3::new(x, y, z),
                        Slot {
                            tree: None,
                            threshold,
                        },
                    );
                }
            }
        }
        Ok(world)
    }

    /// An unbounded world with no chunks; add them with [`ChunkWorld::add_chunk`].
    /// New chunks start at `threshold`.
    pub fn unbounded(
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
        let world = ChunkWorld {
            origin,
            cell_size,
            chunk_res,
            settings,
            bounds: None,
            default_threshold: threshold,
            slots: HashMap::default(),
        };
        world.chunk_grid(IVec3::ZERO).validate()?;
        Ok(world)
    }

    /// The block size of a bounded world; `None` when unbounded.
    pub fn bounds(&self) -> Option<UVec3> {
        self.bounds
    }

    fn slot(&self, c: IVec3) -> &Slot {
        self.slots
            .get(&c)
            .unwrap_or_else(|| panic!("chunk {c} is not a member of this world"))
    }

    fn slot_mut(&mut self, c: IVec3) -> &mut Slot {
        self.slots
            .get_mut(&c)
            .unwrap_or_else(|| panic!("chunk {c} is not a member of this world"))
    }

    /// Whether `c` is a member chunk of this world.
    pub fn contains(&self, c: IVec3) -> bool {
        self.slots.contains_key(&c)
    }

    /// Number of member chunks.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether the world has no chunk.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Makes `c` a member (unbuilt, at the default threshold). Returns whether it is
    /// new. Errors when `c` is outside a bounded world's block, or so far out that
    /// its lattice coordinates would overflow.
    pub fn add_chunk(&mut self, c: IVec3) -> Result<bool> {
        if let Some(b) = self.bounds {
            if !(c.cmpge(IVec3::ZERO).all() && c.cmplt(b.as_ivec3()).all()) {
                return Err(Error::InvalidSetting {
                    name: "chunk",
                    reason: format!("{c} is outside the bounded world's {b} chunks"),
                });
            }
        }
        let far = c.abs().max_element() as i64 * self.chunk_res as i64;
        if far >= MAX_LATTICE {
            return Err(Error::InvalidSetting {
                name: "chunk",
                reason: format!("{c} is more than 2^30 cells from the origin"),
            });
        }
        if self.slots.contains_key(&c) {
            return Ok(false);
        }
        self.slots.insert(
            c,
            Slot {
                tree: None,
                threshold: self.default_threshold,
            },
        );
        Ok(true)
    }

    /// Drops member `c` and its tree. Returns whether it was a member. The seams of
    /// [`ChunkWorld::seam_owners_touching`]`(c)`, computed before the call, need
    /// re-extracting: they lose the triangles that joined `c`.
    pub fn remove_chunk(&mut self, c: IVec3) -> bool {
        self.slots.remove(&c).is_some()
    }

    /// The grid chunk `c` samples: its cells plus one cell of halo on every side.
    pub fn chunk_grid(&self, c: IVec3) -> Grid {
        Grid {
            origin: self.origin,
            cell_size: self.cell_size,
            cells: UVec3::splat(self.chunk_res + 2),
            offset: c * self.chunk_res as i32 - IVec3::ONE,
        }
    }

    /// The world box of chunk `c` (min, max).
    pub fn chunk_bounds(&self, c: IVec3) -> (Vec3, Vec3) {
        let side = self.chunk_res as f32 * self.cell_size;
        let lo = self.origin + c.as_vec3() * side;
        (lo, lo + Vec3::splat(side))
    }

    /// The chunk whose box holds world point `p`.
    pub fn chunk_at(&self, p: Vec3) -> IVec3 {
        let side = self.chunk_res as f32 * self.cell_size;
        ((p - self.origin) / side).floor().as_ivec3()
    }

    /// Every chunk (member or not) whose box comes within `radius` of `center`,
    /// sorted nearest first.
    pub fn chunks_near(&self, center: Vec3, radius: f32) -> Vec<IVec3> {
        let lo = self.chunk_at(center - Vec3::splat(radius));
        let hi = self.chunk_at(center + Vec3::splat(radius));
        let mut out = Vec::new();
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let c = IVec3::new(x, y, z);
                    let (a, b) = self.chunk_bounds(c);
                    let d = center.clamp(a, b).distance(center);
                    if d <= radius {
                        out.push((d, c));
                    }
                }
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(key(a.1).cmp(&key(b.1))));
        out.into_iter().map(|(_, c)| c).collect()
    }

    /// Samples `field` for chunk `c` and builds its tree (replacing an old one).
    pub fn build_chunk(&mut self, c: IVec3, field: &dyn Field) -> Result<()> {
        let tree = self.chunk_build(c).run(field)?;
        self.insert_tree(c, tree);
        Ok(())
    }

    /// Builds every member chunk (in parallel over chunks).
    pub fn build_all(&mut self, field: &dyn Field) -> Result<()> {
        use rayon::prelude::*;
        let coords = self.coords();
        let grids: Vec<Grid> = coords.iter().map(|&c| self.chunk_grid(c)).collect();
        let (res, settings) = (self.chunk_res, self.settings.clone());
        let inner = Settings {
            threads: 0,
            ..settings.clone()
        };
        let trees: Vec<Result<KdTree>> = settings.run(|| {
            grids
                .par_iter()
                .map(|g| build_chunk_tree(g, res, field, &inner))
                .collect()
        })?;
        for (c, t) in coords.into_iter().zip(trees) {
            self.insert_tree(c, t?);
        }
        Ok(())
    }

    /// Every member chunk, sorted z, then y, then x.
    pub fn coords(&self) -> Vec<IVec3> {
        let mut v: Vec<IVec3> = self.slots.keys().copied().collect();
        v.sort_by_key(|&c| key(c));
        v
    }

    /// The tree of chunk `c`, if built.
    pub fn tree(&self, c: IVec3) -> Option<&KdTree> {
        self.slot(c).tree.as_deref()
    }

    /// Everything needed to build chunk `c` elsewhere (a task, another thread).
    pub fn chunk_build(&self, c: IVec3) -> ChunkBuild {
        ChunkBuild {
            grid: self.chunk_grid(c),
            res: self.chunk_res,
            settings: self.settings.clone(),
        }
    }

    /// Installs a tree built by [`ChunkBuild::run`] for member chunk `c`.
    pub fn insert_tree(&mut self, c: IVec3, tree: KdTree) {
        self.slot_mut(c).tree = Some(Arc::new(tree));
    }

    /// Forgets member chunk `c`'s tree (its mesh and the seams it owns become
    /// empty); it stays a member.
    pub fn remove_tree(&mut self, c: IVec3) {
        self.slot_mut(c).tree = None;
    }

    /// What extracting chunk `c` (interior and owned seams) needs, detached from the
    /// world so a task can run it: the trees of `c` and its upper neighbours, and
    /// their thresholds. `None` when `c` has no tree.
    pub fn snapshot(&self, c: IVec3) -> Option<ChunkSnapshot> {
        let (coords, jobs) = self.owned_jobs(c);
        if coords.is_empty() {
            return None;
        }
        let owned = coords
            .iter()
            .map(|&cc| {
                let slot = self.slot(cc);
                (
                    slot.tree.clone().expect("owned_jobs lists built chunks"),
                    self.part_offset(cc),
                    slot.threshold,
                )
            })
            .collect();
        let mut interior = vec![Job::Cell(0)];
        interior.extend(jobs);
        Some(ChunkSnapshot {
            parts: owned,
            jobs: interior,
        })
    }

    /// The threshold member chunk `c` is cut at.
    pub fn threshold(&self, c: IVec3) -> f32 {
        self.slot(c).threshold
    }

    /// Sets member chunk `c`'s threshold. Re-extract `c` and the seams of
    /// [`ChunkWorld::seam_owners_touching`]`(c)` to show it.
    pub fn set_threshold(&mut self, c: IVec3, threshold: f32) {
        self.slot_mut(c).threshold = threshold;
    }

    /// The member chunks whose owned seams touch chunk `c`: `c` and its lower
    /// neighbours across one or two axes (up to seven chunks).
    pub fn seam_owners_touching(&self, c: IVec3) -> Vec<IVec3> {
        let mut out = Vec::new();
        for mask in 0..8u32 {
            if mask.count_ones() == 3 {
                continue;
            }
            let d = IVec3::new(
                (mask & 1) as i32,
                (mask >> 1 & 1) as i32,
                (mask >> 2 & 1) as i32,
            );
            let o = c - d;
            if self.contains(o) {
                out.push(o);
            }
        }
        out
    }

    fn part_offset(&self, c: IVec3) -> IVec3 {
        c * self.chunk_res as i32 - IVec3::ONE
    }

    fn part(&self, c: IVec3) -> Option<Part<'_>> {
        let slot = self.slots.get(&c)?;
        slot.tree.as_deref().map(|tree| Part {
            tree,
            offset: self.part_offset(c),
            threshold: slot.threshold,
            shift: 0,
        })
    }

    /// The seam jobs chunk `c` owns, with the chunks they need (chunk 0 is `c`;
    /// every listed chunk is built).
    fn owned_jobs(&self, c: IVec3) -> (Vec<IVec3>, Vec<Job>) {
        let mut jobs = Vec::new();
        if self.part(c).is_none() {
            return (Vec::new(), jobs);
        }
        let mut coords = vec![c];
        let mut find = |o: IVec3| -> Option<usize> {
            self.part(o)?;
            coords.push(o);
            Some(coords.len() - 1)
        };
        for a in 0..3 {
            if let Some(high) = find(c + IVec3::AXES[a]) {
                jobs.push(Job::Face {
                    low: 0,
                    high,
                    axis: a,
                });
            }
        }
        for a in 0..3 {
            let (u, v) = (IVec3::AXES[(a + 1) % 3], IVec3::AXES[(a + 2) % 3]);
            let q1 = find(c + u);
            let q2 = find(c + u + v);
            let q3 = find(c + v);
            if let (Some(q1), Some(q2), Some(q3)) = (q1, q2, q3) {
                jobs.push(Job::Edge {
                    parts: [0, q1, q2, q3],
                    axis: a,
                });
            }
        }
        (coords, jobs)
    }

    /// Contours the inside of chunk `c` at its threshold into `out` (cleared).
    pub fn extract_interior(&self, c: IVec3, out: &mut IndexedMesh) {
        out.reset();
        if let Some(p) = self.part(c) {
            contour(&[p], &[Job::Cell(0)], out);
        }
    }

    /// Contours the seams chunk `c` owns into `out` (cleared), each neighbour at its
    /// own threshold.
    pub fn extract_seams(&self, c: IVec3, out: &mut IndexedMesh) {
        out.reset();
        let (coords, jobs) = self.owned_jobs(c);
        let parts: Vec<Part> = coords.iter().filter_map(|&cc| self.part(cc)).collect();
        contour(&parts, &jobs, out);
    }

    /// The whole world as one welded mesh: every built chunk's interior and every
    /// seam between built chunks, vertices shared, so it can be checked for
    /// watertightness as a whole.
    pub fn extract_all(&self) -> IndexedMesh {
        let coords: Vec<IVec3> = self
            .coords()
            .into_iter()
            .filter(|&c| self.part(c).is_some())
            .collect();
        let index_of: HashMap<IVec3, usize> =
            coords.iter().enumerate().map(|(i, &c)| (c, i)).collect();
        let parts: Vec<Part> = coords.iter().filter_map(|&c| self.part(c)).collect();
        let mut jobs = Vec::new();
        for (i, &c) in coords.iter().enumerate() {
            jobs.push(Job::Cell(i));
            let at = |o: IVec3| index_of.get(&o).copied();
            for a in 0..3 {
                if let Some(high) = at(c + IVec3::AXES[a]) {
                    jobs.push(Job::Face {
                        low: i,
                        high,
                        axis: a,
                    });
                }
                let (u, v) = (IVec3::AXES[(a + 1) % 3], IVec3::AXES[(a + 2) % 3]);
                if let (Some(q1), Some(q2), Some(q3)) = (at(c + u), at(c + u + v), at(c + v)) {
                    jobs.push(Job::Edge {
                        parts: [i, q1, q2, q3],
                        axis: a,
                    });
                }
            }
        }
        let mut out = IndexedMesh::default();
        contour(&parts, &jobs, &mut out);
        out
    }

    /// Bytes held by all retained trees.
    pub fn retained_bytes(&self) -> usize {
        self.slots
            .values()
            .filter_map(|s| s.tree.as_ref())
            .map(|t| t.retained_bytes())
            .sum()
    }
}

/// A chunk threshold must be finite.
/// Checks a world against the memory budget before any chunk exists: the trees
/// of a surface as large as the faces of its `extent` (in level-0 chunks), the
/// samples of one chunk per worker thread, and one map `Entry` per chunk.
pub(crate) fn check_world_budget<Entry>(
    extent: UVec3,
    chunk_count: u64,
    chunk_grid: &Grid,
    settings: &Settings,
) -> Result<()> {
    let res = chunk_grid.cells.max_element().saturating_sub(2).max(1) as u64;
    let cells = extent.as_u64vec3() * res;
    let threads = match settings.threads {
        0 => rayon::current_num_threads(),
        n => n,
    } as u64;
    // A hash map entry and its control byte.
    let slot = std::mem::size_of::<Entry>() as u64 + 1;
    let needed = crate::hermite::surface_bytes(cells)
        .saturating_add(threads.saturating_mul(crate::hermite::estimate_bytes(chunk_grid)))
        .saturating_add(chunk_count.saturating_mul(slot));
    crate::settings::check_budget(
        format!(
            "a world of {}x{}x{} chunks of {res}^3 cells",
            extent.x, extent.y, extent.z
        ),
        needed,
        settings.memory_budget,
    )
}

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

/// Sort key: z, then y, then x.
fn key(c: IVec3) -> (i32, i32, i32) {
    (c.z, c.y, c.x)
}

/// A chunk build detached from its world (see [`ChunkWorld::chunk_build`]).
#[derive(Clone, Debug)]
pub struct ChunkBuild {
    /// The chunk's grid, halo included.
    pub grid: Grid,
    /// Cells per chunk.
    pub res: u32,
    /// Build settings.
    pub settings: Settings,
}

impl ChunkBuild {
    /// Samples the field and builds the chunk's tree.
    pub fn run(&self, field: &dyn Field) -> Result<KdTree> {
        build_chunk_tree(&self.grid, self.res, field, &self.settings)
    }
}

/// A chunk's extraction detached from its world (see [`ChunkWorld::snapshot`]).
#[derive(Clone)]
pub struct ChunkSnapshot {
    parts: Vec<(Arc<KdTree>, IVec3, f32)>,
    jobs: Vec<Job>,
}

impl ChunkSnapshot {
    /// Contours the chunk's interior and its owned seams into `out` (cleared).
    pub fn extract(&self, out: &mut IndexedMesh) {
        out.reset();
        let parts: Vec<Part> = self
            .parts
            .iter()
            .map(|(t, offset, threshold)| Part {
                tree: t,
                offset: *offset,
                threshold: *threshold,
                shift: 0,
            })
            .collect();
        contour(&parts, &self.jobs, out);
    }
}

/// Samples a chunk's grid (with halo) and builds the tree over its core cells.
fn build_chunk_tree(
    grid: &Grid,
    res: u32,
    field: &dyn Field,
    settings: &Settings,
) -> Result<KdTree> {
    settings.run(|| {
        // A chunk the field's bound proves one-signed has no surface: its tree is
        // built from the signs alone, as sampling would have built it.
        let values = match crate::hermite::one_sign(field, grid, 0, settings)? {
            Some(v) => v,
            None => crate::hermite::sample(field, grid, settings)?,
        };
        let h = Hermite::new(field, grid, &values, settings)?;
        let r = res as u16;
        let mut tree = kdtree::build_in(
            &h,
            field,
            settings.partition,
            [1, 1, 1],
            [r + 1, r + 1, r + 1],
        );
        crate::material::paint_tree(&mut tree, field, settings);
        Ok(tree)
    })?
}
