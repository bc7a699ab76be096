//! Undo and redo: an edit log grouped into steps (one brush, or a stroke of
//! dabs), of which the newest can be taken back and put back.
//!
//! The history keeps every brush it has: the applied ones, then the undone
//! ones (the redo tail). The field it shows is a prefix of that log, sharing
//! the compiled brushes, so after undoing a step it samples bit for bit as a
//! replay of the brushes before that step would, and a world re-meshes only
//! the chunks the step's brushes reach ([`EditHistory::undo`] returns those
//! reaches). A new edit after an undo drops the redo tail.
//!
//! Only the newest steps can be undone (the `max_steps` given to
//! [`EditHistory::apply`]); older brushes form the *floor*.
//! [`EditHistory::saved`] compacts the floor and each step on its own
//! ([`super::compact`]), so every undo and redo survives a save.

use super::{compact, Brush, EditedField};
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// How a saved log divides into undo steps (saved with it; see
/// [`EditHistory::saved`]). The default, all zeros, makes every brush floor:
/// a log saved without a history loads with nothing to undo.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct UndoSteps {
    /// Brushes before the first step (cannot be undone).
    pub floor: u64,
    /// Where each step ends, in brushes of the log, ascending; the last is the
    /// log's length.
    pub ends: Vec<u64>,
    /// Steps applied; the brushes after the last applied step's end are the
    /// undone ones (redo).
    pub applied: u64,
    /// The last step is a stroke still open: the next dab that continues a
    /// stroke joins it (so a replica that starts from a save groups the next
    /// dabs as the history it was saved from does).
    #[serde(default)]
    pub open: bool,
}

impl UndoSteps {
    /// Whether these steps fit a log of `len` brushes: step ends rise from the
    /// floor to the log's end, and no more steps are applied than there are.
    pub fn check(&self, len: usize) -> Result<()> {
        let n = len as u64;
        let bad = |reason: String| Error::InvalidSetting {
            name: "undo steps",
            reason,
        };
        if self.ends.is_empty() {
            if self.floor != 0 && self.floor != n || self.applied != 0 {
                return Err(bad(format!(
                    "no steps, but a floor of {} and {} applied, for a log of {n} brushes",
                    self.floor, self.applied
                )));
            }
            return Ok(());
        }
        let mut prev = self.floor;
        for &end in &self.ends {
            if end <= prev {
                return Err(bad(format!(
                    "step ends must rise from the floor ({}): {:?}",
                    self.floor, self.ends
                )));
            }
            prev = end;
        }
        if prev != n {
            return Err(bad(format!(
                "the last step ends at brush {prev}, but the log has {n}"
            )));
        }
        if self.applied > self.ends.len() as u64 {
            return Err(bad(format!(
                "{} steps applied of {}",
                self.applied,
                self.ends.len()
            )));
        }
        Ok(())
    }
}

/// An edited field with undo and redo (see the module docs).
#[derive(Clone)]
pub struct EditHistory {
    /// Every brush: the applied ones, then the undone ones.
    all: EditedField,
    /// The applied ones: a prefix of `all`.
    field: EditedField,
    /// Brushes before the first step.
    floor: usize,
    /// Where each step ends, in brushes of `all`, ascending.
    ends: Vec<usize>,
    /// Steps applied (`ends[..applied]`).
    applied: usize,
    /// The last applied step is a stroke that more dabs may join.
    open: bool,
    /// Changes with every edit, undo and redo.
    revision: u64,
}

impl EditHistory {
    /// A history over `field`, whose brushes (if any) cannot be undone.
    pub fn new(field: EditedField) -> Self {
        EditHistory {
            floor: field.edit_count(),
            all: field.clone(),
            field,
            ends: Vec::new(),
            applied: 0,
            open: false,
            revision: 0,
        }
    }

