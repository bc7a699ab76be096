//! The packed dual vertex of one surface component (a Dual Marching Cubes patch of a
//! cell, or a merged component of a clustered node): its vertex as fractions of the
//! owning box and its unit normal, 14 bytes. The k-d tree stores one per component,
//! and uniform DMC ([`crate::dmc`]) packs its vertices the same way, so both give
//! bitwise the same positions. Re-exported as `kdtree::Comp`.

use glam::Vec3;

/// A surface component of a clusterable node: one dual vertex, packed in 14 bytes.
///
/// The vertex (the QEF minimiser, always inside its node's box) is stored as 16-bit
/// fractions of that box: 1/65535 of a cell for cell leaves, and never coarser than
/// 1/65535 of the node's extent. The unit normal is stored as 16-bit snorm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comp {
    /// Vertex position as fractions (0..=65535) of the node's box along x, y, z.
    pub vertex: [u16; 3],
    /// Unit normal in snorm16: the normalised sum of its crossings' normals.
    pub normal: [i16; 3],
    /// Index of the component of the parent node this one merges into.
    pub parent: u8,
}

impl Comp {
    /// Packs a vertex (grid units, inside `[lo, hi]`) and a normal (any length).
    pub fn pack(vertex: Vec3, normal: Vec3, lo: Vec3, hi: Vec3, parent: u8) -> Comp {
        let t = ((vertex - lo) / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE)))
            .clamp(Vec3::ZERO, Vec3::ONE)
            * 65535.0;
        let n = normal.normalize_or_zero() * 32767.0;
        // Rounding by adding one half away from zero and truncating: `f32::round`
        // is a libm call on the baseline x86-64 target, and this is on the build's
        // hot path (once per component).
        Comp {
            vertex: t.to_array().map(|x| (x + 0.5) as u16),
            normal: n.to_array().map(|x| (x + 0.5f32.copysign(x)) as i16),
            parent,
        }
    }

    /// The vertex (grid units) in the box `[lo, hi]` of the node that owns it.
    #[inline]
    pub fn position(&self, lo: Vec3, hi: Vec3) -> Vec3 {
        let t = Vec3::new(
            self.vertex[0] as f32,
            self.vertex[1] as f32,
            self.vertex[2] as f32,
        ) / 65535.0;
        lo + (hi - lo) * t
    }

    /// The unit normal (zero when its crossings' normals cancelled).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        Vec3::new(
            self.normal[0] as f32,
            self.normal[1] as f32,
            self.normal[2] as f32,
        )
        .normalize_or_zero()
    }
}
