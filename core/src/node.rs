//! The kd-tree node: 2 words, pbrt-v3's `KdAccelNode` layout (Pharr, Jakob & Humphreys,
//! *Physically Based Rendering* 3rd ed., §4.4.1).
//!
//! ```text
//! word 1, bits 0..2   flags: split axis 0 = x, 1 = y, 2 = z, or 3 = leaf
//! word 1, bits 2..32  interior: index of the above child (the below child is this index + 1)
//!                     leaf: number of primitives
//! word 0              interior: the split plane position (f32 bits)
//!                     leaf with 1 primitive: its id; with more: offset into the index list;
//!                     with none: 0
//! ```

/// The `flags` value of a leaf.
pub const LEAF: u32 = 3;

/// One node as stored: `[word 0, word 1]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Node {
    words: [u32; 2],
}

const _: () = assert!(core::mem::size_of::<Node>() == 8);

impl Node {
    /// Largest child index or primitive count that fits in 30 bits.
    pub const MAX_FIELD: u32 = (1 << 30) - 1;

    #[inline(always)]
    pub const fn from_words(words: [u32; 2]) -> Self {
        Self { words }
    }

    #[inline(always)]
    pub const fn words(&self) -> [u32; 2] {
        self.words
    }

    /// An interior node splitting `axis` at `split`, above child at `above`.
    /// `above` must be at most [`Node::MAX_FIELD`] (the writer checks).
    #[inline]
    pub const fn interior(axis: u32, split: f32, above: u32) -> Self {
        Self {
            words: [split.to_bits(), (above << 2) | (axis & 3)],
        }
    }

    /// A leaf of `count` primitives whose `payload` is the one id or the index-list offset.
    #[inline]
    pub const fn leaf(count: u32, payload: u32) -> Self {
        Self {
            words: [payload, (count << 2) | LEAF],
        }
    }

    #[inline(always)]
    pub const fn is_leaf(&self) -> bool {
        self.words[1] & 3 == LEAF
    }

    /// Split axis of an interior node (0, 1, 2).
    #[inline(always)]
    pub const fn axis(&self) -> usize {
        (self.words[1] & 3) as usize
    }

    #[inline(always)]
    pub fn split(&self) -> f32 {
        f32::from_bits(self.words[0])
    }

    #[inline(always)]
    pub const fn above_child(&self) -> u32 {
        self.words[1] >> 2
    }

    #[inline(always)]
    pub const fn prim_count(&self) -> u32 {
        self.words[1] >> 2
    }

    #[inline(always)]
    pub const fn payload(&self) -> u32 {
        self.words[0]
    }
}
