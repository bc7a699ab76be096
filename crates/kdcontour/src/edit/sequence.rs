//! Sequenced edits: how peers that share only an edit history (a server and its
//! clients) keep the same one, whatever the network does to the messages.
//!
//! The authority ([`Sequencer`]) numbers every accepted [`EditOp`] (an edit,
//! an undo or a redo) from 1 and applies it to its own [`EditHistory`]. A
//! replica ([`Replica`]) applies ops strictly in that order, each exactly once:
//! an op that arrives early waits, one that arrives again is ignored, and a gap
//! (a lost message) is reported as the range to ask for again, which the
//! authority sends from the newest ops it keeps. A replica that joins late,
//! reconnects, or misses more than the authority keeps starts from a
//! [`Snapshot`]: the authority's saved history (compacted, see
//! [`EditHistory::saved`]) and the number of the last op in it, then takes the
//! ops after it. Meshing is deterministic, so equal
//! histories mesh to equal bytes on every peer.

use super::{Brush, EditHistory, EditedField, UndoSteps};
use crate::error::Result;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, VecDeque};
use std::ops::Range;

/// One change to an edit history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum EditOp {
    /// Apply a brush ([`EditHistory::apply`]).
    Apply {
        /// The brush.
        brush: Brush,
        /// It continues the stroke before it.
        continues_stroke: bool,
    },
    /// Take back the last step ([`EditHistory::undo`]).
    Undo,
    /// Put back the last undone step ([`EditHistory::redo`]).
    Redo,
}

impl EditOp {
    /// Applies the op to `history` (keeping at most `max_steps` undo steps);
    /// returns the reach (center, radius) of every brush it changed, empty when
    /// it changed nothing (an undo with nothing to undo).
    pub fn apply_to(
        &self,
        history: &mut EditHistory,
        max_steps: usize,
    ) -> Result<Vec<(glam::Vec3, f32)>> {
        Ok(match self {
            EditOp::Apply {
                brush,
                continues_stroke,
            } => vec![history.apply(brush.clone(), *continues_stroke, max_steps)?],
            EditOp::Undo => history.undo().unwrap_or_default(),
            EditOp::Redo => history.redo().unwrap_or_default(),
        })
    }
}

/// A history as a late joiner receives it: the authority's saved log and steps,
/// and the number of the last op they hold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// The last op the log holds (0: none).
    pub through: u64,
    /// The saved log ([`EditHistory::saved`]).
    pub log: Vec<Brush>,
    /// Its undo steps.
    pub steps: UndoSteps,
}

/// The authority's numbering: numbers every op applied to the authority's
/// history, and keeps the newest of them to send again to a replica that
/// missed some. The history itself stays with its owner (a volume), which
/// applies each op and then records it here, or calls [`Sequencer::accept`].
pub struct Sequencer {
    /// The number of the last op accepted.
    last: u64,
    /// The newest ops, oldest first (op `last - len + 1 + i` is `recent[i]`).
    recent: VecDeque<EditOp>,
    /// How many ops `recent` holds at most.
    keep: usize,
}

impl Sequencer {
    /// A numbering from op 1 (the history's brushes so far come before it),
    /// keeping the newest `keep` ops.
    pub fn new(keep: usize) -> Self {
        Sequencer {
            last: 0,
            recent: VecDeque::new(),
            keep,
        }
    }

    /// The number of the last op accepted (0: none).
    pub fn last(&self) -> u64 {
        self.last
    }

    /// Numbers `op`, which its owner has just applied to the authority's
    /// history; returns its number.
    pub fn record(&mut self, op: EditOp) -> u64 {
        self.last += 1;
        self.recent.push_back(op);
        if self.recent.len() > self.keep {
            self.recent.pop_front();
        }
        self.last
    }

    /// Applies `op` to `history` (keeping at most `max_steps` undo steps) and
    /// numbers it; returns its number and the reaches it changed. An op the
    /// history refuses (a brush the core rejects) gets no number and changes
    /// nothing.
    pub fn accept(
        &mut self,
        history: &mut EditHistory,
        max_steps: usize,
        op: EditOp,
    ) -> Result<(u64, Vec<(glam::Vec3, f32)>)> {
        let reaches = op.apply_to(history, max_steps)?;
        Ok((self.record(op), reaches))
    }

    /// The ops numbered in `range` (up to the last), with their numbers; `None`
    /// when the range starts before the oldest op kept (the asker must start
    /// again from a [`Sequencer::snapshot`]).
    pub fn ops(&self, range: Range<u64>) -> Option<Vec<(u64, EditOp)>> {
        let first = self.last + 1 - self.recent.len() as u64;
        if range.start < first.max(1) {
            return None;
        }
        let end = range.end.min(self.last + 1);
        Some(
            (range.start..end)
                .map(|n| (n, self.recent[(n - first) as usize].clone()))
                .collect(),
        )
    }

