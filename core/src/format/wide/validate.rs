//! Validation of the wide section against the node section (see the [module doc](super)): one
//! walk over the wide nodes in index order, each node's cut recomputed from the node section
//! ([`frontier`]) and its references, count and orders required bit for bit; each box checked
//! inside its cell and around what its child holds. Linear in the words: each wide node is
//! checked once, each leaf's primitives once (a leaf is the child of one slot), each binary node
//! is in one cut.

use super::{
    EMPTY_BOX, LEAF_REF, MAX_WIDE_DEPTH, REFS, STACK, WIDTH, WideNode, contains, frontier,
    intersection, prim_box, skeleton, slot_box,
};
use crate::format::{FormatError, Scene};

/// A wide node waiting for its turn: its index as its parent's reference gives it, the binary
/// node it stands for, its cell, the parent slot's box and its depth.
type Pending = (u32, u32, super::Bounds, super::Bounds, usize);

/// Checks `scene`'s wide section against its node section (already validated).
///
/// # Errors
/// [`FormatError::BadWideNode`] for a node whose references, counts, orders or unused slots are
/// not the ones its cut gives, or that is entered out of turn; [`FormatError::BadWideBox`] for a
/// box outside its cell or not containing its child; [`FormatError::BadDepth`] past
/// [`MAX_WIDE_DEPTH`].
#[inline(never)]
pub fn validate(scene: &Scene, wide: &[WideNode]) -> Result<(), FormatError> {
    let n_wide = wide.len();
    if n_wide == 0 || n_wide >= LEAF_REF as usize {
        return Err(FormatError::BadContents);
    }
    let node = |i: u32| scene.node(i);
    let bounds = scene.bounds();
    let mut stack: heapless::Vec<Pending, STACK> = heapless::Vec::new();
    let mut next = 0u32;
    let mut current = Some((0u32, 0u32, bounds, bounds, 1usize));
    while let Some((w, b, cell, parent_box, depth)) = current {
        let bad = FormatError::BadWideNode { node: w };
        if w != next || w as usize >= n_wide {
            return Err(bad);
        }
        if depth > MAX_WIDE_DEPTH {
            return Err(FormatError::BadDepth);
        }
        next += 1;
        let stored = &wide[w as usize];
        let f = frontier(node, b, cell);
        // Everything but the boxes and the wide references is determined by the cut.
        let mut expected = skeleton(&f);
        for k in 0..f.count {
            expected[REFS + k] = if f.leaves[k] {
                LEAF_REF | f.nodes[k]
            } else {
                stored[REFS + k] & !LEAF_REF
            };
            super::set_slot_box(&mut expected, k, slot_box(stored, k));
        }
        if !crate::format::same_words(&expected, stored) {
            return Err(bad);
        }
        let bad_box = FormatError::BadWideBox { node: w };
        let mut children: heapless::Vec<Pending, WIDTH> = heapless::Vec::new();
        for k in 0..f.count {
            let b = slot_box(stored, k);
            let (lo, hi) = (b[0], b[1]);
            // A box inside its cell (and so inside the parent's cell) and the parent slot's box;
            // an empty box (low > high on an axis) only where the child holds nothing to hit.
            let empty = !lo.cmple(hi).all();
            let fits = contains(f.cells[k], b) && contains(parent_box, b);
            if !(empty || fits && lo.is_finite() && hi.is_finite()) {
                return Err(bad_box);
            }
            if f.leaves[k] {
                let prims = scene.leaf_prims(&node(f.nodes[k]));
                for prim in prims.ids() {
                    let inside = prim_box(scene, prim)
                        .and_then(|p| intersection(p, f.cells[k]))
                        .is_none_or(|p| !empty && contains(b, p));
                    if !inside {
                        return Err(bad_box);
                    }
                }
            } else {
                let child = stored[REFS + k];
                let item = (
                    child,
                    f.nodes[k],
                    f.cells[k],
                    if empty { EMPTY_BOX } else { b },
                );
                let _ = children.push((item.0, item.1, item.2, item.3, depth + 1));
            }
        }
        // Depth first in slot order: the first wide child is entered next.
        for &item in children.iter().rev() {
            stack.push(item).map_err(|_| FormatError::BadDepth)?;
        }
        current = stack.pop();
    }
    if next as usize != n_wide {
        return Err(FormatError::BadWideNode { node: next });
    }
    Ok(())
}

/// What the wide walk needs of the wide section of words this process's builder
/// wrote ([`Scene::from_built_words`]) to stay in range and end: every reference a ray can enter
/// is a leaf of the node section or a wide node after its own, so every path through the section
/// is at most its length. A slot a ray can never enter is one whose box is [`EMPTY_BOX`]
/// (low = +∞, high = −∞ on every axis: no slab test enters it, whatever the direction), which is
/// how the builder writes the slots past a node's count (their reference 0; [`validate`] accepts
/// them on the same ground). Linear in the section, without the node section's cuts or the
/// boxes' contents.
///
/// # Errors
/// [`FormatError::BadWideNode`] for a node with a reference out of range or pointing back.
pub fn forward_refs(scene: &Scene, wide: &[WideNode]) -> Result<(), FormatError> {
    let n_wide = wide.len();
    if n_wide == 0 || n_wide >= LEAF_REF as usize {
        return Err(FormatError::BadContents);
    }
    for (w, stored) in wide.iter().enumerate() {
        for k in 0..WIDTH {
            let r = stored[REFS + k];
            let ok = if r & LEAF_REF != 0 {
                (r & !LEAF_REF) < scene.node_count()
            } else {
                (w + 1..n_wide).contains(&(r as usize))
            };
            if !ok && slot_box(stored, k) != EMPTY_BOX {
                return Err(FormatError::BadWideNode { node: w as u32 });
            }
        }
    }
    Ok(())
}
