//! Lists the flipped faces of a level world's seams, one line per face, for
//! looking at what the `defects` example counts: the same worlds (8^3 level-0
//! chunks of 16 cells over `[-1, 1]^3`, levels 0 to 2), every chunk at one
//! threshold, and each seam between chunks of two levels (or of one)
//! contoured on its own ([`World::extract_seam`]). A face is flipped where its
//! normal opposes the field's gradient at its centroid, as `validate` counts it.
//! Positions are in level-0 cells from the world's corner.
//!
//! `cargo run --release -p kdcontour --example seam_flips -- SCENE LAYOUT THRESHOLD [between|same]`
//! with LAYOUT one of `random:3`, `random:7`, `camera` (the `defects` example's).

use glam::{IVec3, Vec3};
use kdcontour::world::{Layout, Seam, World};
use kdcontour::{scenes, IndexedMesh, Settings};

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: seam_flips SCENE random:3|random:7|camera THRESHOLD [between|same|inside]";
    let name = args.next().expect(usage);
    let layout_name = args.next().expect(usage);
    let threshold: f32 = args.next().expect(usage).parse().expect(usage);
    let (same_level, inside) = match args.next().as_deref() {
        None | Some("between") => (false, false),
        Some("same") => (true, false),
        Some("inside") => (false, true),
        Some(_) => panic!("{usage}"),
    };
    let scene = scenes::scene(&name).unwrap_or_else(|e| panic!("{e}"));
    let field = &*scene.field;
    let (lo, hi) = (IVec3::ZERO, IVec3::splat(8));
    let layout = match layout_name.as_str() {
        "random:3" => Layout::random(lo, hi, 2, 0.3, 3),
        "random:7" => Layout::random(lo, hi, 2, 0.5, 7),
        "camera" => Layout::around(lo, hi, 2, Vec3::splat(7.6), 0.9),
        _ => panic!("{usage}"),
    }
    .expect("a valid layout");
    let cell = 2.0 / 128.0;
    let corner = Vec3::splat(-1.0);
    let mut w = World::new(corner, cell, 16, layout, threshold, Settings::default())
        .expect("a valid world");
    w.build_all(field).unwrap_or_else(|e| panic!("{e}"));
    let in_cells = |v: Vec3| {
        ((v - corner) / cell)
            .to_array()
            .map(|x| (x * 100.0).round() / 100.0)
    };
    let (mut seams, mut flipped) = (0, 0);
    let mut one = IndexedMesh::default();
    // Prints the flipped faces of `one` under `heading` (once, before the
    // first); returns how many there are.
    let list = |one: &IndexedMesh, heading: &dyn Fn() -> String| {
        let mut count = 0;
        for t in one.indices.chunks(3) {
            let p = [0, 1, 2].map(|i| one.positions[t[i] as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let g = field.gradient((p[0] + p[1] + p[2]) / 3.0);
            if n.dot(g) >= 0.0 {
                continue;
            }
            if count == 0 {
                println!("{}: {} faces", heading(), one.triangle_count());
            }
            count += 1;
            println!(
                "  {:?} normal {:?} gradient {:?}",
                p.map(in_cells),
                n.normalize_or_zero(),
                g.normalize_or_zero()
            );
        }
        count
    };
    if inside {
        for k in w.chunks() {
            w.extract_interior(&k, &mut one);
            flipped += list(&one, &|| format!("chunk {k:?}"));
        }
        println!("{name} {layout_name} at {threshold}: {flipped} flipped faces inside chunks");
        return;
    }
    for k in w.chunks() {
        for s in w.owned_seams(&k) {
            let Seam::Face { low, high, axis } = s else {
                continue;
            };
            if (low.level == high.level) != same_level {
                continue;
            }
            seams += 1;
            w.extract_seam(&s, &mut one);
            flipped += list(&one, &|| {
                format!("seam {low:?} | {high:?} across axis {axis}")
            });
        }
    }
    let kind = if same_level {
        "within one level"
    } else {
        "between levels"
    };
    println!(
        "{name} {layout_name} at {threshold}: {flipped} flipped faces on {seams} seams {kind}"
    );
}
