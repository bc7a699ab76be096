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

use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::{self, Hermite};
use crate::kdtree::{self, contour, Job, KdTree, Part};
use crate::mesh::IndexedMesh;
use crate::Settings;
use glam::{IVec3, UVec3, Vec3};
use std::sync::Arc;

/// A grid of chunks with retained trees and per-chunk thresholds.
pub struct ChunkWorld {
    /// World position of lattice corner (0, 0, 0).
    pub origin: Vec3,
    /// Side of one cell (world units).
    pub cell_size: f32,
    /// Cells per chunk along each axis.
    pub chunk_res: u32,
    /// Chunks along x, y, z.
    pub chunks: UVec3,
    /// Build settings used for every chunk.
    pub settings: Settings,
    trees: Vec<Option<Arc<KdTree>>>,
    thresholds: Vec<f32>,
}

impl ChunkWorld {
    /// An empty world (no chunk built yet). Every chunk starts at `threshold`.
    pub fn new(
        origin: Vec3,
        cell_size: f32,
        chunk_res: u32,
        chunks: UVec3,
        threshold: f32,
        settings: Settings,
    ) -> Result<Self> {
        if !(1..=4096).contains(&chunk_res) {
            return Err(Error::InvalidSetting {
                name: "chunk_res",
                reason: format!("{chunk_res} cells per chunk; allowed 1 to 4096"),
            });
        }
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
        if !threshold.is_finite() {
            return Err(Error::InvalidSetting {
                name: "threshold",
                reason: format!("{threshold} must be finite"),
            });
        }
        let n = (chunks.x * chunks.y * chunks.z) as usize;
        let world = ChunkWorld {
            origin,
            cell_size,
            chunk_res,
            chunks,
            settings,
            trees: (0..n).map(|_| None).collect(),
            thresholds: vec![threshold; n],
        };
        world.chunk_grid(UVec3::ZERO).validate()?;
        Ok(world)
    }

    fn index(&self, c: UVec3) -> usize {
        assert!(
            c.cmplt(self.chunks).all(),
            "chunk {c} outside the world's {}",
            self.chunks
        );
        (c.x + self.chunks.x * (c.y + self.chunks.y * c.z)) as usize
    }

    /// Whether `c` is a chunk of this world.
    pub fn contains(&self, c: IVec3) -> bool {
        c.cmpge(IVec3::ZERO).all() && c.cmplt(self.chunks.as_ivec3()).all()
    }

    /// The grid chunk `c` samples: its cells plus one cell of halo on every side.
    pub fn chunk_grid(&self, c: UVec3) -> Grid {
        Grid {
            origin: self.origin,
            cell_size: self.cell_size,
            cells: UVec3::splat(self.chunk_res + 2),
            offset: (c * self.chunk_res).as_ivec3() - IVec3::ONE,
        }
    }

    /// The world box of chunk `c` (min, max).
    pub fn chunk_bounds(&self, c: UVec3) -> (Vec3, Vec3) {
        let lo = self.origin + (c * self.chunk_res).as_vec3() * self.cell_size;
        (lo, lo + Vec3::splat(self.chunk_res as f32 * self.cell_size))
    }

    /// Samples `field` for chunk `c` and builds its tree (replacing an old one).
    pub fn build_chunk(&mut self, c: UVec3, field: &dyn Field) -> Result<()> {
        let tree = self.chunk_build(c).run(field)?;
        self.insert_tree(c, tree);
        Ok(())
    }

    /// Builds every chunk (in parallel over chunks).
    pub fn build_all(&mut self, field: &dyn Field) -> Result<()> {
        use rayon::prelude::*;
        let coords: Vec<UVec3> = self.coords().collect();
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

    /// Every chunk coordinate, x fastest.
    pub fn coords(&self) -> impl Iterator<Item = UVec3> + '_ {
        let n = self.chunks;
        (0..n.z).flat_map(move |z| {
            (0..n.y).flat_map(move |y| (0..n.x).map(move |x| UVec3::new(x, y, z)))
        })
    }

    /// The tree of chunk `c`, if built.
    pub fn tree(&self, c: UVec3) -> Option<&KdTree> {
        self.trees[self.index(c)].as_deref()
    }

