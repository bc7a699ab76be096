//! Where the camera will be when a level change lands ([`CameraMotion`]): a
//! level change takes as long as its chunk builds (a second or two for a
//! 4,096-cell view on two cores), and a camera flying meanwhile would find the
//! levels made for where it was. So a horizon volume lays its chunks out for
//! the camera's position ahead by its velocity (over the last
//! [`WINDOW`] seconds) times one and a half level changes (the mean duration
//! of the last [`CHANGES_KEPT`]; a change's size varies with where the rings
//! move, and the mean guesses the next one better than the last alone): the
//! new levels land with the camera half a change short of that point and are
//! replaced with it half a change past, so they are shown centred on it. The
//! look-ahead is at most
//! the reach of level 2 (four times the level-0 reach), so a camera that stops
//! short is among level-2 chunks or finer until the next change (as a
//! camera flying without look-ahead is while a change runs), and a step
//! longer than that in one frame is a cut, not motion: it forgets the
//! velocity. A still camera gets the layout of where it is.

use bevy::math::Vec3;
use std::collections::VecDeque;

/// Seconds of camera positions the velocity is measured over.
pub(crate) const WINDOW: f64 = 0.25;

/// Level changes whose durations are averaged.
pub(crate) const CHANGES_KEPT: usize = 4;

/// Level changes last this many of their own durations ahead: one to land,
/// half of the next one's while shown (see the module docs).
const CHANGES_AHEAD: f64 = 1.5;

/// The camera's recent positions and how long level changes take.
#[derive(Default)]
pub(crate) struct CameraMotion {
    /// (real seconds, position in level-0 chunks), oldest first, spanning at
    /// most a little over [`WINDOW`].
    seen: VecDeque<(f64, Vec3)>,
    /// The last [`CHANGES_KEPT`] level changes' durations, from their
    /// layout's request to their meshes shown (seconds), oldest first.
    changes: VecDeque<f64>,
}

impl CameraMotion {
    /// Records the camera at `at` (level-0 chunks) at `now` (real seconds). A
    /// step of more than `cut` chunks from the last position starts over (a
    /// cut or a teleport, not motion).
    pub(crate) fn observe(&mut self, now: f64, at: Vec3, cut: f32) {
        if !at.is_finite() {
            return;
        }
        if let Some(&(t, last)) = self.seen.back() {
            if now < t || last.distance(at) > cut {
                self.seen.clear();
            }
        }
        self.seen.push_back((now, at));
        // Keep one position at least WINDOW old, so the span covers the window.
        while self.seen.len() > 2 && now - self.seen[1].0 >= WINDOW {
            self.seen.pop_front();
        }
    }

    /// The camera's velocity (level-0 chunks a second) over the last
    /// [`WINDOW`] seconds; zero until it has been seen over a tenth of one.
    pub(crate) fn velocity(&self) -> Vec3 {
        match (self.seen.front(), self.seen.back()) {
            (Some(&(t0, p0)), Some(&(t1, p1))) if t1 - t0 >= 0.1 * WINDOW => {
                (p1 - p0) / (t1 - t0) as f32
            }
            _ => Vec3::ZERO,
        }
    }

    /// Records that a level change took `secs` from request to shown.
    pub(crate) fn change_took(&mut self, secs: f64) {
        if secs.is_finite() && secs >= 0.0 {
            if self.changes.len() == CHANGES_KEPT {
                self.changes.pop_front();
            }
            self.changes.push_back(secs);
        }
    }

    /// The last level change's duration (seconds; zero before the first).
    pub(crate) fn change_seconds(&self) -> f64 {
        self.changes.back().copied().unwrap_or(0.0)
    }

    /// The mean duration of the last [`CHANGES_KEPT`] level changes (seconds;
    /// zero before the first).
    fn typical_change(&self) -> f64 {
        self.changes.iter().sum::<f64>() / self.changes.len().max(1) as f64
    }

