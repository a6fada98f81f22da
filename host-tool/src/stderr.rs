//! Messages on stderr that never end the program: std's `eprintln!` panics (exit 101) when
//! stderr is closed (`2>&1 >/dev/null | head -n 1`) or full; a warning or a status line lost
//! that way is no reason to fail a command, so every line this tool writes to stderr goes
//! through [`eprintln_best_effort!`](crate::eprintln_best_effort).

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

#[cfg(test)]
mod tests {
    #[test]
    fn expands_with_and_without_arguments() {
        // Writes to the test's stderr; the point is that both forms compile and return ().
        let () = crate::eprintln_best_effort!();
        let () = crate::eprintln_best_effort!("{} {x}", 1, x = 2);
    }
}
