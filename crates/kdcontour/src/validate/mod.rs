//! The mesh checker every test uses: watertight, edge- and vertex-manifold,
//! consistently oriented, Euler characteristic, components; zero-area faces,
//! slivers and coincident vertices; against the field, the error, flipped
//! faces and the fold measure ([`Folds`]: the angle between each face's normal
//! and the gradient); vertex materials against the field's ([`Materials`]);
//! and, on request ([`Checks`]), crossing and overlapping triangles and a
//! two-sided distance between mesh and surface.
//!
//! ## The distances, in cells
//! - [`MeshReport::max_error`] (and `mean_error`, `max_vertex_error`) is cheap and
//!   local: at vertices and triangle centroids, the first-order `|f| / |∇f|` where
//!   that is at most one cell; where it is larger, or the gradient vanishes (the
//!   flat regions of a sampled volume), the distance to a sign change of the field
//!   searched as below. It never divides by a vanishing gradient, and sees neither
//!   triangle interiors nor surface the mesh misses.
//! - [`Distance::mesh_to_surface_max`] is how far the mesh strays: the largest
//!   distance from a point of the mesh (every vertex and points inside every
//!   triangle, about one per square cell and at least four per triangle) to the
//!   surface. A distance is the length to a crossing of the field, found along the
//!   gradient (then along the axes when that finds none within a cell), bracketed
//!   and refined on the field to 1e-4 cells: a real surface point, so it can only
//!   overstate the true distance (exactly along a distance field's normal). The
//!   points that could hold the maximum are measured again along rays in every
//!   direction, narrowing on the nearest crossing, which finds the nearest surface
//!   point where the gradient does not lead to it (inside a shell thinner than a
//!   cell, at a kink of the field, where a sampled volume is flat). The mean is
//!   of the first figures.
//! - [`Distance::surface_to_mesh_max`] is how much surface the mesh misses: the
//!   largest distance from a surface point (every crossing of the edges of the
//!   sampling grid, of that grid shifted by half a cell, and of a lattice three
//!   times finer inside every cell with a sign change or too near the surface for
//!   the field's Lipschitz bound to prove it empty, found by false position on
//!   the field) to the nearest triangle, exactly. The cells nearest the maximum
//!   are sampled again on a lattice twelve times finer (sub-cell peaks of a
//!   noisy surface are often the farthest points). The two finer lattices are
//!   [`Checks::refine_surface`]: they cost tens of times the grid's own samples,
//!   so [`Checks::standard`] leaves them out ([`Distance::refined`] says which
//!   ran).
//!   [`Distance::lost_surface`] is the share of the sampling grid's own crossings
//!   (the surface the mesher saw) farther than [`LOST_CELLS`] cells; the shifted
//!   grid also sees features thinner than a cell, which no mesh of the grid can
//!   hold, so they raise the maximum but are not counted lost.
//!
//! Both are searched up to [`DISTANCE_CAP_CELLS`] cells: that value means "at
//! least that far". Their maximum is the two-sided (Hausdorff) distance as far as
//! the samples see it. Against a brute-force two-sided distance (both meshes
//! sampled a sixth of a cell apart, the surface an eight times finer uniform mesh)
//! the figures agree within 10% or 0.02 cells on every built-in scene, a smooth
//! and a segmented volume, uniform and adaptive (`tests/distance_agrees.rs`).

mod distance;
mod faces;
mod folds;
mod materials;
mod spatial;

use crate::geometry::tritri;
pub use crate::geometry::{CREASE_DEGREES, INTERSECTION_TOL_CELLS, ZERO_AREA_CELLS2};
pub use distance::{DISTANCE_CAP_CELLS, LOST_CELLS};
pub use faces::SLIVER_DEGREES;
pub use folds::{Folds, FOLD_BUCKET_DEGREES, FOLD_DEGREES};
pub use materials::Materials;

use crate::field::Field;
use crate::grid::Grid;
use crate::mesh::IndexedMesh;
use glam::Vec3;
use std::collections::HashMap;