    /// Where to lay the chunks out for: the camera `at` plus its velocity
    /// times [`CHANGES_AHEAD`] typical level changes, at most `reach` chunks
    /// ahead.
    pub(crate) fn ahead(&self, at: Vec3, reach: f32) -> Vec3 {
        let step = self.velocity() * (CHANGES_AHEAD * self.typical_change()) as f32;
        at + step.clamp_length_max(reach.max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera flying at `v` chunks a second, seen 60 times a second for
    /// `secs`, from the origin.
    fn flown(v: Vec3, secs: f64) -> CameraMotion {
        let mut m = CameraMotion::default();
        let frames = (secs * 60.0) as usize;
        for f in 0..=frames {
            let t = f as f64 / 60.0;
            m.observe(t, v * t as f32, 4.0);
        }
        m
    }

    #[test]
    fn a_steady_flight_is_laid_out_one_and_a_half_changes_ahead() {
        let v = Vec3::new(1.5, 0.0, 0.3);
        let mut m = flown(v, 2.0);
        assert!(m.velocity().distance(v) < 1e-3, "{}", m.velocity());
        // No level change measured yet: no look-ahead.
        assert_eq!(m.ahead(Vec3::ONE, 4.0), Vec3::ONE);
        m.change_took(1.2);
        assert_eq!(m.change_seconds(), 1.2);
        let p = m.ahead(Vec3::ONE, 4.0);
        assert!(p.distance(Vec3::ONE + v * 1.8) < 1e-3, "{p}");
        // Capped at the reach, along the motion.
        let p = m.ahead(Vec3::ZERO, 2.0);
        assert!((p.length() - 2.0).abs() < 1e-4 && p.normalize().dot(v.normalize()) > 0.9999);
        // Nonsense durations are ignored.
        m.change_took(f64::NAN);
        m.change_took(-1.0);
        assert_eq!(m.change_seconds(), 1.2);
        // The look-ahead follows the mean of the last four changes.
        for secs in [2.0, 0.4, 0.8, 2.0, 0.8] {
            m.change_took(secs);
        }
        assert_eq!(m.change_seconds(), 0.8);
        let p = m.ahead(Vec3::ONE, 4.0);
        assert!(p.distance(Vec3::ONE + v * 1.5 * 1.0) < 1e-3, "{p}");
    }

    #[test]
    fn a_still_camera_is_laid_out_where_it_is() {
        let mut m = flown(Vec3::new(2.0, 0.0, 0.0), 1.0);
        m.change_took(1.0);
        // It stops at x = 2 and stays for a window.
        for f in 1..=20 {
            m.observe(1.0 + f as f64 / 60.0, Vec3::new(2.0, 0.0, 0.0), 4.0);
        }
        assert_eq!(m.velocity(), Vec3::ZERO);
        assert_eq!(
            m.ahead(Vec3::new(2.0, 0.0, 0.0), 4.0),
            Vec3::new(2.0, 0.0, 0.0)
        );
    }

    #[test]
    fn a_cut_forgets_the_velocity() {
        let mut m = flown(Vec3::new(2.0, 0.0, 0.0), 1.0);
        m.change_took(1.0);
        // Teleported 100 chunks in one frame.
        let at = Vec3::new(102.0, 0.0, 0.0);
        m.observe(1.0 + 1.0 / 60.0, at, 4.0);
        assert_eq!(m.velocity(), Vec3::ZERO);
        assert_eq!(m.ahead(at, 4.0), at);
        // A clock that goes back starts over too, and NaN is not seen.
        m.observe(0.5, at, 4.0);
        m.observe(0.6, Vec3::NAN, 4.0);
        assert_eq!(m.velocity(), Vec3::ZERO);
        // Updates far apart in time still measure the speed.
        let mut m = CameraMotion::default();
        m.observe(0.0, Vec3::ZERO, 4.0);
        m.observe(0.5, Vec3::new(1.0, 0.0, 0.0), 4.0);
        assert!(m.velocity().distance(Vec3::new(2.0, 0.0, 0.0)) < 1e-6);
    }
}
