//! Stop signals: Ctrl-C (SIGINT), SIGTERM (a service manager, `kill`) and SIGHUP (the terminal
//! closed). One portable handler (`ctrlc` with its `termination` feature) rather than platform
//! signal code: std has none and `unsafe_code` is denied. Installed once per process by
//! [`install_for_every_command`]:
//! - a command that stops cleanly (`record`, `replay`, `decode`) asks for a flag with
//!   [`install`]: the first signal sets it (final flush, MCAP summary and footer, exit 0), a
//!   second one exits at once;
//! - every other command exits at the first signal;
//!
//! and either way, before exiting, the temporary files and staging directories of the writes
//! under way are removed ([`crate::temp_paths`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// Exit code of a stop by signal (the user wants out now; a log holds what was flushed):
/// 128 + SIGINT, as a shell reports it.
pub const FORCED_EXIT_CODE: i32 = 130;

/// Set when a signal exits the process, before the temporary paths are removed: a command
/// that fails meanwhile (its staging directory removed under it) must not exit with its own
/// code first ([`exiting`]).
static EXITING: AtomicBool = AtomicBool::new(false);

/// Whether a stop signal is exiting the process (its handler exits with
/// [`FORCED_EXIT_CODE`] once the temporary paths are removed).
pub fn exiting() -> bool {
    EXITING.load(Ordering::SeqCst)
}

/// The flag of a command that stops cleanly, once it asked for one.
static CLEAN_STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Installs the process's handler; installing it again is harmless.
pub fn install_for_every_command() -> Result<(), ctrlc::Error> {
    let handled = ctrlc::set_handler(|| {
        if let Some(flag) = CLEAN_STOP.get() {
            if !flag.swap(true, Ordering::Relaxed) {
                return;
            }
        }
        EXITING.store(true, Ordering::SeqCst);
        crate::temp_paths::remove_all();
        std::process::exit(FORCED_EXIT_CODE);
    });
    match handled {
        Ok(()) | Err(ctrlc::Error::MultipleHandlers) => Ok(()),
        Err(e) => Err(e),
    }
}

/// The stop flag of a command that stops cleanly: `true` from the first SIGINT, SIGTERM or
/// SIGHUP on; a second one exits at once with [`FORCED_EXIT_CODE`].
pub fn install() -> Result<Arc<AtomicBool>, ctrlc::Error> {
    install_for_every_command()?;
    Ok(Arc::clone(
        CLEAN_STOP.get_or_init(|| Arc::new(AtomicBool::new(false))),
    ))
}
