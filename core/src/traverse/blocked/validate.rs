//! Validation of the blocks section: the blocked tree must be the node tree (see the
//! [module doc](super)), checked by one walk over both in lockstep, in time linear in the node
//! count and with a stack of at most [`MAX_DEPTH`] items.

use super::{
    AXES_WORD, Block, EMPTY, EMPTY_SHIFT, MAX_BLOCKS, REFS_WORD, SLOTS, axis, is_interior, is_root,
    kind, ref_index, reference_at,
};
use crate::format::{FormatError, MAX_DEPTH, Scene};

/// Checks `blocks` against `scene`'s node section (already validated).
///
/// # Errors
/// [`FormatError::BadBlockFlags`] for a block whose axes word or unused words are not as the
/// layout requires, [`FormatError::BadBlockRef`] for a reference out of range, back to an earlier
/// block, out of turn, or naming another node, [`FormatError::BlockMismatch`] where the blocked
/// tree differs from the node tree, [`FormatError::BadDepth`] past [`MAX_DEPTH`].
pub fn validate(scene: &Scene, blocks: &[Block]) -> Result<(), FormatError> {
    let n_blocks = blocks.len() as u32;
    if blocks.len() > MAX_BLOCKS as usize {
        return Err(FormatError::CountOverflow);
    }
    let Some(root) = blocks.first() else {
        return Err(FormatError::BadContents);
    };
    check_flags(root, 0)?;
    let n_nodes = scene.node_count();
    // Pending above children as (block, position).
    let mut stack: heapless::Vec<(u32, usize), MAX_DEPTH> = heapless::Vec::new();
    // The next node of the pre-order walk, and the highest block entered so far.
    let (mut next_node, mut last_block) = (0u32, 0u32);
    let mut current = Some((0u32, 0usize));
    while let Some((b, p)) = current {
        let mismatch = FormatError::BlockMismatch { block: b };
        let bad_ref = FormatError::BadBlockRef { block: b };
        // The node at this place of the pre-order walk; one per step, so the loop is bounded.
        let index = next_node;
        if index >= n_nodes {
            return Err(mismatch);
        }
        next_node += 1;
        let node = scene.node(index);
        let block = &blocks[b as usize];
        let (b, s) = if is_interior(block, p) {
            (b, p)
        } else {
            let r = reference_at(block, p);
            let value = r >> 2;
            let leaf_ok = match r & 3 {
                kind::BLOCK => {
                    // A later block, and either one entered before (a block of packed subtrees)
                    // or the next one: blocks are first entered in index order.
                    let (child, slot) = (value >> 3, (value & 7) as usize);
                    if child <= b || child >= n_blocks || child > last_block + 1 {
                        return Err(bad_ref);
                    }
                    if child == last_block + 1 {
                        last_block = child;
                        check_flags(&blocks[child as usize], child)?;
                    }
                    if !is_root(&blocks[child as usize], slot) {
                        return Err(bad_ref);
                    }
                    None
                }
                kind::LEAF if value != index => return Err(bad_ref),
                kind::LEAF => Some(node.is_leaf() && node.prim_count() > 0),
                kind::ONE => {
                    Some(node.is_leaf() && node.prim_count() == 1 && node.payload() == value)
                }
                _ => Some(r == EMPTY && node.is_empty_leaf()),
            };
            match leaf_ok {
                Some(true) => {
                    current = stack.pop();
                    continue;
                }
                Some(false) => return Err(mismatch),
                None => (value >> 3, (value & 7) as usize),
            }
        };
        let block = &blocks[b as usize];
        let mismatch = FormatError::BlockMismatch { block: b };
        if node.is_leaf() || axis(block, s) != node.axis() as u32 || block[s] != node.words()[0] {
            return Err(mismatch);
        }
        stack
            .push((b, 2 * s + 2))
            .map_err(|_| FormatError::BadDepth)?;
        current = Some((b, 2 * s + 1));
    }
    if next_node != n_nodes {
        return Err(FormatError::BlockMismatch { block: 0 });
    }
    if last_block + 1 != n_blocks {
        return Err(FormatError::BadBlockRef {
            block: last_block + 1,
        });
    }
    Ok(())
}

/// The layout rules inside one block (see the [module doc](super)): the flags word's top bits
/// are 0; every slot, plane and reference that no root reaches is 0 (axis 3), and so is the
/// plane of a leaf slot; the empty bits say exactly which leaf positions hold an empty leaf.
fn check_flags(block: &Block, b: u32) -> Result<(), FormatError> {
    let bad = Err(FormatError::BadBlockFlags { block: b });
    if block[AXES_WORD] >> (EMPTY_SHIFT + 15) != 0 {
        return bad;
    }
    let mut used_refs = [false; 8];
    // Position p is a leaf when its parent slot is interior (or it is the root of a tree that
    // is one leaf: block 0, slot 0).
    for p in 0..15 {
        let leaf = if p == 0 {
            b == 0 && !is_interior(block, 0)
        } else {
            is_interior(block, (p - 1) / 2) && !is_interior(block, p)
        };
        // Position 0 has no empty bit (a tree that is one empty leaf has no child to skip).
        let empty_bit = p > 0 && (block[AXES_WORD] >> (EMPTY_SHIFT + p)) & 1 != 0;
        if p > 0 && empty_bit != (leaf && reference_at(block, p) == EMPTY) {
            return bad;
        }
        if leaf {
            used_refs[ref_index(p)] = true;
        }
        if p < SLOTS && !is_interior(block, p) && block[p] != 0 {
            return bad;
        }
    }
    let unused_set = (0..8).any(|r| !used_refs[r] && block[REFS_WORD + r] != 0);
    if unused_set { bad } else { Ok(()) }
}
