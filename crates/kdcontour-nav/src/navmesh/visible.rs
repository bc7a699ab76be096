//! Straight lines over the floor: a walk along a segment seen from above,
//! from polygon to polygon (Detour's raycast), and the pass that pulls a
//! path's corners straight where the floor between them is open.
//!
//! The funnel gives the shortest way through the corridor A* found, and A*
//! over polygons finds the corridor of least cost between entry points, not
//! the one with the shortest way through it: over many small polygons (a
//! tile's floor cut along its outline) a corridor can bow several units off
//! the straight line on open ground. Where the walk finds the floor open
//! from one corner of the path to a later one, the corners between go.

use super::{NavMesh, Node};
use glam::Vec3;

/// Polygons a walk may cross before it gives up (a walk never enters a
/// polygon twice, so this only bounds a long one).
const MAX_STEPS: usize = 4096;

/// How close (volume units) a walk's end must come to the end point, and a
/// crossing to a portal.
const REACH: f32 = 1e-3;

impl NavMesh {
    /// The polygons the segment from `a` (on polygon `from`) to `b` crosses,
    /// seen from above, in order: the walk leaves each polygon through the
    /// edge the segment crosses, into the polygon across it in the tile or
    /// through the link whose portal the crossing is on, and ends in the
    /// polygon that holds `b`. `None` when the segment meets a wall (an edge
    /// with nothing across it), turns back, or ends on a floor more than a
    /// climb above or below `b` (another storey).
    pub(super) fn walk(&self, from: Node, a: Vec3, b: Vec3) -> Option<Vec<Node>> {
        let d = Vec3::new(b.x - a.x, 0.0, b.z - a.z);
        let len = d.length();
        // Two tiles' outlines may lie the link tolerance apart (overlapping
        // or not): entering a tile, the walk may be that far into its
        // polygon, or short of it.
        let slack = |t: &crate::NavTile| self.settings.link_tolerance * t.cell_size + REACH;
        let climb = self.settings.max_climb;
        let ends = |at: Node| {
            let t = &self.tiles[&at.0].tile;
            (t.height_near(at.1, b.x, b.z) - b.y).abs() <= climb + 2.0 * t.cell_height
        };
        let mut at = from;
        let mut out = vec![from];
        // How far along the segment (0 to 1) the walk is.
        let mut done = 0.0f32;
        for _ in 0..MAX_STEPS {
            let e = self.tiles.get(&at.0)?;
            let Some((leave, edge)) = leaves(&e.tile, at.1, a, d) else {
                return ends(at).then_some(out);
            };
            if leave * len >= len - REACH {
                return ends(at).then_some(out);
            }
            if leave * len < done * len - slack(&e.tile) {
                return None;
            }
            done = done.max(leave);
            let next = match e.tile.polys[at.1 as usize].neighbors[edge] {
                Some(q) => (at.0, q),
                None => {
                    // Across a tile's edge: the link whose portal the
                    // crossing is on (the two tiles' outlines may lie the
                    // link tolerance apart; the portal runs between them).
                    let x = a + (b - a) * done;
                    let across = slack(&e.tile);
                    let found = e
                        .links
                        .iter()
                        .filter(|(_, l)| l.from == at.1)
                        .map(|(k, l)| (flat_distance(x, l.portal), (k, l)))
                        .filter(|(dist, _)| *dist <= across)
                        .min_by(|p, q| p.0.total_cmp(&q.0));
                    let (k, l) = found?.1;
                    (*k, l.to)
                }
            };
            if out.contains(&next) {
                return None;
            }
            out.push(next);
            at = next;
        }
        None
    }

