//! Long calls without the GIL, interruptible by Ctrl-C — the call only.
//!
//! The work runs on a scoped worker thread while the calling thread, the GIL released,
//! waits for it in slices of [`SLICE`]; between slices it takes the GIL for
//! `Python::check_signals` (which runs Python's signal handlers: on the main thread a
//! SIGINT raises `KeyboardInterrupt` there; on other threads it does nothing). When a
//! handler raises, this call's [`StopToken`] is stopped (the runs poll it at every output
//! step, the sweeps before every point; calls of other threads have their own token and
//! run on), the worker is waited for (it stops within one output step), and the handler's
//! exception is raised — never the partial result. Results are held in memory until the
//! call returns, so nothing is half-written.
//!
//! At interpreter exit a daemon thread's call cannot take the GIL any more
//! (`Python::try_attach` fails): the call is stopped and its thread parks until it ends
//! with the process, without touching Python again (returning would re-take the GIL, and a
//! finalizing CPython ends such a thread by a forced unwind, which aborts the process when
//! it meets the binding's panic guard).

use std::sync::mpsc;
use std::time::Duration;

use codegen_cli::Error;
use codegen_cli::interrupt::StopToken;
use pyo3::prelude::*;

/// The worker thread's name.
pub const WORKER: &str = "damper-worker";

/// How often the waiting thread looks at Python's signals.
const SLICE: Duration = Duration::from_millis(25);

/// Runs `job` without the GIL on a worker thread, watching for Python signals (see the
/// module documentation). `Ok(Err(e))`: the job's own error; `Err`: a signal handler's
/// exception (the job was stopped) or a panic of the job.
pub fn interruptible<T, F>(py: Python<'_>, job: F) -> PyResult<Result<T, Error>>
where
    T: Send,
    F: FnOnce() -> Result<T, Error> + Send,
{
    let token = StopToken::new();
    let mut raised: Option<PyErr> = None;
    let joined = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel::<()>();
            let worker_token = token.clone();
            // Named, so that a test (or a profiler) can see the run in progress.
            let worker = std::thread::Builder::new()
                .name(WORKER.into())
                .spawn_scoped(s, move || {
                    let out = worker_token.run(job);
                    let _ = tx.send(());
                    out
                })
                .map_err(|e| {
                    pyo3::exceptions::PyRuntimeError::new_err(format!(
                        "cannot start the worker thread: {e}"
                    ))
                })?;
            // Bounded by the job: it ends by itself, or within an output step of a stop.
            loop {
                match rx.recv_timeout(SLICE) {
                    Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => break,
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                }
                if raised.is_some() || token.is_stopped() {
                    continue;
                }
                match Python::try_attach(|py| py.check_signals()) {
                    Some(Ok(())) => {}
                    Some(Err(e)) => {
                        raised = Some(e);
                        token.stop();
                    }
                    // The interpreter is shutting down: stop the call and never return
                    // to Python (re-taking the GIL there would end this thread by a forced
                    // unwind through the binding's frames: an abort, "exception not
                    // rethrown"); the thread ends with the process.
                    None => {
                        token.stop();
                        loop {
                            std::thread::park();
                        }
                    }
                }
            }
            Ok::<_, PyErr>(worker.join())
        })
    })?;
    if let Some(e) = raised {
        return Err(e);
    }
    if token.is_stopped() {
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(
            "interrupted: the interpreter is shutting down",
        ));
    }
    match joined {
        Ok(out) => Ok(out),
        Err(_) => Err(pyo3::exceptions::PyRuntimeError::new_err(
            "the computation panicked (a bug: please report it)",
        )),
    }
}
