//! Links between tiles: an open polygon edge of one tile that runs along an
//! open edge of a touching tile (within the link tolerance across and the
//! climb in height) is a portal between the two polygons.

use crate::settings::NavSettings;
use crate::tile::NavTile;
use glam::{Vec2, Vec3};

/// A portal from a polygon of one tile to a polygon of another.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Link {
    /// The polygon it leaves (in the tile that holds the link).
    pub from: u32,
    /// The polygon it enters (in the tile `to` names).
    pub to: u32,
    /// The portal's ends.
    pub portal: [Vec3; 2],
}

/// Whether two tiles' boxes touch (share a face, an edge or a corner, or
/// overlap), so their floors may meet.
pub(crate) fn touch(a: &NavTile, b: &NavTile) -> bool {
    let e = 1e-3 * (a.hi - a.lo).max_element().max(1.0);
    (a.lo.cmple(b.hi + e) & b.lo.cmple(a.hi + e)).all()
}

fn xz(v: Vec3) -> Vec2 {
    Vec2::new(v.x, v.z)
}

/// Whether `p` lies within `margin` of `t`'s box on the ground plane and
/// within `dy` of its height range.
fn near_box(t: &NavTile, p: Vec3, margin: f32, dy: f32) -> bool {
    p.x >= t.lo.x - margin
        && p.x <= t.hi.x + margin
        && p.z >= t.lo.z - margin
        && p.z <= t.hi.z + margin
        && p.y >= t.lo.y - dy
        && p.y <= t.hi.y + dy
}

/// The links from `a`'s polygons to `b`'s, and from `b`'s to `a`'s.
pub(crate) fn link(a: &NavTile, b: &NavTile, s: &NavSettings) -> (Vec<Link>, Vec<Link>) {
    let (mut ab, mut ba) = (Vec::new(), Vec::new());
    if a.is_empty() || b.is_empty() || !touch(a, b) {
        return (ab, ba);
    }
    let cs = a.cell_size.max(b.cell_size);
    let across = s.link_tolerance * cs;
    let climb = s.max_climb + 2.0 * a.cell_height.max(b.cell_height);
    // Only the edges near the other tile can meet it.
    let ea: Vec<_> = a
        .open_edges
        .iter()
        .filter(|(_, p, q)| near_box(b, *p, across, climb) || near_box(b, *q, across, climb))
        .copied()
        .collect();
    let eb: Vec<_> = b
        .open_edges
        .iter()
        .filter(|(_, p, q)| near_box(a, *p, across, climb) || near_box(a, *q, across, climb))
        .copied()
        .collect();
    for &(pa, a0, a1) in &ea {
        let d = xz(a1) - xz(a0);
        let len = d.length();
        if len < 1e-5 {
            continue;
        }
        let u = d / len;
        for &(pb, b0, b1) in &eb {
            let (t0, t1) = ((xz(b0) - xz(a0)).dot(u), (xz(b1) - xz(a0)).dot(u));
            if (t1 - t0).abs() < 1e-6 {
                continue;
            }
            let (lo, hi) = (t0.min(t1).max(0.0), t0.max(t1).min(len));
            if hi - lo < cs {
                continue;
            }
            let on_a = |t: f32| a0.lerp(a1, t / len);
            let on_b = |t: f32| b0.lerp(b1, (t - t0) / (t1 - t0));
            let ends = [lo, hi].map(|t| (on_a(t), on_b(t)));
            let fits = ends
                .iter()
                .all(|(p, q)| xz(*p).distance(xz(*q)) <= across && (p.y - q.y).abs() <= climb);
            if !fits {
                continue;
            }
            let portal = ends.map(|(p, q)| (p + q) * 0.5);
            ab.push(Link {
                from: pa,
                to: pb,
                portal,
            });
            ba.push(Link {
                from: pb,
                to: pa,
                portal,
            });
        }
    }
    (ab, ba)
}