    /// The path's corners pulled straight: from each corner, the farthest
    /// later corner the floor is open to ([`NavMesh::walk`]; the goal first)
    /// is the next, else the next corner of the funnel. `corners` are the
    /// funnel's, each with how many of the corridor's portals it has passed;
    /// returns the corners kept and the polygons under the path.
    pub(super) fn straighten(
        &self,
        corners: &[(Vec3, usize)],
        corridor: &[Node],
    ) -> (Vec<Vec3>, Vec<Node>) {
        let last = corridor.len() - 1;
        // A corner that has passed `k` portals stands on the polygon the
        // `k`th portal enters (on that portal's outline).
        let on = |k: usize| corridor[k.min(last)];
        let mut points = vec![corners[0].0];
        let mut under = vec![corridor[0]];
        let mut i = 0;
        while i + 1 < corners.len() {
            let (p, k) = corners[i];
            let try_to = |j: usize| self.walk(on(k), p, corners[j].0);
            // The goal first; else forward while the floor stays open.
            let mut best = None;
            if i + 2 < corners.len() {
                best = try_to(corners.len() - 1).map(|w| (corners.len() - 1, w));
                if best.is_none() {
                    for j in i + 2..corners.len() - 1 {
                        match try_to(j) {
                            Some(w) => best = Some((j, w)),
                            None => break,
                        }
                    }
                }
            }
            let (j, polys) = best.unwrap_or_else(|| {
                let (from, to) = (k.min(last), corners[i + 1].1.min(last));
                (i + 1, corridor[from..=to].to_vec())
            });
            points.push(corners[j].0);
            for n in polys {
                if under.last() != Some(&n) {
                    under.push(n);
                }
            }
            i = j;
        }
        (points, under)
    }
}

/// Where the segment `a + t d` (`t` from 0 to 1, on the ground plane) last
/// leaves polygon `p` of `tile`: the least `t` at which it passes to the
/// outer side of one of the polygon's edges, and that edge; `None` when it
/// leaves none (a segment of no length).
fn leaves(tile: &crate::NavTile, p: u32, a: Vec3, d: Vec3) -> Option<(f32, usize)> {
    let poly = &tile.polys[p as usize];
    let n = poly.verts.len();
    let v = |i: usize| tile.vertices[poly.verts[i % n] as usize];
    let cross = |u: Vec3, w: Vec3| u.x * w.z - u.z * w.x;
    // Which side is inside: the sign of the outline's area.
    let area: f32 = (0..n).map(|i| cross(v(i), v(i + 1))).sum();
    let inside = area.signum();
    let mut best: Option<(f32, usize)> = None;
    for i in 0..n {
        let (p0, p1) = (v(i), v(i + 1));
        let e = p1 - p0;
        let rate = inside * cross(e, d);
        // Only an edge the segment moves outward across can be where it
        // leaves.
        if rate >= -1e-9 * e.length() * d.length() {
            continue;
        }
        let t = -inside * cross(e, a - p0) / rate;
        if best.is_none_or(|(b, _)| t < b) {
            best = Some((t, i));
        }
    }
    best
}

