//! Validation of the wide section against the node section (see the [module doc](super)): what
//! the walk ([`crate::traverse::wide::walk`]) needs to stay in range, end, and return the closest
//! hit of the node section's leaves, checked in one depth-first pass over the wide nodes in slot
//! order, in step with a pre-order pass over the node section that yields each non-empty leaf and
//! its cell:
//!
//! - **Shape.** Wide nodes are entered in index order (every reference points forward to the
//!   next one: a tree, no node shared or left out), at most [`MAX_WIDE_DEPTH`] deep (the walk's
//!   fixed stack holds the pending children of that many levels). Each node's eight order words
//!   carry one count `c ≤ 8`; their first `c` slots are a permutation of slots `0..c` and the rest
//!   are 0; slots past `c` hold [`EMPTY_BOX`] and reference 0, as the writer leaves them. The walk
//!   takes the entered slots among the first `c` positions of the order word, so a slot missing
//!   from them would never be entered, and one named twice would be entered twice per visit.
//! - **Leaves.** The leaf references, in that slot order, are exactly the node section's
//!   non-empty leaves in pre-order, each once, or, for a leaf cut into `m` parts, its parts
//!   `0..m` in consecutive slots of one wide node (each reference encoded as the writer encodes
//!   it, [`LeafRef::encode`]): every primitive a leaf holds is reachable, and each leaf's
//!   primitives are checked once, which keeps the pass linear.
//! - **Boxes.** Each used slot's box is finite and inside its parent slot's box (the root's: the
//!   scene box), and contains what its child holds: for a leaf, each hittable primitive's box
//!   clipped to the leaf's cell. An empty box (low > high on an axis) only where the child holds
//!   nothing to hit. So a hit point of a primitive inside the cell of a leaf that holds it (where
//!   the node walk finds it) lies in that leaf's box and in every box above it, and the
//!   conservative slab test enters them all. (That the node section's leaves hold every
//!   primitive meeting their cells is not checked, here or by the node walk's validation: a
//!   crafted tree answers for the scene it stores.)
//!
//! Not checked, because the walk's answers do not depend on it: that a node's children are the
//! greedy cut ([`super::frontier`]) of a binary node, that a box lies inside its cell, and that
//! the orders are front to back. The walk skips a pending child only when its entry distance is
//! beyond the closest hit so far, which is right whatever order the children come in and whether
//! or not the boxes overlap; the cut, the cells and the orders make it fast, not right (a crafted
//! file that breaks them is slower; a tie between two primitives at the same `t` may go to the
//! other one). Random damage to them is caught by the checksum.
//!
//! Linear in the words: each wide node is entered once and each slot read once, each node of the
//! node section passed once, each leaf's primitives checked once.

use super::{
    BOXES, Bounds, EMPTY_BOX, LEAF_REF, LeafRef, MAX_WIDE_DEPTH, ORDERS, REFS, WIDTH, WideNode,
    contains, intersection, prim_box, slot_box,
};
use crate::format::{FormatError, LeafPrims, MAX_DEPTH, Scene};
use crate::group::{self, Group, slot};
use core::cmp::Ordering;

/// The node section's non-empty leaves in pre-order, with their cells: the node section's
/// order, which [`Scene::from_words`] has checked (each interior node's below child follows it,
/// the above child comes after the below child's subtree).
struct Leaves<'s, 'a> {
    scene: &'s Scene<'a>,
    /// The next node to pass and its cell.
    next: u32,
    cell: Bounds,
    /// The cells of the above children still to come.
    above: heapless::Vec<Bounds, { MAX_DEPTH + 1 }>,
}

impl Iterator for Leaves<'_, '_> {
    type Item = (u32, Bounds);

    fn next(&mut self) -> Option<(u32, Bounds)> {
        while self.next < self.scene.node_count() {
            let (index, cell) = (self.next, self.cell);
            let node = self.scene.node(index);
            self.next += 1;
            if node.is_leaf() {
                // The next node in pre-order is the latest pending above child (none at the end).
                self.cell = self.above.pop().unwrap_or(EMPTY_BOX);
                if !node.is_empty_leaf() {
                    return Some((index, cell));
                }
            } else {
                let (axis, split) = (node.axis(), node.split());
                let (mut below, mut above) = (cell, cell);
                below[1][axis] = split;
                above[0][axis] = split;
                // The tree is at most MAX_DEPTH deep (checked): the push cannot fail.
                self.above.push(above).ok()?;
                self.cell = below;
            }
        }
        None
    }
}

