//! The one writer of output files: every file of a run is prepared in memory, or streamed
//! to a temporary file while the run goes ([`super::stream::StreamFile`], time histories),
//! then committed as a set ([`commit_files`], [`commit`]).
//!
//! Each output path is first resolved with the user's path semantics ([`target`]):
//!
//! - a **regular file** (existing or not) is replaced atomically: the bytes go to a temporary
//!   file next to it (same directory, so the rename is atomic), renamed over the final name
//!   only when every file of the set has been written; an error removes the temporary files;
//! - a **symbolic link** is followed: its target is replaced atomically and the link is kept
//!   (also a dangling link, whose target is created);
//! - a **non-regular file** (character device such as `/dev/null`, a terminal, a fifo,
//!   `/dev/stdout` on a pipe) is opened for writing and written to directly, streaming: it
//!   is never read, never renamed over and never replaced.
//!
//! Missing directories of the output paths are created at the commit, when the run has its
//! outputs (for a streamed file: when its stream is opened, at the start of the run), and
//! removed again (when still empty) if the commit or the run fails. A signal during the
//! commit is handled once the commit is over ([`crate::interrupt`]), so an interrupted run
//! leaves either nothing or the complete set, and never a temporary file.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A file prepared in memory, to be committed with [`commit_files`].
#[derive(Clone, Debug)]
pub struct OutputFile {
    /// Final path.
    pub path: PathBuf,
    /// Content.
    pub bytes: Vec<u8>,
}

/// An output file that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot {what} {}: {error}", path.display())]
pub struct WriteError {
    /// What failed: `write` (the file) or `create the directory`.
    pub what: &'static str,
    /// The path as the user gave it (or the directory).
    pub path: PathBuf,
    /// The I/O error.
    pub error: std::io::Error,
}

pub use mbs_symbolic::emit::{Target, target};

use super::stream::{Finished, StreamFile};

/// The temporary file next to `final_path`.
pub(crate) fn tmp_of(final_path: &Path) -> PathBuf {
    let mut name = final_path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(format!(".tmp-{}", std::process::id()));
    final_path.with_file_name(name)
}

/// Creates the missing ancestors of `dir`; returns the ones it created, outermost first.
pub(crate) fn create_dirs(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let missing: Vec<PathBuf> = dir
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .take_while(|a| std::fs::symlink_metadata(a).is_err())
        .map(Path::to_path_buf)
        .collect();
    let mut created = vec![];
    for d in missing.into_iter().rev() {
        match std::fs::create_dir(&d) {
            Ok(()) => created.push(d),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => {
                remove_dirs(&created);
                return Err(e);
            }
        }
    }
    Ok(created)
}

/// Removes directories created by [`create_dirs`] (innermost first) if they are empty.
fn remove_dirs(created: &[PathBuf]) {
    for d in created.iter().rev() {
        let _ = std::fs::remove_dir(d);
    }
}

/// Writes all files as a set: regular files (symbolic links followed) each to a temporary
/// file next to its final name, then renamed; non-regular files (devices, fifos) directly.
/// Missing directories are created here and removed again if the commit fails. On any error
/// the temporary files are removed and no final name has been touched before every file
/// was written.
pub fn commit_files(files: &[OutputFile]) -> Result<(), WriteError> {
    commit(Vec::new(), files)
}

/// Commits streamed files and files prepared in memory as one set: each stream is flushed
/// and synced, the in-memory files are staged as in [`commit_files`], then every temporary
/// file is renamed to its final name. On any error nothing final has been touched and every
/// temporary file (streamed ones too) is removed, with the directories created for them.
pub fn commit(streams: Vec<StreamFile>, files: &[OutputFile]) -> Result<(), WriteError> {
    let _section = crate::interrupt::commit_section();
    let mut finished = Vec::with_capacity(streams.len());
    for s in streams {
        // On error, the remaining streams are dropped: their temporary files removed.
        finished.push(s.finish()?);
    }
    stage_and_rename(finished, files)
}

fn stage_and_rename(streams: Vec<Finished>, files: &[OutputFile]) -> Result<(), WriteError> {
    let fail = |what: &'static str, path: &Path, error: std::io::Error| WriteError {
        what,
        path: path.to_path_buf(),
        error,
    };
    let mut created_dirs: Vec<PathBuf> = vec![];
    let mut staged: Vec<(PathBuf, PathBuf)> = vec![]; // (temporary, final)
    let cleanup = |staged: &[(PathBuf, PathBuf)], dirs: &[PathBuf]| {
        for (tmp, _) in staged {
            let _ = std::fs::remove_file(tmp);
        }
        remove_dirs(dirs);
        for s in &streams {
            s.abandon();
        }
    };
    for f in files {
        let resolved = match target(&f.path) {
            Ok(t) => t,
            Err(e) => {
                cleanup(&staged, &created_dirs);
                return Err(fail("write", &f.path, e));
            }
        };
        let res = match resolved {
            Target::Direct(p) => write_direct(&p, &f.bytes),
            Target::Replace(p) => {
                if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                    match create_dirs(dir) {
                        Ok(c) => created_dirs.extend(c),
                        Err(e) => {
                            cleanup(&staged, &created_dirs);
                            return Err(fail("create the directory", dir, e));
                        }
                    }
                }
                let tmp = tmp_of(&p);
                let res = std::fs::File::create(&tmp).and_then(|mut file| {
                    file.write_all(&f.bytes)?;
                    file.sync_all()
                });
                staged.push((tmp, p));
                res
            }
        };
        if let Err(e) = res {
            cleanup(&staged, &created_dirs);
            return Err(fail("write", &f.path, e));
        }
    }
    let renames = streams
        .iter()
        .filter_map(Finished::staged)
        .chain(staged.iter().map(|(t, p)| (t.as_path(), p.as_path())));
    for (tmp, p) in renames {
        if let Err(e) = std::fs::rename(tmp, p) {
            cleanup(&staged, &[]);
            return Err(fail("write", p, e));
        }
    }
    for s in streams {
        s.committed();
    }
    Ok(())
}

/// Writes `bytes` to an existing non-regular file (device, fifo): opened for writing only
/// (no create, no truncate, no read), streamed.
pub fn write_direct(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.write_all(bytes)?;
    file.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_character_device_is_written_directly_never_replaced() {
        // Only `stat`: the real device is not opened by this test.
        assert_eq!(
            target(Path::new("/dev/null")).unwrap(),
            Target::Direct(PathBuf::from("/dev/null"))
        );
    }

    #[test]
    fn a_directory_is_not_an_output_file() {
        let e = target(&std::env::temp_dir()).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::IsADirectory);
    }
}
