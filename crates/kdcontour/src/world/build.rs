//! Building a world's chunks: the detached build a task runs ([`ChunkBuild`]),
//! installing its result, and which chunks an edit sends back to it.

use super::conform::{BuiltChunk, ChunkBuild, Neighbourhood};
use super::layout::ChunkKey;
use super::{drop_elsewhere, World};
use crate::error::Result;
use crate::field::Field;
use crate::settings::Settings;
use glam::Vec3;

impl World {
    /// Everything needed to build chunk `k` elsewhere (a task, another thread).
    pub fn chunk_build(&self, k: &ChunkKey) -> ChunkBuild {
        let neighbourhood = self
            .neighbourhoods
            .get(k)
            .cloned()
            .unwrap_or_else(|| Neighbourhood::of(&self.layout, k));
        let slot = self.slots.get(k);
        ChunkBuild {
            key: *k,
            grid: self.chunk_grid(k),
            res: self.chunk_res,
            settings: self.settings.clone(),
            kept: slot.and_then(|s| s.samples.clone()),
            kept_crossings: slot.and_then(|s| s.crossings.clone()),
            // Faces toward finer and coarser chunks shape the tree
            // (`Cells::Core`).
            kept_tree: slot
                .filter(|s| {
                    s.built_for.finer_faces == neighbourhood.finer_faces
                        && s.built_for.level_faces == neighbourhood.level_faces
                })
                .and_then(|s| s.tree.clone()),
            neighbourhood,
            keep: self.keep_samples,
        }
    }

    /// Installs a chunk built by [`ChunkBuild::build`], keeping its samples and
    /// crossings when [`World::keep_samples`] is set.
    pub fn insert_built(&mut self, build: &ChunkBuild, built: BuiltChunk) {
        let keep = self.keep_samples;
        let s = self.slot_mut(&build.key);
        let old = (
            s.tree.replace(built.tree),
            std::mem::replace(&mut s.samples, built.samples.filter(|_| keep)),
            std::mem::replace(&mut s.crossings, built.crossings.filter(|_| keep)),
        );
        s.built_for = build.neighbourhood.clone();
        drop_elsewhere(old);
    }

    /// Drops the kept samples and crossings of `keys` (chunks not in the world
    /// are ignored): the field changed there, so their next build samples it.
    pub fn forget_samples(&mut self, keys: &[ChunkKey]) {
        for k in keys {
            if let Some(s) = self.slots.get_mut(k) {
                drop_elsewhere((s.samples.take(), s.crossings.take()));
            }
        }
    }

    /// The field changed within `radius` of `center` (an edit): drops the kept
    /// samples of the chunks it reaches and returns them
    /// ([`World::chunks_near_edit`]), to rebuild.
    pub fn edited(&mut self, center: Vec3, radius: f32) -> Vec<ChunkKey> {
        let keys = self.chunks_near_edit(center, radius);
        self.forget_samples(&keys);
        keys
    }

    /// Forgets chunk `k`'s tree (a failed build): its mesh and the seams it owns
    /// become empty, and [`World::stale`] lists it again.
    pub fn remove_tree(&mut self, k: &ChunkKey) {
        let s = self.slot_mut(k);
        drop_elsewhere((s.tree.take(), s.samples.take(), s.crossings.take()));
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
    ///
    /// The memory budget holds what the world actually retains: chunks are
    /// built in batches (16 per thread), and before each batch the trees and
    /// samples retained so far, the estimate
    /// ([`crate::hermite::estimate_bytes`]) of each build that runs at once,
    /// and the batch's trees at the mean size of those built so far must fit;
    /// a world that outgrows its budget stops with [`crate::Error::TooLarge`]
    /// (the chunks built so far are kept).
    pub fn build(&mut self, keys: &[ChunkKey], field: &dyn Field) -> Result<()> {
        use rayon::prelude::*;
        let inner = Settings {
            threads: 0,
            ..self.settings.clone()
        };
        // At most `threads` builds run at once; a batch of many keeps every
        // thread busy (chunks differ in cost), and the trees it will add are
        // counted ahead at the mean of the trees built so far.
        let threads = self.settings.run(rayon::current_num_threads)?.max(1);
        let batch = threads * 16;
        let (mut added, mut built_count) = (0u64, 0u64);
        let budget = self.settings.memory_budget;
        let mut retained = self.retained_bytes() as u64;
        for (done, part) in keys.chunks(batch).enumerate() {
            let builds: Vec<ChunkBuild> = part
                .iter()
                .map(|k| ChunkBuild {
                    settings: inner.clone(),
                    ..self.chunk_build(k)
                })
                .collect();
            let transient = builds
                .iter()
                .map(|b| crate::hermite::estimate_bytes(&b.grid))
                .max()
                .unwrap_or(0)
                .saturating_mul(threads.min(builds.len()) as u64)
                .saturating_add((added / built_count.max(1)).saturating_mul(builds.len() as u64));
            crate::budget::check_budget(
                format!(
                    "a world of {} chunks of {}^3 cells, with {} built ({} retained)",
                    keys.len(),
                    self.chunk_res,
                    done * batch,
                    crate::error::Size(retained),
                ),
                retained.saturating_add(transient),
                budget,
            )?;
            let built: Vec<Result<BuiltChunk>> = self
                .settings
                .run(|| builds.par_iter().map(|b| b.build(field)).collect())?;
            for (b, t) in builds.iter().zip(built) {
                let before = self
                    .slots
                    .get(&b.key)
                    .map_or(0, super::Slot::retained_bytes);
                self.insert_built(b, t?);
                let after = self
                    .slots
                    .get(&b.key)
                    .map_or(0, super::Slot::retained_bytes);
                retained = (retained + after as u64).saturating_sub(before as u64);
                added += after as u64;
                built_count += 1;
            }
        }
        Ok(())
    }

    /// Builds every chunk.
    pub fn build_all(&mut self, field: &dyn Field) -> Result<()> {
        self.build(&self.chunks(), field)
    }

    /// Builds the chunks [`World::stale`] lists; returns them.
    pub fn build_stale(&mut self, field: &dyn Field) -> Result<Vec<ChunkKey>> {
        let stale = self.stale();
        self.build(&stale, field)?;
        Ok(stale)
    }

    /// The chunks an edit within `radius` of `center` (world units) reaches:
    /// those whose box, grown by the cells their samples read past it, meets that
    /// ball (one cell of halo, and one more where the chunk conforms to a coarser
    /// neighbour). Rebuild them with [`World::build`]; every level that covers the
    /// edit is among them. (When the field changed there, [`World::edited`] also
    /// drops their kept samples.)
    pub fn chunks_near_edit(&self, center: Vec3, radius: f32) -> Vec<ChunkKey> {
        self.chunks()
            .into_iter()
            .filter(|k| {
                let (lo, hi) = self.chunk_bounds(k);
                let conforms = self
                    .neighbourhoods
                    .get(k)
                    .is_some_and(|n| !n.coarser.is_empty() || n.level_faces.contains(&true));
                let cells = if conforms { 2.0 } else { 1.0 };
                let grow = cells * self.chunk_grid(k).cell_size;
                center.clamp(lo - grow, hi + grow).distance(center) <= radius
            })
            .collect()
    }
}
