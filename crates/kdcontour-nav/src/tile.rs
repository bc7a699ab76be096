//! A chunk's navmesh tile: Recast's steps over the chunk's own mesh, with
//! aprons continuing its open edges; the floor of the chunk's own triangles.

use crate::settings::{NavError, NavSettings};
use glam::{UVec3, Vec2, Vec3, Vec3A};
use kdcontour::IndexedMesh;
use rerecast::{
    Aabb3d, AreaType, BuildContoursFlags, ContourSet, DetailNavmesh, HeightfieldBuilder,
    PolygonNavmesh, TriMesh,
};
use std::collections::HashMap;

/// The side of the cells open edges are bucketed in for linking, in Recast
/// cells.
const EDGE_CELLS: f32 = 8.0;
/// Recast's outline simplification error, in cells (its default).
const MAX_SIMPLIFICATION_ERROR: f32 = 1.3;
/// The detail mesh samples heights this many cells apart: twice Recast's
/// default 6, which halves a tile's build (the detail mesh was most of it: 14.7
/// to 7.1 ms a demo chunk) for paths 0.34 rather than 0.31 units from rolling
/// ground at the most (`cargo bench -p kdcontour-nav --bench tiles`, the
/// `paths_follow_rolling_ground_across_chunk_seams` test).
const DETAIL_SAMPLE_CELLS: f32 = 12.0;
/// Outline edges between the chunk's floor and its aprons are cut every
/// `radius * 8` cells, as walls are: else the floor's edge along a chunk's
/// face is one long outline edge, and Recast cuts the floor there into long
/// thin polygons, which its detail mesh samples inside only when they are two
/// sample distances wide. One such polygon, 12 units long on rolling ground
/// (chunks of 16 cells cut into four-cell tiles along their faces), missed a
/// valley by 1.25 units, and a path over such polygons ran more than 0.6
/// units above the ground (`paths_cross_level_boundaries`). It costs 4% more time
/// per tile and 24% more polygons (`cargo bench -p kdcontour-nav --bench
/// tiles`).
const OUTLINES: BuildContoursFlags = BuildContoursFlags::TESSELLATE_AREA_EDGES;
/// Polygons have at most this many vertices (Recast's default, Detour's limit).
const MAX_POLY_VERTS: u16 = 6;
/// Regions smaller than this many cells are dropped; small, because a chunk
/// may own a thin strip of a floor that its neighbours continue.
const MIN_REGION_AREA: u16 = 4;
/// Regions smaller than this many cells are merged into a neighbour (Recast's
/// default, 20 x 20).
const MERGE_REGION_AREA: u16 = 400;

/// One convex walkable polygon of a tile.
#[derive(Clone, Debug)]
pub struct NavPoly {
    /// Its corners (indices into [`NavTile::vertices`]), counter-clockwise
    /// seen from above.
    pub verts: Vec<u32>,
    /// For edge `i` (from corner `i` to corner `i + 1`): the polygon of this
    /// tile across it, if any (an open edge may be linked to another tile).
    pub neighbors: Vec<Option<u32>>,
    /// The mean of its corners.
    pub center: Vec3,
    /// Its detail triangles (Recast's detail mesh): the floor's heights
    /// inside it, within a cell height of the surface.
    pub detail: Vec<[Vec3; 3]>,
}

/// The walkable floor of one chunk as convex polygons (volume-local units).
#[derive(Clone, Debug, Default)]
pub struct NavTile {
    /// The low corner of the chunk's mesh's bounds.
    pub lo: Vec3,
    /// The high corner of the chunk's mesh's bounds.
    pub hi: Vec3,
    /// Polygon corners.
    pub vertices: Vec<Vec3>,
    /// The polygons.
    pub polys: Vec<NavPoly>,
    /// Recast's cell on the ground plane.
    pub cell_size: f32,
    /// Recast's cell height.
    pub cell_height: f32,
    /// Floor outlines Recast could not cut into polygons (an outline that
    /// crosses itself), left out of the tile.
    pub dropped_outlines: usize,
    /// The polygon edges with no neighbour in the tile (walls, and where the
    /// floors of other tiles may link): polygon and the edge's ends. Found
    /// once, where the tile is built, so linking it in is quick.
    pub open_edges: Vec<(u32, Vec3, Vec3)>,
    /// The open edges bucketed on the ground plane, for linking.
    pub(crate) edge_grid: crate::links::EdgeGrid,
}

