//! A volume's navmesh: the tiles of its chunks, the links between them, and
//! path queries over the whole.

use crate::links::{self, Link};
use crate::path::{funnel_passed, oriented};
use crate::settings::{NavError, NavSettings};
use crate::tile::NavTile;
use glam::Vec3;
use kdcontour::world::ChunkKey;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::sync::Arc;
use thiserror::Error;

mod visible;

/// A tile and the links that leave it.
struct Entry {
    tile: Arc<NavTile>,
    links: Vec<(ChunkKey, Link)>,
}

/// The tiles of a volume's chunks, stitched.
pub struct NavMesh {
    settings: NavSettings,
    tiles: HashMap<ChunkKey, Entry>,
    /// Polygons A* may open before a query gives up.
    max_search: usize,
}

/// A path: points on the floor from the start to the goal.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// From the start to the goal, on the floor: the corners of the shortest
    /// way through the polygons, and points between them at most a unit
    /// apart.
    pub points: Vec<Vec3>,
    /// Polygons the path crosses.
    pub polygons: usize,
}

impl Path {
    /// Its length.
    pub fn length(&self) -> f32 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }
}

/// Why there is no path.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PathError {
    /// The start or the goal is not a finite point.
    #[error("the {which} {point} is not a finite point")]
    NotFinite {
        /// "start" or "goal".
        which: &'static str,
        /// The point.
        point: Vec3,
    },
    /// No walkable floor near the start or the goal.
    #[error("no path: the {which} {point} is not on walkable ground (no navmesh floor within {reach} above or below it: inside rock, in the air, on a slope steeper than the limit, or where no tile is built)")]
    OffMesh {
        /// "start" or "goal".
        which: &'static str,
        /// The point.
        point: Vec3,
        /// How far up and down it was looked for.
        reach: f32,
    },
    /// The two floors are not connected.
    #[error(
        "no path: the goal's floor is not connected to the start's ({searched} polygons searched)"
    )]
    Unreachable {
        /// Polygons searched.
        searched: usize,
    },
    /// The search opened its limit of polygons.
    #[error("no path found within the search limit of {limit} polygons")]
    TooFar {
        /// The limit.
        limit: usize,
    },
}

/// A path's points are at most this far apart (volume units), each on the
/// floor.
const FLOOR_STEP: f32 = 1.0;

/// A polygon: its tile and its index there.
type Node = (ChunkKey, u32);

/// An A* queue entry (lowest estimate first).
struct Open {
    f: f32,
    node: Node,
}

impl PartialEq for Open {
    fn eq(&self, o: &Self) -> bool {
        self.f == o.f
    }
}
impl Eq for Open {}
impl PartialOrd for Open {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Open {
    fn cmp(&self, o: &Self) -> Ordering {
        o.f.total_cmp(&self.f)
    }
}

impl NavMesh {
    /// An empty navmesh for agents as `settings` describes.
    pub fn new(settings: NavSettings) -> Result<Self, NavError> {
        settings.check()?;
        Ok(NavMesh {
            settings,
            tiles: HashMap::new(),
            max_search: 200_000,
        })
    }

    /// The agent it is built for.
    pub fn settings(&self) -> &NavSettings {
        &self.settings
    }

    /// Builds a chunk's tile from its mesh ([`NavTile::build`] with these
    /// settings), without inserting it (for a worker thread).
    pub fn build_tile(&self, mesh: &kdcontour::IndexedMesh) -> Result<NavTile, NavError> {
        NavTile::build(mesh, &self.settings)
    }

    /// Puts chunk `key`'s tile in (replacing its old one) and links it to the
    /// tiles it touches.
    pub fn insert(&mut self, key: ChunkKey, tile: Arc<NavTile>) {
        self.remove(&key);
        let mut mine = Vec::new();
        for (k, other) in self.tiles.iter_mut() {
            if !links::touch(&tile, &other.tile) {
                continue;
            }
            // Always matched in the chunks' order, so that the links do not
            // depend on which tile came first.
            let (out, back) = if key.order() < k.order() {
                links::link(&tile, &other.tile, &self.settings)
            } else {
                let (back, out) = links::link(&other.tile, &tile, &self.settings);
                (out, back)
            };
            mine.extend(out.into_iter().map(|l| (*k, l)));
            other.links.extend(back.into_iter().map(|l| (key, l)));
        }
        self.tiles.insert(key, Entry { tile, links: mine });
    }