    /// Everything needed to build chunk `c` elsewhere (a task, another thread).
    pub fn chunk_build(&self, c: UVec3) -> ChunkBuild {
        ChunkBuild {
            grid: self.chunk_grid(c),
            res: self.chunk_res,
            settings: self.settings.clone(),
        }
    }

    /// Installs a tree built by [`ChunkBuild::run`] for chunk `c`.
    pub fn insert_tree(&mut self, c: UVec3, tree: KdTree) {
        let i = self.index(c);
        self.trees[i] = Some(Arc::new(tree));
    }

    /// Forgets chunk `c`'s tree (its mesh and the seams it owns become empty).
    pub fn remove_tree(&mut self, c: UVec3) {
        let i = self.index(c);
        self.trees[i] = None;
    }

    /// What extracting chunk `c` (interior and owned seams) needs, detached from the
    /// world so a task can run it: the trees of `c` and its upper neighbours, and
    /// their thresholds. `None` when `c` has no tree.
    pub fn snapshot(&self, c: UVec3) -> Option<ChunkSnapshot> {
        let (parts, jobs) = self.owned_jobs(c);
        if parts.is_empty() {
            return None;
        }
        // owned_jobs lists chunk c first; map parts back to their Arcs.
        let mut owned = Vec::new();
        for p in &parts {
            let cc = ((p.offset + IVec3::ONE) / self.chunk_res as i32).as_uvec3();
            owned.push((
                self.trees[self.index(cc)].clone().expect("built"),
                p.offset,
                p.threshold,
            ));
        }
        let mut interior = vec![Job::Cell(0)];
        interior.extend(jobs);
        Some(ChunkSnapshot {
            parts: owned,
            jobs: interior,
        })
    }

    /// The threshold chunk `c` is cut at.
    pub fn threshold(&self, c: UVec3) -> f32 {
        self.thresholds[self.index(c)]
    }

    /// Sets chunk `c`'s threshold. Re-extract `c` and the seams of
    /// [`ChunkWorld::seam_owners_touching`]`(c)` to show it.
    pub fn set_threshold(&mut self, c: UVec3, threshold: f32) {
        let i = self.index(c);
        self.thresholds[i] = threshold;
    }

