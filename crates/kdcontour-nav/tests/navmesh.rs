//! Navmesh tiles from chunk meshes: paths follow the floor across chunk seams
//! and level boundaries, go around a pit dug after the pit's chunks re-mesh
//! (only their tiles rebuilt) and over a ramp raised across a cliff; a goal in
//! rock or in the air has no path.

use glam::{IVec3, UVec3, Vec3};
use kdcontour::edit::{Brush, BrushOp, EditedField};
use kdcontour::world::{ChunkKey, Layout, World};
use kdcontour::{CsgNode, Field, IndexedMesh, Settings};
use kdcontour_nav::{NavMesh, NavSettings, NavTile, PathError};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Rolling ground that crosses the chunk boundary at y = 0 again and again.
struct Rolling;

fn rolling(x: f32, z: f32) -> f32 {
    2.5 * (x / 6.0).sin() + 1.5 * (z / 8.0).cos()
}

impl Field for Rolling {
    fn value(&self, p: Vec3) -> f32 {
        p.y - rolling(p.x, p.z)
    }
}

/// Low ground (y = 3.3) for x < 0, high ground (y = 6.3) beyond a cliff.
struct Terrace;

fn terrace(x: f32) -> f32 {
    4.8 + 1.5 * (x / 0.3).tanh()
}

impl Field for Terrace {
    fn value(&self, p: Vec3) -> f32 {
        p.y - terrace(p.x)
    }
}

/// 4 x 2 x 4 chunks of 16 cells of 1 unit: x and z in [-32, 32], y in
/// [-16, 16].
fn world(field: &dyn Field) -> World {
    wide_world(field, 4)
}

/// `n` x 2 x `n` chunks of 16 cells of 1 unit around the origin.
fn wide_world(field: &dyn Field, n: u32) -> World {
    let half = 8.0 * n as f32;
    let mut w = World::bounded(
        Vec3::new(-half, -16.0, -half),
        1.0,
        16,
        UVec3::new(n, 2, n),
        0.01,
        Settings::default(),
    )
    .unwrap();
    w.build_all(field).unwrap();
    w
}

fn chunk_mesh(w: &World, k: &ChunkKey) -> IndexedMesh {
    let mut m = IndexedMesh::default();
    if let Some(s) = w.snapshot(k) {
        s.extract(&mut m);
    }
    m
}

/// Builds (or rebuilds) the tiles of `keys`.
fn tile(nav: &mut NavMesh, w: &World, keys: &[ChunkKey]) {
    for k in keys {
        let t = nav.build_tile(&chunk_mesh(w, k)).unwrap();
        nav.insert(*k, Arc::new(t));
    }
}

fn navmesh(w: &World) -> NavMesh {
    let mut nav = NavMesh::new(NavSettings::default()).unwrap();
    tile(&mut nav, w, &w.chunks());
    nav
}

/// Applies `brush` to the field and re-meshes what it reaches; returns the
/// chunks whose meshes changed (the rebuilt ones and the owners of seams
/// touching them), the ones whose tiles must be rebuilt.
fn edit(w: &mut World, field: &mut EditedField, brush: Brush, reach: (Vec3, f32)) -> Vec<ChunkKey> {
    *field = field.with_edit(brush).unwrap();
    let rebuilt = w.edited(reach.0, reach.1);
    w.build(&rebuilt, &*field).unwrap();
    let mut remeshed = BTreeSet::new();
    for k in &rebuilt {
        for o in w.seam_owners_touching(k) {
            remeshed.insert(o.order());
        }
    }
    w.chunks()
        .into_iter()
        .filter(|k| remeshed.contains(&k.order()))
        .collect()
}

fn xz_distance(a: Vec3, b: Vec3) -> f32 {
    ((a.x - b.x).powi(2) + (a.z - b.z).powi(2)).sqrt()
}

/// The least ground-plane distance from `c` to the path's segments.
fn closest_approach(points: &[Vec3], c: Vec3) -> f32 {
    let mut best = f32::INFINITY;
    for s in points.windows(2) {
        for i in 0..=20 {
            best = best.min(xz_distance(s[0].lerp(s[1], i as f32 / 20.0), c));
        }
    }
    best
}

