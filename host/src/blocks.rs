//! Cutting the serialized node tree into the 64-byte blocks of format v7's blocks section
//! (`kdray_core::traverse::blocked`, where the encoding is documented). Each block takes the top
//! three levels of the subtree it starts; below it, a subtree of three or more levels gets a block
//! of its own, and the shallower ones (one or two levels) hanging below the same block are packed
//! together into shared blocks (two-level ones at slots 1 and 2, one-level ones at 3..6). Blocks
//! are numbered in the order a depth-first walk, below child first, first enters them: what
//! validation requires.

use kdray_core::node::Node;
use kdray_core::traverse::blocked::{
    AXES_WORD, BLOCK_WORDS, Block, EMPTY, EMPTY_SHIFT, MAX_BLOCKS, MAX_VALUE, NO_SLOTS, REFS_WORD,
    SLOTS, kind, ref_index, reference,
};

/// The blocks of the tree in `nodes` (pre-order, as `flat::serialize` writes them).
///
/// # Errors
/// More blocks than the format can number ([`MAX_BLOCKS`]).
pub fn to_blocks(nodes: &[Node]) -> Result<Vec<Block>, String> {
    let mut blocks = Vec::with_capacity(nodes.len() / 8 + 1);
    emit(nodes, 0, &mut blocks)?;
    Ok(blocks)
}

/// A new block with no slot in use, appended; its index.
fn new_block(blocks: &mut Vec<Block>) -> Result<u32, String> {
    if blocks.len() >= MAX_BLOCKS as usize {
        return Err("tree too large for the blocked layout (2^27 blocks)".to_string());
    }
    let mut block = [0; BLOCK_WORDS];
    block[AXES_WORD] = NO_SLOTS;
    blocks.push(block);
    Ok(blocks.len() as u32 - 1)
}

/// Appends the block whose slot 0 is node `root`, then the blocks below it in order; returns
/// its index.
fn emit(nodes: &[Node], root: u32, blocks: &mut Vec<Block>) -> Result<u32, String> {
    let at = new_block(blocks)?;
    let mut below = Vec::new(); // (reference index, subtree root node), in reference order
    fill(nodes, &mut blocks[at as usize], 0, root, &mut below);
    // The open block of packed subtrees and which of its quarters (slot 3 + q) are taken.
    let mut packed: Option<(u32, [bool; 4])> = None;
    for (r, node) in below {
        let target = match height(nodes, node, 3) {
            3 => 8 * emit(nodes, node, blocks)?,
            h => {
                // Two levels take slot 1 (quarters 0, 1) or 2 (quarters 2, 3); one takes a quarter.
                let fits = |taken: &[bool; 4]| -> Option<(usize, [usize; 2])> {
                    let free = |q: usize| !taken[q];
                    if h == 2 {
                        [(1, [0, 1]), (2, [2, 3])]
                            .into_iter()
                            .find(|(_, qs)| qs.iter().all(|&q| free(q)))
                    } else {
                        (0..4).find(|&q| free(q)).map(|q| (3 + q, [q, q]))
                    }
                };
                let (index, slot) = match packed.as_mut().and_then(|(i, t)| Some((*i, fits(t)?))) {
                    Some(found) => found,
                    None => {
                        let i = new_block(blocks)?;
                        packed = Some((i, [false; 4]));
                        (i, fits(&[false; 4]).expect("an empty block fits"))
                    }
                };
                let (slot, quarters) = slot;
                if let Some((_, taken)) = packed.as_mut() {
                    quarters.iter().for_each(|&q| taken[q] = true);
                }
                let mut none = Vec::new();
                fill(nodes, &mut blocks[index as usize], slot, node, &mut none);
                debug_assert!(none.is_empty(), "a packed subtree fits its slots");
                8 * index + slot as u32
            }
        };
        blocks[at as usize][REFS_WORD + r] = reference(kind::BLOCK, target);
    }
    Ok(at)
}

/// Interior levels of the subtree at node `index`, counted up to `cap`.
fn height(nodes: &[Node], index: u32, cap: u32) -> u32 {
    let node = nodes[index as usize];
    if cap == 0 || node.is_leaf() {
        return 0;
    }
    let below = height(nodes, index + 1, cap - 1);
    1 + below.max(height(nodes, node.above_child(), cap - 1))
}

/// Places node `index` at position `p` of `block`: an interior node in a slot (and its children
/// below it), a leaf as a reference; an interior node past the bottom slots is left in `below`
/// to become a child block.
fn fill(nodes: &[Node], block: &mut Block, p: usize, index: u32, below: &mut Vec<(usize, u32)>) {
    let node = nodes[index as usize];
    if node.is_leaf() {
        block[REFS_WORD + ref_index(p)] = match node.prim_count() {
            0 => EMPTY,
            1 if node.payload() <= MAX_VALUE => reference(kind::ONE, node.payload()),
            _ => reference(kind::LEAF, index),
        };
        if node.is_empty_leaf() && p > 0 {
            block[AXES_WORD] |= 1 << (EMPTY_SHIFT + p);
        }
    } else if p < SLOTS {
        block[p] = node.words()[0];
        let shift = 2 * p;
        block[AXES_WORD] = block[AXES_WORD] & !(3 << shift) | (node.axis() as u32) << shift;
        fill(nodes, block, 2 * p + 1, index + 1, below);
        fill(nodes, block, 2 * p + 2, node.above_child(), below);
    } else {
        below.push((ref_index(p), index));
    }
}