    /// The chunks whose owned seams touch chunk `c`: `c` and its lower neighbours
    /// across one or two axes (up to seven chunks).
    pub fn seam_owners_touching(&self, c: UVec3) -> Vec<UVec3> {
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
            let o = c.as_ivec3() - d;
            if self.contains(o) {
                out.push(o.as_uvec3());
            }
        }
        out
    }

    fn part(&self, c: UVec3) -> Option<Part<'_>> {
        let i = self.index(c);
        self.trees[i].as_deref().map(|tree| Part {
            tree,
            offset: (c * self.chunk_res).as_ivec3() - IVec3::ONE,
            threshold: self.thresholds[i],
        })
    }

    /// The seam jobs chunk `c` owns, with the parts they need (part 0 is `c`).
    fn owned_jobs(&self, c: UVec3) -> (Vec<Part<'_>>, Vec<Job>) {
        let mut jobs = Vec::new();
        let Some(me) = self.part(c) else {
            return (Vec::new(), jobs);
        };
        let mut parts = vec![me];
        let mut find = |o: IVec3| -> Option<usize> {
            if !self.contains(o) {
                return None;
            }
            let p = self.part(o.as_uvec3())?;
            parts.push(p);
            Some(parts.len() - 1)
        };
        let ci = c.as_ivec3();
        for a in 0..3 {
            if let Some(high) = find(ci + IVec3::AXES[a]) {
                jobs.push(Job::Face {
                    low: 0,
                    high,
                    axis: a,
                });
            }
        }
        for a in 0..3 {
            let (u, v) = (IVec3::AXES[(a + 1) % 3], IVec3::AXES[(a + 2) % 3]);
            let q1 = find(ci + u);
            let q2 = find(ci + u + v);
            let q3 = find(ci + v);
            if let (Some(q1), Some(q2), Some(q3)) = (q1, q2, q3) {
                jobs.push(Job::Edge {
                    parts: [0, q1, q2, q3],
                    axis: a,
                });
            }
        }
        (parts, jobs)
    }

    /// Contours the inside of chunk `c` at its threshold into `out` (cleared).
    pub fn extract_interior(&self, c: UVec3, out: &mut IndexedMesh) {
        out.reset();
        if let Some(p) = self.part(c) {
            contour(&[p], &[Job::Cell(0)], out);
        }
    }

    /// Contours the seams chunk `c` owns into `out` (cleared), each neighbour at its
    /// own threshold.
    pub fn extract_seams(&self, c: UVec3, out: &mut IndexedMesh) {
        out.reset();
        let (parts, jobs) = self.owned_jobs(c);
        contour(&parts, &jobs, out);
    }

    /// The whole world as one welded mesh: every interior and every seam, vertices
    /// shared, so it can be checked for watertightness as a whole.
    pub fn extract_all(&self) -> IndexedMesh {
        let coords: Vec<UVec3> = self.coords().collect();
        let index_of: std::collections::HashMap<UVec3, usize> =
            coords.iter().enumerate().map(|(i, &c)| (c, i)).collect();
        let parts: Vec<Part> = coords
            .iter()
            .map(|&c| {
                self.part(c)
                    .unwrap_or_else(|| panic!("chunk {c} is not built"))
            })
            .collect();
        let mut jobs = Vec::new();
        for (i, &c) in coords.iter().enumerate() {
            jobs.push(Job::Cell(i));
            let ci = c.as_ivec3();
            let at = |o: IVec3| {
                if self.contains(o) {
                    index_of.get(&o.as_uvec3()).copied()
                } else {
                    None
                }
            };
            for a in 0..3 {
                if let Some(high) = at(ci + IVec3::AXES[a]) {
                    jobs.push(Job::Face {
                        low: i,
                        high,
                        axis: a,
                    });
                }
                let (u, v) = (IVec3::AXES[(a + 1) % 3], IVec3::AXES[(a + 2) % 3]);
                if let (Some(q1), Some(q2), Some(q3)) = (at(ci + u), at(ci + u + v), at(ci + v)) {
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
        self.trees
            .iter()
            .flatten()
            .map(|t| t.retained_bytes())
            .sum()
    }
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
        let values = hermite::sample(field, grid, settings)?;
        let h = Hermite::new(field, grid, &values, settings)?;
        let r = res as u16;
        Ok(kdtree::build_in(
            &h,
            settings.partition,
            [1, 1, 1],
            [r + 1, r + 1, r + 1],
        ))
    })?
}

/// A chunk's threshold from its distance to the camera:
/// `base * max(1, d / near)^growth`, capped at `max`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lod {
    /// Threshold within `near` of the camera.
    pub base: f32,
    /// Distance (world units) up to which chunks stay at `base`.
    pub near: f32,
    /// How fast the threshold grows with distance (2: quadratic).
    pub growth: f32,
    /// Largest threshold.
    pub max: f32,
}

impl Default for Lod {
    fn default() -> Self {
        Lod {
            base: 0.001,
            near: 0.25,
            growth: 2.0,
            max: 10.0,
        }
    }
}

impl Lod {
    /// The threshold at distance `d`.
    pub fn threshold(&self, d: f32) -> f32 {
        (self.base * (d / self.near).max(1.0).powf(self.growth)).min(self.max)
    }

    /// Checks the curve's values.
    pub fn check(&self) -> Result<()> {
        let ok = self.base.is_finite()
            && self.near.is_finite()
            && self.near > 0.0
            && self.growth.is_finite()
            && self.growth >= 0.0
            && self.max.is_finite()
            && self.max >= self.base;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidSetting {
                name: "lod",
                reason: format!("{self:?}: near must be > 0, growth >= 0, max >= base, all finite"),
            })
        }
    }
}

impl ChunkWorld {
    /// Sets every chunk's threshold from its distance to `camera` (the nearest point
    /// of its box). Returns the chunks whose threshold changed.
    pub fn apply_lod(&mut self, camera: Vec3, lod: &Lod) -> Vec<UVec3> {
        let coords: Vec<UVec3> = self.coords().collect();
        let mut changed = Vec::new();
        for c in coords {
            let (lo, hi) = self.chunk_bounds(c);
            let e = lod.threshold(camera.clamp(lo, hi).distance(camera));
            if e != self.threshold(c) {
                self.set_threshold(c, e);
                changed.push(c);
            }
        }
        changed
    }
}
