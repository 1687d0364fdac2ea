//! Write-if-changed: unchanged output keeps its modification time, so cargo does not rebuild.

use std::path::Path;

use super::EmitError;

/// Writes `contents` to `path` only if the file does not already hold exactly these bytes
/// (so unchanged output does not trigger rebuilds). The write goes through a temporary file
/// and a rename, so a reader never sees a half-written file. Returns whether it wrote.
pub fn write_if_changed(path: &Path, contents: &str) -> Result<bool, EmitError> {
    if std::fs::read(path).ok().as_deref() == Some(contents.as_bytes()) {
        return Ok(false);
    }
    let io = |e| EmitError::Io {
        path: path.display().to_string(),
        source: e,
    };
    let tmp = path.with_extension("rs.tmp");
    let written = std::fs::write(&tmp, contents).and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        // Leave nothing behind: neither a partial output nor the temporary file.
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(true)
}
