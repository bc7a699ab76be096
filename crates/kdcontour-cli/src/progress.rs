//! Progress for long commands on a terminal: the stage, the chunks done and the
//! time so far, on one line of stderr ([indicatif]). Nothing is drawn when stdout
//! or stderr is not a terminal (output piped or redirected) or with `--json`, so
//! scripts read exactly what they did before; the line is cleared before the
//! command prints its results or its error.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::cell::RefCell;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// How often the line redraws on its own, so the elapsed time moves during a
/// long stage with nothing to count.
const TICK: Duration = Duration::from_millis(100);

/// A stage with nothing to count.
const STAGE: &str = "{spinner} {msg} [{elapsed}]";

/// A stage that counts chunks.
const CHUNKS: &str = "{spinner} {msg}: {pos}/{len} chunks {wide_bar} [{elapsed}, about {eta} left]";

/// One command's progress line (hidden off a terminal).
pub struct Progress {
    /// The current stage's line; `None` when nothing is drawn.
    bar: RefCell<Option<ProgressBar>>,
    /// When the command started: every stage shows the time since.
    start: Instant,
}

impl Progress {
    /// The progress line of a command run with `--json` or not: shown only when
    /// both stdout and stderr are terminals and `json` is false.
    pub fn new(json: bool) -> Self {
        let terminal = std::io::stdout().is_terminal() && std::io::stderr().is_terminal();
        Self::shown_if(!json && terminal)
    }

    fn shown_if(shown: bool) -> Self {
        Progress {
            bar: RefCell::new(shown.then(ProgressBar::hidden)),
            start: Instant::now(),
        }
    }

    /// Whether the line is drawn.
    #[cfg(test)]
    fn is_shown(&self) -> bool {
        self.bar.borrow().is_some()
    }

    /// Replaces the stage's line by one set up whole before it is first drawn
    /// (style, message, count and the time so far), so no half-set line shows.
    fn begin(&self, template: &str, what: String, total: Option<u64>) {
        let mut bar = self.bar.borrow_mut();
        let Some(old) = bar.as_ref() else {
            return;
        };
        old.finish_and_clear();
        let new = ProgressBar::with_draw_target(total, ProgressDrawTarget::stderr())
            .with_style(style(template))
            .with_message(what)
            .with_elapsed(self.start.elapsed());
        new.enable_steady_tick(TICK);
        *bar = Some(new);
    }

    /// A stage with nothing to count (sampling, checking, writing).
    pub fn stage(&self, what: impl Into<String>) {
        self.begin(STAGE, what.into(), None);
    }

    /// A stage of `total` chunks, counted by [`Progress::done`].
    pub fn chunks(&self, what: impl Into<String>, total: u64) {
        self.begin(CHUNKS, what.into(), Some(total));
    }

    /// `n` more chunks of the stage done.
    pub fn done(&self, n: u64) {
        if let Some(bar) = self.bar.borrow().as_ref() {
            bar.inc(n);
        }
    }

    /// Runs `print` with the line taken away, so what it prints is not drawn
    /// over (the line comes back after).
    pub fn suspend<R>(&self, print: impl FnOnce() -> R) -> R {
        match self.bar.borrow().as_ref() {
            Some(bar) => bar.suspend(print),
            None => print(),
        }
    }

    /// Clears the line, before the command prints its results.
    pub fn finish(&self) {
        if let Some(bar) = self.bar.borrow_mut().take() {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    /// An error returned mid-stage clears the line too, before `main` prints it.
    fn drop(&mut self) {
        self.finish();
    }
}

/// A progress template (the templates above are fixed and valid).
fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .expect("a valid progress template")
        .progress_chars("=> ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_or_no_terminal_draws_nothing() {
        assert!(!Progress::new(true).is_shown());
        // The test harness captures stdout: not a terminal.
        assert!(!Progress::new(false).is_shown());
        assert!(!Progress::shown_if(false).is_shown());
    }

    #[test]
    fn stages_count_chunks_on_a_line_set_up_whole() {
        // Shown, on a hidden target (no terminal here): the same calls.
        let p = Progress::shown_if(true);
        p.stage("checking");
        p.chunks("building level 0", 10);
        p.done(3);
        {
            let bar = p.bar.borrow();
            let bar = bar.as_ref().expect("shown");
            assert_eq!((bar.position(), bar.length()), (3, Some(10)));
            assert_eq!(bar.message(), "building level 0");
        }
        p.stage("writing");
        assert_eq!(p.bar.borrow().as_ref().unwrap().length(), None);
        p.finish();
        assert!(!p.is_shown());
        // Hidden: nothing kept, the calls do nothing.
        let q = Progress::shown_if(false);
        q.chunks("building level 0", 10);
        q.done(3);
        assert_eq!(q.suspend(|| 7), 7);
    }
}
