//! Shared by the integration tests: a seeded generator, so random thresholds and
//! layouts are the same on every run, and a chunk world over `[-1, 1]^3`.

/// A 64-bit linear congruential generator (Knuth's MMIX constants); `next` returns
/// the high bits.
#[allow(dead_code)]
pub struct Lcg(pub u64);

#[allow(dead_code)]
impl Lcg {
    /// The next value (31 bits).
    pub fn next(&mut self) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) as usize
    }
}

/// A world of `chunks`³ chunks of `res`³ cells over `[-1, 1]^3` at threshold 0.01,
/// built from `field`. (Not every test file that shares this module uses it.)
#[allow(dead_code)]
pub fn chunk_world(field: &dyn kdcontour::Field, chunks: u32, res: u32) -> kdcontour::World {
    let cell = 2.0 / (chunks * res) as f32;
    let mut w = kdcontour::World::bounded(
        glam::Vec3::splat(-1.0),
        cell,
        res,
        glam::UVec3::splat(chunks),
        0.01,
        kdcontour::Settings::default(),
    )
    .unwrap();
    w.build_all(field).unwrap();
    w
}

/// The area of `m` that faces the way the field's gradient does, less the area
/// that faces against it: the surface covered, counted once where a fan folds
/// over itself (folds are counted as flipped and overlapping faces by
/// `validate`, issue 13's deliver 2), and the raw area.
#[allow(dead_code)]
pub fn area(m: &kdcontour::IndexedMesh, field: &dyn kdcontour::Field) -> (f64, f64) {
    let (mut covered, mut raw) = (0.0, 0.0);
    for t in m.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|i| m.positions[t[i] as usize]);
        let n = (b - a).as_dvec3().cross((c - a).as_dvec3());
        let g = field.gradient((a + b + c) / 3.0).as_dvec3();
        raw += 0.5 * n.length();
        covered += 0.5 * n.length() * n.dot(g).signum();
    }
    (covered, raw)
}
