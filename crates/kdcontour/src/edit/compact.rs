//! Compacting an edit log: dropping the brushes a later brush provably erases, so
//! a long sculpting session saves and replays in less.
//!
//! ## The rule
//! A hard brush (`Add` or `Subtract`) `A` is dropped when a later brush `B` of the
//! same operation *covers* it (`B`'s distance is at most `A`'s everywhere, so `B`'s
//! shape contains `A`'s) and every brush between them is hard too.
//!
//! Why the field is unchanged: at a point, a hard brush is `v -> min(v, s)` (add)
//! or `v -> max(v, -s)` (dig), so the brushes between `A` and `B` compose to a
//! clamp `v -> min(max(v, l), u)`. Take `A` and `B` adding (digging is the same
//! with signs flipped), and `s_B <= s_A`. Where `s_A >= v`, `A` changes nothing.
//! Elsewhere both `min(v, s_A) = s_A` and `v` are at least `s_B`, and for any
//! `x >= s_B`, `min(clamp(x), s_B) = min(u, s_B)` whatever `x` is: `B` erases what
//! `A` did. A smooth brush in between is not a clamp (it blends), so it keeps `A`.
//!
//! Which shapes count as covering: an identical shape (exactly, bit for bit, so
//! `s_B = s_A`), and a sphere inside another sphere: `|c_A - c_B| <= r_B - r_A`
//! gives `s_B <= s_A` by the triangle inequality. In `f32` the two distances are
//! rounded, so the sphere test keeps a margin of `1e-4` times the radii: enough for
//! the values to agree bit for bit within about 200 radii of the brushes, which is
//! everywhere a mesh reads values near the surface (farther out, in open air or
//! deep rock, the values may differ in the last bits but never in sign). Other
//! shapes are not compared and are kept.
//!
//! ## Materials and paints
//! A hard brush leaves its material where it wins (its value is strictly the
//! new one). `B` covering `A` erases `A`'s material too when both have the same
//! material: where `B` wins it sets that material either way, and where it does
//! not, the value after the brushes between is the same with or without `A`
//! (as above), so the last brush that won is too (up to exact ties of values).
//! So a cover must also have the same material.
//!
//! A paint changes no value and sets its material inside its shape whatever
//! was there: it is transparent to the rule above (it sets the same material
//! with or without `A`), and a paint is itself dropped when a later paint's
//! shape covers it, whatever lies between (the later paint overrides it
//! everywhere it painted). A paint's reach is its shape.

use super::{Brush, BrushOp};
use crate::field::csg::CsgNode;

/// `log` without the brushes a later brush erases (see the module docs): replaying
/// the result gives the same field near the surface and the same signs
/// everywhere. Keeps the order of what it keeps.
pub fn compact(log: &[Brush]) -> Vec<Brush> {
    // Walking back from the newest brush: the hard brushes seen since the last
    // smooth one, each a possible cover of the older ones.
    let mut covers: Vec<&Brush> = Vec::new();
    // Every paint seen so far (later than the brush looked at).
    let mut paints: Vec<&Brush> = Vec::new();
    let mut keep = vec![true; log.len()];
    for (i, brush) in log.iter().enumerate().rev() {
        if brush.op == BrushOp::Paint {
            if paints.iter().any(|b| covered(brush, b)) {
                keep[i] = false;
            } else {
                paints.push(brush);
            }
            continue;
        }
        if !is_hard(brush.op) {
            covers.clear();
            continue;
        }
        if covers
            .iter()
            .any(|b| b.op == brush.op && b.material == brush.material && covered(brush, b))
        {
            keep[i] = false;
        } else {
            covers.push(brush);
        }
    }
    log.iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(b, _)| b.clone())
        .collect()
}

fn is_hard(op: BrushOp) -> bool {
    matches!(op, BrushOp::Add | BrushOp::Subtract)
}

