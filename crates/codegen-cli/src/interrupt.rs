//! SIGINT and SIGTERM: one policy for every command.
//!
//! Every output of a run is held in memory until the run is over and then committed as a
//! set by the one writer ([`crate::report::commit_files`], and `generate`'s
//! write-if-changed). So an interrupted run has nothing to save half-way:
//!
//! - a signal **before the commit** ends the process at once with status 128 + signal
//!   (130 for SIGINT, 143 for SIGTERM): nothing is written, no output directory is created,
//!   no temporary file exists;
//! - a signal **during the commit** waits for the commit to finish (it is short and
//!   atomic), then exits the same way: the set of files is complete, never half-replaced,
//!   and no temporary file is left;
//! - a **second** signal exits immediately, even during a commit (for a commit blocked on a
//!   fifo without a reader); only then can a temporary file be left behind.
//!
//! [`install`] is called once by the binary; the library functions only mark their commit
//! sections ([`commit_section`]), so library users without [`install`] keep the default
//! behaviour.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, MutexGuard};

use signal_hook::consts::{SIGINT, SIGTERM};

/// Held while output files are being committed.
static COMMIT: Mutex<()> = Mutex::new(());

/// Marks a commit of output files: a signal arriving while the guard lives is handled when
/// it is dropped.
pub fn commit_section() -> MutexGuard<'static, ()> {
    COMMIT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Installs the policy described in the module documentation: a watcher thread receives
/// SIGINT and SIGTERM, waits for a running commit to finish and exits with 128 + signal; a
/// second signal exits at once.
pub fn install() -> std::io::Result<()> {
    let received = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Order matters: the shutdown checks the flag before the second action sets it.
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&received))?;
        signal_hook::flag::register(sig, Arc::clone(&received))?;
    }
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let _commit = commit_section();
                std::process::exit(128 + sig);
            }
        })?;
    Ok(())
}