#[test]
fn paths_follow_rolling_ground_across_chunk_seams() {
    let w = world(&Rolling);
    let nav = navmesh(&w);
    assert!(nav.polygon_count() > 0 && nav.link_count() > 0);
    // Every chunk the ground passes through has a tile linked to a neighbour.
    let with_floor: Vec<ChunkKey> = nav
        .keys()
        .filter(|k| !nav.tile(k).unwrap().is_empty())
        .copied()
        .collect();
    assert!(
        with_floor.len() >= 16,
        "{} tiles with floor",
        with_floor.len()
    );
    for k in &with_floor {
        assert!(
            !nav.linked_tiles(k).is_empty(),
            "tile {k:?} is linked to none"
        );
    }
    // Paths between points spread over the whole world (they cross x = -16,
    // 0, 16 and z = -16, 0, 16, and the ground's crossings of y = 0).
    let mut n = 0;
    let mut worst = 0f32;
    for (sx, sz, gx, gz) in [
        (-28.0, -28.0, 28.0, 28.0),
        (-28.0, 28.0, 28.0, -28.0),
        (-5.0, -27.0, 6.0, 27.0),
        (27.0, 3.0, -27.0, -2.0),
        (-10.0, 10.0, 12.0, 11.0),
    ] {
        let s = Vec3::new(sx, rolling(sx, sz) + 0.5, sz);
        let g = Vec3::new(gx, rolling(gx, gz) + 0.5, gz);
        let path = nav
            .find_path(s, g)
            .unwrap_or_else(|e| panic!("{s} to {g}: {e}"));
        let straight = s.distance(g);
        let len = path.length();
        // The ground's length under the straight line seen from above.
        let over_ground: f32 = (0..1000)
            .map(|i| {
                let at = |t: f32| {
                    let (x, z) = (sx + (gx - sx) * t, sz + (gz - sz) * t);
                    Vec3::new(x, rolling(x, z), z)
                };
                at(i as f32 / 1000.0).distance(at((i + 1) as f32 / 1000.0))
            })
            .sum();
        println!(
            "{s} -> {g}: {} points, {} polygons, length {len:.2} (straight {straight:.2}, \
             over the ground {over_ground:.2})",
            path.points.len(),
            path.polygons
        );
        assert!(len >= xz_distance(s, g) - 1e-3 && len <= straight * 1.25);
        // Open ground all the way: the path runs along the straight line, as
        // long as the ground under it (through A*'s corridor alone, up to 4.5%
        // longer: 84.87 against 81.20 on the first).
        assert!(
            len <= over_ground * 1.01,
            "{len} long where the ground under the straight line is {over_ground}"
        );
        // On the floor: every point within half a unit of the ground, and so
        // is every segment's middle.
        for p in &path.points {
            assert!((p.y - rolling(p.x, p.z)).abs() < 0.5, "{p} off the ground");
            worst = worst.max((p.y - rolling(p.x, p.z)).abs());
        }
        n += 1;
    }
    assert_eq!(n, 5);
    println!("path points at most {worst:.3} from the ground");
}

#[test]
fn a_pit_dug_between_two_points_is_walked_around_and_only_its_tiles_rebuilt() {
    let base: Arc<dyn Field> = Arc::new(Rolling);
    let mut field = EditedField::new(base);
    let mut w = wide_world(&field, 6);
    let mut nav = navmesh(&w);
    let (s, g) = (Vec3::new(-20.0, 0.0, 3.0), Vec3::new(20.0, 0.0, 3.0));
    let (s, g) = (
        Vec3::new(s.x, rolling(s.x, s.z) + 0.5, s.z),
        Vec3::new(g.x, rolling(g.x, g.z) + 0.5, g.z),
    );
    let before = nav.find_path(s, g).unwrap();
    let c = Vec3::new(1.0, rolling(1.0, 3.0), 3.0);
    assert!(closest_approach(&before.points, c) < 3.0);
    // Open ground between the two: the straight line is walkable.
    assert_eq!(nav.is_open_between(s, g), Ok(true));
    // A pit of radius 7 with steep walls, dug where the path ran.
    let pit = Brush::sphere(c, 7.0, BrushOp::Subtract);
    let changed = edit(&mut w, &mut field, pit, (c, 7.0));
    let total = w.chunks().len();
    println!("the pit re-meshed {} of {total} chunks", changed.len());
    // The chunks around the pit (it spans the corner of eight) and the owners
    // of the seams touching them: a 3 x 2 x 3 block at most.
    assert!(!changed.is_empty() && changed.len() <= 18, "{changed:?}");
    let kept: Vec<(ChunkKey, Arc<NavTile>)> = w
        .chunks()
        .into_iter()
        .filter(|k| !changed.contains(k))
        .map(|k| (k, nav.tile(&k).unwrap().clone()))
        .collect();
    tile(&mut nav, &w, &changed);
    // The rest are the very tiles built before (not rebuilt).
    assert_eq!(kept.len(), total - changed.len());
    for (k, t) in &kept {
        assert!(Arc::ptr_eq(t, nav.tile(k).unwrap()), "{k:?} was rebuilt");
    }
    let after = nav.find_path(s, g).unwrap();
    println!(
        "before {:.2} over {} polygons; after {:.2} over {} polygons, {} points",
        before.length(),
        before.polygons,
        after.length(),
        after.polygons,
        after.points.len()
    );
    assert!(after.length() > before.length() + 2.0);
    // The pit is in the way of the straight line now, not of the path's
    // legs; and a point in the pit's rock has no floor.
    assert_eq!(nav.is_open_between(s, g), Ok(false));
    for w in after.points.windows(2) {
        assert_eq!(
            nav.is_open_between(w[0], w[1]),
            Ok(true),
            "{} to {}",
            w[0],
            w[1]
        );
    }
    assert!(matches!(
        nav.is_open_between(s, c - Vec3::Y * 3.0),
        Err(PathError::OffMesh { which: "goal", .. })
    ));
    // Around the rim: the pit's walls are too steep, so the path keeps clear
    // of the hole (radius 7 at ground level, less the slope of its lip).
    let clear = closest_approach(&after.points, c);
    assert!(clear > 5.0, "the path passes {clear} from the pit's centre");
    // Rebuilding only those gives the navmesh a fresh build gives.
    let fresh = navmesh(&w);
    assert_eq!(fresh.polygon_count(), nav.polygon_count());
    assert_eq!(fresh.link_count(), nav.link_count());
    assert_eq!(fresh.find_path(s, g).unwrap(), after);
}

