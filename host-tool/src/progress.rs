//! Progress bars for jobs that take longer than a second (indicatif), shown on stderr only when
//! it is a terminal and `--quiet` was not given; the running status line of the commands that
//! run until stopped.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

static QUIET: AtomicBool = AtomicBool::new(false);

/// The bar's layout: what, bar, position/length, elapsed and remaining time.
const TEMPLATE: &str = "{msg} [{bar:30}] {human_pos}/{human_len} ({elapsed} elapsed, {eta} left)";

/// Hides every bar from now on (the CLI's `--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether bars are drawn: stderr is a terminal and not quiet.
pub fn visible() -> bool {
    !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal()
}

/// A bar of `len` steps labelled `what`; hidden (every call a no-op) unless [`visible`].
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let target = if visible() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let style = ProgressStyle::with_template(TEMPLATE)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    ProgressBar::with_draw_target(Some(len), target)
        .with_style(style)
        .with_message(what.to_owned())
}

/// How often a status goes into a file or a pipe: a line a person reads, not a redraw.
pub const LOGGED_STATUS_EVERY: Duration = Duration::from_secs(10);

/// A running status on stderr (`record`, `decode`): one line rewritten in place on a terminal;
/// into a file or a pipe a line at most every [`LOGGED_STATUS_EVERY`], and every one the caller
/// marks as news (a device gone or back, the last one), so an hour's recording logs a few
/// hundred lines, not one per redraw. A closed stderr is ignored.
#[derive(Debug)]
pub struct StatusLine {
    stderr: std::io::Stderr,
    live: bool,
    shown: bool,
    logged_at: Option<Instant>,
}

impl StatusLine {
    /// On stderr, live when it is a terminal.
    pub fn stderr() -> Self {
        let stderr = std::io::stderr();
        let live = stderr.is_terminal();
        Self {
            stderr,
            live,
            shown: false,
            logged_at: None,
        }
    }

    /// Whether `line` would be written now into a file or a pipe: the first, `news`, or one
    /// [`LOGGED_STATUS_EVERY`] after the last written.
    fn due(&self, news: bool, now: Instant) -> bool {
        news || self
            .logged_at
            .is_none_or(|at| now.duration_since(at) >= LOGGED_STATUS_EVERY)
    }

    /// Shows `line`: redrawn on a terminal; into a file or a pipe when [`due`](Self::due).
    pub fn show(&mut self, line: &str, news: bool) {
        let _ = if self.live {
            write!(self.stderr, "\r\x1b[2K{line}")
        } else {
            let now = Instant::now();
            if !self.due(news, now) {
                return;
            }
            self.logged_at = Some(now);
            writeln!(self.stderr, "{line}")
        };
        let _ = self.stderr.flush();
        self.shown = true;
    }

    /// On a terminal, ends the running line where it stands (it stays on screen).
    pub fn keep(&mut self) {
        if self.live && self.shown {
            let _ = writeln!(self.stderr);
        }
    }

    /// Replaces the running line (on a terminal) with `last`, or clears it.
    pub fn finish(&mut self, last: Option<&str>) {
        let _ = match (last, self.live && self.shown) {
            (Some(last), true) => writeln!(self.stderr, "\r\x1b[2K{last}"),
            (Some(last), false) => writeln!(self.stderr, "{last}"),
            (None, true) => write!(self.stderr, "\r\x1b[2K"),
            (None, false) => Ok(()),
        };
        let _ = self.stderr.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn into_a_file_a_status_is_written_when_due_or_news() {
        let start = Instant::now();
        let mut line = StatusLine {
            stderr: std::io::stderr(),
            live: false,
            shown: false,
            logged_at: None,
        };
        assert!(line.due(false, start), "the first");
        line.logged_at = Some(start);
        assert!(!line.due(false, start + Duration::from_secs(1)));
        assert!(line.due(true, start + Duration::from_secs(1)), "news");
        assert!(line.due(false, start + LOGGED_STATUS_EVERY));
    }

    #[test]
    fn template_parses() {
        assert!(ProgressStyle::with_template(TEMPLATE).is_ok());
    }

    #[test]
    fn quiet_hides_bars_and_they_still_count() {
        set_quiet(true);
        assert!(!visible());
        let pb = bar(10, "testing");
        assert!(pb.is_hidden());
        pb.inc(3);
        assert_eq!(pb.position(), 3);
        assert_eq!(pb.length(), Some(10));
        pb.finish_and_clear();
    }
}
