//! Pipeline stages side by side: sampling + Hermite data, tree build, contouring,
//! and re-extraction at a new threshold, on one and two threads.
//!
//! `cargo bench -p kdcontour --bench pipeline`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use kdcontour::pipeline::{self, Cells};
use kdcontour::{hermite, scenes, Grid, IndexedMesh, KdTree, Settings};
use std::hint::black_box;
use std::time::Duration;

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

fn stages(c: &mut Criterion, scene: &str, res: u32, threshold: f32) {
    let s = scenes::scene(scene).unwrap();
    let field = &*s.field;
    let grid = Grid::cube(1.0, res);
    let settings = Settings::default();
    let mut g = c.benchmark_group(format!("{scene}_{res}"));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    for threads in [1, 2] {
        let p = pool(threads);
        g.bench_function(BenchmarkId::new("sample", threads), |b| {
            b.iter(|| p.install(|| black_box(pipeline::hermite(field, &grid, &settings).unwrap())))
        });
        let h = p.install(|| pipeline::hermite(field, &grid, &settings).unwrap());
        g.bench_function(BenchmarkId::new("build", threads), |b| {
            b.iter(|| p.install(|| black_box(pipeline::tree(&h, field, &settings, Cells::All))))
        });
        let tree = pipeline::tree(&h, field, &settings, Cells::All);
        let mut mesh = IndexedMesh::default();
        g.bench_function(BenchmarkId::new("contour", threads), |b| {
            b.iter(|| tree.extract(black_box(threshold), &mut mesh))
        });
        // A threshold change: re-walk the retained tree at another threshold.
        let mut flip = false;
        g.bench_function(BenchmarkId::new("reextract", threads), |b| {
            b.iter(|| {
                flip = !flip;
                tree.extract(if flip { threshold * 10.0 } else { threshold }, &mut mesh)
            })
        });
        g.bench_function(BenchmarkId::new("total", threads), |b| {
            b.iter(|| {
                p.install(|| {
                    let t = KdTree::build(field, &grid, &settings).unwrap();
                    let mut m = IndexedMesh::default();
                    t.extract(threshold, &mut m);
                    black_box(m.triangle_count())
                })
            })
        });
    }
    g.finish();
}

/// A streaming terrain chunk: 32³ cells of 1 m over an fBm height field (batched
/// column sampling, no closing box), as the Bevy terrain meshes it.
fn terrain_chunk(c: &mut Criterion) {
    let (field, grid) = kdcontour::scenes::terrain_chunk(32);
    let settings = Settings::default();
    let mut g = c.benchmark_group("terrain_chunk_32");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    let p = pool(1);
    let tree = p.install(|| KdTree::build(&field, &grid, &settings).unwrap());
    let mut mesh = IndexedMesh::default();
    tree.extract(0.01, &mut mesh);
    println!(
        "terrain chunk: {} active cells, {} triangles at 0.01, {} bytes retained",
        tree.stats().active_cells,
        mesh.triangle_count(),
        tree.retained_bytes()
    );
    g.bench_function("sample/1", |b| {
        b.iter(|| {
            p.install(|| black_box(hermite::Hermite::from_field(&field, &grid, &settings).unwrap()))
        })
    });
    g.bench_function("total/1", |b| {
        b.iter(|| {
            p.install(|| {
                let t = KdTree::build(&field, &grid, &settings).unwrap();
                t.extract(0.01, &mut mesh);
                black_box(mesh.triangle_count())
            })
        })
    });
    g.bench_function("reextract/1", |b| {
        let mut flip = false;
        b.iter(|| {
            flip = !flip;
            tree.extract(if flip { 0.1 } else { 0.01 }, &mut mesh)
        })
    });
    g.finish();
}

/// Edit-to-mesh latency: a brush lands in a 32³ terrain chunk; rebuild the chunks
/// it reaches, then re-extract every chunk whose mesh or seams touch them.
fn edit_latency(c: &mut Criterion) {
    use kdcontour::edit::{Brush, BrushOp, EditedField};
    use kdcontour::field::terrain::{Heightfield, HeightfieldParams};
    use kdcontour::world::ChunkKey;
    use kdcontour::World;
    use std::sync::Arc;
    let base: Arc<dyn kdcontour::Field> = Arc::new(Heightfield::new(HeightfieldParams {
        seed: 3,
        base: 48.0,
        amplitude: 10.0,
        frequency: 0.015,
        octaves: 5,
    }));
    let settings = Settings {
        threads: 1,
        ..Default::default()
    };
    let mut world = World::bounded(
        glam::Vec3::ZERO,
        1.0,
        32,
        glam::UVec3::splat(3),
        0.01,
        settings,
    )
    .unwrap();
    world.build_all(&*base).unwrap();
    let center = glam::Vec3::new(48.0, 48.0, 48.0);
    let field = EditedField::new(base)
        .with_edit(Brush::sphere(center, 4.0, BrushOp::Subtract))
        .unwrap();
    let (lo_r, r) = field.last_reach().unwrap();
    let touched: Vec<ChunkKey> = world
        .chunks()
        .into_iter()
        .filter(|c| {
            let (lo, hi) = world.chunk_bounds(c);
            lo_r.clamp(lo - glam::Vec3::ONE, hi + glam::Vec3::ONE)
                .distance(lo_r)
                <= r
        })
        .collect();
    println!("edit latency: the brush reaches {} chunk(s)", touched.len());
    let mut g = c.benchmark_group("edit_latency_32");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    let mut mesh = IndexedMesh::default();
    g.bench_function("rebuild+reextract/1", |b| {
        b.iter(|| {
            for t in &touched {
                world.build_chunk(t, &field).unwrap();
            }
            let mut owners: Vec<ChunkKey> = touched
                .iter()
                .flat_map(|t| world.seam_owners_touching(t))
                .collect();
            owners.sort_by_key(|c| c.order());
            owners.dedup();
            for o in owners {
                world.snapshot(&o).unwrap().extract(&mut mesh);
            }
            black_box(mesh.triangle_count())
        })
    });
    g.finish();
}

fn pipeline(c: &mut Criterion) {
    stages(c, "disk_pole", 128, 0.01);
    stages(c, "terrain", 32, 0.01);
    stages(c, "sphere", 64, 0.01);
}

criterion_group!(benches, terrain_chunk, edit_latency, pipeline);
criterion_main!(benches);
