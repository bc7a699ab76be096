//! Times each build stage of one scene on one thread and prints the tree's size.
//!
//! `cargo run --release -p kdcontour --example stages -- disk_pole 128`

use kdcontour::{hermite, kdtree, scenes, Grid, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "disk_pole".into());
    let res: u32 = args
        .next()
        .map(|s| s.parse().expect("res is a number"))
        .unwrap_or(128);
    let scene = scenes::scene(&name).unwrap_or_else(|e| panic!("{e}"));
    let grid = Grid::cube(1.0, res);
    let settings = Settings {
        threads: 1,
        ..Default::default()
    };
    settings
        .run(|| {
            let t0 = Instant::now();
            let values = hermite::sample(&*scene.field, &grid, &settings).unwrap();
            let t1 = Instant::now();
            let h = hermite::Hermite::new(&*scene.field, &grid, &values, &settings).unwrap();
            let t2 = Instant::now();
            let tree = kdtree::build(&h);
            let t3 = Instant::now();
            let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
            println!(
                "{name} res {res}: sample {:.1} ms, hermite {:.1} ms, build {:.1} ms; \
                 {} active cells, {} nodes, {} components, {:.1} bytes per node",
                ms(t0, t1),
                ms(t1, t2),
                ms(t2, t3),
                h.cells.len(),
                tree.nodes.len(),
                tree.comps.len(),
                tree.retained_bytes() as f64 / tree.nodes.len().max(1) as f64
            );
        })
        .unwrap();
}
