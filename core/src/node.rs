//! The kd-tree node: 2 words, pbrt-v3's `KdAccelNode` layout (Pharr, Jakob & Humphreys,
//! *Physically Based Rendering* 3rd ed., §4.4.1).
//!
//! ```text
//! word 1, bits 0..2   flags: split axis 0 = x, 1 = y, 2 = z, or 3 = leaf
//! word 1, bit 2       interior: the below child is an empty leaf
//! word 1, bit 3       interior: the above child is an empty leaf
//! word 1, bits 4..32  interior: index of the above child (the below child is this index + 1)
//! word 1, bits 2..32  leaf: number of primitives
//! word 0              interior: the split plane position (f32 bits)
//!                     leaf with 1 primitive: its id; with more: offset into the index list;
//!                     with none: 0
//! ```
//!
//! Differs from pbrt-v3: the two empty-child bits. An SAH tree with an empty-space bonus cuts
//! empty space off into empty leaves (28 % of the dragon's nodes); with the bits, a walk treats
//! such a split as a clip of its interval and never loads, pushes or pops the empty child.
//! Validation requires each bit to say exactly whether that child is an empty leaf.

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
    /// Largest above-child index an interior node can hold (28 bits).
    pub const MAX_CHILD: u32 = (1 << 28) - 1;
    /// Largest primitive count a leaf can hold (30 bits).
    pub const MAX_COUNT: u32 = (1 << 30) - 1;
    /// Interior flag bit: the below child is an empty leaf.
    const BELOW_EMPTY: u32 = 1 << 2;
    /// Interior flag bit: the above child is an empty leaf.
    const ABOVE_EMPTY: u32 = 1 << 3;

    #[inline(always)]
    pub const fn from_words(words: [u32; 2]) -> Self {
        Self { words }
    }

    #[inline(always)]
    pub const fn words(&self) -> [u32; 2] {
        self.words
    }

    /// An interior node splitting `axis` at `split`, above child at `above`; `empty` says which
    /// children are empty leaves, `[below, above]`.
    /// `above` must be at most [`Node::MAX_CHILD`] (the writer checks).
    #[inline]
    pub const fn interior(axis: u32, split: f32, above: u32, empty: [bool; 2]) -> Self {
        let flags = (empty[0] as u32 * Self::BELOW_EMPTY) | (empty[1] as u32 * Self::ABOVE_EMPTY);
        Self {
            words: [split.to_bits(), (above << 4) | flags | (axis & 3)],
        }
    }

    /// A leaf of `count` primitives whose `payload` is the one id or the index-list offset.
    /// `count` must be at most [`Node::MAX_COUNT`] (the writer checks).
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
        self.words[1] >> 4
    }

    /// Of an interior node: whether its `[below, above]` children are empty leaves.
    #[inline(always)]
    pub const fn empty_children(&self) -> [bool; 2] {
        [
            self.words[1] & Self::BELOW_EMPTY != 0,
            self.words[1] & Self::ABOVE_EMPTY != 0,
        ]
    }

    /// A leaf with no primitives.
    #[inline(always)]
    pub const fn is_empty_leaf(&self) -> bool {
        self.words[1] == LEAF
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
