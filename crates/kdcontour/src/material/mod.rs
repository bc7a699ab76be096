//! Materials carried by a field: which material is where, as up to four ids with
//! weights ([`MaterialBlend`]), read by [`crate::Field::material`] at each mesh vertex.
//!
//! A field that has materials says so ([`crate::Field::has_materials`]); then every mesh
//! the core makes from it carries one blend per vertex
//! ([`crate::IndexedMesh::materials`]), and the tree keeps material borders crisp: a node
//! on or beside a border is a leaf only where its vertex leaves the border where
//! it was, running along it (see `kdtree/borders.rs` and
//! [`Settings::material_borders`](crate::Settings::material_borders)). Fields
//! without materials give the same meshes as before, with no blends. A mesh to
//! be drawn can have its vertices split where two materials meet at a crease
//! ([`split_borders`]), so the border is drawn along the crease.
//!
//! The terrain's ids are [`terrain_ids`]; CSG scenes name any id `0..=255` with a
//! `material` node ([`crate::CsgNode::Material`]); brushes carry one too
//! ([`crate::edit::Brush::material`]).

mod attach;
mod borders;

pub use attach::attach;
pub use borders::{split_borders, BorderSplit, SIDE_CELLS};

use serde::{Deserialize, Serialize};

/// The material ids the noise terrain assigns ([`crate::field::terrain`]).
pub mod terrain_ids {
    /// Grass, on flat ground.
    pub const GRASS: u8 = 0;
    /// Rock, on steep slopes.
    pub const ROCK: u8 = 1;
    /// Dirt, in a noise mask, low ground and cave walls.
    pub const DIRT: u8 = 2;
    /// Snow, above a height.
    pub const SNOW: u8 = 3;
}

/// Up to four material ids with weights: weights are `>= 0`, sum to 1 and are
/// sorted heaviest first (ties by id); unused slots have id 0 and weight 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialBlend {
    /// Material ids, heaviest first.
    pub ids: [u8; 4],
    /// Their weights, summing to 1.
    pub weights: [f32; 4],
}

impl Default for MaterialBlend {
    fn default() -> Self {
        MaterialBlend::single(0)
    }
}