#[test]
fn a_ramp_raised_across_a_cliff_is_walked_up() {
    let base: Arc<dyn Field> = Arc::new(Terrace);
    let mut field = EditedField::new(base);
    let mut w = world(&field);
    let mut nav = navmesh(&w);
    let s = Vec3::new(-20.0, terrace(-20.0) + 0.5, 4.0);
    let g = Vec3::new(20.0, terrace(20.0) + 0.5, 4.0);
    match nav.find_path(s, g) {
        Err(PathError::Unreachable { searched }) => assert!(searched > 0),
        other => panic!("the cliff is walkable? {other:?}"),
    }
    // A ramp 4 wide from the low ground (x = -10) up to the cliff's top
    // (x = 0), at z in [3, 7].
    let angle = (3.0f32 / 10.0).atan();
    let (sin, cos) = angle.sin_cos();
    let ramp = CsgNode::Transform {
        translate: Vec3::new(-5.0, 4.8, 5.0) - Vec3::new(-sin, cos, 0.0) * 0.5,
        rotate_axis: Vec3::Z,
        rotate_degrees: angle.to_degrees(),
        scale: 1.0,
        child: Box::new(CsgNode::Box {
            half_extents: Vec3::new(6.0, 0.5, 2.0),
            center: Vec3::ZERO,
        }),
    };
    let brush = Brush {
        shape: ramp,
        op: BrushOp::Add,
        material: 0,
    };
    let changed = edit(&mut w, &mut field, brush, (Vec3::new(-5.0, 4.8, 5.0), 7.0));
    tile(&mut nav, &w, &changed);
    let path = nav.find_path(s, g).unwrap();
    println!("over the ramp: {:.2}, {:?}", path.length(), path.points);
    // It crosses the cliff (x = 0) on the ramp.
    let crossing = path
        .points
        .windows(2)
        .find(|p| p[0].x <= 0.0 && p[1].x > 0.0)
        .expect("crosses x = 0");
    let t = -crossing[0].x / (crossing[1].x - crossing[0].x);
    let at = crossing[0].lerp(crossing[1], t);
    assert!((3.0..=7.0).contains(&at.z), "crosses the cliff at {at}");
    assert!((at.y - 6.3).abs() < 0.6, "crosses at height {}", at.y);
    // And goes up it: half way up (x = -5) it is on the ramp, not the cliff's
    // foot.
    let half = path
        .points
        .windows(2)
        .find(|p| p[0].x <= -5.0 && p[1].x > -5.0)
        .expect("passes x = -5");
    assert!(
        (3.0..=7.0).contains(&half[0].z) && (half[0].y - 4.8).abs() < 0.6,
        "{half:?}"
    );
}