    /// A history restored from a saved log and its steps, on `base` (a field
    /// with no brushes, or brushes to keep below the log). Steps that do not
    /// fit the log are refused with what is wrong.
    pub fn restore(base: EditedField, log: Vec<Brush>, steps: &UndoSteps) -> Result<Self> {
        steps.check(log.len())?;
        let below = base.edit_count();
        let n = log.len();
        let all = base.with_edits(log)?;
        let mut history = EditHistory::new(base);
        history.all = all;
        if steps.ends.is_empty() {
            history.floor = below + n;
        } else {
            history.floor = below + steps.floor as usize;
            history.ends = steps.ends.iter().map(|&e| below + e as usize).collect();
            history.applied = steps.applied as usize;
            history.open = steps.open && history.applied == history.ends.len();
        }
        history.field = history.all.prefix(history.applied_len());
        Ok(history)
    }

    /// The field with every applied brush.
    pub fn field(&self) -> &EditedField {
        &self.field
    }

    /// Changes with every edit, undo and redo (to notice that the field changed
    /// even when its brush count did not).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Steps that can be undone.
    pub fn undo_steps(&self) -> usize {
        self.applied
    }

    /// Steps that can be redone.
    pub fn redo_steps(&self) -> usize {
        self.ends.len() - self.applied
    }

    /// Every brush kept: the applied ones and the undone ones.
    pub fn brush_count(&self) -> usize {
        self.all.edit_count()
    }

    /// Applies `brush`; with `continues_stroke` it joins the last step if that
    /// is a stroke still open (no undo or redo asked for since), so one undo takes back
    /// the whole stroke. Drops the redo tail. Keeps at most `max_steps` steps
    /// (older brushes become floor; 0: nothing can be undone). Returns the
    /// brush's reach (center, radius); on an error (a brush the core refuses)
    /// nothing changes.
    pub fn apply(
        &mut self,
        brush: Brush,
        continues_stroke: bool,
        max_steps: usize,
    ) -> Result<(Vec3, f32)> {
        let field = self.field.with_edit(brush)?;
        let reach = field.last_reach().expect("a brush was just added");
        self.ends.truncate(self.applied);
        let n = field.edit_count();
        if continues_stroke && self.open && self.applied > 0 {
            self.ends[self.applied - 1] = n;
        } else {
            self.ends.push(n);
        }
        self.all = field.clone();
        self.field = field;
        self.open = true;
        if self.ends.len() > max_steps {
            let drop = self.ends.len() - max_steps;
            self.floor = if max_steps == 0 {
                n
            } else {
                self.ends[drop - 1]
            };
            self.ends.drain(..drop);
            if max_steps == 0 {
                self.open = false;
            }
        }
        self.applied = self.ends.len();
        self.revision += 1;
        Ok(reach)
    }

    /// Takes back the last applied step; returns the reach of each of its
    /// brushes (what to re-mesh), or `None` with nothing to undo.
    pub fn undo(&mut self) -> Option<Vec<(Vec3, f32)>> {
        self.open = false;
        if self.applied == 0 {
            return None;
        }
        let range = self.step(self.applied - 1);
        self.applied -= 1;
        self.field = self.all.prefix(range.start);
        self.revision += 1;
        Some(self.all.reaches(range))
    }

    /// Puts back the last undone step; returns the reach of each of its
    /// brushes, or `None` with nothing to redo.
    pub fn redo(&mut self) -> Option<Vec<(Vec3, f32)>> {
        self.open = false;
        if self.applied == self.ends.len() {
            return None;
        }
        let range = self.step(self.applied);
        self.applied += 1;
        self.field = self.all.prefix(range.end);
        self.revision += 1;
        Some(self.all.reaches(range))
    }

    /// The same history on another base field (the volume's field was
    /// swapped): every brush, applied or undone, is kept.
    pub fn rebase(&mut self, base: std::sync::Arc<dyn crate::Field>) {
        self.all = self.all.rebased(base);
        self.field = self.all.prefix(self.applied_len());
        self.revision += 1;
    }