    /// Takes chunk `key`'s tile out (and every link to it); whether it had one.
    pub fn remove(&mut self, key: &ChunkKey) -> bool {
        let Some(old) = self.tiles.remove(key) else {
            return false;
        };
        for other in self.tiles.values_mut() {
            if links::touch(&old.tile, &other.tile) {
                other.links.retain(|(k, _)| k != key);
            }
        }
        true
    }

    /// Chunk `key`'s tile.
    pub fn tile(&self, key: &ChunkKey) -> Option<&Arc<NavTile>> {
        self.tiles.get(key).map(|e| &e.tile)
    }

    /// The chunks with a tile.
    pub fn keys(&self) -> impl Iterator<Item = &ChunkKey> {
        self.tiles.keys()
    }

    /// Tiles held.
    pub fn len(&self) -> usize {
        self.tiles.len()
    }

    /// Whether it holds no tile.
    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// Polygons over all tiles.
    pub fn polygon_count(&self) -> usize {
        self.tiles.values().map(|e| e.tile.polys.len()).sum()
    }

    /// Links between tiles (each way counted once).
    pub fn link_count(&self) -> usize {
        self.tiles.values().map(|e| e.links.len()).sum::<usize>() / 2
    }

    /// The tiles that chunk `key`'s tile is linked to.
    pub fn linked_tiles(&self, key: &ChunkKey) -> Vec<ChunkKey> {
        let mut out: Vec<ChunkKey> = self
            .tiles
            .get(key)
            .map(|e| e.links.iter().map(|(k, _)| *k).collect())
            .unwrap_or_default();
        out.sort_by_key(|k| k.order());
        out.dedup();
        out
    }

    /// Every link as a portal (its two ends), once each way: for drawing.
    pub fn portals(&self) -> impl Iterator<Item = [Vec3; 2]> + '_ {
        self.tiles
            .values()
            .flat_map(|e| e.links.iter().map(|(_, l)| l.portal))
    }

    /// The floor point for `p`: the walkable polygon under or over it (within
    /// the agent's height), or the nearest point of one within twice the
    /// agent's radius on the ground plane; the nearest wins.
    pub fn locate(&self, p: Vec3) -> Option<(Node, Vec3)> {
        let reach = self.settings.agent_height;
        let snap = 2.0 * self.settings.agent_radius;
        let mut best: Option<(f32, Node, Vec3)> = None;
        let mut consider = |d: f32, node: Node, q: Vec3| {
            if best.as_ref().is_none_or(|b| d < b.0) {
                best = Some((d, node, q));
            }
        };
        for (key, e) in &self.tiles {
            let t = &e.tile;
            if p.x < t.lo.x - snap
                || p.x > t.hi.x + snap
                || p.z < t.lo.z - snap
                || p.z > t.hi.z + snap
                || p.y < t.lo.y - reach - t.cell_height * 4.0
                || p.y > t.hi.y + reach + t.cell_height * 4.0
            {
                continue;
            }
            for (i, poly) in t.polys.iter().enumerate() {
                let i = i as u32;
                if let Some(h) = t.height_in(i, p.x, p.z) {
                    if (h - p.y).abs() <= reach {
                        consider((h - p.y).abs(), (*key, i), Vec3::new(p.x, h, p.z));
                    }
                    continue;
                }
                if (poly.center.y - p.y).abs() > reach + snap * 4.0 {
                    continue;
                }
                let q = t.nearest_on_outline(i, p.x, p.z);
                let across = ((q.x - p.x).powi(2) + (q.z - p.z).powi(2)).sqrt();
                if across <= snap && (q.y - p.y).abs() <= reach {
                    consider(across + (q.y - p.y).abs(), (*key, i), q);
                }
            }
        }
        best.map(|(_, n, q)| (n, q))
    }

