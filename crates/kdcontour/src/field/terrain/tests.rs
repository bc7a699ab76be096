use super::*;
use crate::field::{gradient_step, FnField, GRADIENT_STEP};
use crate::grid::Grid;
use crate::world::layout::Rng;
use noise::NoiseFn;

/// The value at `q` computed in f64 throughout: a reference for gradients.
fn value64(d: &Density, q: DVec3) -> f64 {
    let q = q.to_array();
    let solid = q[1] - d.params.base as f64 - d.params.amplitude as f64 * d.noise.get(q);
    match d.cave_noise(q) {
        Some((c, n1, n2)) => {
            let tunnel = (c.radius as f64 - n1.hypot(n2)) / c.frequency as f64;
            solid.max(tunnel - c.fade(-solid))
        }
        None => solid,
    }
}

/// `params` with its caves at every depth (no depth band).
fn caves_everywhere(params: &DensityParams) -> DensityParams {
    DensityParams {
        caves: params
            .caves
            .clone()
            .map(|c| CaveParams { depth: None, ..c }),
        ..params.clone()
    }
}

/// A height field of rolling hills, 10 units high, 67 across.
fn hills() -> Heightfield {
    Heightfield::new(HeightfieldParams {
        seed: 3,
        base: 0.0,
        amplitude: 10.0,
        frequency: 0.015,
        octaves: 5,
    })
}

/// A point of the box `[lo, hi]` drawn from `rng`.
fn point_in(rng: &mut Rng, lo: Vec3, hi: Vec3) -> Vec3 {
    let t = Vec3::new(rng.unit() as f32, rng.unit() as f32, rng.unit() as f32);
    (lo + (hi - lo) * t).clamp(lo, hi)
}

#[test]
fn the_default_gradient_resolves_far_coordinates() {
    // A sphere of radius 10 centerd far out: its exact normal is known.
    for far in [4096.0f32, 65536.0] {
        let c = Vec3::new(far, -far, 0.5 * far);
        let sphere = FnField(move |p: Vec3| (p - c).length() - 10.0);
        assert!(gradient_step(c) > GRADIENT_STEP);
        for dir in [Vec3::new(0.6, 0.8, 0.0), Vec3::new(-0.48, 0.6, 0.64)] {
            let p = c + dir * 10.0;
            let exact = (p.as_dvec3() - c.as_dvec3()).normalize();
            let g = sphere.gradient(p).as_dvec3();
            assert!(
                (g - exact).length() < 0.02,
                "at {p}: {g} against the exact {exact}"
            );
        }
    }
    // Near the origin the step stays the fixed one.
    assert_eq!(gradient_step(Vec3::new(3.0, -1.0, 0.5)), GRADIENT_STEP);
}

#[test]
fn terrain_gradients_match_f64_differences_far_out() {
    let density = Density::new(DensityParams {
        caves: None,
        ..DensityParams::demo(3)
    });
    let height = Heightfield::new(HeightfieldParams {
        seed: 3,
        base: 0.0,
        amplitude: 22.0,
        frequency: 0.011,
        octaves: 5,
    });
    // References from the noise crate in f64, with their own step.
    let d_noise = fbm(3, 0.011, 5);
    // (Both gradients are analytic.)
    let d_ref = |q: DVec3| q.y - 22.0 * d_noise.get(q.to_array());
    let h_ref = |q: DVec3| q.y - 22.0 * d_noise.get([q.x, q.z]);
    let h = 0.01;
    let diff = |f: &dyn Fn(DVec3) -> f64, q: DVec3| {
        DVec3::from_array([0, 1, 2].map(|a| {
            let e = DVec3::AXES[a] * h;
            (f(q + e) - f(q - e)) / (2.0 * h)
        }))
    };
    for far in [4096.0f32, 65536.0] {
        for p in [Vec3::new(far, 3.0, 17.5), Vec3::new(-9.25, -4.0, far)] {
            let q = p.as_dvec3();
            for (name, g, r) in [
                ("density", density.gradient(p), diff(&d_ref, q)),
                ("height field", height.gradient(p), diff(&h_ref, q)),
            ] {
                let g = g.as_dvec3();
                assert!(
                    (g - r).length() < 1e-3 * r.length(),
                    "{name} at {p}: {g} against {r}"
                );
                // The horizontal slope is resolved, not lost to f32 spacing.
                assert!(r.x.abs() + r.z.abs() > 1e-3, "{name} at {p}: flat {r}");
            }
        }
    }
}

