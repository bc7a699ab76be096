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

/// Edge pairs from which [`link`] looks the other tile's edges up in its
/// [`EdgeGrid`] rather than trying every pair.
const GRID_PAIRS: usize = 1024;

/// A tile's open edges bucketed by the ground-plane cells their boxes cover
/// (rows of cells, each cell's edges in one run), built with the tile so that
/// linking it in only looks edges up.
#[derive(Clone, Debug, Default)]
pub(crate) struct EdgeGrid {
    lo: Vec2,
    cell: f32,
    dims: (i32, i32),
    /// Where each cell's run starts in `items` (one more than the cells).
    starts: Vec<u32>,
    /// Edge indices (into the tile's open edges), ascending in each cell.
    items: Vec<u32>,
}

impl EdgeGrid {
    /// Buckets `edges` in cells of side `cell` over the box `lo..hi`.
    pub(crate) fn new(edges: &[(u32, Vec3, Vec3)], lo: Vec2, hi: Vec2, cell: f32) -> Self {
        let dims = (
            ((hi.x - lo.x) / cell).floor() as i32 + 1,
            ((hi.y - lo.y) / cell).floor() as i32 + 1,
        );
        let mut grid = EdgeGrid {
            lo,
            cell,
            dims,
            ..Default::default()
        };
        if edges.is_empty() || cell.is_nan() || cell <= 0.0 {
            return grid;
        }
        let n = (dims.0 * dims.1) as usize;
        let mut counts = vec![0u32; n + 1];
        for pass in 0..2 {
            for (j, &(_, p, q)) in edges.iter().enumerate() {
                let Some((x0, x1, z0, z1)) = grid.cells(xz(p).min(xz(q)), xz(p).max(xz(q))) else {
                    continue;
                };
                for z in z0..=z1 {
                    for x in x0..=x1 {
                        let c = (z * dims.0 + x) as usize;
                        if pass == 0 {
                            counts[c + 1] += 1;
                        } else {
                            grid.items[counts[c] as usize] = j as u32;
                            counts[c] += 1;
                        }
                    }
                }
            }
            if pass == 0 {
                for c in 0..n {
                    counts[c + 1] += counts[c];
                }
                grid.starts = counts.clone();
                grid.items = vec![0; counts[n] as usize];
            }
        }
        grid
    }

    /// The cells (x and z ranges) the box `lo..hi` covers, clamped to the
    /// grid; `None` when it misses it.
    fn cells(&self, lo: Vec2, hi: Vec2) -> Option<(i32, i32, i32, i32)> {
        let at = |v: f32, o: f32| ((v - o) / self.cell).floor();
        let (x0, x1) = (at(lo.x, self.lo.x), at(hi.x, self.lo.x));
        let (z0, z1) = (at(lo.y, self.lo.y), at(hi.y, self.lo.y));
        let (w, h) = (self.dims.0 as f32, self.dims.1 as f32);
        if x1 < 0.0 || z1 < 0.0 || x0 >= w || z0 >= h || x0.is_nan() || z0.is_nan() {
            return None;
        }
        let clamp = |v: f32, n: f32| v.clamp(0.0, n - 1.0) as i32;
        Some((clamp(x0, w), clamp(x1, w), clamp(z0, h), clamp(z1, h)))
    }