    /// The shortest path (over the polygons, then pulled tight) from `start`
    /// to `goal`, or why there is none.
    pub fn find_path(&self, start: Vec3, goal: Vec3) -> Result<Path, PathError> {
        let [(from, s), (to, g)] = self.ends(start, goal)?;
        let corridor = self.search(from, s, to, g)?;
        let mut portals = Vec::with_capacity(corridor.len());
        for w in corridor.windows(2) {
            let (a, _) = w[0];
            let (b, portal) = w[1];
            let _ = b;
            let inside = self.tiles[&a.0].tile.polys[a.1 as usize].center;
            portals.push(oriented(inside, portal));
        }
        let nodes: Vec<Node> = corridor.iter().map(|(n, _)| *n).collect();
        let (corners, nodes) = self.straighten(&funnel_passed(s, g, &portals), &nodes);
        Ok(Path {
            points: self.on_floor(&corners, &nodes),
            polygons: nodes.len(),
        })
    }

    /// Whether the floor is open along the straight line from `from` to `to`
    /// seen from above: an agent walking it meets no wall, hole, ledge or
    /// slope too steep (the polygons it crosses are linked one to the next),
    /// and it ends on the floor `to` is on. Both points are taken to their
    /// floor as [`NavMesh::find_path`] takes them; what `find_path` would say
    /// of a point off the floor is the error.
    pub fn is_open_between(&self, from: Vec3, to: Vec3) -> Result<bool, PathError> {
        let [(start, a), (_, b)] = self.ends(from, to)?;
        Ok(self.walk(start, a, b).is_some())
    }