#[test]
fn fbm_stays_within_its_proven_bound() {
    let mut rng = Rng(11);
    let mut largest = 0.0f64;
    for octaves in 1..=8 {
        for seed in [0, 7, 1234] {
            let n = fbm(seed, 0.37, octaves);
            let p = Perlin::new(seed);
            for _ in 0..4000 {
                let q = [0, 1, 2].map(|_| (rng.unit() - 0.5) * 200.0);
                for v in [n.get(q), n.get([q[0], q[2]]), p.get(q)] {
                    assert!(v.abs() <= FBM_MAX, "{v} at {q:?}");
                    largest = largest.max(v.abs());
                }
            }
        }
    }
    // The points explore the range: the bound is not vacuous.
    assert!(largest > 0.6, "largest |fbm| seen {largest}");
}

#[test]
fn terrain_bounds_hold_over_random_boxes() {
    let banded = DensityParams::demo(5);
    let everywhere = caves_everywhere(&banded);
    let bare = DensityParams {
        caves: None,
        ..banded.clone()
    };
    let fields: Vec<Box<dyn Field>> = vec![
        Box::new(Density::new(banded)),
        Box::new(Density::new(everywhere)),
        Box::new(Density::new(bare)),
        Box::new(Heightfield::new(HeightfieldParams {
            seed: 5,
            base: 2.0,
            amplitude: 22.0,
            frequency: 0.011,
            octaves: 5,
        })),
    ];
    let mut rng = Rng(3);
    for f in &fields {
        let (mut lows, mut highs) = (0, 0);
        for _ in 0..300 {
            let size = Vec3::splat(2f32.powi((rng.unit() * 8.0) as i32));
            let lo = point_in(
                &mut rng,
                Vec3::new(-300.0, -90.0, -300.0),
                Vec3::splat(300.0),
            );
            let (a, b) = f.bound(lo, lo + size).unwrap();
            assert!(a <= b);
            for _ in 0..40 {
                let v = f.value(point_in(&mut rng, lo, lo + size));
                assert!(a <= v && v <= b, "{v} outside [{a}, {b}] in {lo}+{size}");
                lows += (v - a < 0.5 * (b - a)) as usize;
                highs += (b - v < 0.5 * (b - a)) as usize;
            }
        }
        assert!(lows > 0 && highs > 0);
    }
}

#[test]
fn the_depth_band_closes_caves_and_the_bound_proves_it() {
    let demo = DensityParams::demo(9);
    let c = demo.caves.clone().unwrap();
    let w = (c.radius / c.frequency) as f64;
    // The fade: 0 above the depth, continuous with its slope, never decreasing.
    let depth = DEMO_CAVE_DEPTH as f64;
    assert_eq!(c.fade(depth), 0.0);
    assert_eq!(c.fade(-50.0), 0.0);
    for x in [depth, depth + w] {
        let e = 1e-7;
        assert!((c.fade(x + e) - c.fade(x - e)).abs() < 1e-6);
        let slope = |t: f64| (c.fade(t + e) - c.fade(t)) / e;
        assert!((slope(x + 2.0 * e) - slope(x - 3.0 * e)).abs() < 1e-3);
    }
    assert!((0..200).all(|i| c.fade(i as f64 * 0.3) <= c.fade(i as f64 * 0.3 + 0.3)));
    let no_band = CaveParams { depth: None, ..c };
    assert_eq!(no_band.fade(1e6), 0.0);

    // Above the band the banded field is the unbanded one, bit for bit; well
    // below it, it is solid.
    let banded = Density::new(demo.clone());
    let everywhere = Density::new(caves_everywhere(&demo));
    let closed = 22.0 + DEMO_CAVE_DEPTH + 1.5 * w as f32;
    let mut rng = Rng(5);
    let (mut same, mut tunnels_cut) = (0, 0);
    for _ in 0..20000 {
        let p = point_in(
            &mut rng,
            Vec3::new(-500.0, -120.0, -500.0),
            Vec3::splat(500.0),
        );
        let (b, e) = (banded.value(p), everywhere.value(p));
        // At least `22 - y` below the surface: above the band from y = -2 on.
        if p.y > 22.0 - DEMO_CAVE_DEPTH + 0.01 {
            assert_eq!(b.to_bits(), e.to_bits(), "at {p}");
            same += 1;
        }
        assert!(b <= e, "the band only fills caves: {b} > {e} at {p}");
        if p.y < -closed {
            assert!(b < 0.0, "air at {p} below the band");
            tunnels_cut += (e >= 0.0) as usize;
        }
    }
    assert!(same > 0);
    assert!(tunnels_cut > 0, "no cave below the band to fill");

    // The bound proves chunks below the band solid and above the hills air.
    let below = banded.bound(
        Vec3::new(0.0, -300.0, 0.0),
        Vec3::new(64.0, -closed - 1.0, 64.0),
    );
    assert!(below.unwrap().1 < 0.0, "{below:?}");
    let above = banded.bound(Vec3::new(0.0, 23.0, 0.0), Vec3::new(64.0, 300.0, 64.0));
    assert!(above.unwrap().0 > 0.0, "{above:?}");
    // Caves everywhere: nothing below is provably solid.
    let deep = everywhere.bound(Vec3::new(0.0, -300.0, 0.0), Vec3::new(64.0, -200.0, 64.0));
    assert!(deep.unwrap().1 > 0.0);
}

