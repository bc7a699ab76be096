//! Isosurface extraction inside one box: its faces' iso line segments joined into
//! closed edge loops, each loop triangulated by cutting ears.
//!
//! The paper cuts a triangle from three consecutive loop vertices, removes the
//! middle one and repeats, rejecting triangles whose normal deviates too far from
//! the gradients at their vertices and relaxing the bound when none passes. We
//! take the ear that deviates least (the limit of that relaxation), and before
//! that we avoid an ear whose new edge would lie in one of the box's faces: the
//! box across that face may draw the same edge, and two boxes' triangles would
//! then meet along it (a non-manifold edge).

use super::boxes::SimpleBox;
use super::Climb;
use glam::Vec3;

/// A loop vertex: its edge key, position (grid units), normal and the box faces
/// (bit `2 * axis + side`) it lies on.
#[derive(Clone, Copy)]
struct Vertex {
    key: u64,
    point: Vec3,
    normal: Vec3,
    faces: u8,
}

/// Joins `segs` (directed iso line segments on the faces of `b`) into loops and
/// appends their triangles (edge keys, outward winding) to `out`.
pub(super) fn triangulate_box(
    c: &Climb,
    b: &SimpleBox,
    segs: &mut [(u64, u64)],
    out: &mut Vec<[u64; 3]>,
) {
    // Every crossing on the box's faces starts one segment and ends one.
    segs.sort_unstable();
    let mut used = vec![false; segs.len()];
    let mut ring: Vec<Vertex> = Vec::new();
    for first in 0..segs.len() {
        if used[first] {
            continue;
        }
        ring.clear();
        let mut i = first;
        let closed = loop {
            used[i] = true;
            ring.push(vertex(c, b, segs[i].0));
            let to = segs[i].1;
            if to == segs[first].0 {
                break true;
            }
            match segs.binary_search_by(|s| s.0.cmp(&to)) {
                Ok(j) if !used[j] => i = j,
                _ => break false,
            }
        };
        debug_assert!(closed, "iso lines on a box's faces close into loops");
        if closed && ring.len() >= 3 {
            cut_ears(&mut ring, out);
        }
    }
}

/// The loop vertex of the crossing with edge key `key` on box `b`.
fn vertex(c: &Climb, b: &SimpleBox, key: u64) -> Vertex {
    let x = &c.h.edges[c.index[&key] as usize];
    let axis = (key % 3) as usize;
    let corners = c.h.grid.corners();
    let i = (key / 3) as u32;
    let g = [
        i % corners.x,
        (i / corners.x) % corners.y,
        i / (corners.x * corners.y),
    ];
    let mut faces = 0u8;
    for a in (0..3).filter(|&a| a != axis) {
        faces |= ((g[a] == b.lo[a]) as u8) << (2 * a);
        faces |= ((g[a] == b.hi(a)) as u8) << (2 * a + 1);
    }
    Vertex {
        key,
        point: x.point,
        normal: x.normal,
        faces,
    }
}

/// Triangulates the loop `ring` (consumed) by cutting ears.
fn cut_ears(ring: &mut Vec<Vertex>, out: &mut Vec<[u64; 3]>) {
    while ring.len() > 3 {
        let n = ring.len();
        let mut best = (true, f32::NEG_INFINITY, 0usize);
        for i in 0..n {
            let (p, q, r) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            let in_face = p.faces & r.faces != 0;
            let score = agreement(p, q, r);
            if (!in_face && best.0) || (in_face == best.0 && score > best.1) {
                best = (in_face, score, i);
            }
        }
        let i = best.2;
        out.push([
            ring[(i + n - 1) % n].key,
            ring[i].key,
            ring[(i + 1) % n].key,
        ]);
        ring.remove(i);
    }
    out.push([ring[0].key, ring[1].key, ring[2].key]);
}

/// How well triangle `(p, q, r)` agrees with the gradients at its corners: the
/// least cosine between its normal and theirs (-2 for a degenerate triangle).
fn agreement(p: Vertex, q: Vertex, r: Vertex) -> f32 {
    let n = (q.point - p.point).cross(r.point - p.point);
    if n.length_squared() <= 1e-12 {
        return -2.0;
    }
    let n = n.normalize();
    n.dot(p.normal).min(n.dot(q.normal)).min(n.dot(r.normal))
}