    /// The log to save and its steps. The floor and each step are compacted
    /// on their own ([`super::compact`] keeps the field a run of brushes
    /// leaves, whatever it started from, so the field after every step, and
    /// with it every undo and redo, is kept).
    pub fn saved(&self) -> (Vec<Brush>, UndoSteps) {
        let mut log = compact(&self.all.brushes(0..self.floor));
        if self.ends.is_empty() {
            // No steps: the whole log is floor.
            return (log, UndoSteps::default());
        }
        let floor = log.len() as u64;
        let mut ends = Vec::with_capacity(self.ends.len());
        for i in 0..self.ends.len() {
            // A step keeps its last brush: nothing after it in the step covers it.
            log.extend(compact(&self.all.brushes(self.step(i))));
            ends.push(log.len() as u64);
        }
        let steps = UndoSteps {
            floor,
            ends,
            applied: self.applied as u64,
            open: self.open,
        };
        (log, steps)
    }

    /// Brushes applied.
    fn applied_len(&self) -> usize {
        match self.applied {
            0 => self.floor,
            a => self.ends[a - 1],
        }
    }

    /// The brushes of step `i`.
    fn step(&self, i: usize) -> std::ops::Range<usize> {
        let start = if i == 0 { self.floor } else { self.ends[i - 1] };
        start..self.ends[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::test_base as base;
    use crate::edit::BrushOp;
    use crate::field::Field;

    fn dab(i: u32) -> Brush {
        let a = i as f32 * 0.7;
        let op = if i.is_multiple_of(2) {
            BrushOp::Subtract
        } else {
            BrushOp::SmoothAdd { radius: 0.5 }
        };
        Brush::sphere(Vec3::new(10.0 * a.cos(), 10.0 * a.sin(), 0.0), 2.0, op)
    }

    /// Values on a lattice around the sphere, to compare fields bit for bit.
    fn samples(f: &EditedField) -> Vec<u32> {
        let mut out = Vec::new();
        for x in -14..=14 {
            for y in -14..=14 {
                for z in -3..=3 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) * 0.93;
                    out.push(f.value(p).to_bits());
                }
            }
        }
        out
    }

    /// A plain model: the steps applied and the steps undone, as brush lists.
    #[derive(Default)]
    struct Model {
        /// Brushes older than the depth.
        floor: Vec<Brush>,
        done: Vec<Vec<Brush>>,
        undone: Vec<Vec<Brush>>,
        open: bool,
    }

    /// Steps kept in the random test (small, so the floor grows).
    const DEPTH: usize = 7;