#[test]
fn cave_depth_is_optional_in_scene_files() {
    let old = r#"{"seed":1,"amplitude":2,"frequency":0.5,"caves":{"frequency":1,"radius":0.1}}"#;
    let p: DensityParams = serde_json::from_str(old).unwrap();
    assert_eq!(p.caves.as_ref().unwrap().depth, None);
    // Without a depth nothing is written, so old files round-trip unchanged.
    assert!(!serde_json::to_string(&p).unwrap().contains("depth"));
    let banded =
        r#"{"amplitude":2,"frequency":0.5,"caves":{"frequency":1,"radius":0.1,"depth":8}}"#;
    let p: DensityParams = serde_json::from_str(banded).unwrap();
    assert_eq!(p.caves.unwrap().depth, Some(8.0));
    let bad = r#"{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":1,"radius":0.1,"depth":-1}}"#;
    let err = crate::field::csg::CsgNode::from_json(bad).unwrap_err();
    assert!(err.to_string().contains("caves.depth"), "{err}");
}

#[test]
fn skipping_the_cave_noise_changes_no_value() {
    // The full formula, cave noises always evaluated.
    let full = |d: &Density, p: Vec3| {
        let q = [p.x as f64, p.y as f64, p.z as f64];
        let solid = p.y - d.params.base - d.params.amplitude * d.noise.get(q) as f32;
        let (c, n1, n2) = d.cave_noise(q).unwrap();
        let (n1, n2) = (n1 as f32, n2 as f32);
        let tunnel = (c.radius - (n1 * n1 + n2 * n2).sqrt()) / c.frequency;
        solid.max(tunnel - c.fade(-solid as f64) as f32)
    };
    let banded = DensityParams::demo(4);
    let everywhere = caves_everywhere(&banded);
    let mut rng = Rng(8);
    for params in [banded, everywhere] {
        let d = Density::new(params);
        let mut tunnels = 0;
        for _ in 0..20000 {
            let p = point_in(
                &mut rng,
                Vec3::new(-400.0, -100.0, -400.0),
                Vec3::splat(400.0),
            );
            let v = d.value(p);
            assert_eq!(v.to_bits(), full(&d, p).to_bits(), "at {p}");
            tunnels += (v > p.y + 22.0) as usize;
        }
        assert!(tunnels > 0, "no point in a tunnel");
    }
}

