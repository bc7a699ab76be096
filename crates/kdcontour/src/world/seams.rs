//! The seams of a world: which chunks meet where, who owns each seam, the seam
//! walk's jobs, and extraction (the rules are in the parent module's docs).

use super::layout::{ChunkKey, Layout};
use super::World;
use crate::kdtree::{contour, Job, KdTree, Part};
use crate::mesh::IndexedMesh;
use glam::IVec3;
use std::collections::HashMap;
use std::sync::Arc;

/// [`ChunkKey::order`]'s key.
type SortKey = (i32, i32, i32, u32);

/// A seam between chunks of a world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Seam {
    /// Two chunks whose faces overlap: `low` below the face along `axis`.
    Face {
        /// The chunk below.
        low: ChunkKey,
        /// The chunk above.
        high: ChunkKey,
        /// The face's axis.
        axis: usize,
    },
    /// The chunks around a stretch of chunk edge along `axis`, in quadrant order.
    Edge {
        /// The four chunks (one may fill two quadrants).
        parts: [ChunkKey; 4],
        /// The edge's axis.
        axis: usize,
        /// The edge line in level-0 chunks (the coordinate along `axis` unused).
        line: IVec3,
    },
}

impl Seam {
    /// The chunk that owns the seam.
    pub fn owner(&self) -> ChunkKey {
        match *self {
            Seam::Face { low, high, .. } => {
                if high.level < low.level {
                    high
                } else {
                    low
                }
            }
            Seam::Edge { parts, .. } => {
                let mut best = parts[0];
                for p in &parts[1..] {
                    if p.level < best.level {
                        best = *p;
                    }
                }
                best
            }
        }
    }

    /// The chunks it joins.
    pub fn chunks(&self) -> Vec<ChunkKey> {
        match *self {
            Seam::Face { low, high, .. } => vec![low, high],
            Seam::Edge { parts, .. } => parts.to_vec(),
        }
    }

    /// Order of a chunk's owned seams: by axis, the face before the edges, then by
    /// position.
    fn order(&self) -> (usize, u8, [SortKey; 4]) {
        let z = (0, 0, 0, 0);
        match *self {
            Seam::Face { low, high, axis } => (axis, 0, [low.order(), high.order(), z, z]),
            Seam::Edge { parts, axis, .. } => (axis, 1, parts.map(|p| p.order())),
        }
    }
}

impl Layout {
    /// Every seam that involves chunk `k` (built or not), each once.
    pub fn seams_of(&self, k: &ChunkKey) -> Vec<Seam> {
        let mut out = Vec::new();
        let l = self;
        // Faces: the chunks across each face of k whose faces overlap k's.
        for a in 0..3 {
            for side in [-1, 1] {
                let mut probe = k.lo();
                if side == 1 {
                    probe[a] = k.hi()[a];
                } else {
                    probe[a] -= 1;
                }
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                // Neighbours are at most one level finer: one probe per quarter.
                let step = (k.side() / 2).max(1);
                for i in 0..k.side() / step {
                    for j in 0..k.side() / step {
                        let mut p = probe;
                        p[u] += i * step;
                        p[v] += j * step;
                        let Some(n) = l.chunk_at(p) else { continue };
                        let (low, high) = if side == 1 { (*k, n) } else { (n, *k) };
                        let s = Seam::Face { low, high, axis: a };
                        if !out.contains(&s) {
                            out.push(s);
                        }
                    }
                }
            }
        }
        // Edges: around each of k's 12 edges, stretch by stretch (half edges:
        // finer neighbours are half as long).
        for d in 0..3 {
            let (u, v) = ((d + 1) % 3, (d + 2) % 3);
            for ou in 0..2 {
                for ov in 0..2 {
                    let mut line = k.lo();
                    line[u] += ou * k.side();
                    line[v] += ov * k.side();
                    let steps = k.side().max(2) / 2;
                    for h in 0..k.side() / steps {
                        let mut parts = [*k; 4];
                        let mut ok = true;
                        for (q, (qu, qv)) in
                            [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate()
                        {
                            let mut p = line;
                            p[d] += h * steps;
                            p[u] += qu - 1;
                            p[v] += qv - 1;
                            match l.chunk_at(p) {
                                Some(n) => parts[q] = n,
                                None => ok = false,
                            }
                        }
                        let distinct = parts
                            .iter()
                            .enumerate()
                            .filter(|(i, p)| !parts[..*i].contains(p))
                            .count();
                        let s = Seam::Edge {
                            parts,
                            axis: d,
                            line,
                        };
                        if ok && distinct >= 3 && !out.contains(&s) {
                            out.push(s);
                        }
                    }
                }
            }
        }
        out
    }

    /// The seams chunk `k` owns, in extraction order.
    pub fn owned_seams(&self, k: &ChunkKey) -> Vec<Seam> {
        let mut v: Vec<Seam> = self
            .seams_of(k)
            .into_iter()
            .filter(|s| s.owner() == *k)
            .collect();
        v.sort_by_key(|s| s.order());
        v
    }

    /// The chunks whose owned seams touch chunk `k`, `k` first.
    pub fn seam_owners_touching(&self, k: &ChunkKey) -> Vec<ChunkKey> {
        let mut out = vec![*k];
        for s in self.seams_of(k) {
            let o = s.owner();
            if !out.contains(&o) {
                out.push(o);
            }
        }
        out
    }
}

impl World {
    /// Every seam that involves chunk `k` (built or not), each once
    /// ([`Layout::seams_of`]).
    pub fn seams_of(&self, k: &ChunkKey) -> Vec<Seam> {
        self.layout.seams_of(k)
    }