/// Whether `later`'s shape provably contains `earlier`'s (see the module docs).
fn covered(earlier: &Brush, later: &Brush) -> bool {
    if earlier.shape == later.shape {
        // Identical, so the two distances are too (spheres included: the
        // margin below is for different spheres).
        return true;
    }
    match (&earlier.shape, &later.shape) {
        (
            CsgNode::Sphere {
                radius: ra,
                center: ca,
            },
            CsgNode::Sphere {
                radius: rb,
                center: cb,
            },
        ) => {
            let (ra, rb) = (*ra as f64, *rb as f64);
            let gap = ca.as_dvec3().distance(cb.as_dvec3());
            gap <= rb - ra - 1e-4 * (ra + rb)
        }
        (a, b) => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::EditedField;
    use crate::field::terrain::{Density, DensityParams};
    use crate::field::Field;
    use glam::Vec3;
    use std::sync::Arc;

    fn sphere(x: f32, y: f32, z: f32, r: f32, op: BrushOp) -> Brush {
        Brush::sphere(Vec3::new(x, y, z), r, op)
    }

    #[test]
    fn a_brush_inside_a_later_one_of_the_same_kind_is_dropped() {
        let log = vec![
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Subtract),
            sphere(5.0, 0.0, 0.0, 1.0, BrushOp::Add),
            sphere(0.5, 0.0, 0.0, 2.0, BrushOp::Subtract),
        ];
        let c = compact(&log);
        assert_eq!(c, log[1..].to_vec());
        // The same sphere dug twice: the first is dropped.
        let log = vec![
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Subtract),
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Subtract),
        ];
        assert_eq!(compact(&log), log[1..].to_vec());
        // Touching the outside (no margin left) is not covered.
        let log = vec![
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Add),
            sphere(1.0, 0.0, 0.0, 2.0, BrushOp::Add),
        ];
        assert_eq!(compact(&log), log);
        // An earlier dig is not erased by a later add, nor an add by a dig.
        let log = vec![
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Subtract),
            sphere(0.0, 0.0, 0.0, 2.0, BrushOp::Add),
            sphere(0.0, 0.0, 0.0, 3.0, BrushOp::Subtract),
        ];
        assert_eq!(compact(&log), log[1..].to_vec());
    }

    #[test]
    fn a_smooth_brush_between_keeps_the_older_one() {
        let log = vec![
            sphere(0.0, 0.0, 0.0, 1.0, BrushOp::Add),
            sphere(3.0, 0.0, 0.0, 1.0, BrushOp::SmoothAdd { radius: 0.5 }),
            sphere(0.0, 0.0, 0.0, 2.0, BrushOp::Add),
        ];
        assert_eq!(compact(&log), log);
        // Smooth brushes are never dropped, even when repeated.
        let s = sphere(0.0, 0.0, 0.0, 1.0, BrushOp::SmoothSubtract { radius: 0.5 });
        assert_eq!(compact(&[s.clone(), s.clone()]).len(), 2);
        // Repeated hard brushes of any shape collapse to the last.
        let b = Brush {
            shape: CsgNode::Box {
                half_extents: Vec3::ONE,
                center: Vec3::ZERO,
            },
            op: BrushOp::Add,
            material: 0,
        };
        assert_eq!(compact(&[b.clone(), b.clone(), b.clone()]), vec![b]);
    }

    /// A sculpting session on the demo terrain: strokes of overlapping brushes
    /// (each a little larger than the last dab around it), both kinds, some
    /// smooth. The compacted log gives bitwise the same values at points near
    /// the surface and the brushes, and the same signs far out.
    #[test]
    fn a_compacted_session_replays_to_the_same_field() {
        let base: Arc<dyn Field> = Arc::new(Density::new(DensityParams::demo(3)));
        let mut rng = crate::world::layout::Rng(5);
        let mut log = Vec::new();
        for stroke in 0..60 {
            let op = match stroke % 5 {
                0 | 1 => BrushOp::Subtract,
                2 | 3 => BrushOp::Add,
                _ => BrushOp::SmoothAdd { radius: 1.5 },
            };
            let at = Vec3::new(
                rng.unit() as f32 * 80.0 - 40.0,
                rng.unit() as f32 * 20.0 - 10.0,
                rng.unit() as f32 * 80.0 - 40.0,
            );
            // Dabs that grow over a point: each covers the previous one.
            for dab in 0..6 {
                let r = 2.0 + dab as f32 * 0.7;
                let jitter = Vec3::new(rng.unit() as f32, 0.0, rng.unit() as f32) * 0.3;
                log.push(Brush::sphere(at + jitter, r, op));
            }
        }
        let compacted = compact(&log);
        assert!(
            compacted.len() * 2 < log.len(),
            "{} of {} kept",
            compacted.len(),
            log.len()
        );
        let full = EditedField::replay(base.clone(), &log).unwrap();
        let short = EditedField::replay(base, &compacted).unwrap();
        let mut near = 0;
        for _ in 0..20_000 {
            let p = Vec3::new(
                rng.unit() as f32 * 100.0 - 50.0,
                rng.unit() as f32 * 60.0 - 30.0,
                rng.unit() as f32 * 100.0 - 50.0,
            );
            let (a, b) = (full.value(p), short.value(p));
            assert_eq!(a < 0.0, b < 0.0, "sign at {p}");
            assert_eq!(a.to_bits(), b.to_bits(), "value at {p}: {a} vs {b}");
            near += (a.abs() < 2.0) as usize;
        }
        assert!(near > 200, "only {near} points near the surface");
    }
}

