//! Layouts: which chunk, at which level, covers each part of a region (an octree
//! of chunks), or, for streaming terrain, an open set of level-0 chunks.
//!
//! A chunk at level `k` covers `2^k` level-0 chunks per axis and sits at a
//! multiple of `2^k` level-0 chunks, so every chunk is an octree cell and the
//! leaves of a layout tile its region. A layout is **balanced** when every two
//! chunks that touch (through a face, an edge or a corner) differ by at most one
//! level; [`Layout::check`] says whether it covers its region exactly once and is
//! balanced, and the constructors ([`Layout::uniform`], [`Layout::random`],
//! [`Layout::around`]) return only such layouts. An **open** layout
//! ([`Layout::open`]) has no region: its level-0 chunks come and go one by one
//! ([`super::World::add_chunk`]), and a seam whose neighbour is missing stays open.

use crate::error::{Error, Result};
use glam::{IVec3, Vec3};
use std::collections::{HashMap, HashSet};
use std::hash::BuildHasherDefault;

/// Deepest level a layout may use (a level-20 chunk is a million level-0 chunks
/// wide).
pub const MAX_LEVEL: u32 = 20;

/// A fast hasher for [`ChunkKey`]s (a multiply-rotate hash of the level and the
/// three coordinates, as rustc's FxHash): layouts look chunks up by the
/// thousand per change, and the keys come from our own code, not from input
/// an attacker chooses, so the standard library's DoS-resistant SipHash only
/// costs time here.
#[derive(Clone, Copy, Default)]
pub struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }

    fn write_u32(&mut self, n: u32) {
        self.write_u64(n as u64);
    }

    fn write_i32(&mut self, n: i32) {
        self.write_u64(n as u32 as u64);
    }

    fn write_u64(&mut self, n: u64) {
        self.0 = (self.0.rotate_left(5) ^ n).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// A map keyed by chunk ([`KeyHasher`]).
pub type ChunkMap<V> = HashMap<ChunkKey, V, BuildHasherDefault<KeyHasher>>;

/// A set of chunks ([`KeyHasher`]).
pub type ChunkSet = HashSet<ChunkKey, BuildHasherDefault<KeyHasher>>;

/// A chunk of a level layout: level `level`, at `coord` in units of
/// level-`level` chunks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ChunkKey {
    /// The level: cells of `2^level` level-0 cells.
    pub level: u32,
    /// Position in units of chunks of this level.
    pub coord: IVec3,
}

impl ChunkKey {
    /// The chunk at `level` and `coord`.
    pub fn new(level: u32, coord: IVec3) -> Self {
        ChunkKey { level, coord }
    }

    /// Its lowest corner, in level-0 chunks.
    pub fn lo(&self) -> IVec3 {
        self.coord << self.level as i32
    }

    /// Its highest corner (exclusive), in level-0 chunks.
    pub fn hi(&self) -> IVec3 {
        (self.coord + IVec3::ONE) << self.level as i32
    }

    /// Its side in level-0 chunks.
    pub fn side(&self) -> i32 {
        1 << self.level
    }

    /// The chunk one level up that holds it.
    pub fn parent(&self) -> ChunkKey {
        ChunkKey::new(self.level + 1, self.coord >> 1)
    }

    /// Its eight halves one level down, x fastest.
    pub fn children(&self) -> [ChunkKey; 8] {
        debug_assert!(self.level > 0);
        std::array::from_fn(|i| {
            let o = IVec3::new(i as i32 & 1, (i as i32 >> 1) & 1, (i as i32 >> 2) & 1);
            ChunkKey::new(self.level - 1, self.coord * 2 + o)
        })
    }

    /// Whether the closed boxes of the two chunks meet (they share a face, an
    /// edge or a corner, or overlap).
    pub fn touches(&self, other: &ChunkKey) -> bool {
        self.lo().cmple(other.hi()).all() && other.lo().cmple(self.hi()).all()
    }

    /// Sort key: lowest corner z, then y, then x, then level.
    pub fn order(&self) -> (i32, i32, i32, u32) {
        let lo = self.lo();
        (lo.z, lo.y, lo.x, self.level)
    }
}

impl std::fmt::Display for ChunkKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "level-{} chunk {}", self.level, self.coord)
    }
}

/// A set of chunks that tiles a box of level-0 chunks, or an open set of level-0
/// chunks ([`Layout::open`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    lo: IVec3,
    hi: IVec3,
    leaves: ChunkSet,
    max_level: u32,
    open: bool,
}