/// The count of a wide node whose orders, unused slots and references past the count are as
/// the module doc says, or `None`.
fn shape(stored: &WideNode) -> Option<usize> {
    let count = (stored[ORDERS] >> 24) as usize;
    if count > WIDTH {
        return None;
    }
    let used = (1u32 << count) - 1;
    // The order's fields past the count must be 0, and its bits 24.. the count.
    let fields = (1u32 << (3 * count)) - 1;
    let orders_ok = stored[ORDERS..].iter().all(|&order| {
        let seen = (0..count).fold(0u32, |seen, k| seen | 1 << (order >> (3 * k) & 7));
        order & !fields == (count as u32) << 24 && seen == used
    });
    let unused_ok = (count..WIDTH).all(|k| stored[REFS + k] == 0 && unused_box(stored, k));
    (orders_ok && unused_ok).then_some(count)
}

/// Whether slot `k`'s box is [`EMPTY_BOX`], bit for bit.
fn unused_box(stored: &WideNode, k: usize) -> bool {
    (0..6).all(|w| {
        let side = w & 1;
        stored[BOXES + 8 * w + k] == EMPTY_BOX[side][w / 2].to_bits()
    })
}

/// Whether each hittable lane of group `g` (threshold below `+∞`; padding lanes are `+∞`) has
/// its box, clipped to `cell`, inside `b`, or misses `cell` — [`prim_box`]'s check, four lanes
/// at a time from the group's own copy of its triangles, which validation has found equal to the
/// triangles section's bit for bit (`Scene::validate_groups`): no id to follow, no threshold to
/// look up (a third of the wide check's instructions on the dragon, and its cache misses).
fn group_inside(g: &Group, cell: Bounds, b: Bounds, empty: bool) -> bool {
    let vertex = |k: usize, c: usize| group::floats(g, slot::VERTICES + 12 * k + 4 * c);
    // As glam's `Vec3::min` and `max` (one instruction a lane, no NaN case: the vertices are
    // finite, checked).
    let min = |x: f32, y: f32| if x < y { x } else { y };
    let max = |x: f32, y: f32| if x > y { x } else { y };
    let (mut meets, mut inside) = ([true; group::WIDTH], [true; group::WIDTH]);
    for c in 0..3 {
        let (v0, v1, v2) = (vertex(0, c), vertex(1, c), vertex(2, c));
        let (cell_lo, cell_hi, b_lo, b_hi) = (cell[0][c], cell[1][c], b[0][c], b[1][c]);
        for j in 0..group::WIDTH {
            let lo = max(min(min(v0[j], v1[j]), v2[j]), cell_lo);
            let hi = min(max(max(v0[j], v1[j]), v2[j]), cell_hi);
            meets[j] &= lo <= hi;
            inside[j] &= b_lo <= lo && hi <= b_hi;
        }
    }
    let thresholds = group::floats(g, slot::MIN_DET2);
    (0..group::WIDTH).all(|j| thresholds[j] == f32::INFINITY || !meets[j] || !empty && inside[j])
}

/// A wide node being checked: its index, the next slot to check, its count and its depth.
type Frame = (u32, usize, usize, usize);

