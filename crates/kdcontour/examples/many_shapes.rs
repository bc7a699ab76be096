//! Times a scene of many shapes with and without materials: a union (or, with
//! `smooth`, a smooth union) of `N` small spheres, each in one of five
//! materials, built on a 64³ grid on one thread and cut at 0.01. Materials
//! are read at every vertex the tree can have (painting), so this is what a
//! CSG editor's scene of thousands of shapes pays for them.
//!
//! `cargo run --release -p kdcontour --example many_shapes -- 2000 [smooth]`

use kdcontour::field::csg::CsgNode;
use kdcontour::{Grid, IndexedMesh, KdTree, Settings};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args
        .next()
        .map(|s| s.parse().expect("N is a number"))
        .unwrap_or(2000);
    let smooth = args.next().is_some_and(|s| s == "smooth");
    let parts: Vec<String> = (0..n)
        .map(|i| {
            let t = i as f32 * 0.37;
            format!(
                r#"{{"type":"material","id":{},"child":{{"type":"sphere","radius":0.06,"center":[{},{},{}]}}}}"#,
                i % 5,
                t.sin() * 0.8,
                (1.3 * t).cos() * 0.8,
                (0.7 * t).sin() * 0.8
            )
        })
        .collect();
    let json = if smooth {
        format!(
            r#"{{"type":"smooth_union","radius":0.03,"children":[{}]}}"#,
            parts.join(",")
        )
    } else {
        format!(r#"{{"type":"union","children":[{}]}}"#, parts.join(","))
    };
    let node = CsgNode::from_json(&json).unwrap_or_else(|e| panic!("{e}"));
    let field = node.compile().unwrap_or_else(|e| panic!("{e}"));
    for materials in [false, true] {
        let settings = Settings {
            threads: 1,
            materials,
            ..Settings::default()
        };
        let t = Instant::now();
        let tree = KdTree::build(&field, &Grid::cube(1.0, 64), &settings)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut mesh = IndexedMesh::default();
        tree.extract(0.01, &mut mesh);
        println!(
            "{n} spheres, {} union, materials {}: {:.1} ms, {} triangles",
            if smooth { "smooth" } else { "plain" },
            if materials { "on" } else { "off" },
            t.elapsed().as_secs_f64() * 1e3,
            mesh.triangle_count()
        );
    }
}
