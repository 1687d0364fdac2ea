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
//! `KeyboardInterrupt`) stops one call, not the process: it runs the call under a
//! [`StopToken`] ([`StopToken::run`]) and asks that call to stop with [`StopToken::stop`].
//! The token is the calling thread's (a thread-local), handed on to the threads the call
//! starts (the sweep's and the nonlinear frequency response's thread pools, the
//! optimiser's parallel grid: [`current`], [`StopToken::run`]); other calls, on other
//! threads, do not see it and run to their end. The hybrid time-domain runs poll
//! [`stop_requested`] at every output step, the closed-loop mechanism runs before every
//! step (`Simulator::set_stop`), the steady states of the nonlinear frequency response
//! every period, the sweeps before every point, and fail with
//! [`crate::Error::Interrupted`]; nothing is half-written (runs held in memory write
//! nothing at all).

use std::cell::RefCell;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use signal_hook::consts::{SIGINT, SIGTERM};

/// The stop request of one call of the library: cloned into every thread that works for
/// the call; [`StopToken::stop`] makes [`stop_requested`] true on those threads only.
#[derive(Clone, Debug, Default)]
pub struct StopToken(Arc<AtomicBool>);

thread_local! {
    /// The token of the call this thread works for (none: never asked to stop).
    static CURRENT: RefCell<Option<StopToken>> = const { RefCell::new(None) };
}

impl StopToken {
    /// A token not stopped.
    pub fn new() -> StopToken {
        StopToken::default()
    }

    /// Asks the call of this token to stop at its next output step (it fails with
    /// [`crate::Error::Interrupted`]); stays set.
    pub fn stop(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether [`StopToken::stop`] was called.
    pub fn is_stopped(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Runs `f` on this thread as work of this token's call (the previous token of the
    /// thread restored afterwards, also when `f` panics).
    pub fn run<R>(&self, f: impl FnOnce() -> R) -> R {
        with_current(Some(self.clone()), f)
    }
}

/// Runs `f` with `token` as this thread's (restored afterwards): how the threads a call
/// starts take on its token ([`current`] read before they start).
pub fn with_current<R>(token: Option<StopToken>, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<StopToken>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let previous = self.0.take();
            CURRENT.with(|c| *c.borrow_mut() = previous);
        }
    }
    let previous = CURRENT.with(|c| std::mem::replace(&mut *c.borrow_mut(), token));
    let _restore = Restore(previous);
    f()
}

/// Makes `token` this thread's for good: a thread started for one call only (the start
/// handler of a call's own thread pool).
pub fn adopt(token: Option<StopToken>) {
    CURRENT.with(|c| *c.borrow_mut() = token);
}

/// The token of the call this thread works for, to hand on to the threads it starts.
pub fn current() -> Option<StopToken> {
    CURRENT.with(|c| c.borrow().clone())
}

/// Whether the call this thread works for was asked to stop ([`StopToken::stop`]).
pub fn stop_requested() -> bool {
    CURRENT.with(|c| c.borrow().as_ref().is_some_and(StopToken::is_stopped))
}

/// Held while output files are being committed.
static COMMIT: Mutex<()> = Mutex::new(());

/// Marks a commit of output files: a signal arriving while the guard lives is handled when
/// it is dropped.
pub fn commit_section() -> MutexGuard<'static, ()> {
    COMMITTING.store(true, Ordering::SeqCst);
    COMMIT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Waits for a running commit without marking one as started (the signal handler's).
fn commit_section_unmarked() -> MutexGuard<'static, ()> {
    COMMIT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Set when a commit of output files starts ([`commit_section`]): a signal after it cannot
/// say that nothing was written.
static COMMITTING: AtomicBool = AtomicBool::new(false);

/// The line a signal prints before the process exits: "nothing written" unless a commit of
/// output files had started (outputs are only ever written by a commit).
fn interrupted_line() -> &'static str {
    if COMMITTING.load(Ordering::SeqCst) {
        "interrupted"
    } else {
        "interrupted: nothing written"
    }
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
                let _commit = commit_section_unmarked();
                Leftovers::remove_all();
                // A closed standard error is no reason not to exit.
                let _ = writeln!(std::io::stderr(), "{}", interrupted_line());
                std::process::exit(128 + sig);
            }
        })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_reaches_the_threads_of_its_call_only() {
        let a = StopToken::new();
        let b = StopToken::new();
        assert!(!stop_requested());
        a.stop();
        assert!(a.run(stop_requested));
        assert!(
            !b.run(stop_requested),
            "another call's token is not stopped"
        );
        assert!(!stop_requested(), "no token outside a call");
        // Handed on to a thread the call starts.
        let seen = a.run(|| {
            let token = current();
            std::thread::spawn(move || with_current(token, stop_requested))
                .join()
                .unwrap()
        });
        assert!(seen);
        // Restored after a nested call and after a panic.
        b.run(|| {
            assert!(a.run(stop_requested));
            assert!(!stop_requested());
        });
        let caught = std::panic::catch_unwind(|| a.run(|| panic!("boom")));
        assert!(caught.is_err());
        assert!(!stop_requested());
    }
}