impl NavTile {
    /// The tile of a chunk whose mesh (interior and owned seams, as it is
    /// shown) is `mesh`: the walkable floor of exactly those triangles. An
    /// empty mesh gives an empty tile.
    pub fn build(mesh: &IndexedMesh, settings: &NavSettings) -> Result<NavTile, NavError> {
        settings.check()?;
        unpanicked(|| Self::build_checked(mesh, settings))
    }

    /// [`NavTile::build`] with its settings checked.
    fn build_checked(mesh: &IndexedMesh, settings: &NavSettings) -> Result<NavTile, NavError> {
        let cs = settings.cell_size;
        let ch = cs * 0.5;
        let mut tile = NavTile {
            cell_size: cs,
            cell_height: ch,
            ..Default::default()
        };
        if mesh.indices.is_empty() {
            return Ok(tile);
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in &mesh.indices {
            let p = mesh.positions[i as usize];
            (lo, hi) = (lo.min(p), hi.max(p));
        }
        (tile.lo, tile.hi) = (lo, hi);
        let radius = (settings.agent_radius / cs).ceil() as u16;
        let border = radius + 3;
        // The tile's columns on one grid for every tile (whole cells from the
        // origin), so that two tiles rasterize a shared floor alike.
        let (x0, x1) = ((lo.x / cs).floor() - 1.0, (hi.x / cs).ceil() + 1.0);
        let (z0, z1) = ((lo.z / cs).floor() - 1.0, (hi.z / cs).ceil() + 1.0);
        let (w, d) = (
            (x1 - x0) as u64 + 2 * border as u64,
            (z1 - z0) as u64 + 2 * border as u64,
        );
        if w * d > settings.max_tile_columns as u64 || w.max(d) > u16::MAX as u64 / 2 {
            return Err(NavError::TileTooLarge {
                columns: w * d,
                width: w,
                depth: d,
                max: settings.max_tile_columns,
            });
        }
        let climb = (settings.max_climb / ch).floor() as u16;
        let height = (settings.agent_height / ch).ceil() as u16;
        let apron = (border as f32 + 1.0) * cs;
        let mut trimesh = with_aprons(mesh, apron, settings.max_slope_degrees.to_radians());
        let (y0, y1) = (
            ((lo.y - apron) / ch).floor() - 1.0,
            ((hi.y + apron + settings.agent_height) / ch).ceil() + 1.0,
        );
        let b = border as f32;
        let aabb = Aabb3d {
            min: Vec3::new((x0 - b) * cs, y0 * ch, (z0 - b) * cs),
            max: Vec3::new((x1 + b) * cs, y1 * ch, (z1 + b) * cs),
        };
        let recast = |step: &'static str| {
            move |e: &dyn std::fmt::Display| NavError::Recast {
                step,
                message: e.to_string(),
            }
        };
        let mut hf = HeightfieldBuilder {
            aabb,
            cell_size: cs,
            cell_height: ch,
        }
        .build()
        .map_err(|e| recast("heightfield")(&e))?;
        off_cell_lines(&mut trimesh.vertices, aabb.min, cs);
        hf.rasterize_triangles(&trimesh, climb)
            .map_err(|e| recast("rasterization")(&e))?;
        hf.filter_low_hanging_walkable_obstacles(climb);
        hf.filter_ledge_spans(height, climb);
        hf.filter_walkable_low_height_spans(height);
        let mut chf = hf
            .into_compact(height, climb)
            .map_err(|e| recast("compaction")(&e))?;
        // Aprons count as floor here, so the ends of the chunk's mesh are not
        // taken for ledges; their polygons are dropped below.
        chf.erode_walkable_area(radius);
        chf.build_distance_field();
        chf.build_regions(border, MIN_REGION_AREA, MERGE_REGION_AREA)
            .map_err(|e| recast("regions")(&e))?;
        let mut contours = chf.build_contours(MAX_SIMPLIFICATION_ERROR, radius * 8, OUTLINES);
        let poly = match contours.clone().into_polygon_mesh(MAX_POLY_VERTS) {
            Ok(p) => p,
            Err(_) => {
                // Recast's polygon step refuses an outline that crosses itself
                // (C++ Recast warns and goes on); leave out each outline that
                // cannot be cut into polygons on its own, and try again.
                let empty = contours.clone_empty();
                let before = contours.contours.len();
                contours.contours.retain(|c| {
                    let one = ContourSet {
                        contours: vec![c.clone()],
                        ..empty.clone_empty()
                    };
                    one.into_polygon_mesh(MAX_POLY_VERTS).is_ok()
                });
                tile.dropped_outlines = before - contours.contours.len();
                contours
                    .into_polygon_mesh(MAX_POLY_VERTS)
                    .map_err(|e| recast("polygon mesh")(&e))?
            }
        };
        let detail = DetailNavmesh::new(&poly, &chf, DETAIL_SAMPLE_CELLS * cs, ch)
            .map_err(|e| recast("detail mesh")(&e))?;
        tile.take_polygons(&poly, &detail);
        tile.open_edges = tile.find_open_edges();
        tile.edge_grid = crate::links::EdgeGrid::new(
            &tile.open_edges,
            Vec2::new(tile.lo.x, tile.lo.z),
            Vec2::new(tile.hi.x, tile.hi.z),
            EDGE_CELLS * cs,
        );
        Ok(tile)
    }