#[test]
fn analytic_density_gradients_match_f64_differences() {
    let mut rng = Rng(21);
    let h = 1e-4;
    for params in [DensityParams::demo(2), DensityParams::demo(31)] {
        let d = Density::new(params);
        let (mut checked, mut in_tunnels) = (0, 0);
        for _ in 0..3000 {
            let p = point_in(
                &mut rng,
                Vec3::new(-300.0, -60.0, -300.0),
                Vec3::new(300.0, 25.0, 300.0),
            );
            let q = p.as_dvec3();
            // Away from the seam where the two terms swap (the gradient jumps).
            let c = d.params.caves.as_ref().unwrap();
            let q3 = q.to_array();
            let solid = q.y - d.params.amplitude as f64 * d.noise.get(q3);
            let (_, n1, n2) = d.cave_noise(q3).unwrap();
            let tunnel = (c.radius as f64 - n1.hypot(n2)) / c.frequency as f64 - c.fade(-solid);
            if (solid - tunnel).abs() < 0.05 {
                continue;
            }
            let r = DVec3::from_array([0, 1, 2].map(|a| {
                let e = DVec3::AXES[a] * h;
                (value64(&d, q + e) - value64(&d, q - e)) / (2.0 * h)
            }));
            let g = d.gradient(p).as_dvec3();
            assert!(
                (g - r).length() < 1e-3 * r.length().max(1.0),
                "at {p}: {g} against {r}"
            );
            checked += 1;
            in_tunnels += (tunnel > solid) as usize;
        }
        assert!(
            checked > 2500 && in_tunnels > 10,
            "{checked} points, {in_tunnels} in tunnels"
        );
    }
    // The fBm alone, value and gradient, against the noise crate.
    let (n, ng) = (fbm(5, 0.3, 6), perlin::Fbm3::new(5, 0.3, 6));
    for _ in 0..2000 {
        let q = DVec3::from_array([0, 1, 2].map(|_| (rng.unit() - 0.5) * 100.0));
        let (v, g) = ng.get_grad(q);
        assert!((v - n.get(q.to_array())).abs() < 1e-12);
        let r = DVec3::from_array([0, 1, 2].map(|a| {
            let e = DVec3::AXES[a] * h;
            (n.get((q + e).to_array()) - n.get((q - e).to_array())) / (2.0 * h)
        }));
        assert!(
            (g - r).length() < 1e-4 * r.length().max(1.0),
            "at {q}: {g} against {r}"
        );
    }
}

#[test]
fn the_fast_noise_is_the_noise_crates_bit_for_bit() {
    let mut rng = Rng(13);
    for (seed, frequency, octaves) in [(0, 0.011, 5), (7, 1.8, 4), (123_456, 0.37, 8)] {
        let (slow, fast) = (
            fbm(seed, frequency, octaves),
            perlin::Fbm3::new(seed, frequency, octaves),
        );
        let (p_slow, p_fast) = (Perlin::new(seed), perlin::Perlin3::new(seed));
        for i in 0..20000 {
            // Random points, and lattice points (integers, negative ones too).
            let mut q = [0, 1, 2].map(|_| (rng.unit() - 0.5) * 2000.0);
            if i % 4 == 0 {
                q = q.map(|x| (x * 0.01).round());
            }
            assert_eq!(slow.get(q).to_bits(), fast.get(q).to_bits(), "fbm at {q:?}");
            assert_eq!(
                p_slow.get(q).to_bits(),
                p_fast.get(q).to_bits(),
                "perlin at {q:?}"
            );
        }
    }
}

#[test]
fn the_fast_2d_noise_is_the_noise_crates_bit_for_bit_and_differentiates_it() {
    let mut rng = Rng(17);
    for (seed, frequency, octaves) in [(3, 0.015, 5), (7, 1.8, 4), (123_456, 0.37, 8)] {
        let (slow, fast) = (
            fbm(seed, frequency, octaves),
            perlin::Fbm2::new(seed, frequency, octaves),
        );
        let (p_slow, p_fast) = (Perlin::new(seed), perlin::Perlin2::new(seed));
        // A step of 1e-4 of the finest octave's lattice.
        let h = 1e-4 / (frequency as f64 * 2f64.powi(octaves as i32 - 1));
        for i in 0..20000 {
            // Random points, and lattice points (integers, negative ones too).
            let mut q = [0, 1].map(|_| (rng.unit() - 0.5) * 2000.0);
            if i % 4 == 0 {
                q = q.map(|x| (x * 0.01).round());
            }
            let (v, g) = fast.get_grad(q);
            assert_eq!(slow.get(q).to_bits(), fast.get(q).to_bits(), "fbm at {q:?}");
            assert_eq!(slow.get(q).to_bits(), v.to_bits(), "fbm value at {q:?}");
            let (pv, _) = p_fast.get_grad(q);
            assert_eq!(
                p_slow.get(q).to_bits(),
                p_fast.get(q).to_bits(),
                "perlin at {q:?}"
            );
            assert_eq!(
                p_slow.get(q).to_bits(),
                pv.to_bits(),
                "perlin value at {q:?}"
            );
            // The gradient against f64 central differences of the crate's fBm
            // (away from lattice lines, where the noise is only C2 and the
            // differences straddle nothing).
            if i % 4 != 0 {
                let r = [0, 1].map(|a| {
                    let (mut q0, mut q1) = (q, q);
                    q0[a] -= h;
                    q1[a] += h;
                    (slow.get(q1) - slow.get(q0)) / (2.0 * h)
                });
                let (err, len) = (
                    ((g[0] - r[0]).powi(2) + (g[1] - r[1]).powi(2)).sqrt(),
                    (r[0] * r[0] + r[1] * r[1]).sqrt(),
                );
                assert!(
                    err < 1e-5 * len.max(frequency as f64),
                    "gradient at {q:?}: {g:?} against {r:?}"
                );
            }
        }
    }
}

