//! The one root search on a segment: the Illinois variant of false position,
//! as the Hermite stage finds crossings on the field ([`crate::hermite`]) and
//! the checker finds the surface it measures against ([`crate::validate()`]).
//! Each caller runs its own loop (what it evaluates, when it stops); the
//! bracket and its steps are this one.

/// A bracket `[t0, t1]` of `[0, 1]` whose ends have field values `f0` and `f1`
/// of opposite sides (outside is `>= 0`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bracket {
    /// Low end and its value.
    pub(crate) t0: f32,
    pub(crate) f0: f32,
    /// High end and its value.
    pub(crate) t1: f32,
    pub(crate) f1: f32,
    /// Which end moved last (-1 low, 1 high): a second move of the same end
    /// halves the other end's value (the Illinois step).
    side: i8,
}

impl Bracket {
    /// The whole segment, with the values at its ends.
    pub(crate) fn new(f0: f32, f1: f32) -> Self {
        Bracket {
            t0: 0.0,
            f0,
            t1: 1.0,
            f1,
            side: 0,
        }
    }

    /// The false-position point of the bracket.
    pub(crate) fn secant(&self) -> f32 {
        let (t0, f0, t1, f1) = (self.t0, self.f0, self.t1, self.f1);
        (t0 - f0 * (t1 - t0) / (f1 - f0)).clamp(t0, t1)
    }

    /// Narrows the bracket to the side of `t` (value `ft`) that keeps the sign
    /// change.
    pub(crate) fn narrow(&mut self, t: f32, ft: f32) {
        if (ft >= 0.0) == (self.f0 >= 0.0) {
            self.t0 = t;
            self.f0 = ft;
            if self.side == -1 {
                self.f1 *= 0.5;
            }
            self.side = -1;
        } else {
            self.t1 = t;
            self.f1 = ft;
            if self.side == 1 {
                self.f0 *= 0.5;
            }
            self.side = 1;
        }
    }

    /// Whether the two ends' values are equal (no further secant step).
    pub(crate) fn flat(&self) -> bool {
        self.f0 == self.f1
    }
}
