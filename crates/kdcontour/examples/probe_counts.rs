use kdcontour::*;
use std::sync::atomic::{AtomicUsize, Ordering};
struct Count<'a>(&'a dyn Field, AtomicUsize, AtomicUsize);
impl Field for Count<'_> {
    fn value(&self, p: glam::Vec3) -> f32 {
        self.1.fetch_add(1, Ordering::Relaxed);
        self.0.value(p)
    }
    fn gradient(&self, p: glam::Vec3) -> glam::Vec3 {
        self.2.fetch_add(1, Ordering::Relaxed);
        self.0.gradient(p)
    }
    fn lipschitz(&self) -> Option<f32> {
        self.0.lipschitz()
    }
}
fn main() {
    let name = std::env::args().nth(1).unwrap();
    let s = scenes::scene(&name).unwrap();
    let grid = Grid::cube(1.0, 128);
    let c = Count(&*s.field, AtomicUsize::new(0), AtomicUsize::new(0));
    let v = hermite::sample(&c, &grid, &Settings::default()).unwrap();
    let after_sample = c.1.load(Ordering::Relaxed);
    let h = hermite::Hermite::new(&c, &grid, &v, &Settings::default()).unwrap();
    println!("{name}: corners {} sample evals {} ({:.1}%), crossings {}, total value evals {}, gradients {}",
        grid.corner_count(), after_sample, 100.0 * after_sample as f64 / grid.corner_count() as f64,
        h.crossings, c.1.load(Ordering::Relaxed), c.2.load(Ordering::Relaxed));
}
