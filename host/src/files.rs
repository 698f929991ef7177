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

/// The directory an output `path` is written in (`.` for a bare file name).
fn folder(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Checks, before any work, that `path` can be written as an output file: it is not a directory,
/// its parent directory exists, and a file can be created in it (by creating, exclusively, and
/// removing a temporary file there: permission bits alone do not say, e.g. on a read-only mount
/// or for root), so that a render of an hour does not end in "permission denied".
///
/// # Errors
/// `path` is an existing directory or other file that is not a regular one (a FIFO, a device),
/// ends in a separator, or its parent is missing, not a directory or not writable.
pub fn check_output(path: &Path) -> Result<()> {
    let text = path.as_os_str().to_string_lossy();
    if path.is_dir() || text.ends_with('/') || text.is_empty() {
        return Err(Error::new(
            path,
            "is a directory: the output must name a file",
        ));
    }
    if let Ok(meta) = std::fs::metadata(path)
        && !meta.is_file()
    {
        // Renaming the finished output over it would put a regular file in its place (for
        // root, even in place of `/dev/null`).
        return Err(Error::new(
            path,
            "exists and is not a regular file (a FIFO, socket or device): \
             kdray replaces only regular files",
        ));
    }
    let parent = folder(path);
    if !parent.is_dir() {
        let why = if parent.exists() {
            "is not a directory"
        } else {
            "does not exist"
        };
        let msg = format!("cannot write here: {} {why}", parent.display());
        return Err(Error::new(path, msg));
    }
    if let Err(e) = temp_in(path) {
        let msg = format!("cannot write in the directory {}: {e}", parent.display());
        return Err(Error::new(path, msg));
    }
    Ok(())
}

/// The identity of an existing file: (device, inode) on Unix, the canonical path elsewhere.
#[cfg(unix)]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(path: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(path).ok()
}

/// Where `path` will be once written: its folder made canonical (symbolic links and `..`
/// resolved), joined with its name. Two outputs with the same place would overwrite each other.
fn place(path: &Path) -> Option<PathBuf> {
    let folder = std::fs::canonicalize(folder(path)).ok()?;
    Some(folder.join(path.file_name()?))
}

/// [`check_output`] for each of `outputs`, and refuses an output that is one of `inputs` (the same
/// file by device and inode, however it is named: another path, a hard link or a symbolic link
/// to it) or the same place as another output (e.g. `build s.toml --description s.toml`, or two
/// outputs named alike before either exists). Run before any work.
///
/// # Errors
/// The first output at fault, naming the input or output it would overwrite.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    for (k, &out) in outputs.iter().enumerate() {
        check_output(out)?;
        check_not_inputs(inputs, &[out])?;
        let here = place(out);
        if let Some(other) = outputs[..k]
            .iter()
            .find(|o| here.is_some() && place(o) == here)
        {
            let msg = format!(
                "is also the output {}: two outputs cannot be one file",
                other.display()
            );
            return Err(Error::new(out, msg));
        }
    }
    Ok(())
}

/// How many characters of an output's name its temporary's name repeats: 60, at most 240 bytes
/// of UTF-8, leaving room for the rest of the temporary's name.
const TEMP_NAME_CHARS: usize = 60;

/// Refuses an output that is one of `inputs` (the same file by device and inode), e.g. a mesh
/// that a scene file includes, known only once the scene is read.
///
/// # Errors
/// The first output at fault, naming the input it would overwrite.
pub fn check_not_inputs<P: AsRef<Path>>(inputs: &[P], outputs: &[&Path]) -> Result<()> {
    for &out in outputs {
        if let Some(id) = identity(out)
            && let Some(input) = inputs
                .iter()
                .find(|i| identity(i.as_ref()).as_ref() == Some(&id))
        {
            let msg = format!(
                "is the input {}: an output must not overwrite an input",
                input.as_ref().display()
            );
            return Err(Error::new(out, msg));
        }
    }
    Ok(())
}

/// A new temporary file next to `path`, created exclusively (`O_CREAT | O_EXCL` under a random
/// name, by the `tempfile` crate) so that nothing planted at its name (a symbolic link, a FIFO)
/// is followed or written; removed when dropped.
fn temp_in(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    // At most `TEMP_NAME_CHARS` of the name, so that the temporary's name (`.`, the name, `.`,
    // 6 random characters, `.tmp`) stays within a file system's 255 bytes however long the
    // output's own name is.
    let short: String = name.chars().take(TEMP_NAME_CHARS).collect();
    let mut builder = tempfile::Builder::new();
    let prefix = format!(".{short}.");
    builder.prefix(&prefix).suffix(".tmp");
    // An output is an ordinary file (0666 less the umask, as `File::create` makes it), not the
    // temporary's private 0600.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder.tempfile_in(folder(path))
}

/// An output written in full to a temporary file next to it, not yet in place: [`Staged::commit`]
/// renames it over its path; dropping it removes the temporary. Staging every output of a
/// command before committing any means a failure leaves none of them behind.
pub struct Staged {
    temp: tempfile::TempPath,
    path: PathBuf,
}

impl Staged {
    /// Moves the staged file to its path (replacing a file there).
    ///
    /// # Errors
    /// The rename fails (the temporary is then removed).
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        self.temp
            .persist(&path)
            .map_err(|e| Error::io(&path, e.error))
    }
}

/// Commits `staged` in order; if one fails, removes the outputs already committed, so that a
/// command's outputs appear all or none.
///
/// # Errors
/// The first failed commit.
pub fn commit_all(staged: Vec<Staged>) -> Result<()> {
    let mut done: Vec<PathBuf> = Vec::new();
    for s in staged {
        let path = s.path.clone();
        if let Err(e) = s.commit() {
            for p in &done {
                let _ = std::fs::remove_file(p);
            }
            return Err(e);
        }
        done.push(path);
    }
    Ok(())
}

/// Writes the output `path` in full to a temporary file next to it (see [`Staged`]).
///
/// # Errors
/// As [`check_output`], or `write`, the flush or the sync fails (the temporary is then removed).
pub fn stage(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<Staged> {
    check_output(path)?;
    let (file, temp) = temp_in(path).map_err(|e| Error::io(path, e))?.into_parts();
    let result = (|| {
        let mut w = std::io::BufWriter::new(file);
        write(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()
    })();
    result.map_err(|e| Error::io(path, e))?;
    Ok(Staged {
        temp,
        path: path.to_path_buf(),
    })
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
    stage(path, write)?.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch folder for test `name`, removed with its files when the test ends.
    fn dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix(&format!("kdray-files-{name}-"))
            .tempdir()
            .unwrap()
    }

    #[test]
    fn outputs_are_checked_before_work() {
        let tmp = dir("out");
        let d = tmp.path();
        assert!(check_output(&d.join("x.kdt")).is_ok());
        let err = check_output(d).unwrap_err().to_string();
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
        let tmp = dir("atomic");
        let d = tmp.path();
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
        let names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "no temporary left: {names:?}");
    }

    #[test]
    fn non_regular_inputs_are_refused() {
        let tmp = dir("regular");
        let d = tmp.path();
        let err = read(d).unwrap_err().to_string();
        assert!(err.contains("directory"), "{err}");
        let err = read(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(
            err.contains("not a regular file") && err.contains("/dev/null"),
            "{err}"
        );
        assert!(read(&d.join("missing")).is_err());
    }
}
