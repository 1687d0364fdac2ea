//! The one way user files are read: regular files only, size-capped.
//!
//! A scenario, a mechanism model, a beam or a time table named by the user may be anything
//! the path reaches: a fifo (an `open` that blocks until a writer comes), a device
//! (`/dev/zero`: a read that never ends), a directory, a symbolic-link loop. Each is
//! refused in one line naming the path before anything is read; a regular file larger than
//! [`MAX_INPUT_BYTES`] is refused by its size. The file is opened without blocking
//! (`O_NONBLOCK`, so that a fifo swapped in after the check cannot block the open) and its
//! type checked again on the open handle; at most [`MAX_INPUT_BYTES`] + 1 bytes are read.

use std::io::Read;
use std::path::Path;

use crate::{Diagnostic, Kind};

/// The largest user file read (bytes): 64 MiB, far above any scenario, model or time
/// table the tool needs (the bundled ones are a few kB).
pub const MAX_INPUT_BYTES: u64 = 64 * 1024 * 1024;

fn refuse(path: &Path, message: String) -> Diagnostic {
    Diagnostic::new(Kind::Io, path.display().to_string(), message)
}

/// What a file that is not a regular file is, for messages.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a fifo";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Checks that `path` names a regular file (symbolic links followed) of at most
/// [`MAX_INPUT_BYTES`] and returns its size; `what` names the file in messages (`scenario
/// file`, `model file`).
pub fn check_input(path: &Path, what: &str) -> Result<u64, Diagnostic> {
    let meta = std::fs::metadata(path)
        .map_err(|e| refuse(path, format!("cannot read the {what}: {e}")))?;
    check_meta(path, what, &meta)
}

fn check_meta(path: &Path, what: &str, meta: &std::fs::Metadata) -> Result<u64, Diagnostic> {
    if !meta.is_file() {
        return Err(refuse(
            path,
            format!(
                "cannot read the {what}: {} (a {what} must be a regular file)",
                kind_of(meta)
            ),
        ));
    }
    if meta.len() > MAX_INPUT_BYTES {
        return Err(too_large(path, what, meta.len()));
    }
    Ok(meta.len())
}

fn too_large(path: &Path, what: &str, len: u64) -> Diagnostic {
    refuse(
        path,
        format!(
            "cannot read the {what}: {len} bytes, above the limit of {} MiB",
            MAX_INPUT_BYTES / (1024 * 1024)
        ),
    )
}

/// The bytes of the user file `path`, checked as [`check_input`] does (before opening and
/// again on the open file).
pub fn read_input_bytes(path: &Path, what: &str) -> Result<Vec<u8>, Diagnostic> {
    check_input(path, what)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options
        .open(path)
        .map_err(|e| refuse(path, format!("cannot read the {what}: {e}")))?;
    let meta = file
        .metadata()
        .map_err(|e| refuse(path, format!("cannot read the {what}: {e}")))?;
    let len = check_meta(path, what, &meta)?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| refuse(path, format!("cannot read the {what}: {e}")))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(too_large(path, what, bytes.len() as u64));
    }
    Ok(bytes)
}

/// The text of the user file `path` ([`read_input_bytes`], then UTF-8).
pub fn read_input(path: &Path, what: &str) -> Result<String, Diagnostic> {
    String::from_utf8(read_input_bytes(path, what)?).map_err(|e| {
        refuse(
            path,
            format!("cannot read the {what}: not UTF-8 text ({e})"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("diag-input-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn regular_files_are_read_and_everything_else_refused_in_one_line() {
        let d = dir("kinds");
        let f = d.join("a.toml");
        std::fs::write(&f, "x = 1\n").unwrap();
        assert_eq!(read_input(&f, "scenario file").unwrap(), "x = 1\n");
        let e = read_input(&d, "scenario file").unwrap_err().to_string();
        assert!(
            e.contains("a directory") && e.contains(&*d.to_string_lossy()),
            "{e}"
        );
        assert!(!e.contains('\n'));
        let e = read_input(&d.join("missing"), "model file")
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot read the model file"), "{e}");
        #[cfg(unix)]
        {
            let e = read_input(Path::new("/dev/zero"), "scenario file")
                .unwrap_err()
                .to_string();
            assert!(e.contains("a device"), "{e}");
            let (a, b) = (d.join("loop-a"), d.join("loop-b"));
            std::os::unix::fs::symlink(&b, &a).unwrap();
            std::os::unix::fs::symlink(&a, &b).unwrap();
            let e = read_input(&a, "scenario file").unwrap_err().to_string();
            assert!(e.contains("loop-a") && e.contains("cannot read"), "{e}");
            let fifo = d.join("fifo");
            if std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .is_ok_and(|s| s.success())
            {
                let e = read_input(&fifo, "scenario file").unwrap_err().to_string();
                assert!(e.contains("a fifo"), "{e}");
            }
        }
        let big = d.join("big.toml");
        let file = std::fs::File::create(&big).unwrap();
        file.set_len(MAX_INPUT_BYTES + 1).unwrap();
        let e = read_input(&big, "scenario file").unwrap_err().to_string();
        assert!(e.contains("above the limit of 64 MiB"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }
}