/// Small deterministic generator for random layouts (SplitMix64).
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl Layout {
    /// The layout with the given chunks over the region `lo..hi` (level-0 chunks).
    /// Errors unless they cover it exactly once and are balanced.
    pub fn new(lo: IVec3, hi: IVec3, leaves: impl IntoIterator<Item = ChunkKey>) -> Result<Self> {
        let leaves: ChunkSet = leaves.into_iter().collect();
        let max_level = leaves.iter().map(|k| k.level).max().unwrap_or(0);
        let layout = Layout {
            lo,
            hi,
            leaves,
            max_level,
            open: false,
        };
        layout.check()?;
        Ok(layout)
    }

    /// An open one-level layout with no chunk: no region, level-0 chunks added and
    /// removed one by one (streaming terrain around a camera).
    pub fn open() -> Self {
        Layout {
            lo: IVec3::ZERO,
            hi: IVec3::ZERO,
            leaves: ChunkSet::default(),
            max_level: 0,
            open: true,
        }
    }

    /// Whether the layout is open ([`Layout::open`]).
    pub fn is_open(&self) -> bool {
        self.open
    }

    /// Adds level-0 chunk `k` to an open layout; returns whether it is new.
    pub(crate) fn insert(&mut self, k: ChunkKey) -> bool {
        debug_assert!(self.open && k.level == 0);
        self.leaves.insert(k)
    }

    /// Removes chunk `k` from an open layout; returns whether it was there.
    pub(crate) fn remove(&mut self, k: &ChunkKey) -> bool {
        debug_assert!(self.open);
        self.leaves.remove(k)
    }

    /// The region tiled by chunks of level `top` (`lo` and `hi` multiples of
    /// `2^top`).
    pub fn uniform(lo: IVec3, hi: IVec3, top: u32) -> Result<Self> {
        Self::new(lo, hi, tiles(lo, hi, top)?)
    }

    /// A random balanced layout: chunks of level `top` tile the region, each chunk
    /// above level 0 splits with probability `split` (seeded), then the layout is
    /// balanced by splitting chunks that touch ones two levels finer.
    pub fn random(lo: IVec3, hi: IVec3, top: u32, split: f64, seed: u64) -> Result<Self> {
        let mut rng = Rng(seed);
        let mut out = Vec::new();
        let mut todo = tiles(lo, hi, top)?;
        todo.sort_by_key(|k| std::cmp::Reverse(k.order()));
        while let Some(k) = todo.pop() {
            if k.level > 0 && rng.unit() < split {
                let mut kids = k.children();
                kids.reverse();
                todo.extend(kids);
            } else {
                out.push(k);
            }
        }
        Self::balanced(lo, hi, out)
    }

    /// The balanced layout of rings around `camera` (level-0 chunk units): a chunk
    /// above level 0 splits while the camera is within `ring` of its own side of
    /// its box, so level `k` reaches out to about `ring * 2^(k + 1)` level-0
    /// chunks; chunks of level `top` tile the region.
    pub fn around(lo: IVec3, hi: IVec3, top: u32, camera: Vec3, ring: f32) -> Result<Self> {
        if !(camera.is_finite() && ring.is_finite() && ring >= 0.0) {
            return Err(Error::InvalidSetting {
                name: "camera",
                reason: format!("camera {camera} and ring {ring} must be finite, ring >= 0"),
            });
        }
        let mut out = Vec::new();
        let mut todo = tiles(lo, hi, top)?;
        while let Some(k) = todo.pop() {
            let d = camera
                .clamp(k.lo().as_vec3(), k.hi().as_vec3())
                .distance(camera);
            if k.level > 0 && d < ring * k.side() as f32 {
                todo.extend(k.children());
            } else {
                out.push(k);
            }
        }
        Self::balanced(lo, hi, out)
    }

    /// How far (in its own chunk widths, to the nearest point of its box) a
    /// chunk of an [`Layout::around`] layout below the top level can be from
    /// the camera it was made for: `2 ring + 2√3 + 1`. Its parent split with
    /// the camera within `ring` of its own widths, so within `2 ring` of the
    /// chunk's, and the chunk lies within the parent's diagonal (`2√3`) of it;
    /// balancing splits chunks a little farther (measured on random cameras
    /// for rings 0.5 to 3: at most 5.1 widths, where `2 ring + 2√3` is 4.5 at
    /// ring 0.5), which the last width covers. Top-level chunks tile the
    /// region and are as far as it reaches.
    pub fn around_reach(ring: f32) -> f32 {
        2.0 * ring + 2.0 * 3f32.sqrt() + 1.0
    }

    /// Balances a tiling of the region by splitting every chunk that touches one
    /// two or more levels finer, until none does.
    fn balanced(lo: IVec3, hi: IVec3, leaves: Vec<ChunkKey>) -> Result<Self> {
        let max_level = leaves.iter().map(|k| k.level).max().unwrap_or(0);
        let mut layout = Layout {
            lo,
            hi,
            leaves: leaves.into_iter().collect(),
            max_level,
            open: false,
        };
        loop {
            let mut split: Vec<ChunkKey> = layout
                .leaves
                .iter()
                .filter(|k| k.level >= 2 && layout.finest_touching(k) + 1 < k.level)
                .copied()
                .collect();
            if split.is_empty() {
                break;
            }
            split.sort_by_key(|k| k.order());
            for k in split {
                layout.leaves.remove(&k);
                layout.leaves.extend(k.children());
            }
        }
        layout.check()?;
        Ok(layout)
    }

    /// The region's lowest corner (level-0 chunks; zero for an open layout).
    pub fn lo(&self) -> IVec3 {
        self.lo
    }

    /// The region's highest corner, exclusive (level-0 chunks; zero for an open
    /// layout).
    pub fn hi(&self) -> IVec3 {
        self.hi
    }

    /// The deepest level in use.
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// Number of chunks.
    pub fn len(&self) -> usize {
        self.leaves.len()
    }

    /// Whether the layout has no chunk.
    pub fn is_empty(&self) -> bool {
        self.leaves.is_empty()
    }

    /// Whether `k` is one of the layout's chunks.
    pub fn contains(&self, k: &ChunkKey) -> bool {
        self.leaves.contains(k)
    }

    /// Every chunk, sorted by [`ChunkKey::order`].
    pub fn chunks(&self) -> Vec<ChunkKey> {
        let mut v: Vec<ChunkKey> = self.leaves.iter().copied().collect();
        v.sort_by_key(|k| k.order());
        v
    }

    /// Chunks per level, level 0 first.
    pub fn level_counts(&self) -> Vec<usize> {
        let mut n = vec![0; self.max_level as usize + 1];
        for k in &self.leaves {
            n[k.level as usize] += 1;
        }
        n
    }

    /// The chunk that holds level-0 chunk `c`, if `c` is in the region.
    pub fn chunk_at(&self, c: IVec3) -> Option<ChunkKey> {
        (0..=self.max_level)
            .map(|l| ChunkKey::new(l, c >> l as i32))
            .find(|k| self.leaves.contains(k))
    }

    /// The chunk that is `k` or holds it, if any.
    fn covering(&self, k: &ChunkKey) -> Option<ChunkKey> {
        (k.level..=self.max_level)
            .map(|l| ChunkKey::new(l, k.coord >> (l - k.level) as i32))
            .find(|c| self.leaves.contains(c))
    }

    fn in_region(&self, k: &ChunkKey) -> bool {
        self.open || (k.lo().cmpge(self.lo).all() && k.hi().cmple(self.hi).all())
    }

    /// The finest level among the chunks that touch `k` (`k.level` when none is
    /// finer).
    fn finest_touching(&self, k: &ChunkKey) -> u32 {
        let mut best = k.level;
        for dir in neighbour_dirs() {
            let n = ChunkKey::new(k.level, k.coord + dir);
            if !self.in_region(&n) || self.covering(&n).is_some() {
                continue;
            }
            best = best.min(self.finest_in(&n, k));
        }
        best
    }

    /// The finest chunk inside `n` (not itself a chunk) that touches `k`.
    fn finest_in(&self, n: &ChunkKey, k: &ChunkKey) -> u32 {
        let mut best = n.level;
        if n.level == 0 {
            return 0;
        }
        for c in n.children() {
            if !c.touches(k) {
                continue;
            }
            if self.leaves.contains(&c) {
                best = best.min(c.level);
            } else {
                best = best.min(self.finest_in(&c, k));
            }
        }
        best
    }

    /// The chunks at level `k.level + 1` that touch `k` (its coarser neighbours).
    pub fn coarser_touching(&self, k: &ChunkKey) -> Vec<ChunkKey> {
        let mut out = Vec::new();
        for dir in neighbour_dirs() {
            let n = ChunkKey::new(k.level, k.coord + dir);
            if let Some(c) = self.covering(&n) {
                if c.level > k.level && !out.contains(&c) {
                    out.push(c);
                }
            }
        }
        out.sort_by_key(|c| c.order());
        out
    }

    /// For each face of `k` (`2 * axis + side`), whether the chunks across it are
    /// at another level than `k` (finer or coarser).
    pub fn level_faces(&self, k: &ChunkKey) -> [bool; 6] {
        self.faces_where(k, |n, covering| covering != Some(*n))
    }

    /// For each face of `k` (`2 * axis + side`), whether the chunks across it are
    /// finer than `k`.
    pub fn finer_faces(&self, k: &ChunkKey) -> [bool; 6] {
        // Neither a chunk nor inside one: chunks inside it.
        self.faces_where(k, |_, covering| covering.is_none())
    }

    /// For each face of `k`: whether `test` holds for the same-level key `n`
    /// across it (in the region) and the chunk that is or holds `n`, if any.
    /// All false in a one-level layout (an open one may have holes: no
    /// neighbour is no level).
    fn faces_where(
        &self,
        k: &ChunkKey,
        test: impl Fn(&ChunkKey, Option<ChunkKey>) -> bool,
    ) -> [bool; 6] {
        if self.max_level == 0 {
            return [false; 6];
        }
        std::array::from_fn(|f| {
            let (a, s) = (f / 2, f % 2);
            let mut dir = IVec3::ZERO;
            dir[a] = if s == 1 { 1 } else { -1 };
            let n = ChunkKey::new(k.level, k.coord + dir);
            self.in_region(&n) && test(&n, self.covering(&n))
        })
    }

    /// Checks that the chunks lie in the region on their own level's grid, cover
    /// it exactly once, and that touching chunks differ by at most one level (of
    /// an open layout: that every chunk is at level 0).
    pub fn check(&self) -> Result<()> {
        let bad = |reason: String| {
            Err(Error::InvalidSetting {
                name: "layout",
                reason,
            })
        };
        if self.open {
            return match self.leaves.iter().find(|k| k.level != 0) {
                Some(k) => bad(format!("{k:?} is above level 0 in an open layout")),
                None => Ok(()),
            };
        }
        if !self.lo.cmplt(self.hi).all() {
            return bad(format!("empty region {}..{}", self.lo, self.hi));
        }
        let mut volume = 0i128;
        for k in &self.leaves {
            if k.level > MAX_LEVEL {
                return bad(format!("{k:?} is above level {MAX_LEVEL}"));
            }
            if !self.in_region(k) {
                return bad(format!(
                    "{k:?} is outside the region {}..{}",
                    self.lo, self.hi
                ));
            }
            if let Some(c) = self.covering(&k.parent()) {
                return bad(format!("{k:?} overlaps {c:?}"));
            }
            volume += (k.side() as i128).pow(3);
        }
        let size = (self.hi - self.lo).as_i64vec3();
        let want = size.x as i128 * size.y as i128 * size.z as i128;
        if volume != want {
            return bad(format!(
                "the chunks cover {volume} of the region's {want} level-0 chunks"
            ));
        }
        for k in self.leaves.iter().filter(|k| k.level >= 2) {
            let f = self.finest_touching(k);
            if f + 1 < k.level {
                return bad(format!("{k:?} touches a chunk of level {f}: not balanced"));
            }
        }
        Ok(())
    }
}

