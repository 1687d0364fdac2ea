//! The one writer of output files: every file of a run is prepared in memory, then
//! committed as a set ([`commit_files`]). Each goes to a temporary file next to its final
//! name (same directory, so the rename is atomic), and only when every file has been written
//! are they renamed over their final names; an error removes the temporary files. An
//! interrupted run leaves no half-written file under a final name.

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
#[error("cannot write {}: {error}", path.display())]
pub struct WriteError {
    /// The final path.
    pub path: PathBuf,
    /// The I/O error.
    pub error: std::io::Error,
}

/// Writes all files atomically as a set: each to a temporary file next to its final name,
/// then renames them. On any error the temporary files are removed and no final name is
/// touched before every file has been written.
pub fn commit_files(files: &[OutputFile]) -> Result<(), WriteError> {
    let tmp_of = |p: &Path| {
        let mut name = p.file_name().map(|n| n.to_os_string()).unwrap_or_default();
        name.push(format!(".tmp-{}", std::process::id()));
        p.with_file_name(name)
    };
    let mut written: Vec<PathBuf> = vec![];
    let cleanup = |written: &[PathBuf]| {
        for t in written {
            let _ = std::fs::remove_file(t);
        }
    };
    for f in files {
        let tmp = tmp_of(&f.path);
        let res = std::fs::File::create(&tmp).and_then(|mut file| {
            file.write_all(&f.bytes)?;
            file.sync_all()
        });
        if let Err(e) = res {
            cleanup(&written);
            let _ = std::fs::remove_file(&tmp);
            return Err(WriteError {
                path: f.path.clone(),
                error: e,
            });
        }
        written.push(tmp);
    }
    for (f, tmp) in files.iter().zip(&written) {
        if let Err(e) = std::fs::rename(tmp, &f.path) {
            cleanup(&written);
            return Err(WriteError {
                path: f.path.clone(),
                error: e,
            });
        }
    }
    Ok(())
}