    /// The edges whose boxes meet the box `lo..hi`, ascending (the order
    /// trying every pair would take), in `out`.
    fn near(&self, lo: Vec2, hi: Vec2, out: &mut Vec<u32>) {
        out.clear();
        if self.starts.is_empty() {
            return;
        }
        let Some((x0, x1, z0, z1)) = self.cells(lo, hi) else {
            return;
        };
        for z in z0..=z1 {
            for x in x0..=x1 {
                let c = (z * self.dims.0 + x) as usize;
                let run = self.starts[c] as usize..self.starts[c + 1] as usize;
                out.extend_from_slice(&self.items[run]);
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// The links from `a`'s polygons to `b`'s, and from `b`'s to `a`'s.
pub(crate) fn link(a: &NavTile, b: &NavTile, s: &NavSettings) -> (Vec<Link>, Vec<Link>) {
    link_with(a, b, s, GRID_PAIRS)
}

/// [`link`], bucketing the edges from `grid_pairs` edge pairs on.
fn link_with(
    a: &NavTile,
    b: &NavTile,
    s: &NavSettings,
    grid_pairs: usize,
) -> (Vec<Link>, Vec<Link>) {
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
    let near_a = |&(_, p, q): &(u32, Vec3, Vec3)| {
        near_box(a, p, across, climb) || near_box(a, q, across, climb)
    };
    // Indices into b's open edges, as its grid gives them.
    let eb: Vec<u32> = (0..b.open_edges.len() as u32)
        .filter(|&j| near_a(&b.open_edges[j as usize]))
        .collect();
    // With many edges on both sides (a coarse tile with holes against its
    // neighbours), only b's edges whose boxes come within the tolerance of
    // a's edge are tried, from b's grid.
    let grid = (ea.len() * eb.len() > grid_pairs).then_some(&b.edge_grid);
    let mut near = Vec::new();
    for &(pa, a0, a1) in &ea {
        let d = xz(a1) - xz(a0);
        let len = d.length();
        if len < 1e-5 {
            continue;
        }
        let u = d / len;
        if let Some(g) = grid {
            let grow = Vec2::splat(across);
            g.near(
                xz(a0).min(xz(a1)) - grow,
                xz(a0).max(xz(a1)) + grow,
                &mut near,
            );
            near.retain(|&j| near_a(&b.open_edges[j as usize]));
        }
        let every = if grid.is_none() { &eb[..] } else { &near[..] };
        for &j in every {
            let (pb, b0, b1) = b.open_edges[j as usize];
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

#[cfg(test)]
mod tests {
    use super::*;
    use kdcontour::IndexedMesh;

    /// A rolling floor over `x0..x1` by `0..depth` in squares of `step`, with
    /// a steep bump in every `hole`-th square of each row and column (a hole
    /// in the navmesh: open edges inside the tile too).
    fn floor(x0: f32, x1: f32, depth: f32, step: f32, hole: u32) -> IndexedMesh {
        let (nx, nz) = (((x1 - x0) / step) as u32, (depth / step) as u32);
        let h = |i: u32, j: u32| {
            let (x, z) = (x0 + i as f32 * step, j as f32 * step);
            let bump = if i % hole == 2 && j % hole == 2 {
                3.0 * step
            } else {
                0.0
            };
            0.6 * (x * 0.21).sin() + 0.4 * (z * 0.17).cos() + bump
        };
        let mut m = IndexedMesh::default();
        for j in 0..=nz {
            for i in 0..=nx {
                let x = x0 + i as f32 * step;
                m.positions.push(Vec3::new(x, h(i, j), j as f32 * step));
                m.normals.push(Vec3::Y);
            }
        }
        let at = |i: u32, j: u32| j * (nx + 1) + i;
        for j in 0..nz {
            for i in 0..nx {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                m.indices.extend([a, c, b, a, d, c]);
            }
        }
        m
    }

    #[test]
    fn bucketed_edges_give_the_same_links_as_every_pair() {
        let s = NavSettings::default();
        // A fine floor against a coarse one (a level boundary), both with
        // holes: many open edges on each side.
        let fine = NavTile::build(&floor(0.0, 24.0, 48.0, 0.5, 6), &s).unwrap();
        let coarse = NavTile::build(&floor(24.0, 72.0, 48.0, 2.0, 4), &s).unwrap();
        let edges = |t: &NavTile| t.open_edges.len();
        assert!(
            edges(&fine) * edges(&coarse) > GRID_PAIRS,
            "{} x {} open edges",
            edges(&fine),
            edges(&coarse)
        );
        let (ab_all, ba_all) = link_with(&fine, &coarse, &s, usize::MAX);
        let (ab, ba) = link(&fine, &coarse, &s);
        assert!(ab_all.len() >= 4, "the floors meet: {} links", ab_all.len());
        let key = |l: &Link| (l.from, l.to, l.portal.map(|p| p.to_array()));
        let keys = |v: &[Link]| v.iter().map(key).collect::<Vec<_>>();
        assert_eq!(keys(&ab), keys(&ab_all));
        assert_eq!(keys(&ba), keys(&ba_all));
    }
}
