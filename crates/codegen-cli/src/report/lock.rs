//! The lock of an output directory: one run at a time writes into a directory, so two runs
//! into the same `-o` can never leave a mixed set of files.
//!
//! A run holds an exclusive advisory lock (`flock(2)`, through `rustix`) on
//! `<dir>/.damper.lock` for its whole duration; a second run into the directory is refused
//! at once with the owner's process id ([`LockError::Busy`]). The kernel releases the lock
//! when its process ends, however it ends (a `SIGKILL` too), so a stale lock file never
//! blocks the next run. The file is removed when the run ends.
//!
//! Under the lock, the next run also removes the temporary files `<name>.tmp-<pid>` that a
//! killed run left in the directory (their process is gone; [`super::stream`]).
//!
//! The directory is created (with its missing parents) when it is locked; a run that fails
//! removes the directories it created when they are empty.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::writer::create_dirs;
use crate::interrupt::Leftovers;

/// Name of the lock file in an output directory.
pub const LOCK_FILE: &str = ".damper.lock";

/// An output directory that cannot be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another run holds the lock.
    #[error(
        "output directory {} is in use by another run ({}lock file {}): wait for it to end or write elsewhere with -o",
        dir.display(),
        owner.map(|p| format!("process {p}, ")).unwrap_or_default(),
        lock.display()
    )]
    Busy {
        /// The directory.
        dir: PathBuf,
        /// Its lock file.
        lock: PathBuf,
        /// The process holding it, when it could be read.
        owner: Option<u32>,
    },
    /// The directory or its lock file cannot be created or locked.
    #[error("cannot lock the output directory {}: {what} {}: {error}", dir.display(), path.display())]
    Io {
        /// The directory.
        dir: PathBuf,
        /// What failed.
        what: &'static str,
        /// The file or directory concerned.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
}

/// The exclusive lock of an output directory, held until dropped (see the module
/// documentation).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    _file: File,
}

impl OutputLock {
    /// Locks `dir` (created when missing), then removes the temporary files left there by
    /// runs that were killed.
    pub fn acquire(dir: &Path) -> Result<OutputLock, LockError> {
        let io = |what: &'static str, path: &Path, error: std::io::Error| LockError::Io {
            dir: dir.to_path_buf(),
            what,
            path: path.to_path_buf(),
            error,
        };
        let created = create_dirs(dir).map_err(|e| io("create the directory", dir, e))?;
        let path = dir.join(LOCK_FILE);
        let mut file = match Self::lock(dir, &path) {
            Ok(file) => file,
            Err(e) => {
                // The lock file is another run's unless the directory is ours.
                if !created.is_empty() {
                    let _ = std::fs::remove_file(&path);
                }
                for d in created.iter().rev() {
                    let _ = std::fs::remove_dir(d);
                }
                return Err(e);
            }
        };
        // A signal from here on, or a failed run, removes the lock file and the directories
        // created for it (when empty).
        Leftovers::register(&path, &created);
        let _ = file
            .set_len(0)
            .and_then(|()| writeln!(file, "{}", std::process::id()));
        remove_stale_tmp_files(dir);
        Ok(OutputLock { path, _file: file })
    }

    /// Opens and locks the lock file; retries when it was replaced under us (a run removing
    /// its lock file as we opened it).
    fn lock(dir: &Path, path: &Path) -> Result<File, LockError> {
        let io = |what: &'static str, error: std::io::Error| LockError::Io {
            dir: dir.to_path_buf(),
            what,
            path: path.to_path_buf(),
            error,
        };
        for _ in 0..100 {
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
                .map_err(|e| io("create", e))?;
            match try_lock(&file) {
                Ok(true) => {}
                Ok(false) => {
                    let owner = std::fs::read_to_string(path)
                        .ok()
                        .and_then(|s| s.trim().parse().ok());
                    return Err(LockError::Busy {
                        dir: dir.to_path_buf(),
                        lock: path.to_path_buf(),
                        owner,
                    });
                }
                Err(e) => return Err(io("lock", e)),
            }
            if same_file(&file, path) {
                return Ok(file);
            }
        }
        Err(io(
            "lock",
            std::io::Error::other("the lock file keeps being replaced"),
        ))
    }
}

impl Drop for OutputLock {
    /// Removes the lock file (still locked: a run that opened it meanwhile sees it replaced
    /// and retries), then the directories created for it when the run left them empty.
    fn drop(&mut self) {
        Leftovers::abandon(&self.path);
    }
}

/// Takes the exclusive lock of `file` without waiting: `Ok(false)` when another process
/// holds it.
#[cfg(unix)]
fn try_lock(file: &File) -> std::io::Result<bool> {
    use rustix::fs::{FlockOperation, flock};
    match flock(file, FlockOperation::NonBlockingLockExclusive) {
        Ok(()) => Ok(true),
        Err(e) if e == rustix::io::Errno::WOULDBLOCK => Ok(false),
        Err(e) => Err(e.into()),
    }
}

/// Without `flock`, a directory is not locked.
#[cfg(not(unix))]
fn try_lock(_file: &File) -> std::io::Result<bool> {
    Ok(true)
}

/// Whether the open `file` is still the one at `path`.
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.exists()
}

/// The process id of a temporary file name `<name>.tmp-<pid>` ([`super::writer`]).
pub(crate) fn tmp_pid(name: &str) -> Option<u32> {
    let (stem, pid) = name.rsplit_once(".tmp-")?;
    if stem.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// Whether process `pid` is running (Linux: `/proc/<pid>`; elsewhere every other process
/// counts as gone, the directory being locked).
fn alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    proc.join("self").exists() && proc.join(pid.to_string()).exists()
}

/// Removes the regular files `<name>.tmp-<pid>` of `dir` whose process is not this one and
/// not running: left by a killed run (called under the directory's lock).
fn remove_stale_tmp_files(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let me = std::process::id();
    let mut removed = vec![];
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(tmp_pid) else {
            continue;
        };
        let regular = e.file_type().is_ok_and(|t| t.is_file());
        if regular && pid != me && !alive(pid) && std::fs::remove_file(e.path()).is_ok() {
            removed.push(name.to_string_lossy().into_owned());
        }
    }
    if !removed.is_empty() {
        removed.sort();
        eprintln!(
            "note: {}: removed {} temporary file(s) left by a run that was killed: {}",
            dir.display(),
            removed.len(),
            removed.join(", ")
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_file_names_give_their_process() {
        assert_eq!(tmp_pid("time_history.csv.tmp-1234"), Some(1234));
        assert_eq!(tmp_pid("a.tmp-1.tmp-77"), Some(77));
        for no in [
            "time_history.csv",
            ".tmp-12",
            "a.tmp-",
            "a.tmp-12x",
            "a.tmp--1",
        ] {
            assert_eq!(tmp_pid(no), None, "{no}");
        }
    }
}