#[test]
fn the_row_noise_is_the_point_noise_bit_for_bit() {
    let mut rng = Rng(44);
    for seed in [0, 7, 99_999] {
        let p = perlin::Perlin3::new(seed);
        let fbm = perlin::Fbm3::new(seed, 0.011, 5);
        let mut scratch = Vec::new();
        for row in 0..400 {
            let (y, z) = ((rng.unit() - 0.5) * 600.0, (rng.unit() - 0.5) * 600.0);
            // Steps from a hundredth of a lattice cell (many points per cell) to
            // several cells; every fourth row on integers (lattice corners, and
            // 0, whose lattice cell is -1).
            let step = [0.01, 0.3, 1.0, 7.5][row % 4];
            let x0 = (rng.unit() - 0.5) * 300.0;
            let mut xs: Vec<f64> = (0..40).map(|i| x0 + i as f64 * step).collect();
            let (y, z) = if row % 4 == 2 {
                xs = xs.iter().map(|x| x.round()).collect();
                (y.round(), z.round())
            } else {
                (y, z)
            };
            let mut out = vec![0.0; xs.len()];
            p.get_row(&xs, y, z, &mut out);
            for (x, v) in xs.iter().zip(&out) {
                assert_eq!(v.to_bits(), p.get([*x, y, z]).to_bits(), "at {x} {y} {z}");
            }
            fbm.get_row(&xs, y, z, &mut out, &mut scratch);
            for (x, v) in xs.iter().zip(&out) {
                assert_eq!(v.to_bits(), fbm.get([*x, y, z]).to_bits(), "at {x} {y} {z}");
            }
        }
    }
}

#[test]
fn batched_sampling_is_the_value_bit_for_bit() {
    let mut rng = Rng(5);
    let demo = DensityParams::demo(7);
    let no_caves = DensityParams {
        caves: None,
        ..DensityParams::demo(12)
    };
    let mut sampled = 0usize;
    let mut tunnels = 0usize;
    let mut skipped = 0usize;
    for params in [demo.clone(), caves_everywhere(&demo), no_caves] {
        let d = Density::new(params);
        for k in 0..24 {
            // Chunk grids of the level world: cells of 2^level, lattice offsets
            // around the surface, a fractional origin now and then.
            let cell_size = (1u32 << (k % 8)) as f32;
            let origin = if k % 3 == 0 {
                Vec3::new(0.25, -512.0, -0.75)
            } else {
                Vec3::new(0.0, -512.0, 0.0)
            };
            let cells = glam::UVec3::new(17 + k % 5, 9, 3 + k % 2);
            let span = |r: f64| ((r - 0.5) * 2000.0 / cell_size as f64) as i32;
            let offset = glam::IVec3::new(
                span(rng.unit()),
                ((512.0 - 20.0) / cell_size) as i32 - (k % 4) as i32,
                span(rng.unit()),
            );
            let grid = Grid {
                origin,
                cell_size,
                cells,
                offset,
            };
            let c = grid.corners();
            let mut out = vec![0f32; grid.corner_count() as usize];
            d.sample_grid(&grid, 0..c.z, &mut out);
            let mut i = 0;
            for z in 0..c.z {
                for y in 0..c.y {
                    for x in 0..c.x {
                        let p = grid.corner_pos(glam::UVec3::new(x, y, z));
                        let v = d.value(p);
                        assert_eq!(out[i].to_bits(), v.to_bits(), "at {p}");
                        tunnels += (v > p.y + 22.0) as usize;
                        i += 1;
                    }
                }
            }
            sampled += i;
            // The build's sampling: the same values, or FAR where the value is
            // provably more than `far` (only in the sky).
            for far in [0.5, 2.0 * cell_size] {
                let mut coarse = vec![0f32; out.len()];
                d.sample_grid_far(&grid, 0..c.z, &mut coarse, far);
                for (k, (&a, &b)) in coarse.iter().zip(&out).enumerate() {
                    if a == crate::grid::FAR {
                        assert!(b > far, "corner {k}: {b} given as far from {far}");
                        skipped += 1;
                    } else {
                        assert_eq!(a.to_bits(), b.to_bits(), "corner {k}");
                    }
                }
            }
            // A z sub-range fills only its slabs.
            let mut part = vec![0f32; (c.x * c.y) as usize];
            d.sample_grid(&grid, 1..2, &mut part);
            assert_eq!(part, out[(c.x * c.y) as usize..2 * (c.x * c.y) as usize]);
        }
    }
    assert!(
        sampled > 20_000 && tunnels > 0 && skipped > sampled / 10,
        "{sampled} corners, {tunnels} in tunnels, {skipped} skipped"
    );
    // Out of the noise's reach: NaN, as `value` gives.
    let d = Density::new(DensityParams::demo(1));
    let grid = Grid {
        origin: Vec3::new(1e17, 0.0, 0.0),
        cell_size: 1.0,
        cells: glam::UVec3::splat(2),
        offset: glam::IVec3::ZERO,
    };
    let mut out = vec![0f32; 27];
    d.sample_grid(&grid, 0..3, &mut out);
    assert!(out.iter().all(|v| v.is_nan()));
}