/// The chunks of level `top` that tile `lo..hi`.
fn tiles(lo: IVec3, hi: IVec3, top: u32) -> Result<Vec<ChunkKey>> {
    let side = 1i64 << top.min(MAX_LEVEL);
    let aligned = |v: IVec3| {
        v.to_array()
            .iter()
            .all(|&x| (x as i64).rem_euclid(side) == 0)
    };
    let cells = (hi - lo).as_i64vec3() / side;
    if top > MAX_LEVEL
        || !lo.cmplt(hi).all()
        || !aligned(lo)
        || !aligned(hi)
        || cells.x * cells.y * cells.z > 1 << 24
    {
        return Err(Error::InvalidSetting {
            name: "layout",
            reason: format!(
                "region {lo}..{hi} (level-0 chunks) must be non-empty, a whole number of \
                 level-{top} chunks along every axis (levels 0 to {MAX_LEVEL}), and at most \
                 2^24 of them"
            ),
        });
    }
    let mut out = Vec::new();
    let (a, b) = (lo >> top as i32, hi >> top as i32);
    for z in a.z..b.z {
        for y in a.y..b.y {
            for x in a.x..b.x {
                out.push(ChunkKey::new(top, IVec3::new(x, y, z)));
            }
        }
    }
    Ok(out)
}

/// The 26 directions to face, edge and corner neighbours.
fn neighbour_dirs() -> impl Iterator<Item = IVec3> {
    (0..27)
        .filter(|&i| i != 13)
        .map(|i| IVec3::new(i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1))
}
