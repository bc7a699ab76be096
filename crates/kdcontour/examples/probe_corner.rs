use glam::{Quat, Vec3};
use kdcontour::*;
fn main() {
    let rot = Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 17f32.to_radians());
    let scene = scenes::scene("box").unwrap();
    let grid = Grid::cube(1.0, 32);
    let set = Settings {
        root_iterations: 32,
        ..Default::default()
    };
    let v = hermite::sample(&*scene.field, &grid, &set).unwrap();
    let h = hermite::Hermite::new(&*scene.field, &grid, &v, &set).unwrap();
    let corner = rot * (Vec3::new(1.0, -1.0, -1.0) * Vec3::new(0.61, 0.47, 0.39));
    let local = grid.to_local(corner);
    println!("corner local {local}");
    let cell = local.floor();
    for c in &h.cells {
        let cc = Vec3::new(c.coord[0] as f32, c.coord[1] as f32, c.coord[2] as f32);
        if (cc - cell).abs().max_element() <= 0.0 {
            let t = cell::CellTables::get().cell(c.config, c.mask);
            println!(
                "cell {:?} config {:08b} mask {} comps {}",
                c.coord, c.config, c.mask, t.count
            );
            for k in 0..t.count as usize {
                let q = h.patch_qef[c.patch_base as usize + k];
                let (x, e) = q.solve(cc, cc + Vec3::ONE);
                println!(
                    "  patch {k}: count {} vertex {x} err {e} mass {}",
                    q.count,
                    q.mass_point()
                );
                let (vals, vecs) = qef::sym_eigen(q.ata);
                println!("  eig {vals:?} {vecs:?}");
            }
        }
    }
    println!("value at corner {}", scene.field.value(corner));
    // crossings on the 12 edges of the cell
    for e in 0..12 {
        let (a, b) = cell::edge_corners(e);
        let off = |i: usize| {
            let o = cell::corner_offset(i);
            Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32)
        };
        let pa = grid.to_world(cell + off(a));
        let pb = grid.to_world(cell + off(b));
        let (va, vb) = (scene.field.value(pa), scene.field.value(pb));
        if (va >= 0.0) != (vb >= 0.0) {
            // bisection
            let (mut lo, mut hi) = (0.0f32, 1.0f32);
            for _ in 0..40 {
                let m = 0.5 * (lo + hi);
                let vm = scene.field.value(pa.lerp(pb, m));
                if (vm >= 0.0) == (va >= 0.0) {
                    lo = m
                } else {
                    hi = m
                }
            }
            let p = pa.lerp(pb, lo);
            println!(
                "edge {e}: t {lo} normal {} local normal {}",
                scene.field.gradient(p),
                rot.inverse() * scene.field.gradient(p)
            );
        }
    }
}
#[allow(dead_code)]
fn unused() {}