/// What [`validate`] found.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MeshReport {
    /// Triangles.
    pub triangles: usize,
    /// Vertices referenced by a triangle.
    pub vertices: usize,
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Vertices whose triangles form more than one fan.
    pub nonmanifold_vertices: usize,
    /// Edges whose two triangles traverse it in the same direction.
    pub misoriented_edges: usize,
    /// Triangles with a repeated vertex index.
    pub degenerate_triangles: usize,
    /// Connected components (through shared vertices).
    pub components: usize,
    /// V - E + F over referenced vertices.
    pub euler: i64,
    /// No boundary edges.
    pub watertight: bool,
    /// No non-manifold edge or vertex and no degenerate triangle.
    pub manifold: bool,
    /// Every interior edge is traversed once each way.
    pub oriented: bool,
    /// Largest distance estimate over vertices and triangle centroids, in cells:
    /// |f| / |∇f| where that is at most one cell, the searched distance elsewhere
    /// (see the [module docs](self)).
    pub max_error: f32,
    /// Mean of the same.
    pub mean_error: f32,
    /// The same over vertices only, in cells (sharp features put vertices on
    /// creases and corners, while centroids of triangles that bridge a crease lie
    /// off it).
    pub max_vertex_error: f32,
    /// Triangles with three distinct indices but less than [`ZERO_AREA_CELLS2`]
    /// square cells of area (coincident or collinear corners). Without a field the
    /// cell is the mean edge length.
    pub zero_area_triangles: usize,
    /// Referenced vertices at exactly the position of another referenced vertex.
    pub coincident_vertices: usize,
    /// Triangles of nonzero area whose smallest angle is under [`SLIVER_DEGREES`].
    pub sliver_triangles: usize,
    /// Triangles of nonzero area whose normal points against the field's gradient
    /// at their centroid (`None` without a field).
    pub flipped_triangles: Option<usize>,
    /// The angles between face normals and the field's gradient, and the faces
    /// folded away from creases (`None` without a field; see [`Folds`]).
    pub folds: Option<Folds>,
    /// Crossing and overlapping pairs (`None` unless [`Checks::intersections`]).
    pub intersections: Option<Intersections>,
    /// The two-sided distance (`None` unless [`Checks::surface`]).
    pub distance: Option<Distance>,
    /// The vertex materials, checked against the field's (`None` when neither
    /// the mesh nor the field has materials; see [`Materials`]).
    pub materials: Option<Materials>,
}

/// Triangles that pass through each other, from [`Checks::intersections`]. Pairs
/// that only touch (at a shared vertex or edge, or a vertex resting on a face) do
/// not count; zero-area triangles are left out.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Intersections {
    /// Pairs of triangles, not coplanar, that cross along more than
    /// [`INTERSECTION_TOL_CELLS`].
    pub crossing_pairs: usize,
    /// Triangles in at least one crossing pair.
    pub crossing_triangles: usize,
    /// Deepest crossing, in cells: per pair, how far the shallower of the two
    /// triangles pokes through the other's plane.
    pub max_depth: f32,
    /// Pairs of triangles in one plane (within [`INTERSECTION_TOL_CELLS`]) whose
    /// interiors overlap, adjacent or not.
    pub overlapping_pairs: usize,
    /// Triangles in at least one overlapping pair.
    pub overlapping_triangles: usize,
}

/// The two-sided distance between mesh and surface, in cells, from
/// [`Checks::surface`] (see the [module docs](self)).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Distance {
    /// Largest distance from a point of the mesh to the surface.
    pub mesh_to_surface_max: f32,
    /// Its mean, weighted by area.
    pub mesh_to_surface_mean: f32,
    /// Largest distance from a surface point to the mesh.
    pub surface_to_mesh_max: f32,
    /// Its mean over the surface points (of both grids).
    pub surface_to_mesh_mean: f32,
    /// Surface points the lost share is of (crossings of the grid's edges).
    pub surface_points: usize,
    /// Share of those farther than [`LOST_CELLS`] from the mesh.
    pub lost_surface: f32,
    /// Whether the surface points include the finer lattices
    /// ([`Checks::refine_surface`]).
    pub refined: bool,
}

