//! The chunk world behind a volume ([`VolumeWorld`]): one level of equal chunks
//! (the core's [`ChunkWorld`]: bounded blocks and flat streaming) or chunks whose
//! cells double with distance (the core's [`LevelWorld`]: the far horizon). The
//! other subsystems address chunks by [`ChunkKey`] (level 0 in a one-level
//! world) and go through this type, so builds, extractions, edits and LOD work
//! the same on both.

use bevy::prelude::*;
use kdcontour::field::Field;
use kdcontour::world::{
    BuiltChunk, ChunkBuild, ChunkKey, ChunkSnapshot, LevelBuild, LevelSnapshot,
};
use kdcontour::{ChunkWorld, IndexedMesh, KdTree, LevelWorld};

/// A volume's chunks and their retained trees.
pub enum VolumeWorld {
    /// One level of equal chunks.
    Flat(ChunkWorld),
    /// Chunk levels laid out around the camera.
    Levels(LevelWorld),
}

/// A chunk build detached from its world, to run in a task.
#[derive(Clone, Debug)]
pub enum ChunkJob {
    /// A chunk of a one-level world.
    Flat(ChunkBuild),
    /// A chunk of a level world (with the neighbourhood it conforms to).
    Levels(LevelBuild),
}

impl ChunkJob {
    /// Samples the field (a level chunk reuses its kept samples) and builds
    /// the chunk's tree.
    pub fn run(&self, field: &dyn Field) -> kdcontour::Result<BuiltChunk> {
        match self {
            ChunkJob::Flat(b) => b.run(field).map(|tree| BuiltChunk {
                tree,
                samples: None,
            }),
            ChunkJob::Levels(b) => b.build(field),
        }
    }
}

/// A chunk's extraction detached from its world, to run in a task.
#[derive(Clone)]
pub enum ChunkExtract {
    /// A chunk of a one-level world.
    Flat(ChunkSnapshot),
    /// A chunk of a level world.
    Levels(LevelSnapshot),
}

impl ChunkExtract {
    /// Contours the chunk's interior and its owned seams into `out` (cleared).
    pub fn extract(&self, out: &mut IndexedMesh) {
        match self {
            ChunkExtract::Flat(s) => s.extract(out),
            ChunkExtract::Levels(s) => s.extract(out),
        }
    }
}

impl VolumeWorld {
    /// The one-level world, if this is one.
    pub fn flat(&self) -> Option<&ChunkWorld> {
        match self {
            VolumeWorld::Flat(w) => Some(w),
            VolumeWorld::Levels(_) => None,
        }
    }

    /// The one-level world, to change.
    pub(crate) fn flat_mut(&mut self) -> Option<&mut ChunkWorld> {
        match self {
            VolumeWorld::Flat(w) => Some(w),
            VolumeWorld::Levels(_) => None,
        }
    }

    /// The level world, if this is one.
    pub fn levels(&self) -> Option<&LevelWorld> {
        match self {
            VolumeWorld::Flat(_) => None,
            VolumeWorld::Levels(w) => Some(w),
        }
    }

    /// The level world, to change.
    pub(crate) fn levels_mut(&mut self) -> Option<&mut LevelWorld> {
        match self {
            VolumeWorld::Flat(_) => None,
            VolumeWorld::Levels(w) => Some(w),
        }
    }

    /// Side of a level-0 cell (local units).
    pub fn cell_size(&self) -> f32 {
        match self {
            VolumeWorld::Flat(w) => w.cell_size,
            VolumeWorld::Levels(w) => w.cell_size,
        }
    }

    /// Cells per chunk along each axis (at every level).
    pub fn chunk_res(&self) -> u32 {
        match self {
            VolumeWorld::Flat(w) => w.chunk_res,
            VolumeWorld::Levels(w) => w.chunk_res,
        }
    }

    /// Every chunk, in the world's order.
    pub fn chunks(&self) -> Vec<ChunkKey> {
        match self {
            VolumeWorld::Flat(w) => w.coords().into_iter().map(flat_key).collect(),
            VolumeWorld::Levels(w) => w.chunks(),
        }
    }

    /// Number of chunks (of a level world: every chunk of its layout, built or
    /// not).
    pub fn len(&self) -> usize {
        match self {
            VolumeWorld::Flat(w) => w.len(),
            VolumeWorld::Levels(w) => w.layout().len(),
        }
    }

    /// Whether there is no chunk.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether `k` is one of the world's chunks.
    pub fn contains(&self, k: &ChunkKey) -> bool {
        match self {
            VolumeWorld::Flat(w) => k.level == 0 && w.contains(k.coord),
            VolumeWorld::Levels(w) => w.layout().contains(k),
        }
    }

    /// The local box of chunk `k` (min, max).
    pub fn chunk_bounds(&self, k: &ChunkKey) -> (Vec3, Vec3) {
        match self {
            VolumeWorld::Flat(w) => w.chunk_bounds(k.coord),
            VolumeWorld::Levels(w) => w.chunk_bounds(k),
        }
    }

