//! Batched grid sampling: a height field under unions, intersections and
//! differences is evaluated once per (x, z) column instead of once per corner, with
//! the very same values as [`Node::value`].

use super::compile::{Node, Op};
use super::eval::{nan_max, nan_min};
use crate::field::Field;
use crate::grid::Grid;

impl Node {
    /// Whether sampling a grid pays off batched: the subtree holds a height field
    /// reached through unions, intersections and differences only, so the height
    /// field is evaluated once per (x, z) column instead of once per corner.
    pub(super) fn batches(&self) -> bool {
        match &self.op {
            Op::Heightfield(_) => true,
            Op::Union(ch) | Op::Intersection(ch) => ch.iter().any(Node::batches),
            Op::Difference(a, b) => a.batches() || b.batches(),
            Op::Material(_, child) => child.batches(),
            _ => false,
        }
    }

    /// [`Field::sample_grid`] of this subtree: the same values as [`Node::value`]
    /// at every corner, bit for bit (min and max are exact, and a height field's
    /// column sampling computes each corner as `value` does).
    pub(super) fn sample(&self, grid: &Grid, z_range: std::ops::Range<u32>, out: &mut [f32]) {
        let combine =
            |out: &mut [f32], ch: &mut dyn Iterator<Item = &Node>, f: fn(f32, f32) -> f32| {
                let mut tmp = vec![0f32; out.len()];
                for c in ch {
                    c.sample(grid, z_range.clone(), &mut tmp);
                    for (o, t) in out.iter_mut().zip(&tmp) {
                        *o = f(*o, *t);
                    }
                }
            };
        match &self.op {
            Op::Heightfield(h) => h.sample_grid(grid, z_range, out),
            Op::Union(ch) if self.batches() => {
                out.fill(f32::INFINITY);
                combine(out, &mut ch.iter(), nan_min);
            }
            Op::Intersection(ch) if self.batches() => {
                out.fill(f32::NEG_INFINITY);
                combine(out, &mut ch.iter(), nan_max);
            }
            Op::Difference(a, b) if self.batches() => {
                a.sample(grid, z_range.clone(), out);
                combine(out, &mut std::iter::once(&**b), |a, b| nan_max(a, -b));
            }
            Op::Material(_, child) if self.batches() => child.sample(grid, z_range, out),
            _ => crate::field::sample_each(grid, z_range, out, |p| self.value(p)),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::field::csg::CsgNode;
    use crate::field::Field;
    use glam::Vec3;

    #[test]
    fn batched_grid_sampling_matches_value_bit_for_bit() {
        // Height fields under unions, intersections and differences are sampled by
        // column; everything else (a transformed height field, smooth operators,
        // primitives) per corner. Either way the samples are `value`'s.
        let hf = r#"{"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}"#;
        let scenes = [
            format!(
                r#"{{"type":"intersection","children":[{{"type":"box","half_extents":[0.85,0.85,0.85]}},{hf}]}}"#
            ),
            format!(
                r#"{{"type":"difference","a":{{"type":"union","children":[{hf},
                    {{"type":"sphere","radius":0.3,"center":[0.2,0.5,0]}}]}},
                    "b":{{"type":"transform","translate":[0,0.1,0],"child":{hf}}}}}"#
            ),
            format!(
                r#"{{"type":"smooth_union","radius":0.1,"children":[{hf},{{"type":"sphere","radius":0.4}}]}}"#
            ),
            hf.to_string(),
        ];
        let grid = crate::grid::Grid {
            origin: Vec3::splat(-1.0),
            cell_size: 2.0 / 20.0,
            cells: glam::UVec3::new(20, 17, 23),
            offset: glam::IVec3::new(3, -2, 1),
        };
        let c = grid.corners();
        for (k, json) in scenes.iter().enumerate() {
            let f = CsgNode::from_json(json).unwrap().compile().unwrap();
            assert_eq!(f.root.batches(), k != 2, "{json}");
            let (z0, z1) = (2, 7);
            let mut out = vec![0f32; (c.x * c.y * (z1 - z0)) as usize];
            f.sample_grid(&grid, z0..z1, &mut out);
            let mut i = 0;
            for z in z0..z1 {
                for y in 0..c.y {
                    for x in 0..c.x {
                        let v = f.value(grid.corner_pos(glam::UVec3::new(x, y, z)));
                        assert_eq!(out[i].to_bits(), v.to_bits(), "{json} at {x} {y} {z}");
                        i += 1;
                    }
                }
            }
        }
    }
}
