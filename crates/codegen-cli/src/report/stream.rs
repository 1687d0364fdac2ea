//! Streamed output files: a time history is written row by row while the run goes, so its
//! memory does not grow with `t_end`, and committed with the rest of the run's files by
//! the one writer ([`super::writer::commit`]).
//!
//! The output path is resolved like every output ([`super::writer::target`]):
//!
//! - a **regular file** (symbolic links followed) is written to a temporary file next to it,
//!   `<name>.tmp-<pid>` (same directory: the final rename is atomic), created with any
//!   missing directories when the stream is opened; the commit renames it over the final
//!   name together with the other files of the run. A stream dropped without a commit (the
//!   run failed) removes its temporary file and the directories created for it; a signal
//!   removes them too ([`crate::interrupt::Leftovers`]);
//! - a **non-regular file** (device, fifo, `/dev/stdout`) is opened for writing only and
//!   written directly as the rows come, never read and never renamed over.
//!
//! Writes are buffered (64 KiB).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::writer::{Target, WriteError, create_dirs, target, tmp_of};
use crate::interrupt::Leftovers;

/// Buffer of a stream (bytes).
const BUFFER: usize = 64 * 1024;

/// Where the bytes of a stream go.
#[derive(Debug)]
enum Dest {
    /// Straight to a non-regular file.
    Direct,
    /// To `tmp`, renamed to `final_path` at the commit.
    Staged { tmp: PathBuf, final_path: PathBuf },
}

/// An output file written while the run goes (see the module documentation).
#[derive(Debug)]
pub struct StreamFile {
    /// The path as the user gave it (for messages).
    path: PathBuf,
    dest: Dest,
    out: Option<BufWriter<File>>,
}

impl StreamFile {
    /// Opens the stream for the output `path`: a temporary file next to a regular file
    /// (missing directories created), or the non-regular file itself.
    pub fn create(path: &Path) -> Result<StreamFile, WriteError> {
        let fail = |what: &'static str, p: &Path, error: std::io::Error| WriteError {
            what,
            path: p.to_path_buf(),
            error,
        };
        match target(path).map_err(|e| fail("write", path, e))? {
            Target::Direct(p) => {
                let file = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&p)
                    .map_err(|e| fail("write", path, e))?;
                Ok(StreamFile {
                    path: path.to_path_buf(),
                    dest: Dest::Direct,
                    out: Some(BufWriter::with_capacity(BUFFER, file)),
                })
            }
            Target::Replace(p) => {
                let mut created = vec![];
                if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                    created = create_dirs(dir).map_err(|e| fail("create the directory", dir, e))?;
                }
                let tmp = tmp_of(&p);
                // Registered before it exists, so a signal in between still removes it.
                Leftovers::register(&tmp, &created);
                match File::create(&tmp) {
                    Ok(file) => Ok(StreamFile {
                        path: path.to_path_buf(),
                        dest: Dest::Staged { tmp, final_path: p },
                        out: Some(BufWriter::with_capacity(BUFFER, file)),
                    }),
                    Err(e) => {
                        Leftovers::abandon(&tmp);
                        Err(fail("write", path, e))
                    }
                }
            }
        }
    }

    /// The output path as given.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes and syncs; the stream is then ready to be renamed by the commit.
    pub(super) fn finish(mut self) -> Result<Finished, WriteError> {
        let out = self.out.take().expect("a stream is finished once");
        let res = out
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|file| match self.dest {
                // Devices and fifos cannot be synced (EINVAL); flushed is written.
                Dest::Direct => Ok(()),
                Dest::Staged { .. } => file.sync_all(),
            });
        if let Err(error) = res {
            return Err(WriteError {
                what: "write",
                path: self.path.clone(),
                error,
            });
        }
        let dest = std::mem::replace(&mut self.dest, Dest::Direct);
        Ok(Finished { dest })
    }
}

impl Write for StreamFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.out {
            Some(out) => out.write(buf),
            None => Err(std::io::Error::other("stream already finished")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.out {
            Some(out) => out.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for StreamFile {
    /// A stream not committed: its temporary file and the directories created for it are
    /// removed.
    fn drop(&mut self) {
        if let Dest::Staged { tmp, .. } = &self.dest {
            drop(self.out.take());
            Leftovers::abandon(tmp);
        }
    }
}

/// A stream flushed and synced, waiting for its rename.
#[derive(Debug)]
pub(super) struct Finished {
    dest: Dest,
}

impl Finished {
    /// `(temporary, final)` when there is a rename to do.
    pub(super) fn staged(&self) -> Option<(&Path, &Path)> {
        match &self.dest {
            Dest::Staged { tmp, final_path } => Some((tmp.as_path(), final_path.as_path())),
            Dest::Direct => None,
        }
    }

    /// The commit failed: the temporary file and its directories are removed.
    pub(super) fn abandon(&self) {
        if let Dest::Staged { tmp, .. } = &self.dest {
            Leftovers::abandon(tmp);
        }
    }

    /// The rename is done.
    pub(super) fn committed(self) {
        if let Dest::Staged { tmp, .. } = &self.dest {
            Leftovers::committed(tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("stream-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_committed_stream_replaces_its_file_with_the_in_memory_files() {
        let d = dir("commit");
        let csv = d.join("sub/a.csv");
        let mut s = StreamFile::create(&csv).unwrap();
        // Streaming: the rows are in the temporary file, the final name does not exist yet.
        s.write_all(b"t\n0\n").unwrap();
        assert!(!csv.exists());
        assert!(tmp_of(&csv).exists());
        let summary = super::super::OutputFile {
            path: d.join("sub/s.json"),
            bytes: b"{}".to_vec(),
        };
        super::super::writer::commit(vec![s], &[summary]).unwrap();
        assert_eq!(std::fs::read(&csv).unwrap(), b"t\n0\n");
        assert_eq!(std::fs::read(d.join("sub/s.json")).unwrap(), b"{}");
        assert!(!tmp_of(&csv).exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_dropped_stream_leaves_no_file_and_no_directory() {
        let d = dir("drop");
        let a = StreamFile::create(&d.join("x/y/a.csv")).unwrap();
        let b = StreamFile::create(&d.join("x/y/b.csv")).unwrap();
        assert!(d.join("x/y").is_dir());
        // The directory is still needed by `b`.
        drop(a);
        assert!(d.join("x/y").is_dir());
        drop(b);
        assert!(!d.exists(), "{d:?} left behind");
    }
}
