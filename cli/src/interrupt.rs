//! Signals: Ctrl-C asks a run to stop after its current step and write what it computed (the
//! command then exits with 130, the shell's code for an interrupt); a second Ctrl-C ends the
//! process at once. A closed pipe (`lieflow run | head`) ends the command quietly, as it does
//! any Unix tool, instead of failing to print.

use std::sync::atomic::{AtomicBool, Ordering};

/// Raised by the first Ctrl-C once [`catch_interrupt`] has been called.
pub(crate) static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The exit code of a run stopped by Ctrl-C (`128 + SIGINT`).
pub(crate) const EXIT_INTERRUPTED: u8 = 130;

#[cfg(unix)]
extern "C" fn on_interrupt(_signal: libc::c_int) {
    INTERRUPTED.store(true, Ordering::SeqCst);
    // The next Ctrl-C takes the default action (`signal` is async-signal-safe).
    // SAFETY: resetting a signal's disposition to its default is always sound.
    unsafe {
        libc::signal(libc::SIGINT, libc::SIG_DFL);
    }
}

/// Restores the default action of `SIGPIPE` (Rust ignores it, so printing to a closed pipe
/// would fail with an error on every line): a closed reader ends the command.
pub(crate) fn default_pipe() {
    #[cfg(unix)]
    // SAFETY: setting the default disposition of SIGPIPE at start-up, before any thread runs.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Catches Ctrl-C from now on: the first raises [`INTERRUPTED`], the second ends the process.
pub(crate) fn catch_interrupt() {
    #[cfg(unix)]
    // SAFETY: the handler only stores to an atomic and calls `signal`, both async-signal-safe.
    unsafe {
        libc::signal(
            libc::SIGINT,
            on_interrupt as extern "C" fn(libc::c_int) as libc::sighandler_t,
        );
    }
}
