//! A uniform grid over a mesh's triangles (each listed in every bucket its bounding
//! box touches): candidate pairs for the intersection test, and nearest-triangle
//! queries for the surface-to-mesh distance. Near-linear for meshes whose
//! triangles are of similar size.

use glam::{IVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Bits per axis of a packed bucket key.
const KEY_BITS: u32 = 21;
/// Most bucket entries per listed triangle before buckets are made coarser.
const MAX_ENTRIES_PER_TRIANGLE: u64 = 64;

/// Triangles bucketed on a uniform grid.
pub(crate) struct TriGrid<'a> {
    pos: &'a [Vec3],
    tris: &'a [[u32; 3]],
    origin: Vec3,
    /// Bucket side (world units).
    h: f32,
    /// Packed key -> range of `items`.
    buckets: HashMap<u64, (u32, u32)>,
    /// The buckets in key order, for the pair sweep.
    order: Vec<(u64, u32, u32)>,
    items: Vec<u32>,
    /// Per triangle, its bucket range (lo, hi), inclusive.
    ranges: Vec<(IVec3, IVec3)>,
}

fn pack(c: IVec3) -> u64 {
    c.x as u64 | (c.y as u64) << KEY_BITS | (c.z as u64) << (2 * KEY_BITS)
}

impl<'a> TriGrid<'a> {
    /// Buckets the triangles `tris[i]` with `listed[i]`, on buckets of at least
    /// `min_side` (the median triangle extent when larger).
    pub fn new(pos: &'a [Vec3], tris: &'a [[u32; 3]], listed: &[bool], min_side: f32) -> Self {
        let bounds = |t: &[u32; 3]| {
            let p = t.map(|i| pos[i as usize]);
            (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
        };
        let ids: Vec<u32> = (0..tris.len() as u32)
            .filter(|&i| listed[i as usize])
            .collect();
        let mut origin = Vec3::splat(f32::INFINITY);
        let mut top = Vec3::splat(f32::NEG_INFINITY);
        let mut extents = Vec::with_capacity(ids.len());
        for &i in &ids {
            let (lo, hi) = bounds(&tris[i as usize]);
            origin = origin.min(lo);
            top = top.max(hi);
            extents.push((hi - lo).max_element());
        }
        let mut h = min_side.max(f32::MIN_POSITIVE);
        if !extents.is_empty() {
            let mid = extents.len() / 2;
            h = h.max(*extents.select_nth_unstable_by(mid, f32::total_cmp).1);
            // Keys fit their bits.
            h = h.max((top - origin).max_element() / (1u32 << (KEY_BITS - 1)) as f32);
        } else {
            origin = Vec3::ZERO;
        }
        let cell_of = |p: Vec3, h: f32| ((p - origin) / h).floor().as_ivec3().max(IVec3::ZERO);
        let mut ranges = vec![(IVec3::ZERO, IVec3::splat(-1)); tris.len()];
        // Coarser buckets until the entries stay near-linear in the triangles.
        loop {
            let mut entries = 0u64;
            for &i in &ids {
                let (lo, hi) = bounds(&tris[i as usize]);
                let (a, b) = (cell_of(lo, h), cell_of(hi, h));
                ranges[i as usize] = (a, b);
                let n = (b - a + IVec3::ONE).as_i64vec3();
                entries += (n.x * n.y * n.z) as u64;
            }
            if entries <= MAX_ENTRIES_PER_TRIANGLE * ids.len() as u64 + 1024 {
                break;
            }
            h *= 2.0;
        }
        let mut pairs: Vec<(u64, u32)> = Vec::new();
        for &i in &ids {
            let (a, b) = ranges[i as usize];
            for z in a.z..=b.z {
                for y in a.y..=b.y {
                    for x in a.x..=b.x {
                        pairs.push((pack(IVec3::new(x, y, z)), i));
                    }
                }
            }
        }
        pairs.par_sort_unstable();
        let mut buckets = HashMap::new();
        let mut order = Vec::new();
        let mut start = 0;
        while start < pairs.len() {
            let key = pairs[start].0;
            let mut end = start;
            while end < pairs.len() && pairs[end].0 == key {
                end += 1;
            }
            buckets.insert(key, (start as u32, end as u32));
            order.push((key, start as u32, end as u32));
            start = end;
        }
        TriGrid {
            pos,
            tris,
            origin,
            h,
            buckets,
            order,
            items: pairs.into_iter().map(|(_, t)| t).collect(),
            ranges,
        }
    }

    /// `test(a, b)` on every pair of listed triangles whose buckets overlap, each
    /// pair once (in the first bucket both are in); the results that are `Some`.
    pub fn pairs<R: Send>(&self, test: impl Fn(u32, u32) -> Option<R> + Sync) -> Vec<R> {
        self.order
            .par_iter()
            .flat_map_iter(|&(key, s, e)| {
                let list = &self.items[s as usize..e as usize];
                let test = &test;
                (0..list.len()).flat_map(move |i| {
                    (i + 1..list.len()).filter_map(move |j| {
                        let (a, b) = (list[i], list[j]);
                        let first = self.ranges[a as usize].0.max(self.ranges[b as usize].0);
                        if pack(first) != key {
                            return None;
                        }
                        test(a, b)
                    })
                })
            })
            .collect()
    }

    /// Distance from `q` to the nearest listed triangle, or `cap` when none is
    /// nearer.
    pub fn nearest(&self, q: Vec3, cap: f32) -> f32 {
        let c = ((q - self.origin) / self.h).floor();
        if !c.is_finite() || self.order.is_empty() {
            return cap;
        }
        let c = c.as_ivec3();
        let limit = (1i32 << KEY_BITS) - 1;
        let mut best = cap;
        let mut r = 0i32;
        // A bucket `r` rings away holds nothing nearer than `(r - 1) h`.
        while r <= 1 || ((r - 1) as f32) * self.h < best {
            for z in -r..=r {
                for y in -r..=r {
                    for x in -r..=r {
                        if x.abs().max(y.abs()).max(z.abs()) != r {
                            continue;
                        }
                        let k = c + IVec3::new(x, y, z);
                        if k.min_element() < 0 || k.max_element() > limit {
                            continue;
                        }
                        let Some(&(s, e)) = self.buckets.get(&pack(k)) else {
                            continue;
                        };
                        for &t in &self.items[s as usize..e as usize] {
                            let p = self.tris[t as usize].map(|i| self.pos[i as usize]);
                            best = best.min(point_triangle_distance(q, p));
                        }
                    }
                }
            }
            r += 1;
        }
        best
    }
}

/// Distance from `p` to the triangle `t` (closest point after Ericson,
/// *Real-Time Collision Detection*, 5.1.5).
pub(crate) fn point_triangle_distance(p: Vec3, t: [Vec3; 3]) -> f32 {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return p.distance(a + ab * v);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return p.distance(a + ac * w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return p.distance(b + (c - b) * w);
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        // Degenerate: the nearest of its edges' ends.
        return p.distance(a).min(p.distance(b)).min(p.distance(c));
    }
    let (v, w) = (vb / denom, vc / denom);
    p.distance(a + ab * v + ac * w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        // A strip of triangles along x with one big one far away.
        let mut pos = Vec::new();
        let mut tris = Vec::new();
        for i in 0..40 {
            let x = i as f32 * 0.1;
            let b = pos.len() as u32;
            pos.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.1, 0.0, 0.0),
                Vec3::new(x, 0.1, 0.05 * i as f32),
            ]);
            tris.push([b, b + 1, b + 2]);
        }
        let b = pos.len() as u32;
        pos.extend([
            Vec3::new(-5.0, 3.0, 0.0),
            Vec3::new(5.0, 3.0, 0.0),
            Vec3::new(0.0, 3.0, 5.0),
        ]);
        tris.push([b, b + 1, b + 2]);
        let listed = vec![true; tris.len()];
        let g = TriGrid::new(&pos, &tris, &listed, 0.05);
        for k in 0..200 {
            let q = Vec3::new(
                (k as f32 * 0.37).sin() * 3.0 + 1.5,
                (k as f32 * 0.71).cos() * 2.0 + 1.0,
                (k as f32 * 0.13).sin(),
            );
            let brute = tris
                .iter()
                .map(|t| point_triangle_distance(q, t.map(|i| pos[i as usize])))
                .fold(f32::INFINITY, f32::min);
            assert_eq!(g.nearest(q, 100.0), brute, "at {q}");
            assert_eq!(g.nearest(q, 0.01), brute.min(0.01));
        }
        // Every overlapping pair once.
        let pairs = g.pairs(|a, b| Some((a.min(b), a.max(b))));
        let mut sorted = pairs.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), pairs.len());
        assert!(sorted.contains(&(0, 1)));
    }
}
