//! Where a tree's words live: a copy on pages of its own ([`copy`]: a built tree, a `.kdt` read
//! or unpickled), a read-only memory map of a `.kdt` file ([`map`]), whose pages every process
//! that maps the same file shares through the page cache (workers on one host: one copy of the
//! tree in memory, not one a process), or a Python buffer that nothing can change ([`share`]:
//! an unpickled tree whose words are another tree's, or a `bytes` object's).
//!
//! A mapped file's words are its bytes as they are: little-endian `u32`, so mapping is refused on
//! a big-endian host; a page-aligned map is on cache lines, as the wide section wants.

use crate::Tree;
use crate::owned::Owned;
use memmap2::{Mmap, MmapMut};
use numpy::{PyReadonlyArray1, PyUntypedArray};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyMemoryView};
use std::fs::File;
use std::path::{Path, PathBuf};

/// The words of a tree, wherever they are kept.
pub enum Words {
    /// Written once by [`copy`], read-only since.
    Copied(Mmap),
    /// Whole words: checked by [`map`], the only maker of this variant.
    Mapped(Mmap),
    /// Whole, aligned words that nothing can change: made by [`share`] only.
    Shared(Shared),
}

/// A numpy array's words, kept where they are: the array (which keeps its memory alive), and
/// the address and length of its words.
pub struct Shared {
    _array: Py<PyAny>,
    at: usize,
    len: usize,
}

impl core::ops::Deref for Words {
    type Target = [u32];
    fn deref(&self) -> &[u32] {
        match self {
            // `copy` and `map` checked the length and the alignment (a map starts on a page).
            Words::Copied(m) | Words::Mapped(m) => bytemuck::cast_slice(m),
            // SAFETY: `share` took `at` and `len` from the array's contiguous words, which
            // nothing changes (their memory is a `bytes` object's or a tree's) and which live as
            // long as the array, held here (an array that does not own its memory cannot be
            // resized).
            Words::Shared(s) => unsafe { std::slice::from_raw_parts(s.at as *const u32, s.len) },
        }
    }
}

/// `words` copied onto pages of their own (so on cache lines), made read-only once written.
///
/// Pages of their own rather than the heap's, asked for as transparent huge pages where the
/// kernel has them (Linux, `madvise` mode): a tree is tens of megabytes, and copying the dragon's
/// 56 MiB into fresh 4 KiB pages took 65 ms on this VM, most of it page faults, against 16 ms
/// into huge pages (one fault every 2 MiB); and a walk's scattered reads miss the TLB less on
/// them (random rays on the dragon: about a fifth less CPU time, issue 43).
///
/// # Errors
/// The memory cannot be had.
pub fn copy(words: &[u32]) -> Result<Words, String> {
    let mut fresh = Fresh::new(words.len())?;
    fresh.copy_from_slice(words);
    fresh.seal()
}

/// Words on pages of their own, being written ([`copy`]'s, and the serializer's own buffer for
/// a build: `kdray::flat::serialize_into`); [`Fresh::seal`] makes them read-only [`Words`].
pub struct Fresh(MmapMut);

impl Fresh {
    /// `n` zero words.
    ///
    /// # Errors
    /// The memory cannot be had.
    pub fn new(n: usize) -> Result<Self, String> {
        let bytes = n.saturating_mul(4);
        let map =
            MmapMut::map_anon(bytes).map_err(|e| format!("{bytes} bytes for the tree: {e}"))?;
        // A hint: without huge pages the copy is slower, not wrong.
        #[cfg(target_os = "linux")]
        let _ = map.advise(memmap2::Advice::HugePage);
        Ok(Self(map))
    }

    /// The words, read-only from now on.
    ///
    /// # Errors
    /// The pages' protection cannot be changed.
    pub fn seal(self) -> Result<Words, String> {
        let map = self
            .0
            .make_read_only()
            .map_err(|e| format!("the tree's pages: {e}"))?;
        Ok(Words::Copied(map))
    }
}

impl core::ops::Deref for Fresh {
    type Target = [u32];
    fn deref(&self) -> &[u32] {
        bytemuck::cast_slice(&self.0)
    }
}

impl core::ops::DerefMut for Fresh {
    fn deref_mut(&mut self) -> &mut [u32] {
        bytemuck::cast_slice_mut(&mut self.0)
    }
}

/// The memory of `array` kept where it is, not copied, when nothing can change it: what owns it
/// (following numpy's `base` and memoryviews' `obj`) is a `bytes` object or a [`Tree`] (whose
/// words never change; a mapped tree's file must stay as it is, as for that tree), and it is
/// C-contiguous and 64-byte aligned (the wide section on cache lines, as [`copy`] puts it).
/// `None` otherwise: the caller copies.
///
/// An unpickled scene in the process that pickled it (`pickle.loads` with protocol 5's buffers,
/// as `copy` would) gets the pickled tree's own words this way, and still validates them.
pub fn share(array: &PyReadonlyArray1<'_, u32>) -> PyResult<Option<Words>> {
    if !owned_by_something_immutable(array.as_any())? {
        return Ok(None);
    }
    Ok(array
        .as_slice()
        .ok()
        .filter(|w| (w.as_ptr() as usize).is_multiple_of(64))
        .map(|w| {
            Words::Shared(Shared {
                _array: array.as_any().clone().unbind(),
                at: w.as_ptr() as usize,
                len: w.len(),
            })
        }))
}

/// Whether the memory that `obj` views is a `bytes` object's or a [`Tree`]'s.
fn owned_by_something_immutable(obj: &Bound<'_, PyAny>) -> PyResult<bool> {
    let mut obj = obj.clone();
    // numpy collapses chains of views onto their owner; a few steps are enough.
    for _ in 0..8 {
        if obj.is_exact_instance_of::<PyBytes>() || obj.is_exact_instance_of::<Tree>() {
            return Ok(true);
        }
        obj = if obj.is_instance_of::<PyMemoryView>() {
            obj.getattr("obj")?
        } else if obj.is_instance_of::<PyUntypedArray>() {
            obj.getattr("base")?
        } else {
            return Ok(false);
        };
    }
    Ok(false)
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