/// The distance seen from above from `x` to the segment `portal`.
fn flat_distance(x: Vec3, [a, b]: [Vec3; 2]) -> f32 {
    let flat = |v: Vec3| glam::Vec2::new(v.x, v.z);
    let (x, a, b) = (flat(x), flat(a), flat(b));
    let ab = b - a;
    let t = ((x - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
    x.distance(a + ab * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{NavPoly, NavTile};
    use kdcontour::world::ChunkKey;
    use std::sync::Arc;

    /// A tile of unit squares over `[0, w] x [0, h]` on the ground, leaving
    /// out the squares in `holes` (by column and row).
    fn squares(w: u32, h: u32, holes: &[(u32, u32)]) -> NavTile {
        let mut t = NavTile {
            hi: Vec3::new(w as f32, 0.0, h as f32),
            cell_size: 0.1,
            cell_height: 0.1,
            ..NavTile::default()
        };
        for z in 0..=h {
            for x in 0..=w {
                t.vertices.push(Vec3::new(x as f32, 0.0, z as f32));
            }
        }
        let id = |x: u32, z: u32| -> Option<u32> {
            (x < w && z < h && !holes.contains(&(x, z))).then(|| square(w, holes, x, z))
        };
        let corner = |x: u32, z: u32| z * (w + 1) + x;
        for z in 0..h {
            for x in 0..w {
                if id(x, z).is_none() {
                    continue;
                }
                // Counter-clockwise seen from above (+y): x, then z back.
                let verts = vec![
                    corner(x, z),
                    corner(x, z + 1),
                    corner(x + 1, z + 1),
                    corner(x + 1, z),
                ];
                let across = |dx: i32, dz: i32| {
                    let (nx, nz) = (x as i32 + dx, z as i32 + dz);
                    (nx >= 0 && nz >= 0)
                        .then(|| id(nx as u32, nz as u32))
                        .flatten()
                };
                t.polys.push(NavPoly {
                    verts,
                    neighbors: vec![across(-1, 0), across(0, 1), across(1, 0), across(0, -1)],
                    center: Vec3::new(x as f32 + 0.5, 0.0, z as f32 + 0.5),
                    detail: Vec::new(),
                });
            }
        }
        t
    }

    /// The polygon of the square at column `x`, row `z` of [`squares`]`(w, _,
    /// holes)`: squares are numbered row by row, holes left out.
    fn square(w: u32, holes: &[(u32, u32)], x: u32, z: u32) -> u32 {
        let before = holes.iter().filter(|&&(hx, hz)| hz * w + hx < z * w + x);
        z * w + x - before.count() as u32
    }

    fn mesh(tile: NavTile) -> (NavMesh, ChunkKey) {
        let mut nav = NavMesh::new(crate::NavSettings::default()).unwrap();
        let key = ChunkKey::new(0, glam::IVec3::ZERO);
        nav.insert(key, Arc::new(tile));
        (nav, key)
    }

    #[test]
    fn a_walk_crosses_open_floor_and_stops_at_a_hole() {
        // 6 x 3 squares; the square at column 3, row 1 is a hole.
        let (nav, key) = mesh(squares(6, 3, &[(3, 1)]));
        let poly = |x: u32, z: u32| (key, square(6, &[(3, 1)], x, z));
        let p = |x: f32, z: f32| Vec3::new(x, 0.0, z);
        // Along the first row: every square of it, in order.
        let w = nav.walk(poly(0, 0), p(0.5, 0.5), p(5.5, 0.5));
        assert_eq!(w, Some((0..6).map(|x| poly(x, 0)).collect()));
        // Through the hole: no.
        assert_eq!(nav.walk(poly(0, 1), p(0.5, 1.5), p(5.5, 1.5)), None);
        // Ending on a floor far above or below the end point: no.
        assert_eq!(
            nav.walk(poly(0, 0), p(0.5, 0.5), Vec3::new(5.5, 3.0, 0.5)),
            None
        );
        // Diagonally down the right of the hole: open; across it: not.
        let w = nav.walk(poly(4, 2), p(4.2, 2.5), p(5.5, 0.5));
        let w = w.expect("open floor right of the hole");
        assert_eq!(w.first(), Some(&poly(4, 2)));
        assert!(w.len() >= 4 && w.contains(&poly(4, 1)), "{w:?}");
        assert_eq!(nav.walk(poly(2, 2), p(2.5, 2.5), p(4.5, 0.5)), None);
    }

    #[test]
    fn corners_with_open_floor_between_are_pulled_straight() {
        let (nav, key) = mesh(squares(6, 3, &[]));
        let poly = |x: u32, z: u32| (key, z * 6 + x);
        let p = |x: f32, z: f32| Vec3::new(x, 0.0, z);
        // A corridor that bows through the top row, and a funnel path with
        // two corners there: open floor, so the goal is seen from the start.
        let corridor = [
            poly(0, 0),
            poly(0, 1),
            poly(0, 2),
            poly(1, 2),
            poly(2, 2),
            poly(3, 2),
            poly(4, 2),
            poly(5, 2),
            poly(5, 1),
            poly(5, 0),
        ];
        let corners = [
            (p(0.5, 0.5), 0),
            (p(1.0, 2.0), 3),
            (p(5.0, 2.0), 7),
            (p(5.5, 0.5), 9),
        ];
        let (points, under) = nav.straighten(&corners, &corridor);
        assert_eq!(points, vec![p(0.5, 0.5), p(5.5, 0.5)]);
        assert_eq!(under, (0..6).map(|x| poly(x, 0)).collect::<Vec<_>>());
    }

    #[test]
    fn corners_around_a_wall_are_kept() {
        // A wall: column 2 is a hole in rows 0 and 1.
        let (nav, key) = mesh(squares(5, 3, &[(2, 0), (2, 1)]));
        let id = |x: u32, z: u32| (key, square(5, &[(2, 0), (2, 1)], x, z));
        let p = |x: f32, z: f32| Vec3::new(x, 0.0, z);
        let corridor = [
            id(1, 0),
            id(1, 1),
            id(1, 2),
            id(2, 2),
            id(3, 2),
            id(3, 1),
            id(3, 0),
        ];
        let corners = [
            (p(1.5, 0.5), 0),
            (p(2.0, 2.0), 3),
            (p(3.0, 2.0), 4),
            (p(3.5, 0.5), 6),
        ];
        let (points, under) = nav.straighten(&corners, &corridor);
        assert_eq!(points, corners.map(|c| c.0).to_vec());
        assert_eq!(under, corridor.to_vec());
    }
}
