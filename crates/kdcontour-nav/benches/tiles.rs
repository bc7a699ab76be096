//! A navmesh tile's cost beside its chunk's extraction, side by side in one
//! run: the tile is built in the chunk's meshing task, after the extraction,
//! so the ratio is what navmesh adds to a re-mesh. Then path queries over
//! the linked tiles, corner to corner.
//!
//! `cargo bench -p kdcontour-nav --bench tiles`

use criterion::{criterion_group, criterion_main, Criterion};
use glam::{UVec3, Vec3};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::world::{ChunkKey, World};
use kdcontour::{IndexedMesh, Settings};
use kdcontour_nav::{NavMesh, NavSettings, NavTile};
use std::hint::black_box;
use std::sync::Arc;

fn tiles(c: &mut Criterion) {
    // The demo's terrain: 3 x 2 x 3 chunks of 32 cells at the demo's
    // threshold, the chunks around one with the most floor.
    let field = Density::new(DensityParams::demo(7));
    let mut w = World::bounded(
        Vec3::new(-48.0, -32.0, -48.0),
        1.0,
        32,
        UVec3::new(3, 2, 3),
        0.01,
        Settings::default(),
    )
    .unwrap();
    w.build_all(&field).unwrap();
    let meshes: Vec<(ChunkKey, IndexedMesh)> = w
        .chunks()
        .into_iter()
        .map(|k| {
            let mut m = IndexedMesh::default();
            w.snapshot(&k).unwrap().extract(&mut m);
            (k, m)
        })
        .collect();
    let triangles: usize = meshes.iter().map(|(_, m)| m.triangle_count()).sum();
    let settings = NavSettings::default();
    let built: Vec<NavTile> = meshes
        .iter()
        .map(|(_, m)| NavTile::build(m, &settings).unwrap())
        .collect();
    let polys: usize = built.iter().map(|t| t.polys.len()).sum();
    let dropped: usize = built.iter().map(|t| t.dropped_outlines).sum();
    println!(
        "{} chunks, {triangles} triangles, {polys} navmesh polygons, {dropped} outlines dropped",
        meshes.len()
    );
    let mut g = c.benchmark_group("chunk_32_terrain_all_18");
    g.sample_size(10);
    g.bench_function("extract", |b| {
        let mut m = IndexedMesh::default();
        b.iter(|| {
            for (k, _) in &meshes {
                w.snapshot(k).unwrap().extract(&mut m);
                black_box(m.triangle_count());
            }
        })
    });
    g.bench_function("navmesh_tile", |b| {
        b.iter(|| {
            for (_, m) in &meshes {
                black_box(NavTile::build(m, &settings).unwrap().polys.len());
            }
        })
    });
    // Linking is the main thread's part: every tile put in, linked to the
    // ones already there.
    let tiles: Vec<(ChunkKey, Arc<NavTile>)> = meshes
        .iter()
        .zip(built)
        .map(|((k, _), t)| (*k, Arc::new(t)))
        .collect();
    g.bench_function("link_all", |b| {
        b.iter(|| {
            let mut nav = NavMesh::new(settings.clone()).unwrap();
            for (k, t) in &tiles {
                nav.insert(*k, t.clone());
            }
            black_box(nav.link_count())
        })
    });
    // Paths between polygons far apart: the centres of the polygons first
    // and last by x + z, the second and the second last, and so on.
    let mut nav = NavMesh::new(settings.clone()).unwrap();
    for (k, t) in &tiles {
        nav.insert(*k, t.clone());
    }
    let mut centres: Vec<Vec3> = tiles
        .iter()
        .flat_map(|(_, t)| t.polys.iter().map(|p| p.center))
        .collect();
    centres.sort_by(|a, b| (a.x + a.z).total_cmp(&(b.x + b.z)));
    let pairs: Vec<(Vec3, Vec3)> = (0..16)
        .map(|i| (centres[i * 4], centres[centres.len() - 1 - i * 4]))
        .collect();
    let found: Vec<f32> = pairs
        .iter()
        .filter_map(|(s, g)| nav.find_path(*s, *g).ok())
        .map(|p| p.length())
        .collect();
    println!(
        "{} of {} paths found, {:.1} units long on average",
        found.len(),
        pairs.len(),
        found.iter().sum::<f32>() / found.len().max(1) as f32
    );
    g.bench_function("paths_16", |b| {
        b.iter(|| {
            for (s, g) in &pairs {
                black_box(nav.find_path(*s, *g).map(|p| p.points.len()).ok());
            }
        })
    });
    g.finish();
}

criterion_group!(benches, tiles);
criterion_main!(benches);