    /// The seams chunk `k` owns, in extraction order
    /// ([`Layout::owned_seams`]).
    pub fn owned_seams(&self, k: &ChunkKey) -> Vec<Seam> {
        self.layout.owned_seams(k)
    }

    /// The chunks whose owned seams touch chunk `k`, `k` first
    /// ([`Layout::seam_owners_touching`]).
    pub fn seam_owners_touching(&self, k: &ChunkKey) -> Vec<ChunkKey> {
        self.layout.seam_owners_touching(k)
    }

    /// The job for `seam` over the parts indexed by `index`; `None` when a chunk
    /// is not built.
    pub(super) fn job(
        &self,
        seam: &Seam,
        index: &mut impl FnMut(ChunkKey) -> Option<usize>,
    ) -> Option<Job> {
        let res = self.chunk_res as i32;
        Some(match *seam {
            Seam::Face { low, high, axis } => Job::Face {
                low: index(low)?,
                high: index(high)?,
                axis,
            },
            Seam::Edge { parts, axis, line } => {
                let mut p = [0; 4];
                for (q, k) in parts.iter().enumerate() {
                    p[q] = index(*k)?;
                }
                Job::Edge {
                    parts: p,
                    axis,
                    line: (line * res).to_array(),
                }
            }
        })
    }

    /// What extracting chunk `k` (interior and owned seams) needs, detached from
    /// the world so a task can run it. `None` when `k` has no tree.
    pub fn snapshot(&self, k: &ChunkKey) -> Option<ChunkSnapshot> {
        self.part(k)?;
        let mut keys: Vec<ChunkKey> = vec![*k];
        let mut index = |c: ChunkKey| -> Option<usize> {
            if let Some(i) = keys.iter().position(|x| *x == c) {
                return Some(i);
            }
            self.part(&c)?;
            keys.push(c);
            Some(keys.len() - 1)
        };
        let mut jobs = vec![Job::Cell(0)];
        for s in self.owned_seams(k) {
            if let Some(j) = self.job(&s, &mut index) {
                jobs.push(j);
            }
        }
        let parts = keys
            .iter()
            .map(|c| {
                let p = self.part(c).expect("listed chunks are built");
                (
                    self.slots[c].tree.clone().expect("built"),
                    p.offset,
                    p.threshold,
                    p.shift,
                )
            })
            .collect();
        Some(ChunkSnapshot { parts, jobs })
    }
}

/// A chunk's extraction detached from its world (see [`World::snapshot`]).
#[derive(Clone)]
pub struct ChunkSnapshot {
    parts: Vec<(Arc<KdTree>, IVec3, f32, u32)>,
    jobs: Vec<Job>,
}

impl ChunkSnapshot {
    /// Contours the chunk's interior and its owned seams into `out` (cleared).
    pub fn extract(&self, out: &mut IndexedMesh) {
        out.reset();
        let parts: Vec<Part> = self
            .parts
            .iter()
            .map(|(tree, offset, threshold, shift)| Part {
                tree,
                offset: *offset,
                threshold: *threshold,
                shift: *shift,
            })
            .collect();
        contour(&parts, &self.jobs, out);
    }
}

impl World {
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

    /// Contours one seam into `out` (cleared), each chunk at its own threshold
    /// and level; empty when one of its chunks is not built.
    pub fn extract_seam(&self, seam: &Seam, out: &mut IndexedMesh) {
        out.reset();
        self.contour_seams(&[], &[*seam], out);
    }

    /// The whole world as one welded mesh: every built chunk's interior and every
    /// seam between built chunks, vertices shared, so it can be checked for
    /// watertightness as a whole.
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
