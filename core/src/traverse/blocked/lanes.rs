//! Constant tables for deciding a block's three levels with one ray at once ([`super::walk`]).
//!
//! The eight bottom cells of a block, the positions of references `r0..r7`, are the lanes of an
//! 8-wide vector. Lane `i` lies below slot `a_k(i) = 2ᵏ − 1 + (i >> (3 − k))` at level `k`
//! (0, 1 or 2), on its above side when bit `2 − k` of `i` is set. The tables say which lanes stand
//! for a child that a root reaches and which levels constrain each lane's interval
//! ([`CELLS`]), in which order the node walk would reach the lanes ([`ORDER`]), and how to pack
//! the lanes a ray enters, farthest first ([`COMPACT`]). All are built at compile time from the
//! definitions in [`super`] by the same descent the node walk makes, so they hold no hand-typed
//! entries; `tests/tests/blocked.rs` checks the walk that reads them against the node walk.
//!
//! This is the wide-node decision of Fuetterling et al. 2017 ("Accelerated Single Ray Tracing
//! for Wide Vector Units", HPG, §4: a lane per child, hit mask by compare and movemask,
//! front-to-back order from the direction's signs, a permutation table to compact) applied to the
//! three kd-tree levels of a block. Differs from it: the order is the kd walk's depth-first order
//! by the sign at each level's slot (not a sort by entry distance), so that ties between
//! primitives at the same `t` resolve as in the node walk.

use super::{SLOTS, ref_index};

/// Slot at level `k` above lane `i`.
pub const fn slot_above(k: usize, i: usize) -> usize {
    (1 << k) - 1 + (i >> (3 - k))
}

/// The level of slot `s` (0 for 0, 1 for 1..3, 2 for 3..7).
const fn level(s: usize) -> usize {
    if s == 0 {
        0
    } else if s < 3 {
        1
    } else {
        2
    }
}

/// For the subtree that starts at slot `root` (0..7; 7 is no slot and gives 0) of a block whose
/// slots `s` with bit `s` of `not_interior` set are not interior nodes: bit `i` says that lane `i`
/// is a child the subtree reaches (a reference position, or the leftmost bottom position of a
/// leaf slot, `lm(p)`); bit `8 (k + 1) + i` says that the slot at level `k` above a reached lane
/// `i` is an interior node of the subtree, so that its plane bounds the lane's interval.
pub const fn cells(root: usize, not_interior: usize) -> u32 {
    if root >= SLOTS {
        return 0;
    }
    let mut out = 0u32;
    let mut i = 0;
    while i < 8 {
        if slot_above(level(root), i) == root {
            let mut active = 0u32;
            let mut reached = true;
            let mut k = level(root);
            while k < 3 {
                let s = slot_above(k, i);
                if (not_interior >> s) & 1 != 0 {
                    // A leaf slot: the lane stands for it only at its leftmost bottom position.
                    reached = ref_index(s) == i;
                    break;
                }
                active |= 1 << (8 * (k + 1) + i);
                k += 1;
            }
            if reached {
                out |= (1 << i) | active;
            }
        }
        i += 1;
    }
    out
}

/// [`cells`] for every root slot (0..8) and every set of non-interior slots (7 bits).
pub static CELLS: [[u32; 128]; 8] = {
    let mut t = [[0; 128]; 8];
    let mut root = 0;
    while root < 8 {
        let mut n = 0;
        while n < 128 {
            t[root][n] = cells(root, n);
            n += 1;
        }
        root += 1;
    }
    t
};

/// Lane `i`'s bit in a [`CELLS`] entry saying it is reached, for the lane masks.
pub const VALID_BIT: [u32; 8] = lane_bits(0);
/// Per level, lane `i`'s bit in a [`CELLS`] entry saying the slot above it bounds it.
pub const ACTIVE_BIT: [[u32; 8]; 3] = [lane_bits(8), lane_bits(16), lane_bits(24)];

const fn lane_bits(shift: usize) -> [u32; 8] {
    let mut b = [0; 8];
    let mut i = 0;
    while i < 8 {
        b[i] = 1 << (shift + i);
        i += 1;
    }
    b
}

/// Per level `k`: the slot above each lane (the index that gathers its plane distance).
pub const SLOT: [[u32; 8]; 3] = [level_slots(0), level_slots(1), level_slots(2)];
/// Per level: the bit of the slot above each lane in a 7-bit set of slots.
pub const SLOT_BIT: [[u32; 8]; 3] = [slot_bits(0), slot_bits(1), slot_bits(2)];
/// Per level: all ones where the lane lies on the above side of the slot above it.
pub const ABOVE: [[u32; 8]; 3] = [above(0), above(1), above(2)];

const fn level_slots(k: usize) -> [u32; 8] {
    let mut s = [0; 8];
    let mut i = 0;
    while i < 8 {
        s[i] = slot_above(k, i) as u32;
        i += 1;
    }
    s
}

const fn slot_bits(k: usize) -> [u32; 8] {
    let mut s = [0; 8];
    let mut i = 0;
    while i < 8 {
        s[i] = 1 << slot_above(k, i);
        i += 1;
    }
    s
}

const fn above(k: usize) -> [u32; 8] {
    let mut s = [0; 8];
    let mut i = 0;
    while i < 8 {
        if (i >> (2 - k)) & 1 != 0 {
            s[i] = u32::MAX;
        }
        i += 1;
    }
    s
}

/// Shifts that unpack eight 3-bit fields of a word, one per lane.
pub const FIELD_SHIFT: [u32; 8] = [0, 3, 6, 9, 12, 15, 18, 21];

/// For the set of slots whose near child is the above one (bit `s`: the direction is negative
/// on slot `s`'s axis), the lanes in the node walk's visiting order: field `j` (3 bits) is the
/// lane visited `j`-th, taking the near child first at each of the three levels.
pub static ORDER: [u32; 128] = {
    let mut t = [0; 128];
    let mut neg = 0;
    while neg < 128 {
        let mut packed = 0u32;
        let mut j = 0;
        while j < 8 {
            let (mut lane, mut slot, mut k) = (0, 0, 0);
            while k < 3 {
                let side = ((j >> (2 - k)) & 1) ^ ((neg >> slot) & 1);
                lane = 2 * lane + side;
                slot = 2 * slot + 1 + side;
                k += 1;
            }
            packed |= (lane as u32) << (3 * j);
            j += 1;
        }
        t[neg] = packed;
        neg += 1;
    }
    t
};

/// For a set of positions (8 bits), the positions in it from the highest down, 3 bits each: the
/// stack order, so that the nearest ends on top.
pub static COMPACT: [u32; 256] = {
    let mut t = [0; 256];
    let mut m = 0;
    while m < 256 {
        let (mut packed, mut n, mut j) = (0u32, 0, 8);
        while j > 0 {
            j -= 1;
            if (m >> j) & 1 != 0 {
                packed |= (j as u32) << (3 * n);
                n += 1;
            }
        }
        t[m] = packed;
        m += 1;
    }
    t
};

/// The set of slots (7 bits) whose axis field is [`super::NOT_INTERIOR`], from the flags word.
#[inline(always)]
pub const fn not_interior(flags: u32) -> usize {
    // Both bits of slot s's field set → bit 2s; then gather the even bits 0, 2, …, 12.
    let mut x = flags & (flags >> 1) & 0x1555;
    x = (x | (x >> 1)) & 0x3333;
    x = (x | (x >> 2)) & 0x0f0f;
    x = (x | (x >> 4)) & 0x00ff;
    x as usize
}
