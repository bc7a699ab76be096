//! Issue 13's must-hold: the two-sided distance `validate` reports agrees with a
//! brute-force one within 10% (or 0.02 cells), on every scene, volumes included.
//!
//! The brute force shares nothing with the checker: the surface is a uniform Dual
//! Marching Cubes mesh four times finer (its vertices are crossings found on the
//! field and QEF minimisers, so sharp edges stay sharp), both meshes are sampled
//! densely (a barycentric lattice a sixth of a cell apart on every triangle), and
//! every sample's distance to the other mesh is the exact point-triangle distance
//! to its nearest triangle, found through a bucket grid.

use glam::{UVec3, Vec3};
use kdcontour::field::volume::{Inside, SampledVolume};
use kdcontour::validate::{validate_with, Checks};
use kdcontour::{scenes, Field, Grid, IndexedMesh, KdTree, Settings};
use rayon::prelude::*;

/// How many times finer the reference surface is than the mesh.
const FINER: u32 = 8;

/// Triangles of a mesh bucketed on a uniform grid of `size` world units.
struct Buckets<'a> {
    mesh: &'a IndexedMesh,
    lo: Vec3,
    size: f32,
    dims: UVec3,
    cells: Vec<Vec<u32>>,
}

impl<'a> Buckets<'a> {
    fn new(mesh: &'a IndexedMesh, size: f32) -> Self {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for p in &mesh.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let dims = ((hi - lo) / size).floor().as_uvec3() + UVec3::ONE;
        let mut cells = vec![Vec::new(); (dims.x * dims.y * dims.z) as usize];
        for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let p = [0, 1, 2].map(|i| mesh.positions[tri[i] as usize]);
            let a = ((p[0].min(p[1]).min(p[2]) - lo) / size).as_uvec3();
            let b = ((p[0].max(p[1]).max(p[2]) - lo) / size)
                .as_uvec3()
                .min(dims - 1);
            for z in a.z..=b.z {
                for y in a.y..=b.y {
                    for x in a.x..=b.x {
                        cells[(x + dims.x * (y + dims.y * z)) as usize].push(t as u32);
                    }
                }
            }
        }
        Buckets {
            mesh,
            lo,
            size,
            dims,
            cells,
        }
    }

    fn triangle(&self, t: u32) -> [Vec3; 3] {
        let i = 3 * t as usize;
        [0, 1, 2].map(|k| self.mesh.positions[self.mesh.indices[i + k] as usize])
    }

    /// Distance from `q` to the nearest triangle: rings of buckets around `q`'s
    /// until the ring is farther than the best found.
    fn distance(&self, q: Vec3) -> f32 {
        let c = ((q - self.lo) / self.size).floor().as_ivec3();
        let mut best = f32::INFINITY;
        for ring in 0i32.. {
            if (ring - 1) as f32 * self.size > best || ring as u32 > self.dims.max_element() + 1 {
                break;
            }
            for z in -ring..=ring {
                for y in -ring..=ring {
                    for x in -ring..=ring {
                        if x.abs().max(y.abs()).max(z.abs()) != ring {
                            continue;
                        }
                        let b = c + glam::IVec3::new(x, y, z);
                        if b.min_element() < 0 || b.cmpge(self.dims.as_ivec3()).any() {
                            continue;
                        }
                        let i = b.x as u32 + self.dims.x * (b.y as u32 + self.dims.y * b.z as u32);
                        for &t in &self.cells[i as usize] {
                            best = best.min(point_triangle(q, self.triangle(t)));
                        }
                    }
                }
            }
        }
        best
    }
}

/// Distance from `q` to triangle `t` (region by region, Ericson's closest point).
fn point_triangle(q: Vec3, [a, b, c]: [Vec3; 3]) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, q - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return q.distance(a);
    }
    let bp = q - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return q.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return q.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = q - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return q.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return q.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return q.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    q.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// Points on every triangle of `m`, at most `step` apart.
fn samples(m: &IndexedMesh, step: f32) -> Vec<Vec3> {
    let mut out = Vec::new();
    for t in m.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|i| m.positions[t[i] as usize]);
        let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
        let n = ((longest / step).ceil() as usize).max(1);
        for i in 0..=n {
            for j in 0..=n - i {
                out.push(a + (b - a) * (i as f32 / n as f32) + (c - a) * (j as f32 / n as f32));
            }
        }
    }
    out
}

/// The largest distance from points of `from` to the mesh `to`, in cells.
fn one_side(from: &IndexedMesh, to: &IndexedMesh, cell: f32) -> f32 {
    let buckets = Buckets::new(to, cell);
    samples(from, cell / 6.0)
        .par_iter()
        .map(|&q| buckets.distance(q))
        .reduce(|| 0.0, f32::max)
        / cell
}

