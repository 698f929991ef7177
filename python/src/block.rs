//! The memory of `Tree.intersect`'s and `Top.intersect`'s answers: one block per call for all of
//! its arrays, recycled.
//!
//! Why: a million rays' answers are 20 MB of new arrays a call. Fresh from the allocator they are
//! fresh pages, which the kernel zeroes on first touch: on this VM that cost 2–8 ms a call (varying
//! with whether `malloc` had the pages still mapped), a tenth of tracing the bunny's primary rays,
//! and none of it in `kdray trace`, which writes into the same hits buffer every time. So the
//! arrays are views of one [`Block`], the base object of each; when Python drops the last of them,
//! the block's memory goes back to a small pool ([`RETAIN`]) and the next call of about that
//! size writes into pages already mapped.

use crate::stop::{self, Stop};
use numpy::ndarray::ArrayView1;
use numpy::{Element, PyArray1};
use pyo3::prelude::*;
use std::mem::MaybeUninit;
use std::sync::Mutex;

/// Bytes of blocks kept for reuse at most, and the smallest block worth keeping (a smaller one
/// `malloc` serves from its own free lists).
const RETAIN: usize = 256 << 20;
const SMALLEST: usize = 1 << 20;

/// Blocks given back, for the next calls.
static POOL: Mutex<Vec<Vec<MaybeUninit<u64>>>> = Mutex::new(Vec::new());

/// Memory for a call's arrays; the base object of each array made of it ([`Block::array`]).
#[pyclass(frozen, module = "kdray._kdray")]
pub struct Block {
    words: Vec<MaybeUninit<u64>>,
}

impl Drop for Block {
    fn drop(&mut self) {
        let words = std::mem::take(&mut self.words);
        let bytes = 8 * words.capacity();
        if bytes < SMALLEST {
            return;
        }
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let kept: usize = pool.iter().map(|w| 8 * w.capacity()).sum();
        if kept + bytes <= RETAIN {
            pool.push(words);
        }
    }
}

/// Where each array lies in a block: byte offsets, each on a cache line.
#[derive(Clone, Copy, Debug)]
pub struct Layout<const N: usize> {
    offsets: [usize; N],
    bytes: usize,
}

impl<const N: usize> Layout<N> {
    /// Arrays of `sizes[k].0` elements of `sizes[k].1` bytes, one after another.
    pub fn new(sizes: [(usize, usize); N]) -> Self {
        let mut offsets = [0; N];
        let mut at = 0;
        for (o, (n, width)) in offsets.iter_mut().zip(sizes) {
            *o = at;
            at = (at + n * width).next_multiple_of(64);
        }
        Self { offsets, bytes: at }
    }
}

impl Block {
    /// A block for `layout`: a kept one that fits (not more than twice the size), else a new one.
    /// Its bytes are uninitialized.
    ///
    /// # Errors
    /// A new block's memory cannot be allocated ([`Stop::Memory`]).
    pub fn new<const N: usize>(layout: Layout<N>) -> Result<Self, Stop> {
        // One word more than needed, so that the arrays can start on a cache line whatever the
        // allocation's alignment (`malloc`: 16 bytes).
        let need = layout.bytes.div_ceil(8) + 8;
        let kept = {
            let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
            let best = pool
                .iter()
                .enumerate()
                .filter(|(_, w)| (need..=2 * need).contains(&w.capacity()))
                .min_by_key(|(_, w)| w.capacity())
                .map(|(k, _)| k);
            best.map(|k| pool.swap_remove(k))
        };
        let mut words = match kept {
            Some(w) => w,
            None => {
                let mut w = Vec::new();
                stop::reserve(&mut w, need, "intersect's answers")?;
                w
            }
        };
        // SAFETY: `MaybeUninit` needs no initialization, and the capacity is at least `need`.
        unsafe { words.set_len(need) };
        Ok(Self { words })
    }

    /// The byte offset of the block's first cache line.
    fn start(&self) -> usize {
        (64 - self.words.as_ptr() as usize % 64) % 64
    }

    /// The block's arrays as bytes to write, in `layout`'s order.
    pub fn split<const N: usize>(&mut self, layout: Layout<N>) -> [&mut [MaybeUninit<u8>]; N] {
        let start = self.start();
        let len = 8 * self.words.len();
        // SAFETY: the words' bytes, as bytes (any bits are a valid `MaybeUninit<u8>`).
        let bytes = unsafe {
            std::slice::from_raw_parts_mut(self.words.as_mut_ptr().cast::<MaybeUninit<u8>>(), len)
        };
        let mut rest = &mut bytes[start..start + layout.bytes];
        let mut at = 0;
        let mut next = |k: usize| {
            let end = layout.offsets.get(k + 1).copied().unwrap_or(layout.bytes);
            let (part, tail) = std::mem::take(&mut rest).split_at_mut(end - at);
            (rest, at) = (tail, end);
            part
        };
        core::array::from_fn(&mut next)
    }

    /// Array `k` of `layout` (`len` elements of `T`) as a numpy array whose base is `block`.
    ///
    /// # Safety
    /// `layout` is the block's, array `k` holds `len` elements of `T` (as the layout was made),
    /// and every one of them has been written.
    pub unsafe fn array<'py, T: Element, const N: usize>(
        block: &Bound<'py, Block>,
        layout: Layout<N>,
        k: usize,
        len: usize,
    ) -> Bound<'py, PyArray1<T>> {
        let b = block.get();
        let at = b.start() + layout.offsets[k];
        // SAFETY: array `k` lies inside the block, on a cache line (aligned for any `T` here), its
        // elements written, as the caller promises; the block is the array's base object, so its
        // memory (never reallocated) outlives the array.
        unsafe {
            let ptr = b.words.as_ptr().cast::<u8>().add(at).cast::<T>();
            let view = ArrayView1::from_shape_ptr(len, ptr);
            PyArray1::borrow_from_array(&view, block.clone().into_any())
        }
    }
}

/// `bytes` (a block's array, [`Block::split`]) as `len` elements of `T` to write.
///
/// # Panics
/// If the bytes are too few or not aligned for `T` (a wrong layout).
pub fn typed<T>(bytes: &mut [MaybeUninit<u8>], len: usize) -> &mut [MaybeUninit<T>] {
    // SAFETY: any bytes are a valid `MaybeUninit<T>`.
    let (head, items, _) = unsafe { bytes.align_to_mut::<MaybeUninit<T>>() };
    assert!(
        head.is_empty() && items.len() >= len,
        "a block's array is misplaced"
    );
    &mut items[..len]
}
