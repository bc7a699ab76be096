//! Counts field evaluations while sampling and finding crossings, to see what the
//! Lipschitz block skipping saves.
//!
//! `cargo run --release -p kdcontour --example sample_counts -- disk_pole 128`

use glam::Vec3;
use kdcontour::{hermite, scenes, Field, Grid, Settings};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counted<'a> {
    inner: &'a dyn Field,
    values: AtomicUsize,
    gradients: AtomicUsize,
}

impl Field for Counted<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.values.fetch_add(1, Ordering::Relaxed);
        self.inner.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.gradients.fetch_add(1, Ordering::Relaxed);
        self.inner.gradient(p)
    }
    fn lipschitz(&self) -> Option<f32> {
        self.inner.lipschitz()
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "disk_pole".into());
    let res: u32 = args
        .next()
        .map(|s| s.parse().expect("res is a number"))
        .unwrap_or(128);
    let scene = scenes::scene(&name).unwrap_or_else(|e| panic!("{e}"));
    let grid = Grid::cube(1.0, res);
    let f = Counted {
        inner: &*scene.field,
        values: AtomicUsize::new(0),
        gradients: AtomicUsize::new(0),
    };
    let settings = Settings::default();
    let values = hermite::sample(&f, &grid, &settings).unwrap();
    let sampled = f.values.load(Ordering::Relaxed);
    let h = hermite::Hermite::new(&f, &grid, &values, &settings).unwrap();
    println!(
        "{name} res {res}: {} corners, {sampled} evaluated while sampling ({:.1}%), \
         {} crossings, {} value and {} gradient evaluations in all",
        grid.corner_count(),
        100.0 * sampled as f64 / grid.corner_count() as f64,
        h.crossing_count(),
        f.values.load(Ordering::Relaxed),
        f.gradients.load(Ordering::Relaxed)
    );
}