    /// Copies Recast's polygons into volume units.
    fn take_polygons(&mut self, poly: &PolygonNavmesh, detail: &DetailNavmesh) {
        let o = poly.aabb.min;
        self.vertices = poly
            .vertices
            .iter()
            .map(|v| {
                Vec3::new(
                    o.x + v.x as f32 * poly.cell_size,
                    o.y + v.y as f32 * poly.cell_height,
                    o.z + v.z as f32 * poly.cell_size,
                )
            })
            .collect();
        let nvp = poly.max_vertices_per_polygon as usize;
        // The chunk's own floor: apron polygons go, and edges to them open.
        let mut index = vec![None; poly.polygon_count()];
        let mut kept = 0u32;
        for (i, area) in poly.areas.iter().enumerate() {
            if *area == AreaType::DEFAULT_WALKABLE {
                index[i] = Some(kept);
                kept += 1;
            }
        }
        for (i, (p, n)) in poly
            .polygons
            .chunks_exact(nvp)
            .zip(poly.polygon_neighbors.chunks_exact(nvp))
            .enumerate()
        {
            if index[i].is_none() {
                continue;
            }
            let verts: Vec<u32> = p
                .iter()
                .take_while(|i| **i != PolygonNavmesh::NO_INDEX)
                .map(|&i| i as u32)
                .collect();
            // A neighbour index with the high bit set is Recast's mark for an
            // edge on the tile's border: open, like a wall, until linked.
            let neighbors = n[..verts.len()]
                .iter()
                .map(|&j| {
                    if j & 0x8000 == 0 {
                        index[j as usize]
                    } else {
                        None
                    }
                })
                .collect();
            let center = verts
                .iter()
                .map(|&i| self.vertices[i as usize])
                .sum::<Vec3>()
                / verts.len() as f32;
            let detail = detail
                .meshes
                .get(i)
                .map(|m| {
                    let v =
                        &detail.vertices[m.base_vertex_index as usize..][..m.vertex_count as usize];
                    detail.triangles[m.base_triangle_index as usize..][..m.triangle_count as usize]
                        .iter()
                        .map(|t| t.map(|j| v[j as usize]))
                        .collect()
                })
                .unwrap_or_default();
            self.polys.push(NavPoly {
                verts,
                neighbors,
                center,
                detail,
            });
        }
    }

