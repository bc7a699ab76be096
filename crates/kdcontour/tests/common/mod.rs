//! Shared by the integration tests: a seeded generator, so random thresholds and
//! layouts are the same on every run.

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