    /// The authority's whole `history` for a replica that joins (or rejoins):
    /// saved (compacted) as of the last op, with that op's number.
    pub fn snapshot(&self, history: &EditHistory) -> Snapshot {
        let (log, steps) = history.saved();
        Snapshot {
            through: self.last,
            log,
            steps,
        }
    }
}

/// A replica's place in the authority's numbering: applies the authority's
/// ops to the replica's history in order, each once. The history stays with
/// its owner (a volume).
#[derive(Clone, Debug, Default)]
pub struct Replica {
    /// The last op applied.
    applied: u64,
    /// Ops that came early, by number.
    early: BTreeMap<u64, EditOp>,
}

impl Replica {
    /// A replica whose history holds the authority's ops up to `through`.
    pub fn new(through: u64) -> Self {
        Replica {
            applied: through,
            early: BTreeMap::new(),
        }
    }

    /// A replica starting from `snapshot` on `base` (the shared field with no
    /// brushes), and its history.
    pub fn join(base: EditedField, snapshot: Snapshot) -> Result<(Self, EditHistory)> {
        let history = EditHistory::restore(base, snapshot.log, &snapshot.steps)?;
        Ok((Replica::new(snapshot.through), history))
    }

    /// The number of the last op applied.
    pub fn applied(&self) -> u64 {
        self.applied
    }

    /// Takes op `n`: applies it to `history` (keeping at most `max_steps` undo
    /// steps), with every early op it unblocks, in order, and returns the
    /// reaches they changed. An op already applied, or already waiting, is
    /// ignored. An op the history refuses is an error (the authority accepted
    /// it, so the two histories differ: rejoin).
    pub fn receive(
        &mut self,
        history: &mut EditHistory,
        max_steps: usize,
        n: u64,
        op: EditOp,
    ) -> Result<Vec<(glam::Vec3, f32)>> {
        let mut reaches = Vec::new();
        for op in self.ready(n, op) {
            reaches.extend(op.apply_to(history, max_steps)?);
        }
        Ok(reaches)
    }

    /// Takes op `n` and returns the ops now due, in order (it and every early
    /// op it unblocks), counting them applied: the caller applies them to the
    /// replica's history in that order. An op already applied, or already
    /// waiting, gives nothing.
    pub fn ready(&mut self, n: u64, op: EditOp) -> Vec<EditOp> {
        if n <= self.applied {
            return Vec::new();
        }
        self.early.entry(n).or_insert(op);
        let mut due = Vec::new();
        while let Some(op) = self.early.remove(&(self.applied + 1)) {
            due.push(op);
            self.applied += 1;
        }
        due
    }

    /// Ops that arrived ahead of a missing one and wait for it.
    pub fn waiting(&self) -> usize {
        self.early.len()
    }

    /// The ops to ask for again: from the first missing one up to the first
    /// that has arrived, or `None` when nothing is missing. Ops after the
    /// newest that has arrived cannot be known missing until a later one
    /// arrives (or the authority says how many there are:
    /// [`Replica::missing_before`]).
    pub fn missing(&self) -> Option<Range<u64>> {
        let (&first, _) = self.early.iter().next()?;
        Some(self.applied + 1..first)
    }