#[test]
fn a_goal_in_rock_or_in_the_air_has_no_path() {
    let w = world(&Rolling);
    let nav = navmesh(&w);
    let s = Vec3::new(-20.0, rolling(-20.0, 0.0) + 0.5, 0.0);
    let ground = rolling(10.0, 10.0);
    for (what, goal) in [
        ("rock", Vec3::new(10.0, ground - 6.0, 10.0)),
        ("air", Vec3::new(10.0, ground + 6.0, 10.0)),
    ] {
        match nav.find_path(s, goal) {
            Err(e @ PathError::OffMesh { which: "goal", .. }) => {
                println!("{what}: {e}");
            }
            other => panic!("{what}: {other:?}"),
        }
    }
    assert!(matches!(
        nav.find_path(Vec3::new(f32::NAN, 0.0, 0.0), s),
        Err(PathError::NotFinite { which: "start", .. })
    ));
    // Just above or just below the floor is on it.
    assert!(nav
        .find_path(s, Vec3::new(10.0, ground + 1.0, 10.0))
        .is_ok());
    assert!(nav
        .find_path(s, Vec3::new(10.0, ground - 0.5, 10.0))
        .is_ok());
}

#[test]
fn paths_cross_level_boundaries() {
    // 8 x 2 x 8 chunks of 16 cells; the half nearest x = -64 at level 0, the
    // rest merged into level-1 chunks (32 cells of 2 units... 16 cells each).
    let fine: Vec<ChunkKey> = (0..4)
        .flat_map(|x| {
            (0..2).flat_map(move |y| (0..8).map(move |z| ChunkKey::new(0, IVec3::new(x, y, z))))
        })
        .collect();
    let coarse = (2..4).flat_map(|x| (0..4).map(move |z| ChunkKey::new(1, IVec3::new(x, 0, z))));
    let layout = Layout::new(
        IVec3::ZERO,
        IVec3::new(8, 2, 8),
        fine.into_iter().chain(coarse),
    )
    .unwrap();
    let mut w = World::new(
        Vec3::new(-64.0, -16.0, -64.0),
        1.0,
        16,
        layout,
        0.01,
        Settings::default(),
    )
    .unwrap();
    w.build_all(&Rolling).unwrap();
    let nav = navmesh(&w);
    let across: usize = w
        .chunks()
        .iter()
        .filter(|k| k.level == 0)
        .map(|k| nav.linked_tiles(k).iter().filter(|o| o.level == 1).count())
        .sum();
    println!(
        "{} tiles, {} links, {across} fine-to-coarse tile pairs",
        nav.len(),
        nav.link_count()
    );
    assert!(across >= 4);
    for z in [-50.0f32, -10.0, 20.0, 55.0] {
        let s = Vec3::new(-50.0, rolling(-50.0, z) + 0.5, z);
        let g = Vec3::new(50.0, rolling(50.0, -z) + 0.5, -z);
        let path = nav
            .find_path(s, g)
            .unwrap_or_else(|e| panic!("{s} to {g}: {e}"));
        assert!(path.length() <= s.distance(g) * 1.25);
        for p in &path.points {
            assert!((p.y - rolling(p.x, p.z)).abs() < 0.6, "{p} off the ground");
        }
    }
}

#[test]
fn settings_out_of_range_are_refused_by_name() {
    for (s, name) in [
        (
            NavSettings {
                agent_radius: 0.0,
                ..Default::default()
            },
            "agent_radius",
        ),
        (
            NavSettings {
                agent_height: f32::NAN,
                ..Default::default()
            },
            "agent_height",
        ),
        (
            NavSettings {
                max_slope_degrees: 90.0,
                ..Default::default()
            },
            "max_slope_degrees",
        ),
        (
            NavSettings {
                max_climb: -1.0,
                ..Default::default()
            },
            "max_climb",
        ),
        (
            NavSettings {
                cell_size: 5.0,
                ..Default::default()
            },
            "cell_size",
        ),
    ] {
        let e = NavMesh::new(s).err().expect("refused").to_string();
        assert!(e.contains(name), "{e}");
    }
    // A tile larger than the limit is refused before anything is allocated.
    let s = NavSettings {
        max_tile_columns: 1000,
        ..Default::default()
    };
    let big = IndexedMesh {
        positions: vec![
            Vec3::ZERO,
            Vec3::new(64.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 64.0),
        ],
        indices: vec![0, 2, 1],
        ..Default::default()
    };
    let e = NavTile::build(&big, &s).unwrap_err();
    assert!(e.to_string().contains("1000 allowed"), "{e}");
}