#[cfg(test)]
mod material_tests {
    use super::*;
    use crate::edit::EditedField;
    use crate::field::terrain::{Density, DensityParams};
    use crate::field::Field;
    use glam::Vec3;
    use std::sync::Arc;

    /// A session with materials and paints: the compacted log gives the same
    /// values and the same materials at points near the surface.
    #[test]
    fn a_compacted_session_with_paints_keeps_its_materials() {
        let base: Arc<dyn Field> = Arc::new(Density::new(DensityParams::demo(3)));
        let mut rng = crate::world::layout::Rng(9);
        let mut log = Vec::new();
        for stroke in 0..40 {
            let (op, material) = match stroke % 4 {
                0 => (BrushOp::Subtract, 2),
                1 => (BrushOp::Add, (stroke % 3) as u8 + 4),
                2 => (BrushOp::Paint, (stroke % 5) as u8),
                _ => (BrushOp::Add, 7),
            };
            let at = Vec3::new(
                rng.unit() as f32 * 60.0 - 30.0,
                rng.unit() as f32 * 16.0 - 8.0,
                rng.unit() as f32 * 60.0 - 30.0,
            );
            for dab in 0..5 {
                let r = 2.0 + dab as f32 * 0.7;
                let jitter = Vec3::new(rng.unit() as f32, 0.0, rng.unit() as f32) * 0.3;
                log.push(Brush::sphere(at + jitter, r, op).with_material(material));
            }
        }
        let compacted = compact(&log);
        let dropped_paints = log.iter().filter(|b| b.op == BrushOp::Paint).count()
            - compacted.iter().filter(|b| b.op == BrushOp::Paint).count();
        assert!(dropped_paints > 0 && compacted.len() * 2 < log.len());
        let full = EditedField::replay(base.clone(), &log).unwrap();
        let short = EditedField::replay(base, &compacted).unwrap();
        let mut near = 0;
        for _ in 0..20_000 {
            let p = Vec3::new(
                rng.unit() as f32 * 80.0 - 40.0,
                rng.unit() as f32 * 40.0 - 20.0,
                rng.unit() as f32 * 80.0 - 40.0,
            );
            let (a, b) = (full.value(p), short.value(p));
            assert_eq!(a.to_bits(), b.to_bits(), "value at {p}");
            if a.abs() < 2.0 {
                near += 1;
                assert_eq!(full.material(p), short.material(p), "material at {p}");
            }
        }
        assert!(near > 200, "only {near} points near the surface");
        // A later cover of another material keeps the older brush.
        let two = vec![
            Brush::sphere(Vec3::ZERO, 1.0, BrushOp::Add).with_material(1),
            Brush::sphere(Vec3::ZERO, 2.0, BrushOp::Add).with_material(2),
        ];
        assert_eq!(compact(&two), two);
    }
}