/// Checks `scene`'s wide section against its node section (already validated), see the module
/// doc.
///
/// # Errors
/// [`FormatError::BadWideNode`] for a node entered out of turn, with orders, counts or unused
/// slots not of the shape above, or a leaf reference other than the next leaf;
/// [`FormatError::BadWideBox`] for a box not finite, outside its parent's or not containing
/// what its child holds; [`FormatError::BadDepth`] past [`MAX_WIDE_DEPTH`].
#[inline(never)]
pub fn validate(scene: &Scene, wide: &[WideNode]) -> Result<(), FormatError> {
    let n_wide = wide.len();
    if n_wide == 0 || n_wide >= LEAF_REF as usize {
        return Err(FormatError::BadContents);
    }
    let mut leaves = Leaves {
        scene,
        next: 0,
        cell: scene.bounds(),
        above: heapless::Vec::new(),
    };
    let mut frames: heapless::Vec<Frame, MAX_WIDE_DEPTH> = heapless::Vec::new();
    // Enters wide node `w`, whose parent slot's box is `parent`: its shape and its boxes.
    let enter = |w: u32, parent: Bounds, depth: usize| -> Result<Frame, FormatError> {
        let stored = &wide[w as usize];
        let count = shape(stored).ok_or(FormatError::BadWideNode { node: w })?;
        for k in 0..count {
            let b = slot_box(stored, k);
            let (lo, hi) = (b[0], b[1]);
            let empty = !lo.cmple(hi).all();
            if !(empty || contains(parent, b) && lo.is_finite() && hi.is_finite()) {
                return Err(FormatError::BadWideBox { node: w });
            }
        }
        Ok((w, 0, count, depth))
    };
    frames
        .push(enter(0, scene.bounds(), 1)?)
        .map_err(|_| FormatError::BadDepth)?;
    let mut next = 1u32;
    // The next part of a leaf cut into parts, and its cell: the next slot must be it.
    let mut pending: Option<(LeafRef, Bounds)> = None;
    while let Some(top) = frames.last_mut() {
        let (w, k, count, depth) = *top;
        if k == count {
            if pending.is_some() {
                return Err(FormatError::BadWideNode { node: w });
            }
            frames.pop();
            continue;
        }
        top.1 += 1;
        let stored = &wide[w as usize];
        let (r, b) = (stored[REFS + k], slot_box(stored, k));
        let empty = !b[0].cmple(b[1]).all();
        if r & LEAF_REF != 0 {
            let part = LeafRef::decode(r);
            if part.encode() != r {
                return Err(FormatError::BadWideNode { node: w });
            }
            let cell = match pending.take() {
                Some((want, cell)) if want == part => cell,
                Some(_) => return Err(FormatError::BadWideNode { node: w }),
                None => {
                    let (leaf, cell) = leaves.next().ok_or(FormatError::BadWideNode { node: w })?;
                    match part.leaf.cmp(&leaf) {
                        Ordering::Equal if part.part == 0 => {}
                        // A later leaf of the node tree: this one is left out of the wide section.
                        Ordering::Greater
                            if part.leaf < scene.node_count()
                                && scene.node(part.leaf).is_leaf() =>
                        {
                            return Err(FormatError::WideLeafLeftOut { leaf });
                        }
                        _ => return Err(FormatError::BadWideNode { node: w }),
                    }
                    cell
                }
            };
            if part.part + 1 < part.parts {
                let next_part = LeafRef {
                    part: part.part + 1,
                    ..part
                };
                pending = Some((next_part, cell));
            }
            let prims = scene.leaf_prims(&scene.node(part.leaf));
            let inside = match prims.part(part.part, part.parts) {
                LeafPrims::Groups(groups) => groups.iter().all(|g| group_inside(g, cell, b, empty)),
                prims => prims.ids().all(|prim| {
                    prim_box(scene, prim)
                        .and_then(|p| intersection(p, cell))
                        .is_none_or(|p| !empty && contains(b, p))
                }),
            };
            if !inside {
                return Err(FormatError::BadWideBox { node: w });
            }
        } else {
            if r != next || r as usize >= n_wide || pending.is_some() {
                return Err(FormatError::BadWideNode { node: r });
            }
            if depth + 1 > MAX_WIDE_DEPTH {
                return Err(FormatError::BadDepth);
            }
            next += 1;
            let frame = enter(r, if empty { EMPTY_BOX } else { b }, depth + 1)?;
            frames.push(frame).map_err(|_| FormatError::BadDepth)?;
        }
    }
    if next as usize != n_wide {
        return Err(FormatError::BadWideNode { node: next });
    }
    if let Some((leaf, _)) = leaves.next() {
        return Err(FormatError::WideLeafLeftOut { leaf });
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
                let part = LeafRef::decode(r);
                part.leaf < scene.node_count() && part.part < part.parts
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