    #[test]
    fn random_edits_undos_and_redos_match_a_replay_of_the_applied_steps() {
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u64| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng % n
        };
        let mut h = EditHistory::new(base());
        let mut m = Model::default();
        let mut counter = 0;
        for round in 0..400 {
            let before = h.revision();
            // Whether this round changed the field (an edit always does).
            let changed = match next(6) {
                0..=2 => {
                    let stroke = next(2) == 0;
                    let b = dab(counter);
                    counter += 1;
                    let (c, r) = h.apply(b.clone(), stroke, DEPTH).unwrap();
                    assert!(r >= 2.0 && c.length() > 5.0);
                    m.undone.clear();
                    if stroke && m.open && !m.done.is_empty() {
                        m.done.last_mut().unwrap().push(b);
                    } else {
                        m.done.push(vec![b]);
                    }
                    m.open = true;
                    while m.done.len() > DEPTH {
                        let oldest = m.done.remove(0);
                        m.floor.extend(oldest);
                    }
                    true
                }
                3 | 4 => {
                    let reaches = h.undo();
                    m.open = false;
                    match m.done.pop() {
                        Some(step) => {
                            assert_eq!(reaches.unwrap().len(), step.len(), "round {round}");
                            m.undone.push(step);
                            true
                        }
                        None => reaches.is_some(),
                    }
                }
                _ => {
                    let reaches = h.redo();
                    m.open = false;
                    match m.undone.pop() {
                        Some(step) => {
                            assert_eq!(reaches.unwrap().len(), step.len(), "round {round}");
                            m.done.push(step);
                            true
                        }
                        None => reaches.is_some(),
                    }
                }
            };
            let log: Vec<Brush> = m
                .floor
                .iter()
                .chain(m.done.iter().flatten())
                .cloned()
                .collect();
            assert_eq!(h.field().log(), log, "round {round}");
            assert_eq!(h.undo_steps(), m.done.len(), "round {round}");
            assert_eq!(h.redo_steps(), m.undone.len());
            assert_eq!(h.revision() > before, changed, "round {round}");
            if round % 25 == 0 {
                let replay = EditedField::replay(base().base.clone(), &log).unwrap();
                assert_eq!(samples(h.field()), samples(&replay), "round {round}");
                // Saved and restored: the same field, the same steps to undo
                // and redo.
                let (saved, steps) = h.saved();
                let back = EditHistory::restore(base(), saved, &steps).unwrap();
                assert_eq!(samples(back.field()), samples(h.field()), "round {round}");
                assert_eq!(back.undo_steps(), h.undo_steps());
                assert_eq!(back.redo_steps(), h.redo_steps());
            }
        }
    }

    #[test]
    fn a_new_edit_after_undo_drops_the_redo_tail() {
        let mut h = EditHistory::new(base());
        for i in 0..3 {
            h.apply(dab(i), false, 10).unwrap();
        }
        h.undo().unwrap();
        h.undo().unwrap();
        assert_eq!(h.redo_steps(), 2);
        h.apply(dab(9), false, 10).unwrap();
        assert_eq!(h.redo_steps(), 0);
        assert!(h.redo().is_none());
        assert_eq!(h.field().log(), vec![dab(0), dab(9)]);
        assert_eq!(h.brush_count(), 2, "the dropped brushes are not kept");
    }

    #[test]
    fn a_stroke_is_one_step_and_an_undo_closes_it() {
        let mut h = EditHistory::new(base());
        h.apply(dab(0), false, 10).unwrap();
        for i in 1..5 {
            h.apply(dab(i), true, 10).unwrap();
        }
        assert_eq!(h.undo_steps(), 1, "five dabs of one stroke are one step");
        assert_eq!(h.undo().unwrap().len(), 5);
        assert_eq!(h.field().edit_count(), 0);
        // After an undo a continuing dab starts a new step (the stroke was
        // closed), it does not join the step before.
        h.apply(dab(5), false, 10).unwrap();
        h.undo().unwrap();
        h.redo().unwrap();
        h.apply(dab(6), true, 10).unwrap();
        assert_eq!(h.undo_steps(), 2);
        // An open stroke stays open through a save: the next dab joins it in
        // the restored history as in this one.
        h.apply(dab(7), false, 10).unwrap();
        let (log, steps) = h.saved();
        assert!(steps.open);
        let mut back = EditHistory::restore(base(), log, &steps).unwrap();
        h.apply(dab(8), true, 10).unwrap();
        back.apply(dab(8), true, 10).unwrap();
        assert_eq!(back.undo_steps(), h.undo_steps());
        assert_eq!(back.saved(), h.saved());
    }

    #[test]
    fn a_stroke_saves_compacted_and_still_undoes_whole() {
        let mut h = EditHistory::new(base());
        h.apply(dab(0), false, 10).unwrap();
        // A stroke growing over one point: each dab covers the one before.
        let at = Vec3::new(0.0, 10.0, 0.0);
        for i in 0..5 {
            let b = Brush::sphere(at, 1.0 + i as f32 * 0.5, BrushOp::Subtract);
            h.apply(b, i > 0, 10).unwrap();
        }
        let (log, steps) = h.saved();
        assert_eq!(log.len(), 2, "the stroke saves as its last dab");
        assert_eq!(steps.ends, vec![1, 2]);
        let mut back = EditHistory::restore(base(), log, &steps).unwrap();
        assert_eq!(samples(back.field()), samples(h.field()));
        assert_eq!(back.undo().unwrap(), vec![(at, 3.0)]);
        h.undo().unwrap();
        assert_eq!(samples(back.field()), samples(h.field()));
    }

    #[test]
    fn older_steps_than_the_depth_become_floor_and_save_compacted() {
        let mut h = EditHistory::new(base());
        // The same sphere dug three times: the first two are covered.
        let same = Brush::sphere(Vec3::new(10.0, 0.0, 0.0), 3.0, BrushOp::Subtract);
        for _ in 0..3 {
            h.apply(same.clone(), false, 2).unwrap();
        }
        h.apply(dab(1), false, 2).unwrap();
        assert_eq!(h.undo_steps(), 2, "at most two steps are kept");
        let (log, steps) = h.saved();
        // Floor: the first two digs, compacted to one (the second covers the
        // first; the third covers both but is a step of its own, which an undo
        // takes back, so the floor keeps one).
        assert_eq!(log.len(), 3);
        assert_eq!(steps.floor, 1);
        assert_eq!(steps.ends, vec![2, 3]);
        let mut back = EditHistory::restore(base(), log, &steps).unwrap();
        assert_eq!(samples(back.field()), samples(h.field()));
        back.undo().unwrap();
        back.undo().unwrap();
        assert!(back.undo().is_none(), "the floor cannot be undone");
        assert_eq!(back.field().edit_count(), 1);
        h.undo().unwrap();
        h.undo().unwrap();
        assert_eq!(samples(back.field()), samples(h.field()));

        // Depth 0: nothing to undo, everything is floor.
        let mut none = EditHistory::new(base());
        none.apply(dab(0), false, 0).unwrap();
        none.apply(dab(1), true, 0).unwrap();
        assert!(none.undo().is_none());
        assert_eq!(none.saved().1, UndoSteps::default());
    }

    #[test]
    fn steps_that_do_not_fit_the_log_are_refused() {
        let log = vec![dab(0), dab(1), dab(2)];
        for (steps, says) in [
            (
                UndoSteps {
                    floor: 0,
                    ends: vec![2, 2, 3],
                    applied: 3,
                    open: false,
                },
                "rise",
            ),
            (
                UndoSteps {
                    floor: 0,
                    ends: vec![1, 5],
                    applied: 1,
                    open: false,
                },
                "the log has 3",
            ),
            (
                UndoSteps {
                    floor: 1,
                    ends: vec![3],
                    applied: 2,
                    open: false,
                },
                "2 steps applied of 1",
            ),
            (
                UndoSteps {
                    floor: 9,
                    ends: vec![],
                    applied: 0,
                    open: false,
                },
                "no steps",
            ),
        ] {
            let e = EditHistory::restore(base(), log.clone(), &steps)
                .err()
                .unwrap_or_else(|| panic!("{steps:?} was accepted"))
                .to_string();
            assert!(e.contains(says), "{e}");
        }
        // A log saved without steps: every brush is floor.
        let h = EditHistory::restore(base(), log.clone(), &UndoSteps::default()).unwrap();
        assert_eq!(h.field().edit_count(), 3);
        assert_eq!(h.undo_steps(), 0);
    }

    #[test]
    fn undo_reaches_are_the_step_brushes_reaches() {
        let mut h = EditHistory::new(base());
        h.apply(dab(0), false, 10).unwrap();
        let b = Brush::sphere(Vec3::new(0.0, 10.0, 0.0), 2.0, BrushOp::Subtract);
        h.apply(b, false, 10).unwrap();
        let r = h.undo().unwrap();
        assert_eq!(r, vec![(Vec3::new(0.0, 10.0, 0.0), 2.0)]);
        assert_eq!(h.redo().unwrap(), r);
    }
}