    /// The tree of chunk `k`, if built.
    pub fn tree(&self, k: &ChunkKey) -> Option<&KdTree> {
        match self {
            VolumeWorld::Flat(w) => w.tree(k.coord),
            VolumeWorld::Levels(w) => w.tree(k),
        }
    }

    /// The threshold chunk `k` is cut at (squared cells of its own level).
    pub fn threshold(&self, k: &ChunkKey) -> f32 {
        match self {
            VolumeWorld::Flat(w) => w.threshold(k.coord),
            VolumeWorld::Levels(w) => w.threshold(k),
        }
    }

    /// Sets chunk `k`'s threshold (re-extract the seam owners touching it).
    pub(crate) fn set_threshold(&mut self, k: &ChunkKey, threshold: f32) {
        match self {
            VolumeWorld::Flat(w) => w.set_threshold(k.coord, threshold),
            VolumeWorld::Levels(w) => w.set_threshold(k, threshold),
        }
    }

    /// The chunks whose meshes show part of chunk `k`: `k` and the chunks that
    /// own seams touching it.
    pub fn seam_owners_touching(&self, k: &ChunkKey) -> Vec<ChunkKey> {
        match self {
            VolumeWorld::Flat(w) => w
                .seam_owners_touching(k.coord)
                .into_iter()
                .map(flat_key)
                .collect(),
            VolumeWorld::Levels(w) => w.seam_owners_touching(k),
        }
    }

    /// Everything needed to build chunk `k` in a task.
    pub(crate) fn chunk_build(&self, k: &ChunkKey) -> ChunkJob {
        match self {
            VolumeWorld::Flat(w) => ChunkJob::Flat(w.chunk_build(k.coord)),
            VolumeWorld::Levels(w) => ChunkJob::Levels(w.chunk_build(k)),
        }
    }

    /// Installs the tree (and samples) `job` built for chunk `k`.
    pub(crate) fn insert_built(&mut self, k: &ChunkKey, job: &ChunkJob, built: BuiltChunk) {
        match (self, job) {
            (VolumeWorld::Flat(w), _) => w.insert_tree(k.coord, built.tree),
            (VolumeWorld::Levels(w), ChunkJob::Levels(b)) => w.insert_built(b, built),
            (VolumeWorld::Levels(_), ChunkJob::Flat(_)) => {
                unreachable!("a level world only makes level jobs")
            }
        }
    }

    /// The field changed within `reach` of `centre`: the chunks to rebuild
    /// ([`VolumeWorld::chunks_near_edit`]), whose kept samples are dropped.
    pub(crate) fn edited(&mut self, centre: Vec3, reach: f32) -> Vec<ChunkKey> {
        match self {
            VolumeWorld::Flat(_) => self.chunks_near_edit(centre, reach),
            VolumeWorld::Levels(w) => w.edited(centre, reach),
        }
    }

    /// The whole field changed: drops every kept sample.
    pub(crate) fn forget_samples(&mut self) {
        if let VolumeWorld::Levels(w) = self {
            let all = w.chunks();
            w.forget_samples(&all);
        }
    }

    /// Forgets chunk `k`'s tree (its build failed).
    pub(crate) fn remove_tree(&mut self, k: &ChunkKey) {
        match self {
            VolumeWorld::Flat(w) => w.remove_tree(k.coord),
            VolumeWorld::Levels(w) => w.remove_tree(k),
        }
    }

    /// What extracting chunk `k` needs, detached; `None` when it has no tree.
    pub(crate) fn snapshot(&self, k: &ChunkKey) -> Option<ChunkExtract> {
        match self {
            VolumeWorld::Flat(w) => w.snapshot(k.coord).map(ChunkExtract::Flat),
            VolumeWorld::Levels(w) => w.snapshot(k).map(ChunkExtract::Levels),
        }
    }

    /// The chunks whose samples an edit within `reach` of `centre` changes:
    /// those whose box, grown by the cells they sample beyond it, meets the
    /// ball. In a level world every level that covers the edit is among them.
    pub fn chunks_near_edit(&self, centre: Vec3, reach: f32) -> Vec<ChunkKey> {
        match self {
            VolumeWorld::Flat(w) => {
                let grow = w.cell_size;
                w.coords()
                    .into_iter()
                    .filter(|&c| {
                        let (lo, hi) = w.chunk_bounds(c);
                        centre.clamp(lo - grow, hi + grow).distance(centre) <= reach
                    })
                    .map(flat_key)
                    .collect()
            }
            VolumeWorld::Levels(w) => w.chunks_near_edit(centre, reach),
        }
    }

    /// Bytes held by all retained trees.
    pub fn retained_bytes(&self) -> usize {
        match self {
            VolumeWorld::Flat(w) => w.retained_bytes(),
            VolumeWorld::Levels(w) => w.retained_bytes(),
        }
    }
}

/// The key of chunk `c` of a one-level world.
pub fn flat_key(c: IVec3) -> ChunkKey {
    ChunkKey::new(0, c)
}