/// Checks the reported distances of `field`'s meshes on `grid` (a cube of `res`
/// cells) against the brute force, at a uniform and an adaptive threshold.
fn agrees(name: &str, field: &dyn Field, grid: Grid) {
    let fine_grid = Grid {
        cell_size: grid.cell_size / FINER as f32,
        cells: grid.cells * FINER,
        ..grid
    };
    let surface = KdTree::build(field, &fine_grid, &Settings::default())
        .unwrap()
        .mesh(-1.0);
    let tree = KdTree::build(field, &grid, &Settings::default()).unwrap();
    for e in [-1.0, 0.1] {
        let mesh = tree.mesh(e);
        let r = validate_with(&mesh, &Checks::all(field, &grid));
        let d = r.distance.expect("requested");
        let m2s = one_side(&mesh, &surface, grid.cell_size);
        let s2m = one_side(&surface, &mesh, grid.cell_size);
        println!(
            "{name:<12} e {e:>4}: mesh->surface {:.4} brute {m2s:.4}, surface->mesh {:.4} brute {s2m:.4}",
            d.mesh_to_surface_max, d.surface_to_mesh_max
        );
        let close = |a: f32, b: f32| (a - b).abs() <= (0.1 * b).max(0.02);
        assert!(
            close(d.mesh_to_surface_max, m2s),
            "{name} e {e}: {d:?} vs brute {m2s}"
        );
        assert!(
            close(d.surface_to_mesh_max, s2m),
            "{name} e {e}: {d:?} vs brute {s2m}"
        );
    }
}

/// A volume of 32^3 voxels: a bumpy ball, smooth or segmented (100 in, 0 out: the
/// trilinear gradient is zero wherever eight voxels agree).
fn volume(segmented: bool) -> SampledVolume {
    let n = 32u32;
    let mut data = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = UVec3::new(x, y, z).as_vec3() - Vec3::splat(15.3);
                let r = 10.0 + 1.5 * (p.x * 0.4).sin() * (p.y * 0.3).cos();
                let v = r - p.length();
                data.push(if segmented {
                    100.0 * (v > 0.0) as u8 as f32
                } else {
                    v
                });
            }
        }
    }
    SampledVolume {
        dims: UVec3::splat(n),
        spacing: Vec3::ONE,
        origin: Vec3::ZERO,
        data,
        iso: if segmented { 50.0 } else { 0.0 },
        inside: Inside::Above,
    }
}

fn agrees_on_volume(segmented: bool) {
    let vol = volume(segmented);
    let (lo, hi) = vol.bounds();
    agrees(
        &format!("volume, segmented {segmented}"),
        &vol,
        Grid::fit(lo, hi, 24),
    );
}

/// The must-hold on every scene and both volumes, at res 24 and thresholds -1
/// and 0.1 (about two minutes in the test profile on two cores).
///
/// What it took (reported against brute force, in cells, before and after):
/// - mesh to surface was over-reported where the Newton path from a point finds
///   a farther crossing than the nearest (inside a shell thinner than a cell, at
///   a kink of the field, where a sampled volume is flat): gyroid at -1 0.45
///   against 0.38, caves 1.00 against 0.66, the segmented volume 0.38 against
///   0.34. The checker now measures the points that bound its maximum again
///   along rays in every direction (`validate::distance`): 0.381, 0.687 and
///   0.332 against 0.384, 0.678 and 0.356;
/// - surface to mesh was under-reported on thin_plates (0.40 against 0.47): the
///   farthest surface points are sub-cell peaks of its noisy surface, which a
///   lattice a third of a cell apart misses. The cells nearest the maximum are
///   sampled again twelve times finer: 0.465 against 0.483; with cell vertices
///   held on a cell corner moved to their mass point first, the farthest peak
///   moved to a cell whose coarser lattice saw under 0.7 of the maximum (0.392
///   against 0.459); cells down to half of it are sampled finer now: 0.436;
/// - on `box` at 0.1 the brute force's own reference, a uniform mesh four times
///   finer, was 0.04 cells off at the box's corners, too coarse for the
///   0.02-cell bar (0.022 reported against 0.050). It is eight times finer now:
///   0.022 against 0.027.
///
/// anisotropic (fins thinner than a cell) and caves' surface-to-mesh side agree
/// since the finer lattice also samples cells with no sign change that a
/// Lipschitz bound cannot prove empty.
#[test]
fn reported_distance_agrees_with_brute_force_on_every_scene() {
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        agrees(name, &*scene.field, Grid::cube(1.0, 24));
    }
    agrees_on_volume(false);
    agrees_on_volume(true);
}