#[test]
fn materials_from_a_known_gradient_are_the_fields_materials() {
    use crate::edit::{Brush, BrushOp, EditedField};
    use crate::field::Field;
    let density: std::sync::Arc<dyn Field> =
        std::sync::Arc::new(Density::new(DensityParams::demo(7)));
    let height = hills();
    // An edited field: unedited, and with a brush that paints a region.
    let edited = EditedField::new(density.clone());
    let brush = Brush::sphere(Vec3::new(5.0, 0.0, 5.0), 6.0, BrushOp::Add).with_material(2);
    let dug = edited.with_edit(brush).unwrap();
    let mut rng = Rng(5);
    let (mut caves, mut brushed) = (0, 0);
    for _ in 0..4000 {
        let p = point_in(
            &mut rng,
            Vec3::new(-40.0, -30.0, -40.0),
            Vec3::new(40.0, 25.0, 40.0),
        );
        let fields: [(&str, &dyn Field); 4] = [
            ("density", &*density),
            ("height field", &height),
            ("unedited", &edited),
            ("edited", &dug),
        ];
        for (name, f) in fields {
            let (a, b) = (f.material(p), f.material_with_gradient(p, f.gradient(p)));
            assert_eq!(a.ids, b.ids, "{name} at {p}");
            for (x, y) in a.weights.iter().zip(&b.weights) {
                assert!((x - y).abs() < 1e-4, "{name} at {p}: {a:?} against {b:?}");
            }
        }
        let d = Density::new(DensityParams::demo(7));
        let (g, cave) = d.gradient_and_cave(p);
        assert_eq!(
            g.to_array().map(f32::to_bits),
            d.gradient(p).to_array().map(f32::to_bits)
        );
        assert!((cave - d.cave_weight(p)).abs() < 1e-4, "cave weight at {p}");
        caves += (cave > 0.0) as usize;
        brushed += (dug.material(p) != edited.material(p)) as usize;
    }
    assert!(
        caves > 10 && brushed > 10,
        "{caves} points in cave walls, {brushed} brushed"
    );
}