    /// The polygons and floor points of a query's start and goal
    /// ([`NavMesh::locate`]), or why one has none.
    fn ends(&self, start: Vec3, goal: Vec3) -> Result<[(Node, Vec3); 2], PathError> {
        let reach = self.settings.agent_height;
        let end = |which: &'static str, point: Vec3| {
            if !point.is_finite() {
                return Err(PathError::NotFinite { which, point });
            }
            self.locate(point).ok_or(PathError::OffMesh {
                which,
                point,
                reach,
            })
        };
        Ok([end("start", start)?, end("goal", goal)?])
    }

    /// The corners with points in between (a cell height's worth of floor
    /// apart at most: every `FLOOR_STEP`), each at the height of the floor
    /// under it (the corridor's polygon there, else another polygon of the
    /// corridor's tiles, else the nearest corridor polygon's floor extended).
    fn on_floor(&self, corners: &[Vec3], corridor: &[Node]) -> Vec<Vec3> {
        let mut out = vec![corners[0]];
        let mut at = 0; // the corridor polygon last found, searched from here
        let mut tiles: Vec<ChunkKey> = corridor.iter().map(|(k, _)| *k).collect();
        tiles.sort_unstable_by_key(|k| k.order());
        tiles.dedup();
        for w in corners.windows(2) {
            let steps = (w[0].distance(w[1]) / FLOOR_STEP).ceil().max(1.0) as usize;
            for i in 1..=steps {
                let mut p = w[0].lerp(w[1], i as f32 / steps as f32);
                let mut found = false;
                for j in (at..corridor.len()).chain(0..at) {
                    let (k, poly) = corridor[j];
                    if let Some(h) = self.tiles[&k].tile.height_in(poly, p.x, p.z) {
                        (p.y, at, found) = (h, j, true);
                        break;
                    }
                }
                if !found {
                    // Off the corridor's polygons (a string-pulled line between
                    // linked tiles cuts across their outlines): the floor of
                    // another polygon of the corridor's tiles under it, the
                    // one nearest the line's height.
                    let under = tiles
                        .iter()
                        .flat_map(|k| {
                            let t = &self.tiles[k].tile;
                            (0..t.polys.len() as u32).filter_map(|q| t.height_in(q, p.x, p.z))
                        })
                        .min_by(|a, b| (a - p.y).abs().total_cmp(&(b - p.y).abs()));
                    if let Some(h) = under {
                        p.y = h;
                        found = true;
                    }
                }
                if !found {
                    // Between two linked tiles (their outlines may lie up to
                    // the link tolerance apart): the nearest polygon's floor.
                    let near = corridor.iter().min_by(|a, b| {
                        let d = |(k, poly): &Node| {
                            let q = self.tiles[k].tile.nearest_on_outline(*poly, p.x, p.z);
                            (q.x - p.x).powi(2) + (q.z - p.z).powi(2)
                        };
                        d(a).total_cmp(&d(b))
                    });
                    if let Some((k, poly)) = near {
                        p.y = self.tiles[k].tile.height_near(*poly, p.x, p.z);
                    }
                }
                out.push(p);
            }
        }
        out
    }

    /// The polygons from `from` to `to`, each with the portal it is entered
    /// through (the first's is unused).
    fn search(
        &self,
        from: Node,
        s: Vec3,
        to: Node,
        g: Vec3,
    ) -> Result<Vec<(Node, [Vec3; 2])>, PathError> {
        // Best cost to reach a polygon, where it was entered, and from where.
        let mut seen: HashMap<Node, (f32, Vec3, Option<Node>, [Vec3; 2])> = HashMap::new();
        let mut open = BinaryHeap::new();
        seen.insert(from, (0.0, s, None, [s, s]));
        open.push(Open {
            f: s.distance(g),
            node: from,
        });
        let mut searched = 0;
        while let Some(Open { node, f }) = open.pop() {
            let (cost, at, _, _) = seen[&node];
            if f > cost + at.distance(g) + 1e-4 {
                continue; // an older, worse entry
            }
            if node == to {
                let mut corridor = vec![];
                let mut n = Some(node);
                while let Some(k) = n {
                    let (_, _, prev, portal) = seen[&k];
                    corridor.push((k, portal));
                    n = prev;
                }
                corridor.reverse();
                return Ok(corridor);
            }
            searched += 1;
            if searched > self.max_search {
                return Err(PathError::TooFar {
                    limit: self.max_search,
                });
            }
            for (next, portal) in self.neighbours(node) {
                let entry = if next == to { g } else { toward(portal, at, g) };
                let c = cost + at.distance(entry);
                if seen.get(&next).is_none_or(|o| c < o.0) {
                    seen.insert(next, (c, entry, Some(node), portal));
                    open.push(Open {
                        f: c + entry.distance(g),
                        node: next,
                    });
                }
            }
        }
        Err(PathError::Unreachable { searched })
    }

    /// The polygons next to `node`, with the portal to each.
    fn neighbours(&self, (key, p): Node) -> Vec<(Node, [Vec3; 2])> {
        let e = &self.tiles[&key];
        let poly = &e.tile.polys[p as usize];
        let mut out = Vec::new();
        for (i, n) in poly.neighbors.iter().enumerate() {
            if let Some(q) = n {
                let (a, b) = e.tile.edge(p, i);
                out.push(((key, *q), [a, b]));
            }
        }
        for (k, l) in &e.links {
            if l.from == p {
                out.push(((*k, l.to), l.portal));
            }
        }
        out
    }
}

/// Where a search entering a polygon through `portal` from `at` on its way
/// to `g` crosses it: where the line from `at` to `g` meets it seen from
/// above, else its end nearest that line. Midpoints (Detour's choice) bend
/// the corridor on long portals (a tile's edge, a long polygon's side): on
/// open rolling ground the paths came out up to 9% longer than the straight
/// line (now at most 5%), and a pit dug across one barely lengthened it.
fn toward(portal: [Vec3; 2], at: Vec3, g: Vec3) -> Vec3 {
    let [a, b] = portal;
    let cross = |u: Vec3, v: Vec3| u.x * v.z - u.z * v.x;
    let (ab, dir) = (b - a, g - at);
    let den = cross(ab, dir);
    let t = if den.abs() > 1e-9 * ab.length() * dir.length() {
        cross(at - a, dir) / den
    } else {
        0.5
    };
    a.lerp(b, t.clamp(0.0, 1.0))
}
