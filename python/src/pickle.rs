//! What `pickle` and `copy` take of a tree: its words, viewed in place (no copy) as a read-only
//! numpy array whose base is the tree. The package's `kdray/_pickle.py` wraps the view in a
//! `pickle.PickleBuffer`, so that pickle protocol 5 with out-of-band buffers (Dask's, for one)
//! sends the words without copying them into the pickle; the receiving side validates them as a
//! loaded `.kdt` (`Tree.from_words`), so that a truncated or damaged pickle is a `ValueError`.

use crate::Tree;
use numpy::ndarray::ArrayView1;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;

/// The words of `tree` as a read-only `uint32` array over the tree's own memory (native byte
/// order: a `.kdt`'s bytes on a little-endian host).
#[pyfunction]
pub fn words<'py>(tree: &Bound<'py, Tree>) -> PyResult<Bound<'py, PyArray1<u32>>> {
    let w = tree.get().owned.words();
    let view = ArrayView1::from(w);
    // SAFETY: the tree is frozen and its words are never moved or freed while it lives; it is the
    // array's base object, so it outlives the array.
    let array = unsafe { PyArray1::borrow_from_array(&view, tree.clone().into_any()) };
    // Not writeable (nor can Python make it so: the array does not own its data). A mapped
    // tree's pages are read-only; a copied one's are shared by every view of the tree.
    let readonly = array.readwrite().make_nonwriteable();
    Ok((*readonly).clone())
}
