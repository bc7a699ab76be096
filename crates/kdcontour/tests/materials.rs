//! Materials carried by the field: every vertex has the field's material at it,
//! material borders stay crisp at a coarse threshold (and do not without
//! material-aware clustering), chunk worlds with materials keep every mesh
//! invariant, and a paint changes materials, not the surface.

use glam::{IVec3, Vec3};
use kdcontour::edit::{Brush, BrushOp, EditedField};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::material::{terrain_ids, MaterialBlend};
use kdcontour::world::{ChunkKey, Layout, World};
use kdcontour::{scenes, validate, CsgNode, Field, Grid, IndexedMesh, KdTree, Settings};
use std::sync::Arc;

mod common;

/// Every vertex's blend is the field's material there, every blend is well
/// formed, and the mesh has one per vertex.
fn assert_materials_match(mesh: &IndexedMesh, field: &dyn Field, cell: f32, what: &str) {
    let r = validate(mesh, Some((field, cell)));
    let m = r
        .materials
        .as_ref()
        .unwrap_or_else(|| panic!("{what}: no materials"));
    assert!(m.per_vertex, "{what}: {m:?}");
    assert_eq!(m.bad_blends, 0, "{what}: {m:?}");
    assert_eq!(m.mismatched_vertices, Some(0), "{what}: {m:?}");
}

#[test]
fn vertex_materials_match_the_field_on_every_scene_with_materials() {
    let mut with = Vec::new();
    for name in scenes::SCENES {
        let scene = scenes::scene(name).unwrap();
        if !scene.field.has_materials() {
            continue;
        }
        with.push(*name);
        let grid = Grid::cube(1.0, 40);
        let tree = KdTree::build(&*scene.field, &grid, &Settings::default()).unwrap();
        for t in [-1.0, 0.01, 1.0] {
            let mesh = tree.mesh(t);
            assert_materials_match(
                &mesh,
                &*scene.field,
                grid.cell_size,
                &format!("{name} at {t}"),
            );
            let r = validate(&mesh, None);
            if scene.closed {
                assert!(r.is_closed_manifold(), "{name} at {t}: {r:?}");
            }
        }
        // The baselines get theirs from the field too.
        let s = kdcontour::meshers::sample(&*scene.field, &grid, &Settings::default()).unwrap();
        for mesher in kdcontour::meshers::Mesher::ALL {
            let (mut mesh, _) =
                kdcontour::meshers::run(mesher, &s, 0.01, &Settings::default()).unwrap();
            kdcontour::material::attach(&mut mesh, &*scene.field);
            assert_materials_match(
                &mesh,
                &*scene.field,
                grid.cell_size,
                &format!("{name} {mesher:?}"),
            );
        }
    }
    assert!(
        with.contains(&"csg_mix") && with.contains(&"terrain") && with.contains(&"caves"),
        "{with:?}"
    );
    // Fields without materials give meshes without them.
    let sphere = scenes::scene("sphere").unwrap();
    let mesh = kdcontour::mesh(
        &*sphere.field,
        &Grid::cube(1.0, 16),
        0.01,
        &Settings::default(),
    )
    .unwrap();
    assert!(mesh.materials.is_empty());
    assert_eq!(
        validate(&mesh, Some((&*sphere.field, 0.125))).materials,
        None
    );
}