impl MaterialBlend {
    /// Material `id` alone.
    pub const fn single(id: u8) -> MaterialBlend {
        MaterialBlend {
            ids: [id, 0, 0, 0],
            weights: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// The heaviest material.
    pub fn dominant(&self) -> u8 {
        self.ids[0]
    }

    /// `a` weighted `1 - t` blended with `b` weighted `t` (`t` clamped to
    /// `0..=1`): weights of equal ids add up, the four heaviest are kept and
    /// renormalised.
    pub fn mix(a: MaterialBlend, b: MaterialBlend, t: f32) -> MaterialBlend {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        if t == 0.0 {
            return a;
        }
        if t == 1.0 {
            return b;
        }
        let mut acc: [(u8, f32); 8] = [(0, 0.0); 8];
        let mut n = 0;
        let pairs = a
            .ids
            .iter()
            .zip(a.weights.iter().map(|w| w * (1.0 - t)))
            .chain(b.ids.iter().zip(b.weights.iter().map(|w| w * t)));
        for (&id, w) in pairs {
            if w <= 0.0 {
                continue;
            }
            match acc[..n].iter_mut().find(|(i, _)| *i == id) {
                Some(slot) => slot.1 += w,
                None => {
                    acc[n] = (id, w);
                    n += 1;
                }
            }
        }
        MaterialBlend::from_weights(&mut acc[..n])
    }

    /// The blend of `(id, weight)` pairs with distinct ids and positive weights:
    /// the four heaviest, renormalised. Empty gives material 0.
    fn from_weights(pairs: &mut [(u8, f32)]) -> MaterialBlend {
        pairs.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
        let kept = &pairs[..pairs.len().min(4)];
        let sum: f32 = kept.iter().map(|p| p.1).sum();
        if kept.is_empty() || !(sum > 0.0 && sum.is_finite()) {
            return MaterialBlend::single(0);
        }
        let mut m = MaterialBlend {
            ids: [0; 4],
            weights: [0.0; 4],
        };
        for (k, &(id, w)) in kept.iter().enumerate() {
            m.ids[k] = id;
            m.weights[k] = w / sum;
        }
        m
    }

    /// The blend of `(id, weight)` pairs (weights need not sum to 1; ids may
    /// repeat, their weights add; non-positive and NaN weights are dropped). No
    /// positive weight gives material 0.
    pub fn weighted(pairs: &[(u8, f32)]) -> MaterialBlend {
        // A painted vertex or crossing has a handful of pairs: their sums live
        // on the stack (this runs once per vertex and crossing).
        let mut small = [(0u8, 0.0f32); 8];
        let mut large = Vec::new();
        let acc: &mut [(u8, f32)] = if pairs.len() <= small.len() {
            &mut small
        } else {
            large.resize(pairs.len(), (0, 0.0));
            &mut large
        };
        let mut n = 0;
        for &(id, w) in pairs {
            if w.is_nan() || w <= 0.0 {
                continue;
            }
            match acc[..n].iter_mut().find(|(i, _)| *i == id) {
                Some(slot) => slot.1 += w,
                None => {
                    acc[n] = (id, w);
                    n += 1;
                }
            }
        }
        MaterialBlend::from_weights(&mut acc[..n])
    }

    /// The weight of material `id` (0 when absent).
    pub fn weight_of(&self, id: u8) -> f32 {
        (0..4)
            .filter(|&k| self.ids[k] == id)
            .map(|k| self.weights[k])
            .sum()
    }
}

/// The colours the OBJ writer gives vertices by dominant material
/// ([`colour`]): grass green, rock grey, dirt brown, snow white (the
/// [`terrain_ids`]), then four more for other ids.
pub const PALETTE: [[f32; 3]; 8] = [
    [0.33, 0.55, 0.20],
    [0.50, 0.48, 0.45],
    [0.45, 0.32, 0.20],
    [0.95, 0.95, 0.97],
    [0.80, 0.25, 0.20],
    [0.20, 0.40, 0.80],
    [0.85, 0.70, 0.20],
    [0.55, 0.30, 0.65],
];

/// The colour of material `id`: [`PALETTE`]`[id % 8]`.
pub fn colour(id: u8) -> [f32; 3] {
    PALETTE[id as usize % PALETTE.len()]
}

/// The weight at which a crossing's dominant material counts toward a border:
/// two materials that each hold at least this much at crossings within a cell of
/// each other meet at a hard border, kept crisp. Inside a blend wider than that
/// (terrain fading from grass to rock over a few cells, a wide smooth union)
/// the crossings are mixed, no border is kept, and the blend costs no
/// triangles: the weights at the vertices already show it smoothly.
pub const PURE: f32 = 0.75;

/// A region's material code ([`crate::hermite::Hermite::cell_material`]): no
/// crossing seen.
pub(crate) const UNSET: u16 = u16::MAX - 1;
/// A region's material code: crossings of different dominant materials (a
/// material border runs through it).
pub(crate) const MIXED: u16 = u16::MAX;

/// The material code of a region holding both `a` and `b` ([`UNSET`] is empty,
/// [`MIXED`] absorbs; other codes are dominant material ids).
pub(crate) fn combine(a: u16, b: u16) -> u16 {
    if a == UNSET {
        b
    } else if b == UNSET || a == b {
        a
    } else {
        MIXED
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums_to_one(m: &MaterialBlend) -> bool {
        (m.weights.iter().sum::<f32>() - 1.0).abs() < 1e-6
            && m.weights.windows(2).all(|w| w[0] >= w[1])
            && m.weights.iter().all(|w| *w >= 0.0)
    }

    #[test]
    fn mixes_keep_the_four_heaviest_and_sum_to_one() {
        let a = MaterialBlend::single(3);
        let b = MaterialBlend::single(7);
        assert_eq!(MaterialBlend::mix(a, b, 0.0), a);
        assert_eq!(MaterialBlend::mix(a, b, 1.0), b);
        let m = MaterialBlend::mix(a, b, 0.25);
        assert_eq!(m.ids[..2], [3, 7]);
        assert!((m.weights[0] - 0.75).abs() < 1e-6 && sums_to_one(&m));
        assert_eq!(m.dominant(), 3);
        // Five materials: the lightest is dropped, the rest renormalised.
        let five = MaterialBlend::weighted(&[(1, 0.3), (2, 0.25), (3, 0.2), (4, 0.15), (5, 0.1)]);
        assert_eq!(five.ids, [1, 2, 3, 4]);
        assert!(sums_to_one(&five) && five.weight_of(5) == 0.0);
        let m = MaterialBlend::mix(five, MaterialBlend::single(2), 0.5);
        assert_eq!(m.dominant(), 2);
        assert!(sums_to_one(&m));
        // Equal ids add up; nothing positive is material 0.
        let same = MaterialBlend::weighted(&[(4, 1.0), (4, 3.0)]);
        assert_eq!(same, MaterialBlend::single(4));
        assert_eq!(
            MaterialBlend::weighted(&[(9, 0.0), (8, f32::NAN)]),
            MaterialBlend::single(0)
        );
        // NaN blend factors are read as 0.
        assert_eq!(MaterialBlend::mix(a, b, f32::NAN), a);
    }

    #[test]
    fn codes_combine_to_mixed_on_a_border() {
        assert_eq!(combine(UNSET, 4), 4);
        assert_eq!(combine(4, UNSET), 4);
        assert_eq!(combine(4, 4), 4);
        assert_eq!(combine(4, 5), MIXED);
        assert_eq!(combine(MIXED, 4), MIXED);
    }
}