    /// The ops to ask for again given that the authority's last op is `last`.
    pub fn missing_before(&self, last: u64) -> Option<Range<u64>> {
        self.missing().or_else(|| {
            let end = last + 1;
            (self.applied + 1 < end).then_some(self.applied + 1..end)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::test_base as base;
    use crate::edit::BrushOp;
    use crate::field::Field;
    use glam::Vec3;

    /// Op `i` of a session: dabs (some continuing a stroke), undos, redos.
    fn op(i: u64, r: u64) -> EditOp {
        match r % 7 {
            0 => EditOp::Undo,
            1 => EditOp::Redo,
            k => {
                let a = i as f32 * 0.37;
                let op = if k % 2 == 0 {
                    BrushOp::Subtract
                } else {
                    BrushOp::SmoothAdd { radius: 0.5 }
                };
                EditOp::Apply {
                    brush: Brush::sphere(Vec3::new(10.0 * a.cos(), 10.0 * a.sin(), 0.0), 1.5, op),
                    continues_stroke: k > 4,
                }
            }
        }
    }

    fn samples(h: &EditHistory) -> Vec<u32> {
        (0..600)
            .map(|i| {
                let t = i as f32;
                let p = Vec3::new((t * 0.7).sin(), (t * 0.3).cos(), (t * 0.11).sin()) * 11.0;
                h.field().value(p).to_bits()
            })
            .collect()
    }

    /// A replica's state as the authority's, to compare (a replica that
    /// joined from a snapshot holds the compacted floor, so their saved forms
    /// are compared, not their logs).
    fn same(a: &EditHistory, b: &EditHistory) {
        assert_eq!(a.saved(), b.saved());
        assert_eq!(a.undo_steps(), b.undo_steps());
        assert_eq!(a.redo_steps(), b.redo_steps());
        assert_eq!(samples(a), samples(b));
    }

    #[test]
    fn replicas_converge_through_loss_duplicates_and_reordering() {
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let steps = 12;
        let mut server = (Sequencer::new(12), EditHistory::new(base()));
        let join =
            |s: &(Sequencer, EditHistory)| Replica::join(base(), s.0.snapshot(&s.1)).unwrap();
        let mut clients = [join(&server), join(&server), join(&server)];
        let mut rejoined = 0;
        // Messages in flight to each client: (deliver at round, number, op).
        let mut wire: Vec<Vec<(u64, u64, EditOp)>> = vec![Vec::new(); 3];
        let mut applied_twice = 0;
        for round in 0..600u64 {
            let o = op(round, next());
            let (n, _) = server.0.accept(&mut server.1, steps, o.clone()).unwrap();
            for w in wire.iter_mut() {
                match next() % 10 {
                    0 => {} // lost
                    1 => {
                        // duplicated
                        w.push((round + next() % 5, n, o.clone()));
                        w.push((round + next() % 9, n, o.clone()));
                    }
                    _ => w.push((round + next() % 4, n, o.clone())),
                }
            }
            for (c, w) in clients.iter_mut().zip(wire.iter_mut()) {
                let (now, later): (Vec<_>, Vec<_>) = w.drain(..).partition(|m| m.0 <= round);
                *w = later;
                for (_, n, o) in now {
                    let before = c.0.applied();
                    c.0.receive(&mut c.1, steps, n, o).unwrap();
                    assert!(c.0.applied() >= before);
                    applied_twice += (n <= before) as usize;
                }
                // Every tenth round a client asks for what it misses (and
                // starts again from a snapshot if that is no longer kept).
                if round % 10 == 0 {
                    if let Some(r) = c.0.missing_before(server.0.last()) {
                        match server.0.ops(r) {
                            Some(ops) => {
                                for (n, o) in ops {
                                    c.0.receive(&mut c.1, steps, n, o).unwrap();
                                }
                            }
                            None => {
                                *c = join(&server);
                                rejoined += 1;
                            }
                        }
                    }
                }
            }
            // One client is away for 80 rounds (everything to it is lost),
            // then rejoins from a snapshot.
            if (300..380).contains(&round) {
                wire[2].clear();
            }
            if round == 380 {
                clients[2] = join(&server);
            }
        }
        assert!(applied_twice > 0, "duplicates arrived and were ignored");
        eprintln!(
            "{applied_twice} duplicate deliveries ignored, {rejoined} rejoins for lost ranges"
        );
        // Settle: deliver the rest and fill every gap.
        for (c, w) in clients.iter_mut().zip(wire.iter_mut()) {
            for (_, n, o) in w.drain(..) {
                c.0.receive(&mut c.1, steps, n, o).unwrap();
            }
            while let Some(r) = c.0.missing_before(server.0.last()) {
                match server.0.ops(r) {
                    Some(ops) => {
                        for (n, o) in ops {
                            c.0.receive(&mut c.1, steps, n, o).unwrap();
                        }
                    }
                    None => *c = join(&server),
                }
            }
            assert_eq!(c.0.applied(), server.0.last());
            same(&c.1, &server.1);
        }
    }

    #[test]
    fn a_late_joiner_starts_from_the_compacted_history() {
        let (mut server, mut history) = (Sequencer::new(100), EditHistory::new(base()));
        for i in 0..500 {
            server.accept(&mut history, 8, op(i, i * 3 + 2)).unwrap();
        }
        let snapshot = server.snapshot(&history);
        assert_eq!(snapshot.through, 500);
        let kept = snapshot.log.len();
        let (mut late, mut late_history) = Replica::join(base(), snapshot).unwrap();
        same(&late_history, &history);
        eprintln!("500 ops: a snapshot of {kept} brushes");
        // Only the newest 100 ops are kept one by one.
        assert!(server.ops(1..10).is_none());
        assert_eq!(server.ops(401..403).unwrap().len(), 2);
        for i in 500..520 {
            let (n, _) = server.accept(&mut history, 8, op(i, i)).unwrap();
            let o = server.ops(n..n + 1).unwrap()[0].1.clone();
            late.receive(&mut late_history, 8, n, o).unwrap();
        }
        same(&late_history, &history);
        assert_eq!(late.missing_before(server.last()), None);
        // A gap is reported as the range to ask for.
        let (a, _) = server.accept(&mut history, 8, EditOp::Undo).unwrap();
        let (b, _) = server.accept(&mut history, 8, EditOp::Redo).unwrap();
        late.receive(&mut late_history, 8, b, EditOp::Redo).unwrap();
        assert_eq!(late.missing(), Some(a..b));
        assert_eq!(late.waiting(), 1);
        assert_eq!(late.applied(), a - 1);
    }
}