#[test]
fn a_smooth_union_blends_weights_that_sum_to_one() {
    let scene = scenes::scene("csg_mix").unwrap();
    let mesh = kdcontour::mesh(
        &*scene.field,
        &Grid::cube(1.0, 48),
        -1.0,
        &Settings::default(),
    )
    .unwrap();
    // Vertices where the torus, capsule and rounded box blend carry two ids.
    let blended: Vec<&MaterialBlend> = mesh
        .materials
        .iter()
        .filter(|m| m.weights[1] > 0.05)
        .collect();
    assert!(blended.len() > 20, "{} blended vertices", blended.len());
    for m in &mesh.materials {
        assert!((m.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{m:?}");
    }
    assert!(blended
        .iter()
        .any(|m| m.weight_of(6) > 0.0 && (m.weight_of(1) > 0.0 || m.weight_of(7) > 0.0)));
}

/// A plane at y = 0.37 cells, material 1 where x < `BORDER`, 0 beyond.
struct TwoMaterials;
const BORDER: f32 = 0.113;

impl Field for TwoMaterials {
    fn value(&self, p: Vec3) -> f32 {
        p.y - 0.37 / 32.0
    }
    fn material(&self, p: Vec3) -> MaterialBlend {
        MaterialBlend::single(if p.x < BORDER { 1 } else { 0 })
    }
    fn has_materials(&self) -> bool {
        true
    }
}

/// How crisp the border of `mesh` is, in cells: the farthest vertex of a
/// triangle spanning the border from the true border, and the sampled Hausdorff
/// distance between the mesh's border as drawn (in each triangle across it, the
/// segment between the midpoints of its edges between vertices of two
/// materials) and the true one (`x = BORDER` on the plane, sampled across the
/// grid's interior).
fn border_reach(mesh: &IndexedMesh, cell: f32) -> (f32, f32) {
    let r = validate(mesh, Some((&TwoMaterials, cell)));
    let m = r.materials.unwrap();
    assert!(m.per_vertex && m.mismatched_vertices == Some(0) && m.border_triangles > 0);
    let dom = |i: u32| mesh.materials[i as usize].dominant();
    let mut band = 0f32;
    // Per triangle across the border, the midpoints of its edges that join
    // two materials.
    let mut mids: Vec<Vec<Vec3>> = Vec::new();
    for t in mesh.indices.chunks_exact(3) {
        if dom(t[0]) == dom(t[1]) && dom(t[1]) == dom(t[2]) {
            continue;
        }
        let mut here = Vec::new();
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
            band = band.max((pa.x - BORDER).abs() / cell);
            if dom(a) != dom(b) {
                here.push((pa + pb) * 0.5);
            }
        }
        mids.push(here);
    }
    let to_true = mids
        .iter()
        .flatten()
        .map(|p| (p.x - BORDER).abs() / cell)
        .fold(0f32, f32::max);
    // The border as drawn: in each triangle across it, the segment between the
    // midpoints of its two edges that join the materials (where the blended
    // weights are even).
    let from_true = (0..200)
        .map(|i| Vec3::new(BORDER, 0.0, -0.9 + 1.8 * i as f32 / 199.0))
        .map(|q| {
            mids.iter()
                .map(|s| match s.as_slice() {
                    [a, b] => segment_xz(*a, *b, q),
                    _ => s
                        .iter()
                        .map(|p| Vec2Dist::xz(*p, q))
                        .fold(f32::INFINITY, f32::min),
                })
                .fold(f32::INFINITY, f32::min)
                / cell
        })
        .fold(0f32, f32::max);
    (band, to_true.max(from_true))
}

/// The distance in the xz plane from `q` to the segment `a`-`b`.
fn segment_xz(a: Vec3, b: Vec3, q: Vec3) -> f32 {
    let (a, b, q) = (
        glam::Vec2::new(a.x, a.z),
        glam::Vec2::new(b.x, b.z),
        glam::Vec2::new(q.x, q.z),
    );
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t).distance(q)
}

struct Vec2Dist;
impl Vec2Dist {
    fn xz(a: Vec3, b: Vec3) -> f32 {
        ((a.x - b.x).powi(2) + (a.z - b.z).powi(2)).sqrt()
    }
}

#[test]
fn a_material_border_stays_crisp_at_a_coarse_threshold() {
    let grid = Grid::cube(1.0, 64);
    let cell = grid.cell_size;
    let on = Settings::default();
    let off = Settings {
        material_borders: false,
        ..Default::default()
    };
    let crisp = kdcontour::mesh(&TwoMaterials, &grid, 1.0, &on).unwrap();
    let (band, hausdorff) = border_reach(&crisp, cell);
    assert!(band <= 1.0, "border band reaches {band} cells");
    assert!(
        hausdorff <= 1.0,
        "border Hausdorff distance {hausdorff} cells"
    );
    // The surface itself is simplified away from the border.
    let uniform = kdcontour::mesh(&TwoMaterials, &grid, -1.0, &on).unwrap();
    assert!(crisp.triangle_count() * 2 < uniform.triangle_count());
    // Without material-aware clustering the same mesh spans the border with
    // triangles many cells long: the test above fails.
    let blurred = kdcontour::mesh(&TwoMaterials, &grid, 1.0, &off).unwrap();
    let (band_off, hausdorff_off) = border_reach(&blurred, cell);
    assert!(
        band_off > 1.0 && hausdorff_off > 1.0,
        "without material borders: band {band_off}, Hausdorff {hausdorff_off}"
    );
    assert!(blurred.triangle_count() < crisp.triangle_count());
}

