//! Main-thread time of one frame with 1,000 chunks while the LOD camera moves: the
//! plugin's systems (LOD, scheduling, polling, uploads), meshing tasks aside.
//!
//! `cargo bench -p bevy_kdcontour --bench frame`

use bevy::prelude::*;
use bevy_kdcontour::headless::{run_until_settled, HeadlessPlugins};
use bevy_kdcontour::prelude::*;
use criterion::{criterion_group, criterion_main, Criterion};
use std::sync::Arc;
use std::time::Duration;

fn frame(c: &mut Criterion) {
    let mut app = App::new();
    app.add_plugins((
        HeadlessPlugins,
        KdContourPlugins {
            settings: KdContourSettings {
                lod: LodSettings {
                    near: 0.2,
                    ..Default::default()
                },
                ..Default::default()
            },
        },
    ));
    // 10 x 10 x 10 chunks of 8^3 cells around a sphere.
    let field: Arc<dyn kdcontour::Field> = Arc::new(kdcontour::field::FnField(|p: Vec3| {
        (p - Vec3::splat(1.0)).length() - 0.8
    }));
    let volume = app
        .world_mut()
        .spawn(KdVolume::new(field, UVec3::splat(10), 8, 2.0 / 80.0))
        .id();
    let cam = app
        .world_mut()
        .spawn((LodCamera, Transform::from_xyz(1.0, 1.0, -1.0)))
        .id();
    assert!(
        run_until_settled(&mut app, volume, 20_000, Duration::ZERO),
        "the volume did not settle"
    );
    let mut t = 0.0f32;
    let mut g = c.benchmark_group("frame_1000_chunks");
    g.sample_size(50).measurement_time(Duration::from_secs(5));
    g.bench_function("camera_moving", |b| {
        b.iter(|| {
            t += 0.05;
            app.world_mut()
                .get_mut::<Transform>(cam)
                .unwrap()
                .translation = Vec3::new(1.0 + 1.5 * t.cos(), 1.0, 1.0 + 1.5 * t.sin());
            app.update();
        })
    });
    g.bench_function("camera_still", |b| b.iter(|| app.update()));
    g.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
