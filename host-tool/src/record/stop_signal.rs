//! The recorder's stop request: Ctrl-C (SIGINT), SIGTERM (a service manager, `kill`) and SIGHUP
//! (the terminal closed) all ask for the same clean stop — final flush, MCAP summary and footer,
//! exit 0. One portable handler (`ctrlc` with its `termination` feature) rather than platform
//! signal code: std has none and `unsafe_code` is denied.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Exit code of a second stop request while the first one is still being honoured (the user
/// wants out now; the log holds what was flushed): 128 + SIGINT, as a shell reports it.
pub const FORCED_EXIT_CODE: i32 = 130;

/// Installs the handler once per process; the returned flag turns `true` at the first SIGINT,
/// SIGTERM or SIGHUP, and a second one exits at once with [`FORCED_EXIT_CODE`].
pub fn install() -> Result<Arc<AtomicBool>, ctrlc::Error> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::Relaxed) {
            std::process::exit(FORCED_EXIT_CODE);
        }
    })?;
    Ok(stop)
}