#[test]
fn fields_without_materials_mesh_as_before_whatever_the_switch() {
    let off = Settings {
        material_borders: false,
        ..Default::default()
    };
    for name in ["sphere", "torus", "gyroid", "disk_pole"] {
        let scene = scenes::scene(name).unwrap();
        let grid = Grid::cube(1.0, 32);
        for t in [-1.0, 0.01, 1.0] {
            let a = kdcontour::mesh(&*scene.field, &grid, t, &Settings::default()).unwrap();
            let b = kdcontour::mesh(&*scene.field, &grid, t, &off).unwrap();
            assert_eq!(a, b, "{name} at {t}");
        }
    }
}

#[test]
fn the_demo_terrain_shows_all_four_materials() {
    let field = Density::new(DensityParams::demo(1));
    // A view of 256 x 256 world units sampled on the surface from above.
    let mut seen = [0usize; 4];
    for i in 0..64 {
        for j in 0..64 {
            let (x, z) = (i as f32 * 4.0 - 128.0, j as f32 * 4.0 - 128.0);
            let Some(t) =
                kdcontour::field::raycast(&field, Vec3::new(x, 60.0, z), -Vec3::Y, 120.0, 0.5)
            else {
                continue;
            };
            let m = field.material(Vec3::new(x, 60.0 - t, z));
            seen[m.dominant() as usize] += 1;
        }
    }
    for (id, name) in [
        (terrain_ids::GRASS, "grass"),
        (terrain_ids::ROCK, "rock"),
        (terrain_ids::DIRT, "dirt"),
        (terrain_ids::SNOW, "snow"),
    ] {
        assert!(seen[id as usize] >= 40, "{name}: {seen:?}");
    }
}

#[test]
fn chunk_and_level_worlds_with_materials_keep_every_invariant() {
    for name in ["csg_mix", "caves"] {
        let scene = scenes::scene(name).unwrap();
        let field = &*scene.field;
        let mut w: World = common::chunk_world(field, 3, 12);
        let mut rng = common::Lcg(11);
        for c in w.chunks() {
            w.set_threshold(&c, [-1.0, 0.01, 1.0][rng.next() % 3]);
        }
        let cell = 2.0 / 36.0;
        let m = w.extract_all();
        let r = validate(&m, Some((field, cell)));
        assert!(r.is_closed_manifold(), "{name}: {r:?}");
        assert_materials_match(&m, field, cell, name);
        // Each chunk's own mesh carries its materials too.
        let mut one = IndexedMesh::default();
        for c in w.chunks() {
            w.extract_interior(&c, &mut one);
            assert_eq!(one.materials.len(), one.vertex_count());
            let Some(snapshot) = w.snapshot(&c) else {
                continue;
            };
            snapshot.extract(&mut one);
            assert_materials_match(&one, field, cell, &format!("{name} chunk {c:?}"));
        }
        // Chunks of two levels.
        let layout = Layout::random(IVec3::ZERO, IVec3::splat(4), 2, 0.3, 5).unwrap();
        let mut lw = World::new(
            Vec3::splat(-1.0),
            0.5 / 8.0,
            8,
            layout,
            0.01,
            Settings::default(),
        )
        .unwrap();
        lw.build_all(field).unwrap();
        let m = lw.extract_all();
        let r = validate(&m, Some((field, 0.5 / 8.0)));
        assert!(r.is_closed_manifold(), "{name} levels: {r:?}");
        assert_materials_match(&m, field, 0.5 / 8.0, &format!("{name} levels"));
    }
    // A demo terrain chunk, as the plugin streams it.
    let field = Density::new(DensityParams::demo(2));
    let mut w = World::unbounded(Vec3::ZERO, 1.0, 32, 1.0, Settings::default()).unwrap();
    let c = ChunkKey::new(0, IVec3::new(0, -1, 0));
    w.add_chunk(c.coord).unwrap();
    w.build_chunk(&c, &field).unwrap();
    let mut mesh = IndexedMesh::default();
    w.snapshot(&c).unwrap().extract(&mut mesh);
    assert!(mesh.triangle_count() > 100);
    assert_materials_match(&mesh, &field, 1.0, "demo chunk");
    let r = validate(&mesh, Some((&field, 1.0)));
    assert_eq!(
        (
            r.nonmanifold_edges,
            r.misoriented_edges,
            r.degenerate_triangles
        ),
        (0, 0, 0),
        "{r:?}"
    );
}

