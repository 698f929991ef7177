//! The cache-line-blocked kd-tree (format v7's optional blocks section): the same tree as the
//! node section, cut into 64-byte blocks of up to three levels each, so that one cache line
//! serves three steps of a walk, and one ray decides a block's planes with SIMD at once.
//!
//! # A block: 16 words (64 bytes, one cache line when the words are 64-byte aligned)
//! ```text
//! words 0..7    split planes of slots 0..6 (f32 bits); 0 in a slot that is not an interior node
//! word 7        flags: bits 2k..2k+2 are slot k's split axis (0 = x, 1 = y, 2 = z), or 3 when
//!               slot k is not an interior node (k = 0..6); bit 13 + p (p = 1..14) says that
//!               position p is an empty leaf; bits 28..32 are 0
//! words 8..16   references r0..r7, see below
//! ```
//! The slots are a complete binary tree of three levels in heap order: slot 0 is the top, the
//! children of slot `s` are positions `2s + 1` (below) and `2s + 2` (above). Positions 0..7 are
//! slots; positions 7..15 are the references `r(p − 7)`, the children of the bottom slots 3..6.
//! A child position `p < 7` that is not an interior node (axis 3) is a leaf, stored as the
//! reference at its leftmost bottom position, `r(lm(p))` with `lm(p)` the result of
//! `p ← 2p + 1` until `p ≥ 7`, minus 7 (`lm` of 1..7 is 0, 4, 0, 2, 4, 6): so a subtree shallower
//! than three levels needs no other encoding. The empty bits repeat what the references say, so
//! that a walk skips an empty child (a clip of the interval, as in [`crate::node`]) by one shift of
//! the word it already holds.
//!
//! **Roots.** A block's subtrees start at its *roots*: slot 0 when it is an interior node (every
//! block the builder cuts from the top of a subtree), else each interior slot whose parent slot is
//! not one. The builder packs subtrees of one or two levels that hang below the same block into
//! shared blocks this way (two two-level subtrees at slots 1 and 2, or one-level subtrees at
//! slots 3..6): without it, half of the dragon's blocks held one node. A slot, reference or plane
//! that no root reaches is 0 (axis 3).
//!
//! # A reference: one word
//! ```text
//! bits 0..2   kind: 0 = block, 1 = leaf node, 2 = leaf of one primitive, 3 = empty leaf
//! bits 2..32  kind 0: 8 · block index + the root slot the subtree starts at
//!             kind 1: index of the leaf in the node section (its count and payload, as there)
//!             kind 2: the primitive's id
//!             kind 3: 0 (the whole word is 3)
//! ```
//! A leaf is not stored in the block: a leaf needs a count and an offset, 62 bits of
//! [`crate::node::Node`], and the node section, which every file has for the packet walks, holds
//! it already; one-primitive leaves and empty leaves need no load at all. Block 0 is the root;
//! its slot 0 is a leaf only when the whole tree is one leaf (then `r0` is it).
//!
//! # Order and validation
//! Every reference to a block points to a later block, and blocks are first entered in index
//! order by a depth-first walk of the tree, below child first (the node section's order), so
//! every block is reached and none lies before its parent. Validation ([`validate`]) walks the
//! blocked tree and the node section in lockstep and requires the same tree: each interior slot
//! has the split and axis of the node at the same pre-order position, each leaf reference names
//! that node (kind 1) or has its one primitive (kind 2) or is empty exactly when it is empty (kind
//! 3), and the flags and unused words are as above. The walk over blocks therefore makes the
//! decisions of the walk over nodes, plane for plane ([`walk`]), on a tree that unfolds to
//! exactly the node tree, so it is bounded as that one is.

#[cfg(feature = "blocked")]
pub mod lanes;
pub mod validate;
#[cfg(feature = "blocked")]
pub mod walk;

/// Words per block.
pub const BLOCK_WORDS: usize = 16;
/// Interior slots per block (three levels).
pub const SLOTS: usize = 7;
/// The word holding the slots' axes.
pub const AXES_WORD: usize = 7;
/// The first reference word.
pub const REFS_WORD: usize = 8;
/// The axis value of a slot that is not an interior node.
pub const NOT_INTERIOR: u32 = 3;
/// The most blocks a section may hold: a block reference holds `8 · block + slot` in 30 bits.
pub const MAX_BLOCKS: u32 = 1 << 27;
/// Bit of the flags word marking position `p` (1..15) empty: `1 << (EMPTY_SHIFT + p)`.
pub const EMPTY_SHIFT: usize = 13;
/// The flags word of a block with no slot in use (every axis 3, no empty bit).
pub const NO_SLOTS: u32 = (1 << (2 * SLOTS)) - 1;

/// Reference kinds (bits 0..2 of a reference).
pub mod kind {
    pub const BLOCK: u32 = 0;
    pub const LEAF: u32 = 1;
    pub const ONE: u32 = 2;
    pub const EMPTY: u32 = 3;
}

/// One block as stored.
pub type Block = [u32; BLOCK_WORDS];

/// A reference word of `kind` with `value` (at most 2³⁰ − 1; the writer checks).
#[inline]
pub const fn reference(kind: u32, value: u32) -> u32 {
    (value << 2) | kind
}

/// The empty-leaf reference.
pub const EMPTY: u32 = kind::EMPTY;

/// The largest value a reference holds.
pub const MAX_VALUE: u32 = (1 << 30) - 1;

/// Slot `s`'s axis field: 0..3, or [`NOT_INTERIOR`].
#[inline(always)]
pub const fn axis(block: &Block, s: usize) -> u32 {
    (block[AXES_WORD] >> (2 * s)) & 3
}

/// Whether position `p` (0..15) is an interior slot of `block`.
#[inline(always)]
pub const fn is_interior(block: &Block, p: usize) -> bool {
    p < SLOTS && axis(block, p) != NOT_INTERIOR
}

/// The reference index (0..8) that stands for position `p` when it is not an interior slot:
/// `p − 7` for a reference position, the leftmost bottom position under a slot otherwise.
#[inline(always)]
pub const fn ref_index(p: usize) -> usize {
    // lm(p) for p = 0..7, then p − 7.
    const LM: [u8; 15] = [0, 0, 4, 0, 2, 4, 6, 0, 1, 2, 3, 4, 5, 6, 7];
    LM[p] as usize
}

/// The reference word that position `p` of `block` stands for (`p` not an interior slot).
#[inline(always)]
pub const fn reference_at(block: &Block, p: usize) -> u32 {
    block[REFS_WORD + ref_index(p)]
}

/// Whether child position `p` (1..15) of `block` is an empty leaf (its flag bit).
#[inline(always)]
pub const fn is_empty_at(block: &Block, p: usize) -> bool {
    (block[AXES_WORD] >> (EMPTY_SHIFT + p)) & 1 != 0
}

/// Whether slot `s` starts a subtree: slot 0, or an interior slot under one that is not.
#[inline]
pub const fn is_root(block: &Block, s: usize) -> bool {
    is_interior(block, s) && (s == 0 || !is_interior(block, (s - 1) / 2))
}
