//! Write-if-changed: unchanged output keeps its modification time, so cargo does not rebuild.
//!
//! The output path is taken with the user's path semantics: a symbolic link is followed (its
//! target is replaced, the link kept); a non-regular file (a character device such as
//! `/dev/null`, a fifo, `/dev/stdout` on a pipe or a terminal) is opened for writing and
//! written to directly, never read first and never renamed over. Only a regular file is
//! compared with the new content and replaced atomically.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::EmitError;

/// Where the bytes of an output path go (the one classification of output paths, shared by
/// [`write_if_changed`] and the CLI's atomic writer).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// A regular file (existing or to be created), symbolic links followed: replaced
    /// atomically through a temporary file in its directory.
    Replace(PathBuf),
    /// An existing file that is not a regular file (device, fifo, socket): opened for
    /// writing and written directly, never read and never renamed over.
    Direct(PathBuf),
}

/// Resolves an output path with the user's path semantics: a symbolic link is followed to
/// the file it names (a dangling link to the path it would create), a non-regular file is
/// written directly, a directory is an error. Only looks at the file system (`stat`,
/// `readlink`); opens nothing.
pub fn target(path: &Path) -> std::io::Result<Target> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(Target::Replace(std::fs::canonicalize(path)?)),
        Ok(m) if m.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "is a directory, not a file",
        )),
        Ok(_) => Ok(Target::Direct(path.to_path_buf())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // Not there, or a dangling symbolic link: follow the chain to the path to create.
            let mut p = path.to_path_buf();
            for _ in 0..40 {
                match std::fs::symlink_metadata(&p) {
                    Ok(m) if m.file_type().is_symlink() => {
                        let link = std::fs::read_link(&p)?;
                        p = match p.parent() {
                            Some(dir) if link.is_relative() => dir.join(link),
                            _ => link,
                        };
                    }
                    _ => return Ok(Target::Replace(p)),
                }
            }
            Err(std::io::Error::other("too many levels of symbolic links"))
        }
        Err(e) => Err(e),
    }
}

/// Writes `contents` to `path` only if the file does not already hold exactly these bytes
/// (so unchanged output does not trigger rebuilds). A regular file is written through a
/// temporary file and a rename, so a reader never sees a half-written file; a symbolic link
/// is followed and kept; a non-regular file (device, fifo) is written directly, without
/// reading it first. Returns whether it wrote.
pub fn write_if_changed(path: &Path, contents: &str) -> Result<bool, EmitError> {
    let io = |e| EmitError::Io {
        path: path.display().to_string(),
        source: e,
    };
    let regular = match target(path).map_err(io)? {
        Target::Direct(_) => {
            let written = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .and_then(|mut f| f.write_all(contents.as_bytes()).and_then(|()| f.flush()));
            return written.map(|()| true).map_err(io);
        }
        Target::Replace(p) => p,
    };
    if std::fs::read(&regular).ok().as_deref() == Some(contents.as_bytes()) {
        return Ok(false);
    }
    let mut tmp_name = regular
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    tmp_name.push(".tmp");
    let tmp = regular.with_file_name(tmp_name);
    let written = std::fs::write(&tmp, contents).and_then(|()| std::fs::rename(&tmp, &regular));
    if let Err(e) = written {
        // Leave nothing behind: neither a partial output nor the temporary file.
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mbs-write-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn dev_null_is_classified_special_so_it_is_never_renamed_over() {
        // Only `stat`: the real device is not opened by this test.
        assert_eq!(
            target(Path::new("/dev/null")).unwrap(),
            Target::Direct(PathBuf::from("/dev/null"))
        );
    }

    #[cfg(unix)]
    #[test]
    fn symlinked_output_keeps_the_link_and_replaces_the_target() {
        let dir = temp_dir("symlink");
        let real = dir.join("real.rs");
        std::fs::write(&real, "old").unwrap();
        let link = dir.join("link.rs");
        std::os::unix::fs::symlink("real.rs", &link).unwrap();
        assert!(write_if_changed(&link, "new").unwrap());
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        assert!(!write_if_changed(&link, "new").unwrap());
        // A dangling link: its target is created, the link kept.
        let dangling = dir.join("dangling.rs");
        std::os::unix::fs::symlink("created.rs", &dangling).unwrap();
        assert!(write_if_changed(&dangling, "x").unwrap());
        assert!(
            std::fs::symlink_metadata(&dangling)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(
            std::fs::read_to_string(dir.join("created.rs")).unwrap(),
            "x"
        );
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["created.rs", "dangling.rs", "link.rs", "real.rs"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn fifo_output_is_streamed_not_read_first_and_stays_a_fifo() {
        use std::os::unix::fs::FileTypeExt;
        let dir = temp_dir("fifo");
        let fifo = dir.join("out.rs");
        match std::process::Command::new("mkfifo").arg(&fifo).status() {
            Ok(s) if s.success() => {}
            _ => return eprintln!("mkfifo unavailable: skipped"),
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        // Reading the fifo first would block for ever (the reader waits for a writer).
        assert!(write_if_changed(&fifo, "fn main() {}\n").unwrap());
        assert_eq!(reader.join().unwrap(), "fn main() {}\n");
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
