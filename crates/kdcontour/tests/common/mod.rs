//! Shared by the integration tests: a seeded generator, so random thresholds and
//! layouts are the same on every run, and a chunk world over `[-1, 1]^3`.

/// A 64-bit linear congruential generator (Knuth's MMIX constants); `next` returns
/// the high bits.
pub struct Lcg(pub u64);

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
pub fn chunk_world(field: &dyn kdcontour::Field, chunks: u32, res: u32) -> kdcontour::ChunkWorld {
    let cell = 2.0 / (chunks * res) as f32;
    let mut w = kdcontour::ChunkWorld::new(
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