#[test]
fn a_paint_changes_materials_not_the_surface() {
    let base: Arc<dyn Field> = scenes::scene("csg_mix").unwrap().field.into();
    let before = EditedField::new(base);
    let paint = Brush {
        shape: CsgNode::Sphere {
            radius: 0.3,
            center: Vec3::new(0.3, 0.5, 0.0),
        },
        op: BrushOp::Paint,
        material: 9,
    };
    let after = before.with_edit(paint).unwrap();
    let grid = Grid::cube(1.0, 40);
    let off = Settings {
        material_borders: false,
        ..Default::default()
    };
    // The uniform mesh, and any mesh without material-aware clustering, keeps
    // every position and triangle; the materials change inside the paint only.
    // (With crisp borders the tree's splits follow the materials, so the
    // uniform mesh comes out in another order: vertices are matched by
    // position.)
    let key = |p: Vec3| p.to_array().map(f32::to_bits);
    for (t, settings) in [(-1.0, Settings::default()), (0.01, off.clone()), (1.0, off)] {
        let a = kdcontour::mesh(&before, &grid, t, &settings).unwrap();
        let b = kdcontour::mesh(&after, &grid, t, &settings).unwrap();
        let index_a: std::collections::HashMap<[u32; 3], usize> = a
            .positions
            .iter()
            .enumerate()
            .map(|(i, &p)| (key(p), i))
            .collect();
        assert_eq!(
            index_a.len(),
            a.positions.len(),
            "at {t}: coincident vertices"
        );
        let in_a: Vec<usize> = b.positions.iter().map(|&p| index_a[&key(p)]).collect();
        let triangles = |m: &IndexedMesh, map: &dyn Fn(u32) -> usize| {
            let mut t: Vec<[usize; 3]> = m
                .indices
                .chunks_exact(3)
                .map(|t| {
                    let v = [map(t[0]), map(t[1]), map(t[2])];
                    // Each triangle from its least corner, winding kept.
                    let k = (0..3).min_by_key(|&k| v[k]).unwrap();
                    [v[k], v[(k + 1) % 3], v[(k + 2) % 3]]
                })
                .collect();
            t.sort_unstable();
            t
        };
        assert_eq!(a.positions.len(), b.positions.len(), "at {t}");
        assert_eq!(
            triangles(&a, &|i| i as usize),
            triangles(&b, &|i| in_a[i as usize]),
            "at {t}"
        );
        let changed: Vec<usize> = (0..b.materials.len())
            .filter(|&i| a.materials[in_a[i]] != b.materials[i])
            .collect();
        assert!(!changed.is_empty(), "at {t}");
        for i in changed {
            let p = b.positions[i];
            assert!(p.distance(Vec3::new(0.3, 0.5, 0.0)) < 0.3, "{p}");
            assert_eq!(b.materials[i], MaterialBlend::single(9));
        }
        assert_materials_match(&b, &after, grid.cell_size, &format!("painted at {t}"));
    }
    // With crisp borders the painted patch's border is kept: more triangles
    // there, every vertex still the field's material.
    let a = kdcontour::mesh(&before, &grid, 1.0, &Settings::default()).unwrap();
    let b = kdcontour::mesh(&after, &grid, 1.0, &Settings::default()).unwrap();
    assert!(b.triangle_count() >= a.triangle_count());
    assert_materials_match(&b, &after, grid.cell_size, "painted, crisp");
}

#[test]
fn cells_on_and_beside_a_border_merge_along_it_and_keep_it_where_it_is() {
    // The plane's border runs along z through one column of cells. Those
    // cells, whose crossings hold both materials, and the cells beside them may
    // merge into nodes that run along the border (their vertices keep the
    // cells' distance to it), but not into nodes that reach away from it. A
    // straight border then costs a few strips of nodes the grid's length, at
    // every resolution, not a vertex every cell or two along it (198
    // triangles at 64 cells when the tree cut a node across its strips only
    // where half its cells came out alike, and along the border elsewhere).
    for res in [32, 64, 128] {
        let grid = Grid::cube(1.0, res);
        let cell = grid.cell_size;
        let crisp = kdcontour::mesh(&TwoMaterials, &grid, 1.0, &Settings::default()).unwrap();
        let (band, hausdorff) = border_reach(&crisp, cell);
        assert!(
            band <= 1.0 && hausdorff <= 1.0,
            "res {res}: band {band}, Hausdorff {hausdorff}"
        );
        // Vertices per distance from the border, in whole cells.
        let mut per_ring = [0usize; 4];
        for p in &crisp.positions {
            let ring = ((p.x - BORDER).abs() / cell) as usize;
            if ring < per_ring.len() {
                per_ring[ring] += 1;
            }
        }
        assert!(
            crisp.triangle_count() <= 32 && per_ring[0] + per_ring[1] <= 16,
            "res {res}: {} triangles; vertices within 1, 2, 3 and 4 cells of the border: {per_ring:?}",
            crisp.triangle_count()
        );
    }
}
