//! Chunks whose field bound proves one sign skip sampling and build exactly the
//! tree sampling builds: the demo terrain's sky and deep rock, at every level.

use glam::{IVec3, Vec3};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::grid::Grid;
use kdcontour::hermite;
use kdcontour::world::{ChunkKey, Layout, World};
use kdcontour::KdTree;
use kdcontour::{Field, Settings};

/// The field without its bound: every chunk is sampled.
struct Unbounded<'a>(&'a dyn Field);

impl Field for Unbounded<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.0.gradient(p)
    }
    fn sample_grid(&self, grid: &Grid, z: std::ops::Range<u32>, out: &mut [f32]) {
        self.0.sample_grid(grid, z, out)
    }
    fn material(&self, p: Vec3) -> kdcontour::MaterialBlend {
        self.0.material(p)
    }
    fn has_materials(&self) -> bool {
        self.0.has_materials()
    }
}

fn same_tree(a: &KdTree, b: &KdTree) -> bool {
    a == b
}

/// Cells of 4 units, chunks of 8 cells: a region 512 units tall with the demo's
/// mean surface in its middle, levels 0 to 3 around a camera above the hills.
#[test]
fn one_signed_level_chunks_build_as_sampled() {
    let field = Density::new(DensityParams::demo(7));
    let (lo, hi) = (IVec3::new(-8, 0, -8), IVec3::new(8, 16, 8));
    let settings = Settings {
        threads: 1,
        ..Default::default()
    };
    let origin = Vec3::new(0.0, -256.0, 0.0);
    let mut world = World::new(
        origin,
        4.0,
        8,
        Layout::uniform(lo, hi, 3).unwrap(),
        0.02,
        settings,
    )
    .unwrap();
    let camera = world.to_chunk_units(Vec3::new(5.0, 40.0, 5.0));
    world
        .set_layout(Layout::around(lo, hi, 3, camera, 1.0).unwrap())
        .unwrap();
    let (mut skipped, mut surface) = ([0usize; 4], 0);
    for k in world.chunks() {
        let build = world.chunk_build(&k);
        let fast = build.run(&field).unwrap();
        let slow = build.run(&Unbounded(&field)).unwrap();
        assert!(same_tree(&fast, &slow), "chunk {k:?} differs");
        let grid = &build.grid;
        let one = hermite::one_sign(&field, grid, 3, &build.settings).unwrap();
        if one.is_some() {
            skipped[k.level as usize] += 1;
            assert!(!slow.has_surface(), "skipped chunk {k:?} has a surface");
        }
        if slow.has_surface() {
            surface += 1;
            assert!(one.is_none(), "chunk {k:?} with a surface was skipped");
        }
    }
    // Sky and rock chunks are skipped at levels 0 to 2 (a level-3 chunk is half
    // the region tall: all of them reach the surface band); the surface is built.
    assert!(
        skipped[..3].iter().all(|&n| n > 0),
        "skipped per level {skipped:?}"
    );
    assert!(surface > 0);
    // The welded world is the same, too.
    world.build_all(&field).unwrap();
    let fast = world.extract_all();
    world.build_all(&Unbounded(&field)).unwrap();
    let slow = world.extract_all();
    assert!(!fast.indices.is_empty());
    assert_eq!(fast.positions, slow.positions);
    assert_eq!(fast.indices, slow.indices);
}

#[test]
fn one_signed_chunks_of_a_single_level_world_build_as_sampled() {
    let field = Density::new(DensityParams::demo(3));
    let settings = Settings {
        threads: 1,
        ..Default::default()
    };
    let mut world = World::unbounded(Vec3::ZERO, 2.0, 8, 0.02, settings).unwrap();
    let mut skipped = 0;
    for y in -8..8 {
        let c = IVec3::new(1, y, -2);
        world.add_chunk(c).unwrap();
        let build = world.chunk_build(&ChunkKey::new(0, c));
        let fast = build.run(&field).unwrap();
        let slow = build.run(&Unbounded(&field)).unwrap();
        assert!(same_tree(&fast, &slow), "chunk {c} differs");
        let one = hermite::one_sign(&field, &build.grid, 0, &build.settings).unwrap();
        skipped += one.is_some() as usize;
        if slow.has_surface() {
            assert!(one.is_none(), "chunk {c} with a surface was skipped");
        }
    }
    assert!(skipped >= 8, "{skipped} of 16 chunks skipped");
}