    /// The polygon edges with no neighbour in the tile.
    fn find_open_edges(&self) -> Vec<(u32, Vec3, Vec3)> {
        let mut out = Vec::new();
        for (p, poly) in self.polys.iter().enumerate() {
            for (e, n) in poly.neighbors.iter().enumerate() {
                if n.is_none() {
                    let (a, b) = self.edge(p as u32, e);
                    out.push((p as u32, a, b));
                }
            }
        }
        out
    }

    /// Whether it has no walkable polygon.
    pub fn is_empty(&self) -> bool {
        self.polys.is_empty()
    }

    /// The corners of polygon `p`'s edge `e`.
    pub fn edge(&self, p: u32, e: usize) -> (Vec3, Vec3) {
        let poly = &self.polys[p as usize];
        let a = poly.verts[e];
        let b = poly.verts[(e + 1) % poly.verts.len()];
        (self.vertices[a as usize], self.vertices[b as usize])
    }

    /// Polygon `p`'s height above `(x, z)` (on the plane of its fan triangle
    /// under the point), if the point is inside it seen from above.
    pub fn height_in(&self, p: u32, x: f32, z: f32) -> Option<f32> {
        let poly = &self.polys[p as usize];
        if !self.inside(p, x, z) {
            return None;
        }
        // The detail triangle the point is most inside of (rounding can leave
        // it a hair outside all of them).
        let mut best: Option<(f32, f32)> = None;
        for [a, b, c] in &poly.detail {
            if let Some((inside, h)) = barycentric_height(*a, *b, *c, x, z) {
                if best.is_none_or(|(i, _)| inside > i) {
                    best = Some((inside, h));
                }
            }
        }
        if let Some((_, h)) = best {
            return Some(h);
        }
        let v = |i: usize| self.vertices[poly.verts[i] as usize];
        let a = v(0);
        for i in 1..poly.verts.len() - 1 {
            let (b, c) = (v(i), v(i + 1));
            if let Some(h) = height_in_triangle(a, b, c, x, z) {
                return Some(h);
            }
        }
        None
    }

    /// Polygon `p`'s floor height at `(x, z)`, extended past its outline for a
    /// point just outside it (the plane of the detail triangle nearest).
    pub fn height_near(&self, p: u32, x: f32, z: f32) -> f32 {
        let poly = &self.polys[p as usize];
        let mut best = (f32::NEG_INFINITY, poly.center.y);
        for [a, b, c] in &poly.detail {
            if let Some((inside, h)) = barycentric_height(*a, *b, *c, x, z) {
                if inside > best.0 {
                    best = (inside, h);
                }
            }
        }
        best.1
    }

    /// Whether `(x, z)` is inside polygon `p` seen from above (on its outline
    /// counts).
    pub fn inside(&self, p: u32, x: f32, z: f32) -> bool {
        let poly = &self.polys[p as usize];
        let (mut pos, mut neg) = (false, false);
        for e in 0..poly.verts.len() {
            let (a, b) = self.edge(p, e);
            let c = (b.x - a.x) * (z - a.z) - (b.z - a.z) * (x - a.x);
            pos |= c > 1e-5;
            neg |= c < -1e-5;
        }
        !(pos && neg)
    }

