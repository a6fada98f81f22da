//! Messages on stderr that never end the program: std's `eprintln!` panics (exit 101) when
//! stderr is closed (`2>&1 >/dev/null | head -n 1`) or full; a warning or a status line lost
//! that way is no reason to fail a command, so every line this tool writes to stderr goes
//! through [`eprintln_best_effort!`](crate::eprintln_best_effort). [`error_text`] is how an
//! error reads there (and in the Python package's exceptions).

use std::fmt;
use std::io::{self, Write};

/// Like `eprintln!`, but a stderr that cannot be written (closed, full) is ignored instead of
/// panicking.
#[macro_export]
macro_rules! eprintln_best_effort {
    () => {
        $crate::stderr::write_line(::std::format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::stderr::write_line(::std::format_args!($($arg)*))
    };
}

/// Writes `args` and a newline to stderr, ignoring write errors (see [`eprintln_best_effort!`](crate::eprintln_best_effort)).
pub fn write_line(args: fmt::Arguments<'_>) {
    let mut err = io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

/// The error's message and its causes, each cause once: a library error names its source in
/// its own text (whole when shown alone, as in a report), so a cause whose text the message
/// already holds is not printed again (`{:#}` would: `x.csv: No such file or directory (os
/// error 2): No such file or directory (os error 2)`).
pub fn error_text(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let cause = cause.to_string();
        if text.contains(&cause) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&cause);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;
    use anyhow::Context;
    use std::io;

    #[derive(Debug, thiserror::Error)]
    #[error("{path}: {source}")]
    struct Named {
        path: &'static str,
        #[source]
        source: io::Error,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("{0}")]
    struct Quoting(#[source] Named);

    #[test]
    fn error_text_prints_each_cause_once() {
        let missing = || io::Error::new(io::ErrorKind::NotFound, "No such file or directory");
        // A source quoted in the message, twice over (wrapper and file error).
        let quoted = anyhow::Error::new(Quoting(Named {
            path: "nosuch.csv",
            source: missing(),
        }));
        assert_eq!(error_text(&quoted), "nosuch.csv: No such file or directory");
        // Context that does not quote its cause keeps it, once.
        let context = Err::<(), _>(missing())
            .context("reading x.csv")
            .expect_err("error");
        assert_eq!(
            error_text(&context),
            "reading x.csv: No such file or directory"
        );
        // Both: context above a quoting error.
        let both = Err::<(), _>(Named {
            path: "/dev/ttyNOPE",
            source: missing(),
        })
        .context("record")
        .expect_err("error");
        assert_eq!(
            error_text(&both),
            "record: /dev/ttyNOPE: No such file or directory"
        );
    }

    #[test]
    fn expands_with_and_without_arguments() {
        // Writes to the test's stderr; the point is that both forms compile and return ().
        let () = crate::eprintln_best_effort!();
        let () = crate::eprintln_best_effort!("{} {x}", 1, x = 2);
    }
}
