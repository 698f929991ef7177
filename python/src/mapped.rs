//! Where a tree's words live: a 64-byte aligned copy ([`Aligned`]: a built tree, a `.kdt` read
//! or unpickled), or a read-only memory map of a `.kdt` file ([`map`]), whose pages every
//! process that maps the same file shares through the page cache (workers on one host: one copy
//! of the tree in memory, not one a process).
//!
//! A mapped file's words are its bytes as they are: little-endian `u32`, so mapping is refused on
//! a big-endian host; a page-aligned map is on cache lines, as the wide section wants.

use crate::Tree;
use crate::owned::Owned;
use kdray::flat::Aligned;
use memmap2::Mmap;
use pyo3::prelude::*;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The words of a tree, wherever they are kept.
pub enum Words {
    Copied(Aligned),
    /// Whole words: checked by [`map`], the only maker of this variant.
    Mapped(Mmap),
}

impl core::ops::Deref for Words {
    type Target = [u32];
    fn deref(&self) -> &[u32] {
        match self {
            Words::Copied(a) => a,
            // `map` checked the length and the alignment (a map starts on a page).
            Words::Mapped(m) => bytemuck::cast_slice(m),
        }
    }
}

/// Maps the `.kdt` file at `path` read-only (not yet validated).
///
/// # Errors
/// The file cannot be opened or mapped; its size is not a whole number of words; a big-endian
/// host.
///
/// The file must not be changed or truncated while it is mapped (the caveat of any memory map,
/// `numpy.memmap`'s too): validation vouches for the words it read, not for later writes, and a
/// truncated file's missing pages raise `SIGBUS` when read. `kdray`'s writers replace a file
/// (`rename`) rather than rewrite it, which leaves a mapped one intact.
pub fn map(path: &Path) -> Result<Words, String> {
    if cfg!(target_endian = "big") {
        return Err("mmap=True: a .kdt's words are little-endian; this host is not".into());
    }
    let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    // SAFETY: read-only; the file's stability while mapped is the caller's (documented above).
    let map = unsafe { Mmap::map(&file) }.map_err(|e| format!("{}: {e}", path.display()))?;
    if bytemuck::try_cast_slice::<u8, u32>(&map).is_err() {
        return Err(format!(
            "{}: {} bytes is not a whole number of 32-bit words",
            path.display(),
            map.len()
        ));
    }
    Ok(Words::Mapped(map))
}

/// `Scene.load(path, mmap=True)`: the `.kdt` at `path` mapped and validated (every word read
/// once, which brings the pages into the page cache that the host's other mappings share).
#[pyfunction]
pub fn map_kdt(py: Python<'_>, path: PathBuf) -> PyResult<Tree> {
    py.detach(|| {
        let words = map(&path)?;
        Owned::validate(words).map_err(|e| format!("{}: {e}", path.display()))
    })
    .map(|owned| Tree { owned })
    .map_err(crate::value_error)
}
