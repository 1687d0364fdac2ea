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
//! Writes are buffered (64 KiB). A staged stream's bytes are written back to the disk while
//! the run goes: every 256 KiB that reached the file, a helper thread (started
//! with the first of them) syncs its data, so that the commit's final sync waits for the
//! last few hundred kilobytes and the file's metadata only, not for the whole history
//! (overlapped with the run on another core; the rows' CPU work is not delayed). A flush
//! of the stream (its rows are over, [`super::rows::RowSink::end`]) asks for the rest.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;

use super::writer::{Target, WriteError, create_dirs, target, tmp_of};
use crate::interrupt::Leftovers;

/// Buffer of a stream (bytes).
const BUFFER: usize = 64 * 1024;

/// Bytes of a staged stream's file between two background write-backs (see the module
/// documentation).
pub(crate) const WRITE_BACK: u64 = 256 * 1024;

/// The background write-back of a staged stream: a thread syncing the file's data when
/// asked (requests made while it syncs are merged into one).
#[derive(Debug)]
struct WriteBack {
    /// Bytes of the file at which the next write-back is asked for.
    next: u64,
    /// The thread and its request channel, once started (`None` before the first request,
    /// and for good when it could not be started: the commit's sync then does it all).
    worker: Option<(mpsc::SyncSender<()>, JoinHandle<std::io::Result<()>>)>,
    /// Whether starting it failed (no second attempt).
    unavailable: bool,
}

impl WriteBack {
    fn new() -> WriteBack {
        WriteBack {
            next: WRITE_BACK,
            worker: None,
            unavailable: false,
        }
    }

    /// Asks for a sync of `file`'s data when `in_file` bytes reached it and the last request
    /// was [`WRITE_BACK`] bytes ago.
    fn note(&mut self, in_file: u64, file: &File) {
        if in_file < self.next {
            return;
        }
        self.next = in_file + WRITE_BACK;
        self.request(file);
    }

    /// Asks for a sync of `file`'s data now (the thread started if it is not yet).
    fn request(&mut self, file: &File) {
        if self.unavailable {
            return;
        }
        if self.worker.is_none() {
            let Ok(clone) = file.try_clone() else {
                self.unavailable = true;
                return;
            };
            let (tx, rx) = mpsc::sync_channel::<()>(1);
            let spawned = std::thread::Builder::new()
                .name("write-back".into())
                .spawn(move || {
                    // Ends when the stream is finished (the sender dropped), after the
                    // request in flight.
                    while rx.recv().is_ok() {
                        clone.sync_data()?;
                    }
                    Ok(())
                });
            match spawned {
                Ok(handle) => self.worker = Some((tx, handle)),
                Err(_) => {
                    self.unavailable = true;
                    return;
                }
            }
        }
        if let Some((tx, _)) = &self.worker {
            // Full: a request is waiting already, which will sync these bytes too.
            let _ = tx.try_send(());
        }
    }

    /// Waits for the write-back in flight; its error, if one failed.
    fn finish(&mut self) -> std::io::Result<()> {
        match self.worker.take() {
            Some((tx, handle)) => {
                drop(tx);
                handle
                    .join()
                    .unwrap_or_else(|_| Err(std::io::Error::other("the write-back thread failed")))
            }
            None => Ok(()),
        }
    }
}

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
    /// Bytes accepted by [`Write::write`] (in the file or in the buffer).
    written: u64,
    /// The background write-back of a staged stream (`None` for a direct one).
    write_back: Option<WriteBack>,
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
                    written: 0,
                    write_back: None,
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
                        written: 0,
                        write_back: Some(WriteBack::new()),
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

    /// Flushes, waits for the write-back in flight and syncs; the stream is then ready to be
    /// renamed by the commit.
    pub(super) fn finish(mut self) -> Result<Finished, WriteError> {
        let out = self.out.take().expect("a stream is finished once");
        let flushed = out.into_inner().map_err(|e| e.into_error());
        let written_back = match &mut self.write_back {
            Some(w) => w.finish(),
            None => Ok(()),
        };
        let res = flushed.and_then(|file| {
            written_back?;
            match self.dest {
                // Devices and fifos cannot be synced (EINVAL); flushed is written.
                Dest::Direct => Ok(()),
                Dest::Staged { .. } => file.sync_all(),
            }
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
            Some(out) => {
                let n = out.write(buf)?;
                self.written += n as u64;
                if let Some(w) = &mut self.write_back {
                    w.note(self.written - out.buffer().len() as u64, out.get_ref());
                }
                Ok(n)
            }
            None => Err(std::io::Error::other("stream already finished")),
        }
    }

    /// Writes the buffer into the file; a staged stream of at least 64 KiB also
    /// asks for its data to be synced in the background (the last rows of a run, synced
    /// while the run's other outputs are made).
    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.out {
            Some(out) => {
                out.flush()?;
                if let Some(w) = &mut self.write_back
                    && self.written >= BUFFER as u64
                {
                    w.request(out.get_ref());
                }
                Ok(())
            }
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

    /// A stream of several write-back spans: the helper thread syncs while rows are still
    /// written, the commit waits for it, and the file holds every byte in order; a dropped
    /// one leaves nothing.
    #[test]
    fn a_stream_written_back_while_it_grows_commits_every_byte() {
        let d = dir("write-back");
        let csv = d.join("big.csv");
        let mut s = StreamFile::create(&csv).unwrap();
        let mut expected = Vec::new();
        let mut row = 0u64;
        while (expected.len() as u64) < 3 * WRITE_BACK + 12_345 {
            let line = format!("{row},{}\n", row * row);
            s.write_all(line.as_bytes()).unwrap();
            expected.extend_from_slice(line.as_bytes());
            row += 1;
        }
        let w = s.write_back.as_ref().unwrap();
        assert!(w.worker.is_some() && !w.unavailable, "{w:?}");
        super::super::writer::commit(vec![s], &[]).unwrap();
        assert_eq!(std::fs::read(&csv).unwrap(), expected);
        assert!(!tmp_of(&csv).exists());

        let dropped = d.join("dropped/big.csv");
        let mut s = StreamFile::create(&dropped).unwrap();
        for _ in 0..3 * WRITE_BACK / 1024 {
            s.write_all(&[b'x'; 1024]).unwrap();
        }
        drop(s);
        assert!(!d.join("dropped").exists());
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