#[test]
fn a_height_fields_value_with_gradient_or_material_is_its_own_bit_for_bit() {
    use crate::field::Field;
    let height = hills();
    let mut rng = Rng(11);
    let far = NOISE_REACH as f32;
    let mut points: Vec<Vec3> = (0..4000)
        .map(|_| {
            point_in(
                &mut rng,
                Vec3::new(-400.0, -30.0, -400.0),
                Vec3::new(400.0, 25.0, 400.0),
            )
        })
        .collect();
    // Out of the noise's reach (NaN values) and at its edge.
    points.extend([Vec3::new(far, 0.0, 0.0), Vec3::new(0.0, 1.0, -far * 1e3)]);
    let mut kinds = std::collections::HashSet::new();
    for p in points {
        let (v, g) = height.value_gradient(p);
        assert_eq!(v.to_bits(), height.value(p).to_bits(), "value at {p}");
        let bits3 = |g: Vec3| g.to_array().map(f32::to_bits);
        assert_eq!(bits3(g), bits3(height.gradient(p)), "gradient at {p}");
        let (v, m) = height.value_and_material(p);
        assert_eq!(v.to_bits(), height.value(p).to_bits(), "value at {p}");
        let want = height.material(p);
        assert_eq!(m.ids, want.ids, "material ids at {p}");
        let bits = |w: [f32; 4]| w.map(f32::to_bits);
        assert_eq!(bits(m.weights), bits(want.weights), "weights at {p}");
        kinds.insert(m.dominant());
    }
    // The points cover more than one material.
    assert!(kinds.len() > 1, "materials seen: {kinds:?}");
}

/// A height field asked for its value unless it is below a bar gives its value
/// bit for bit (with the gradient or material asked for), or `None` only where
/// the value is below the bar; most bars a few units away stop within the
/// first octaves, where the amplitude alone does not decide.
#[test]
fn a_height_field_read_unless_below_a_bar_is_its_own_or_below_it() {
    use crate::field::Field;
    let mut rng = Rng(5);
    let far = NOISE_REACH as f32;
    for height in [
        hills(),
        Heightfield::new(HeightfieldParams {
            seed: 8,
            base: -3.0,
            amplitude: 0.0,
            frequency: 0.1,
            octaves: 3,
        }),
    ] {
        let amp = height.params.amplitude;
        let (mut stopped, mut stopped_early) = (0, 0);
        let mut points: Vec<Vec3> = (0..3000)
            .map(|_| {
                point_in(
                    &mut rng,
                    Vec3::new(-300.0, -30.0, -300.0),
                    Vec3::new(300.0, 30.0, 300.0),
                )
            })
            .collect();
        points.extend([Vec3::new(far, 0.0, 0.0), Vec3::new(0.0, 1.0, -far * 1e3)]);
        for p in points {
            let value = height.value(p);
            let offsets = [-8.0, -2.0, -0.5, -1e-6, 0.0, 1e-6, 0.5, 2.0, 8.0];
            let mut bars: Vec<f32> = offsets.iter().map(|o| value + o).collect();
            bars.extend([f32::INFINITY, f32::NEG_INFINITY, f32::NAN, p.y + amp * 0.5]);
            for v in bars {
                let got = height.value_unless_below(p, v);
                let with_gradient = height.value_gradient_unless_below(p, v);
                let with_material = height.value_and_material_unless_below(p, v);
                assert_eq!(got.is_none(), with_gradient.is_none(), "{p}, bar {v}");
                assert_eq!(got.is_none(), with_material.is_none(), "{p}, bar {v}");
                let Some(x) = got else {
                    assert!(value < v, "skipped at {p}: value {value} is not below {v}");
                    stopped += 1;
                    // Not decided by the amplitude alone.
                    stopped_early += usize::from(p.y - height.params.base + amp >= v);
                    continue;
                };
                assert_eq!(x.to_bits(), value.to_bits(), "value at {p}");
                let (x, g) = with_gradient.unwrap();
                let (v0, g0) = height.value_gradient(p);
                assert_eq!(x.to_bits(), v0.to_bits(), "value at {p}");
                assert_eq!(
                    g.to_array().map(f32::to_bits),
                    g0.to_array().map(f32::to_bits),
                    "gradient at {p}"
                );
                let (x, m) = with_material.unwrap();
                let (v0, m0) = height.value_and_material(p);
                assert_eq!(x.to_bits(), v0.to_bits(), "value at {p}");
                assert_eq!(m.ids, m0.ids, "material at {p}");
                assert_eq!(m.weights.map(f32::to_bits), m0.weights.map(f32::to_bits));
            }
        }
        if amp > 0.0 {
            assert!(stopped > 5000, "stopped {stopped}");
            assert!(
                stopped_early > 1000,
                "stopped within the amplitude {stopped_early}"
            );
        } else {
            assert_eq!(stopped, 0, "a flat field is read whole");
        }
    }
}