impl Distance {
    /// The larger of the two maxima: the sampled Hausdorff distance.
    pub fn hausdorff(&self) -> f32 {
        self.mesh_to_surface_max.max(self.surface_to_mesh_max)
    }
}

/// What [`validate_with`] checks beyond topology and the per-triangle geometry.
#[derive(Clone, Copy, Default)]
pub struct Checks<'a> {
    /// The field the mesh approximates and the cell size (world units; the unit
    /// of every distance): the error and flipped faces.
    pub field: Option<(&'a dyn Field, f32)>,
    /// Test triangle pairs for crossings and coplanar overlaps (a uniform grid
    /// over the triangles keeps it near-linear).
    pub intersections: bool,
    /// Sample the two-sided distance and the lost surface on this grid (with
    /// `field`; its cell size is the unit).
    pub surface: Option<&'a Grid>,
    /// With `surface`: also sample the surface on lattices finer than the grid
    /// (three times in every cell that may hold surface, twelve in the farthest;
    /// see the [module docs](self)). Finds the farthest points a grid misses, at
    /// tens of times the grid's samples.
    pub refine_surface: bool,
}

impl<'a> Checks<'a> {
    /// Every check, against `field` sampled on `grid`, the surface on the finer
    /// lattices too.
    pub fn all(field: &'a dyn Field, grid: &'a Grid) -> Self {
        Checks {
            refine_surface: true,
            ..Checks::standard(field, grid)
        }
    }

    /// Every check, against `field` sampled on `grid`, the surface-to-mesh
    /// distance on the grid's crossings and those of the grid shifted by half a
    /// cell only: a cost of a few times the grid's own samples.
    pub fn standard(field: &'a dyn Field, grid: &'a Grid) -> Self {
        Checks {
            field: Some((field, grid.cell_size)),
            intersections: true,
            surface: Some(grid),
            refine_surface: false,
        }
    }
}

impl MeshReport {
    /// Watertight, manifold and consistently oriented.
    pub fn is_closed_manifold(&self) -> bool {
        self.watertight && self.manifold && self.oriented
    }
}

fn find(p: &mut [u32], mut x: u32) -> u32 {
    while p[x as usize] != x {
        p[x as usize] = p[p[x as usize] as usize];
        x = p[x as usize];
    }
    x
}

/// Checks `mesh`: topology and per-triangle geometry, and with `field` (and the
/// grid's cell size) how far vertices and triangle centroids are from the surface,
/// in cells, and which faces are flipped. [`validate_with`] runs more checks.
pub fn validate(mesh: &IndexedMesh, field: Option<(&dyn Field, f32)>) -> MeshReport {
    validate_with(
        mesh,
        &Checks {
            field,
            ..Default::default()
        },
    )
}

