//! Times each build stage (best of `reps`, on `threads` threads, default 1) and
//! prints the tree's size.
//! The scene `chunk` is the streaming-terrain chunk of the Bevy plugin: 32³ cells
//! of 1 m over a 5-octave fBm height field, built as a world builds a chunk (its
//! grid has a cell of halo all round, sampled and given Hermite data; the tree
//! and the mesh are the 32³ core's). `chunk-box` is the same cells meshed as a
//! box of their own (no halo; the surface leaves through its sides).
//!
//! `cargo run --release -p kdcontour --example stages -- disk_pole 128 [reps] [threads]`
//! `cargo run --release -p kdcontour --example stages -- chunk 32 50`
//! The scene `demo` is a chunk of the terrain demo's field (3-D noise with
//! overhangs and caves, [`scenes::demo_chunk`]), built as a world builds it;
//! `demo:L` is one of chunk level `L` (cells `2^L` wide) through the surface.
//! A fifth argument `0` turns crisp material borders off, as the plugin's
//! terrain demo does: `stages demo 32 50 1 0`. A sixth sets the largest
//! threshold the tree is cut at (`Settings::max_threshold`), as the plugin's
//! horizon volumes set it: `stages demo:3 32 50 1 0 0.2`. A seventh sets the
//! smallest (`Settings::min_threshold`), as the plugin's streaming and horizon
//! volumes set it to the lowest threshold they cut at: `stages chunk 32 30 1 1
//! inf 0.01`.

use kdcontour::pipeline::{self, Cells};
use kdcontour::{hermite, scenes, Field, Grid, IndexedMesh, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "disk_pole".into());
    let res: u32 = args
        .next()
        .map(|s| s.parse().expect("res is a number"))
        .unwrap_or(128);
    let reps: usize = args
        .next()
        .map(|s| s.parse().expect("reps is a number"))
        .unwrap_or(1)
        .max(1);
    let threads: usize = args
        .next()
        .map(|s| s.parse().expect("threads is a number"))
        .unwrap_or(1);
    let (field, grid): (Box<dyn Field>, Grid) = if name == "chunk" || name == "chunk-box" {
        let (field, grid) = scenes::terrain_chunk(res);
        (Box::new(field), grid)
    } else if let Some(level) = name.strip_prefix("demo") {
        // `demo:L`: a chunk of level L (cells 2^L wide), through the surface.
        let level: u32 = level
            .strip_prefix(':')
            .map_or(0, |l| l.parse().expect("a level"));
        let (field, mut grid) = scenes::demo_chunk(res);
        grid.cell_size = (1u32 << level) as f32;
        grid.origin.y *= grid.cell_size;
        (Box::new(field), grid)
    } else {
        let scene = scenes::scene(&name).unwrap_or_else(|e| panic!("{e}"));
        (scene.field, Grid::cube(1.0, res))
    };
    // A world's chunk: the grid grown by a cell of halo, the tree over the core.
    let (grid, cells) = if name == "chunk" || name.starts_with("demo") {
        let halo = Grid {
            cells: grid.cells + 2,
            offset: grid.offset - glam::IVec3::ONE,
            ..grid
        };
        (
            halo,
            Cells::Core {
                res,
                finer_faces: 0,
                coarser_faces: 0,
            },
        )
    } else {
        (grid, Cells::All)
    };
    let material_borders = args.next().is_none_or(|s| s != "0");
    let max_threshold: f32 = args
        .next()
        .map(|s| s.parse().expect("max_threshold is a number"))
        .unwrap_or(f32::INFINITY);
    let min_threshold: f32 = args
        .next()
        .map(|s| s.parse().expect("min_threshold is a number"))
        .unwrap_or(f32::NEG_INFINITY);
    let settings = Settings {
        threads,
        material_borders,
        max_threshold,
        min_threshold,
        ..Default::default()
    };
    let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
    let mut best = [f64::INFINITY; 4];
    let mut mesh = IndexedMesh::default();
    let mut info = String::new();
    settings
        .run(|| {
            for _ in 0..reps {
                let t0 = Instant::now();
                let values = hermite::sample(&*field, &grid, &settings).unwrap();
                let t1 = Instant::now();
                let h = hermite::Hermite::new(&*field, &grid, &values, &settings).unwrap();
                let t2 = Instant::now();
                let tree = pipeline::tree(&h, &*field, &settings, cells);
                let t3 = Instant::now();
                tree.extract(0.01, &mut mesh);
                let t4 = Instant::now();
                for (b, t) in best
                    .iter_mut()
                    .zip([ms(t0, t1), ms(t1, t2), ms(t2, t3), ms(t3, t4)])
                {
                    *b = b.min(t);
                }
                info = format!(
                    "{name} res {res}: {} active cells, {} nodes, {} components, \
                         {:.1} bytes per node, {} triangles at 0.01",
                    h.active_cells(),
                    tree.node_count(),
                    tree.component_count(),
                    tree.retained_bytes() as f64 / tree.node_count().max(1) as f64,
                    mesh.triangle_count()
                );
                // A hash of the mesh: an optimisation that must not change the
                // output keeps it.
                let mut hash = 0xcbf2_9ce4_8422_2325u64;
                let bits = mesh
                    .positions
                    .iter()
                    .chain(&mesh.normals)
                    .flat_map(|v| v.to_array())
                    .map(f32::to_bits)
                    .chain(mesh.indices.iter().copied());
                for b in bits {
                    hash = (hash ^ b as u64).wrapping_mul(0x100_0000_01b3);
                }
                info += &format!(", mesh hash {hash:016x}");
            }
        })
        .unwrap();
    println!("{info}");
    println!(
        "best of {reps} on {threads} thread(s): sample {:.3} ms, hermite {:.3} ms, build {:.3} ms, extract {:.3} ms, \
         total {:.3} ms",
        best[0],
        best[1],
        best[2],
        best[3],
        best.iter().sum::<f64>()
    );
}
