//! SIGINT and SIGTERM: one policy for every command.
//!
//! Summaries and plots are held in memory until the run is over; time histories are
//! streamed row by row to a temporary file next to their final name
//! ([`crate::report::stream`]). Everything is committed as a set at the end by the one
//! writer ([`crate::report::writer`], and `generate`'s write-if-changed). So an interrupted
//! run has nothing to save half-way:
//!
//! - a signal **before the commit** removes the temporary files of the streamed time
//!   histories and the output directories created for them, then ends the process with
//!   status 128 + signal (130 for SIGINT, 143 for SIGTERM): nothing is written, no output
//!   directory is left, no temporary file exists;
//! - a signal **during the commit** waits for the commit to finish (it is short and
//!   atomic), then exits the same way: the set of files is complete, never half-replaced,
//!   and no temporary file is left;
//! - a **second** signal exits immediately, even during a commit (for a commit blocked on a
//!   fifo without a reader); only then can a temporary file be left behind.
//!
//! [`install`] is called once by the binary; the library functions only mark their commit
//! sections ([`commit_section`]) and register their temporary files ([`Leftovers`]), so
//! library users without [`install`] keep the default behaviour.
//!
//! A library user that handles signals itself (the Python package: Ctrl-C is Python's
//! `KeyboardInterrupt`) asks the runs in progress to stop with [`request_stop`]: the
//! hybrid time-domain runs poll [`stop_requested`] at every output step, the closed-loop
//! mechanism runs before every step (`Simulator::set_stop`), the steady states of the
//! nonlinear frequency response every period, the sweeps before every point, and fail with
//! [`crate::Error::Interrupted`]; nothing is half-written (runs held
//! in memory write nothing at all). [`clear_stop`] re-arms the flag before the next call.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use signal_hook::consts::{SIGINT, SIGTERM};

/// Set by [`request_stop`]: the runs in progress stop at their next output step.
static STOP: AtomicBool = AtomicBool::new(false);

/// Asks every run in progress in this process to stop at its next output step (it fails
/// with [`crate::Error::Interrupted`]); stays set until [`clear_stop`].
pub fn request_stop() {
    STOP.store(true, Ordering::SeqCst);
}

/// Whether [`request_stop`] was called since the last [`clear_stop`].
pub fn stop_requested() -> bool {
    STOP.load(Ordering::Relaxed)
}

/// Re-arms the flag of [`request_stop`] (before a new call of the library).
pub fn clear_stop() {
    STOP.store(false, Ordering::SeqCst);
}

/// Held while output files are being committed.
static COMMIT: Mutex<()> = Mutex::new(());

/// Marks a commit of output files: a signal arriving while the guard lives is handled when
/// it is dropped.
pub fn commit_section() -> MutexGuard<'static, ()> {
    COMMIT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Temporary files of streamed outputs not yet committed, and the output directories
/// created for them: what a signal before the commit removes.
#[derive(Debug, Default)]
pub struct Leftovers {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
}

static LEFTOVERS: Mutex<Leftovers> = Mutex::new(Leftovers {
    files: vec![],
    dirs: vec![],
});

fn leftovers() -> MutexGuard<'static, Leftovers> {
    LEFTOVERS.lock().unwrap_or_else(|e| e.into_inner())
}

impl Leftovers {
    /// Records a temporary file and the directories created for it (outermost first).
    pub fn register(tmp: &Path, created_dirs: &[PathBuf]) {
        let mut l = leftovers();
        l.files.push(tmp.to_path_buf());
        l.dirs.extend(created_dirs.iter().cloned());
    }

    /// Forgets a temporary file that was committed (renamed to its final name); the
    /// directories above it now hold an output and are forgotten too.
    pub fn committed(tmp: &Path) {
        let mut l = leftovers();
        l.files.retain(|f| f != tmp);
        l.dirs.retain(|d| !tmp.starts_with(d));
    }

    /// Removes a temporary file that will not be committed, and then the directories
    /// created above it that no other registered temporary file needs (when empty).
    pub fn abandon(tmp: &Path) {
        let mut l = leftovers();
        let _ = std::fs::remove_file(tmp);
        l.files.retain(|f| f != tmp);
        let files = l.files.clone();
        let (free, kept): (Vec<PathBuf>, Vec<PathBuf>) = l
            .dirs
            .drain(..)
            .partition(|d| tmp.starts_with(d) && !files.iter().any(|f| f.starts_with(d)));
        l.dirs = kept;
        for d in free.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }

    /// Removes every registered temporary file, then the registered directories (innermost
    /// first, when empty).
    fn remove_all() {
        let mut l = leftovers();
        for f in l.files.drain(..) {
            let _ = std::fs::remove_file(f);
        }
        for d in l.dirs.drain(..).rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Installs the policy described in the module documentation: a watcher thread receives
/// SIGINT and SIGTERM, waits for a running commit to finish, removes the temporary files
/// of streamed outputs not committed ([`Leftovers`]) and exits with 128 + signal; a second
/// signal exits at once.
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
                Leftovers::remove_all();
                std::process::exit(128 + sig);
            }
        })?;
    Ok(())
}