    /// The point of polygon `p`'s outline nearest `(x, z)` seen from above.
    pub fn nearest_on_outline(&self, p: u32, x: f32, z: f32) -> Vec3 {
        let poly = &self.polys[p as usize];
        let mut best = (f32::INFINITY, Vec3::ZERO);
        for e in 0..poly.verts.len() {
            let (a, b) = self.edge(p, e);
            let ab = Vec3::new(b.x - a.x, 0.0, b.z - a.z);
            let ap = Vec3::new(x - a.x, 0.0, z - a.z);
            let t = (ap.dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
            let q = a.lerp(b, t);
            let d = (q.x - x).powi(2) + (q.z - z).powi(2);
            if d < best.0 {
                best = (d, q);
            }
        }
        best.1
    }
}

/// The height of triangle `abc`'s plane above `(x, z)`, and how far inside
/// the triangle the point is (its least barycentric coordinate: negative
/// outside); `None` for a triangle with no area seen from above.
fn barycentric_height(a: Vec3, b: Vec3, c: Vec3, x: f32, z: f32) -> Option<(f32, f32)> {
    let det = (b.x - a.x) * (c.z - a.z) - (c.x - a.x) * (b.z - a.z);
    if det.abs() < 1e-12 {
        return None;
    }
    let u = ((x - a.x) * (c.z - a.z) - (c.x - a.x) * (z - a.z)) / det;
    let v = ((b.x - a.x) * (z - a.z) - (x - a.x) * (b.z - a.z)) / det;
    let inside = u.min(v).min(1.0 - u - v);
    Some((inside, a.y + u * (b.y - a.y) + v * (c.y - a.y)))
}

/// The height of triangle `abc` above `(x, z)`, if the point is inside it
/// seen from above (either winding).
fn height_in_triangle(a: Vec3, b: Vec3, c: Vec3, x: f32, z: f32) -> Option<f32> {
    barycentric_height(a, b, c, x, z).and_then(|(inside, h)| (inside >= -1e-4).then_some(h))
}

/// The area of apron triangles: walkable (so erosion does not eat the mesh's
/// ends) but below the chunk's own floor, which wins where both fall in one
/// cell (Recast keeps the higher area id).
const APRON: AreaType = AreaType(1);

/// The chunk's triangles for Recast, each open edge continued outward by
/// `apron` in the plane of its triangle (where the neighbour's triangles, not
/// in this tile, go on); walkable where no steeper than `max_slope`
/// (radians), the chunk's own as its floor, the aprons as [`APRON`].
fn with_aprons(mesh: &IndexedMesh, apron: f32, max_slope: f32) -> TriMesh {
    let mut vertices: Vec<Vec3A> = mesh.positions.iter().map(|&p| p.into()).collect();
    let mut indices: Vec<UVec3> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| UVec3::new(t[0], t[1], t[2]))
        .collect();
    // Edges used once are open: the chunk's faces (and the domain's).
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &indices {
        for (a, b) in [(t.x, t.y), (t.y, t.z), (t.z, t.x)] {
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let own = indices.len();
    let mut open = Vec::new();
    for t in &indices {
        let t = [t.x, t.y, t.z];
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            if uses[&(a.min(b), a.max(b))] == 1 {
                open.push((a, b, t[(i + 2) % 3]));
            }
        }
    }
    for (a, b, c) in open {
        let (pa, pb, pc) = (
            vertices[a as usize],
            vertices[b as usize],
            vertices[c as usize],
        );
        let along = (pb - pa).normalize_or_zero();
        let inward = (pc - pa) - along * (pc - pa).dot(along);
        let out = -inward.normalize_or_zero();
        if along == Vec3A::ZERO || out == Vec3A::ZERO {
            continue;
        }
        let n = vertices.len() as u32;
        vertices.push(pa + out * apron);
        vertices.push(pb + out * apron);
        // The triangle across edge a-b runs it b to a: same winding as the
        // mesh, so its slope reads the same.
        indices.push(UVec3::new(b, a, n));
        indices.push(UVec3::new(b, n, n + 1));
    }
    let cos = max_slope.cos();
    let area_types = indices
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let (a, b, c) = (
                vertices[t.x as usize],
                vertices[t.y as usize],
                vertices[t.z as usize],
            );
            let n = (b - a).cross(c - a);
            let len = n.length();
            if len > 0.0 && n.y / len > cos {
                if i < own {
                    AreaType::DEFAULT_WALKABLE
                } else {
                    APRON
                }
            } else {
                AreaType::NOT_WALKABLE
            }
        })
        .collect();
    TriMesh {
        vertices,
        indices,
        area_types,
    }
}

