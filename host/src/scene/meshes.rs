//! The mesh files a scene names, checked before any is loaded: each is a regular file of a mesh
//! format, and together they hold at most [`MAX_INFLATED`] bytes once inflated — so a small
//! scene naming one small `.ply.gz` many times cannot make the loader hold gigabytes before the
//! build's memory check.

use super::SceneFile;
use crate::error::Result;
use crate::load::{MAX_INFLATED, MeshFormat, inflated_size};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

impl SceneFile {
    /// The file each `[[mesh]]` entry loads (relative paths start at the scene file's folder),
    /// leaving out meshes held in the binary.
    pub fn mesh_files(&self) -> Vec<PathBuf> {
        self.meshes
            .iter()
            .filter(|m| self.embedded_mesh(&m.path).is_none())
            .map(|m| self.mesh_file(&m.path))
            .collect()
    }

    /// Where the mesh `path` of a `[[mesh]]` entry is read from.
    pub(super) fn mesh_file(&self, path: &Path) -> PathBuf {
        self.path.parent().unwrap_or(Path::new("")).join(path)
    }

    /// Checks every mesh file before any is loaded, each error naming the scene file and the
    /// entry's line: the file exists and is a regular file (not a directory or a FIFO, which
    /// would block), its name says a mesh format, and all of them together — a file named by
    /// several entries counting once per entry — are at most [`MAX_INFLATED`] bytes, `.ply.gz`
    /// files counted inflated (each file inflated once, into nothing).
    ///
    /// # Errors
    /// The first entry at fault.
    pub(super) fn check_meshes(&self) -> Result<()> {
        let mut sizes: HashMap<PathBuf, u64> = HashMap::new();
        let mut total = 0u64;
        for (i, m) in self.meshes.iter().enumerate() {
            if self.embedded_mesh(&m.path).is_some() {
                continue;
            }
            let line = self.lines.mesh.get(i).copied();
            let file = self.mesh_file(&m.path);
            let what = format!("mesh `{}` ({})", m.path.display(), file.display());
            let fail = |msg: String| self.error(line, format!("{what}: {msg}"));
            let size = match sizes.get(&file) {
                Some(&size) => size,
                None => {
                    let size = loaded_size(&file, &m.path).map_err(fail)?;
                    sizes.insert(file.clone(), size);
                    size
                }
            };
            total = total.saturating_add(size);
            if total > MAX_INFLATED as u64 {
                return Err(fail(format!(
                    "the meshes up to this entry hold more than {} MiB in all ({}), the limit \
                     for a scene's meshes together (a .ply.gz counted inflated)",
                    MAX_INFLATED >> 20,
                    crate::memory::mib(total)
                )));
            }
        }
        Ok(())
    }
}

/// The bytes the mesh `file` (named `path` in its scene) decodes from: its size, or inflated for a
/// `.ply.gz`; or why it cannot be a mesh.
fn loaded_size(file: &Path, path: &Path) -> core::result::Result<u64, String> {
    let meta = std::fs::metadata(file).map_err(|e| {
        let mut msg = e.to_string();
        if e.kind() == std::io::ErrorKind::NotFound && in_data_dir(path) {
            // The benchmark meshes are not in the repository:
            // scripts/fetch-meshes.sh downloads them into data/.
            msg.push_str(
                " (the Stanford meshes are not in the repository: \
                 run scripts/fetch-meshes.sh to fetch them into data/)",
            );
        }
        msg
    })?;
    if meta.is_dir() {
        return Err("a directory: expected a mesh file".into());
    }
    if !meta.is_file() {
        return Err("not a regular file (a FIFO, socket or device): expected a mesh file".into());
    }
    match MeshFormat::from_path(file) {
        None => Err("unknown mesh format: expected a .ply, .ply.gz, .obj or .tri file".into()),
        Some(MeshFormat::PlyGz) => {
            let bytes = crate::files::read(file).map_err(|e| e.message)?;
            inflated_size(file, &bytes).map_err(|e| e.message)
        }
        Some(_) => Ok(meta.len()),
    }
}

/// Whether a scene's mesh path points into a `data/` folder, where scripts/fetch-meshes.sh puts
/// the meshes it downloads.
fn in_data_dir(path: &Path) -> bool {
    path.parent()
        .is_some_and(|p| p.components().any(|c| c.as_os_str() == "data"))
}