/// Checks `mesh` as [`validate`] does, plus what `checks` asks for.
pub fn validate_with(mesh: &IndexedMesh, checks: &Checks) -> MeshReport {
    let nv = mesh.positions.len();
    let tris: Vec<[u32; 3]> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let mut r = MeshReport {
        triangles: tris.len(),
        ..Default::default()
    };
    // Directed edge counts keyed by (min, max) with a direction tally.
    let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::with_capacity(tris.len() * 2);
    let mut used = vec![false; nv];
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for (ti, t) in tris.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            r.degenerate_triangles += 1;
            continue;
        }
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            used[a as usize] = true;
            incident[a as usize].push(ti as u32);
            let key = (a.min(b), a.max(b));
            let e = edges.entry(key).or_insert((0, 0));
            e.0 += 1;
            e.1 += if a < b { 1 } else { -1 };
        }
    }
    for &(count, dir) in edges.values() {
        match count {
            1 => r.boundary_edges += 1,
            2 => {
                if dir != 0 {
                    r.misoriented_edges += 1
                }
            }
            _ => r.nonmanifold_edges += 1,
        }
    }
    // Vertex fans: triangles around a vertex joined through edges at the vertex.
    for (v, tri_ids) in incident.iter().enumerate() {
        if tri_ids.len() <= 1 {
            continue;
        }
        let mut parent: Vec<u32> = (0..tri_ids.len() as u32).collect();
        let mut by_other: HashMap<u32, u32> = HashMap::new();
        for (k, &ti) in tri_ids.iter().enumerate() {
            for &o in &tris[ti as usize] {
                if o as usize == v {
                    continue;
                }
                if let Some(&prev) = by_other.get(&o) {
                    let (ra, rb) = (find(&mut parent, prev), find(&mut parent, k as u32));
                    parent[ra as usize] = rb;
                } else {
                    by_other.insert(o, k as u32);
                }
            }
        }
        let fans = (0..tri_ids.len() as u32)
            .filter(|&k| find(&mut parent, k) == k)
            .count();
        if fans > 1 {
            r.nonmanifold_vertices += 1;
        }
    }
    // Components through shared vertices.
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    for t in &tris {
        for i in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[i]));
            parent[a as usize] = b;
        }
    }
    r.vertices = used.iter().filter(|&&u| u).count();
    r.components = (0..nv as u32)
        .filter(|&v| used[v as usize] && find(&mut parent, v) == v)
        .count();
    r.euler = r.vertices as i64 - edges.len() as i64 + (tris.len() - r.degenerate_triangles) as i64;
    r.watertight = r.boundary_edges == 0;
    r.manifold =
        r.nonmanifold_edges == 0 && r.nonmanifold_vertices == 0 && r.degenerate_triangles == 0;
    r.oriented = r.misoriented_edges == 0;

    let cell = checks
        .field
        .map(|f| f.1)
        .or(checks.surface.map(|g| g.cell_size))
        .filter(|c| c.is_finite() && *c > 0.0)
        .unwrap_or_else(|| mean_edge(&mesh.positions, &tris));
    let faces = faces::faces(&mesh.positions, &tris, &used, cell);
    r.zero_area_triangles = faces.zero_area;
    r.sliver_triangles = faces.slivers;
    r.coincident_vertices = faces.coincident_vertices;
    r.materials = materials::check(mesh, checks.field.map(|f| f.0), &used);
    if let Some((f, cell)) = checks.field {
        let s = faces::against_field(f, cell, &mesh.positions, &tris, &used, &faces.listed);
        r.max_error = s.max_error;
        r.mean_error = s.mean_error;
        r.max_vertex_error = s.max_vertex_error;
        r.flipped_triangles = Some(s.flipped);
        r.folds = Some(folds::folds(f, cell, &mesh.positions, &tris, &faces.listed));
    }
    let grid = (checks.intersections || checks.surface.is_some())
        .then(|| spatial::TriGrid::new(&mesh.positions, &tris, &faces.listed, cell));
    if let (true, Some(g)) = (checks.intersections, &grid) {
        r.intersections = Some(intersections(&mesh.positions, &tris, g, cell));
    }
    if let (Some(sg), Some((f, _)), Some(g)) = (checks.surface, checks.field, &grid) {
        let c = sg.cell_size;
        let (m_max, m_mean) =
            distance::mesh_to_surface(f, &mesh.positions, &tris, &faces.listed, &used, c);
        let s = distance::surface_to_mesh(f, sg, g, checks.refine_surface);
        r.distance = Some(Distance {
            mesh_to_surface_max: m_max / c,
            mesh_to_surface_mean: m_mean / c,
            surface_to_mesh_max: s.max / c,
            surface_to_mesh_mean: s.mean / c,
            surface_points: s.points,
            lost_surface: if s.points > 0 {
                s.lost as f32 / s.points as f32
            } else {
                0.0
            },
            refined: checks.refine_surface,
        });
    }
    r
}

