use kdcontour::*;
use std::time::Instant;
fn main() {
    let name = std::env::args().nth(1).unwrap();
    let res: u32 = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(128);
    let s = scenes::scene(&name).unwrap();
    let grid = Grid::cube(1.0, res);
    let set = Settings {
        threads: 1,
        ..Default::default()
    };
    set.run(|| {
        let t0 = Instant::now();
        let v = hermite::sample(&*s.field, &grid, &set).unwrap();
        let t1 = Instant::now();
        let h = hermite::Hermite::new(&*s.field, &grid, &v, &set).unwrap();
        let t2 = Instant::now();
        let mut tree = None;
        for _ in 0..5 {
            tree = Some(kdtree::build(&h));
        }
        let t3 = Instant::now();
        let tree = tree.unwrap();
        println!(
            "sample {:.1} ms, hermite {:.1} ms, build {:.1} ms; nodes {} comps {} cells {}",
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3,
            (t3 - t2).as_secs_f64() * 1e3 / 5.0,
            tree.nodes.len(),
            tree.comps.len(),
            h.cells.len()
        );
    })
    .unwrap();
}
