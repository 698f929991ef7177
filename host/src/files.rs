//! Reading inputs and writing outputs without surprises: every input is a regular file (a FIFO,
//! a device or a directory is refused before it is opened, so `kdray` never blocks on one or reads
//! an endless stream), every output is checked before the work that produces it starts, and a
//! written file appears whole or not at all.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Refuses `path` unless it is a regular file (symbolic links are followed).
///
/// # Errors
/// The path does not exist or cannot be examined, or names something other than a regular file.
pub fn check_regular(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_file() {
        return Ok(());
    }
    let what = if meta.is_dir() {
        "a directory"
    } else {
        "not a regular file (a FIFO, socket or device)"
    };
    Err(Error::new(path, format!("{what}: expected a regular file")))
}

/// Opens the regular file at `path` for reading.
///
/// # Errors
/// As [`check_regular`], or the open fails.
pub fn open(path: &Path) -> Result<std::fs::File> {
    check_regular(path)?;
    std::fs::File::open(path).map_err(|e| Error::io(path, e))
}

/// Reads the whole regular file at `path`.
///
/// # Errors
/// As [`open`], or the read fails.
pub fn read(path: &Path) -> Result<Vec<u8>> {
    check_regular(path)?;
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Reads the whole regular file at `path` as UTF-8 text.
///
/// # Errors
/// As [`read`], or the file is not UTF-8 (with the line where it stops being so).
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = read(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = crate::load::line_of_offset(e.as_bytes(), at);
        Error::at_line(path, line, "the file is not valid UTF-8 text")
    })
}

/// Checks, before any work, that `path` can be written as an output file: it is not a directory
/// and its parent directory exists. (Permissions are left to the write itself.)
///
/// # Errors
/// `path` is an existing directory, ends in a separator, or its parent is missing or not a
/// directory.
pub fn check_output(path: &Path) -> Result<()> {
    let text = path.as_os_str().to_string_lossy();
    if path.is_dir() || text.ends_with('/') || text.is_empty() {
        return Err(Error::new(
            path,
            "is a directory: the output must name a file",
        ));
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        let msg = format!(
            "cannot write here: the directory {} does not exist",
            parent.display()
        );
        return Err(Error::new(path, msg));
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same directory, renamed over `path`
/// once complete, so a failure (or a crash) never leaves a partial output behind.
///
/// # Errors
/// As [`check_output`], or the temporary file cannot be written or renamed (it is then removed).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// [`write_atomic`] for a writer callback (e.g. a PNG encoder).
///
/// # Errors
/// As [`write_atomic`], or `write` fails.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    check_output(path)?;
    let tmp = temp_name(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// `DIR/.NAME.PID.tmp` next to `path`.
fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("kdray-files-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn outputs_are_checked_before_work() {
        let d = dir("out");
        assert!(check_output(&d.join("x.kdt")).is_ok());
        let err = check_output(&d).unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
        let err = check_output(&d.join("missing/x.png"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("does not exist") && err.contains("x.png"),
            "{err}"
        );
    }

    #[test]
    fn atomic_write_leaves_nothing_on_failure() {
        let d = dir("atomic");
        let out = d.join("a.bin");
        write_atomic(&out, b"hello").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"hello");
        let failed = write_atomic_with(&out, |_| Err(std::io::Error::other("boom")));
        assert!(failed.unwrap_err().to_string().contains("boom"));
        assert_eq!(
            std::fs::read(&out).unwrap(),
            b"hello",
            "old file kept whole"
        );
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "no temporary left: {names:?}");
    }

    #[test]
    fn non_regular_inputs_are_refused() {
        let d = dir("regular");
        let err = read(&d).unwrap_err().to_string();
        assert!(err.contains("directory"), "{err}");
        let err = read(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(
            err.contains("not a regular file") && err.contains("/dev/null"),
            "{err}"
        );
        assert!(read(&d.join("missing")).is_err());
    }
}