/// Mean edge length: the scale of a mesh checked without a field.
fn mean_edge(pos: &[Vec3], tris: &[[u32; 3]]) -> f32 {
    let mut sum = 0f64;
    for t in tris {
        for i in 0..3 {
            sum += pos[t[i] as usize].distance(pos[t[(i + 1) % 3] as usize]) as f64;
        }
    }
    if tris.is_empty() {
        1.0
    } else {
        (sum / (3 * tris.len()) as f64) as f32
    }
}

/// Crossing and coplanar overlapping pairs among the bucketed triangles.
fn intersections(
    pos: &[Vec3],
    tris: &[[u32; 3]],
    grid: &spatial::TriGrid,
    cell: f32,
) -> Intersections {
    let tol = tritri::Tolerance {
        length: INTERSECTION_TOL_CELLS * cell as f64,
        area: ZERO_AREA_CELLS2 * (cell as f64).powi(2),
    };
    let hits = grid.pairs(|a, b| {
        let (ta, tb) = (tris[a as usize], tris[b as usize]);
        let (pa, pb) = (faces::corners(pos, ta), faces::corners(pos, tb));
        let (na, nb) = (tritri::unit_normal(&pa), tritri::unit_normal(&pb));
        // Neighbours from one vertex: the quick test first.
        let mut shared = (0, None);
        for i in 0..3 {
            if let Some(j) = tb.iter().position(|&v| v == ta[i]) {
                shared = (shared.0 + 1, Some((i, j)));
            }
        }
        if let (1, Some((i, j))) = shared {
            if tritri::apart_from_shared_corner(&pa, na, i, &pb, nb, j, tol) {
                return None;
            }
        }
        let c = tritri::contact_with_normals(&pa, na, &pb, nb, tol);
        (c != tritri::Contact::None).then_some((a, b, c))
    });
    let mut r = Intersections::default();
    let mut crossing = vec![false; tris.len()];
    let mut overlapping = vec![false; tris.len()];
    for (a, b, c) in hits {
        match c {
            tritri::Contact::Cross { depth } => {
                r.crossing_pairs += 1;
                r.max_depth = r.max_depth.max((depth / cell as f64) as f32);
                crossing[a as usize] = true;
                crossing[b as usize] = true;
            }
            tritri::Contact::Coplanar => {
                r.overlapping_pairs += 1;
                overlapping[a as usize] = true;
                overlapping[b as usize] = true;
            }
            tritri::Contact::None => {}
        }
    }
    r.crossing_triangles = crossing.iter().filter(|&&x| x).count();
    r.overlapping_triangles = overlapping.iter().filter(|&&x| x).count();
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tetra() -> IndexedMesh {
        IndexedMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            normals: vec![Vec3::Z; 4],
            indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
            materials: Vec::new(),
        }
    }

    #[test]
    fn tetrahedron_is_a_closed_sphere() {
        let r = validate(&tetra(), None);
        assert!(r.is_closed_manifold(), "{r:?}");
        assert_eq!(r.euler, 2);
        assert_eq!(r.components, 1);
    }

    #[test]
    fn hole_flip_and_pinch_are_seen() {
        let mut m = tetra();
        m.indices.truncate(9);
        let r = validate(&m, None);
        assert!(!r.watertight && r.boundary_edges == 3);

        let mut m = tetra();
        m.indices[0..3].copy_from_slice(&[0, 1, 2]);
        assert!(!validate(&m, None).oriented);

        // Two tetrahedra sharing one vertex: a pinch.
        let mut m = tetra();
        let t2 = tetra();
        let base = m.positions.len() as u32;
        m.positions
            .extend(t2.positions.iter().map(|p| *p + Vec3::splat(-1.0)));
        m.normals.extend(&t2.normals);
        m.indices.extend(
            t2.indices
                .iter()
                .map(|&i| if i == 1 { 0 } else { i + base }),
        );
        let r = validate(&m, None);
        assert_eq!(r.nonmanifold_vertices, 1, "{r:?}");
        assert!(!r.manifold);
    }
}