/// `build`'s result, or a panic inside it (a bug of the Recast port, as the
/// one [`off_cell_lines`] steps around) as an error: the tile is left out and
/// says why, and the chunk's mesh, built in the same task, is not lost.
fn unpanicked(build: impl FnOnce() -> Result<NavTile, NavError>) -> Result<NavTile, NavError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(build)).unwrap_or_else(|p| {
        let message = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "no message".into());
        Err(NavError::Recast {
            step: "tile build",
            message: format!("Recast panicked ({message}); the tile is left out"),
        })
    })
}

/// How far (in cells) a vertex on a line of Recast's grid is moved off it.
const OFF_LINE: f32 = 1e-3;

/// Moves every vertex that lies exactly on a line between Recast's cells
/// (along x or z, as its rasterizer computes the lines from the grid's
/// corner `min` and cell `cs`) a thousandth of a cell off it. Recast clips
/// each triangle to rows and then cells, and a vertex exactly on a cell's
/// corner can give a clipped polygon an eighth corner where its buffer holds
/// seven (recastnavigation issue 687; rerecast 0.4 then panics with an index
/// out of bounds in `divide_poly`). Chunk meshes have such vertices: a merged
/// leaf's vertex clamped to its box sits on whole cell coordinates, which the
/// default 0.2 grid can meet exactly.
fn off_cell_lines(vertices: &mut [Vec3A], min: Vec3, cs: f32) {
    for v in vertices {
        for (a, o) in [(0, min.x), (2, min.z)] {
            let k = ((v[a] - o) / cs).round();
            // rerecast cuts at a cell's start plus a cell: `(o + (k - 1) cs) + cs`.
            if o + k * cs == v[a] || (o + (k - 1.0) * cs) + cs == v[a] {
                v[a] += OFF_LINE * cs;
            }
        }
    }
}

/// A contour set's grid with no contours in it.
trait CloneEmpty {
    fn clone_empty(&self) -> ContourSet;
}

impl CloneEmpty for ContourSet {
    fn clone_empty(&self) -> ContourSet {
        ContourSet {
            contours: Vec::new(),
            aabb: self.aabb,
            cell_size: self.cell_size,
            cell_height: self.cell_height,
            width: self.width,
            height: self.height,
            border_size: self.border_size,
            max_error: self.max_error,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh of `triangles` (no shared vertices), normals up.
    fn mesh(triangles: &[[Vec3; 3]]) -> IndexedMesh {
        let mut m = IndexedMesh::default();
        for t in triangles {
            for p in t {
                m.indices.push(m.positions.len() as u32);
                m.positions.push(*p);
                m.normals.push(Vec3::Y);
            }
        }
        m
    }

    #[test]
    fn a_vertex_on_a_corner_of_recasts_cells_builds_its_tile() {
        // Three triangles of a demo chunk's mesh (a tile of the plugin's
        // frame bench): the first has a vertex at (187, _, -13), a corner of
        // Recast's 0.2 grid as the tile's bounds place it, and Recast's
        // clipping gave a cell polygon an eighth corner (rerecast panicked).
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let m = mesh(&[
            [
                v(186.44202, 0.55559623, -13.090258),
                v(187.45444, 1.5585871, -13.44091),
                v(187.0, 1.6876631, -13.0),
            ],
            [
                v(163.40254, 0.038849473, -18.614481),
                v(163.16344, 0.06176853, -17.152697),
                v(164.62935, 0.025589347, -17.382376),
            ],
            [
                v(171.49939, 0.6162509, -30.998703),
                v(173.00044, 0.5149462, -30.505974),
                v(172.99995, 0.81753254, -31.498955),
            ],
        ]);
        let tile = NavTile::build(&m, &NavSettings::default()).expect("a tile");
        assert_eq!(tile.dropped_outlines, 0);
    }

    #[test]
    fn a_panic_inside_recast_is_an_error_that_says_so() {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let r = unpanicked(|| panic!("index out of bounds: the len is 7 but the index is 7"));
        std::panic::set_hook(prev);
        match r {
            Err(e @ NavError::Recast { .. }) => {
                let text = e.to_string();
                assert!(
                    text.contains("Recast panicked (index out of bounds")
                        && text.contains("left out"),
                    "{text}"
                );
            }
            other => panic!("{other:?}"),
        }
    }
}
