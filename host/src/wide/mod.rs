//! Collapsing the serialized kd-tree into the format's wide nodes
//! (`kdray_core::format::wide`, where the encoding is documented): each wide node takes the greedy
//! cut of its binary subtree (`kdray_core::format::wide::frontier`; validation checks what the
//! walk's answers need, not the cut itself, which `tests/tests/wide_cut.rs` checks), and each child's box is computed bottom up: a leaf's, the union of its
//! primitives' boxes clipped to its cell; a wide node's, the union of its own boxes. Wide nodes are
//! numbered in the order a depth-first walk in slot order first enters them. On rayon's pool the
//! subtrees below the top `PARALLEL_LEVELS` (two) wide levels are collapsed at once and appended in
//! that order, renumbered: the nodes are the same. A leaf child of a node with free slots is
//! cut into parts (`wide/parts.rs`), whose order of items [`Wide::reorder`] writes into the words.

use crate::par;
use kdray_core::Scene;
use kdray_core::format::LeafPrims;
use kdray_core::format::wide::{
    Bounds, EMPTY_BOX, LEAF_REF, REFS, WIDTH, WideNode, frontier, intersection, prim_box,
    set_slot_box,
};
use parts::{Child, Pass, slots};

mod parts;

/// Wide levels whose children a parallel collapse takes on apart (up to 8² subtrees).
const PARALLEL_LEVELS: u32 = 2;

/// The wide nodes of `scene`'s tree (a scene validated without them), collapsed on rayon's pool
/// when `parallel`; the nodes are the same either way.
///
/// # Errors
/// More wide nodes than a reference can number (2³¹).
pub fn to_wide(scene: &Scene, parallel: bool) -> Result<Wide, String> {
    let levels = if parallel { PARALLEL_LEVELS } else { 0 };
    let (nodes, _, pass) = subtree(scene, 0, scene.bounds(), levels)?;
    Ok(Wide {
        nodes,
        orders: pass.orders,
    })
}

/// The wide section of a tree, and the new order of the leaves it cut into parts.
pub struct Wide {
    /// The wide nodes.
    pub nodes: Vec<WideNode>,
    /// For each leaf cut into parts: the index of its first item, its item count `n`, then `n` positions,
    /// the item that goes first, second, … (items: index-list entries or groups). The parts'
    /// boxes hold for the items in this order: [`Wide::reorder`] writes it into the words.
    orders: Vec<u32>,
}

fn too_large() -> String {
    "tree too large for the wide layout (2^31 wide nodes)".to_string()
}

/// The wide nodes of the subtree standing for binary node `b` with cell `cell`, numbered from
/// its root, and the union of the root's boxes; the wide children of the top `levels` levels
/// are collapsed at once on the pool.
fn subtree(
    scene: &Scene,
    b: u32,
    cell: Bounds,
    levels: u32,
) -> Result<(Vec<WideNode>, Bounds, Pass), String> {
    let mut pass = Pass::default();
    if levels == 0 {
        let mut out = Vec::new();
        let all = emit(scene, b, cell, &mut out, &mut pass)?;
        return Ok((out, all, pass));
    }
    let f = slots(scene, &frontier(|i| scene.node(i), b, cell), &mut pass);
    let children = par::map_each(true, f.count, |k| match f.children[k] {
        Child::Wide(node) => subtree(scene, node, f.cells[k], levels - 1).map(Some),
        Child::Leaf(_) => Ok(None),
    });
    let mut out = vec![f.skeleton()];
    let mut all = EMPTY_BOX;
    for (k, child) in children.into_iter().enumerate() {
        let (reference, bounds) = match (child?, f.children[k]) {
            (None, Child::Leaf(part)) => (part.encode(), f.boxes[k]),
            (None, Child::Wide(_)) => unreachable!("a wide child's subtree is collapsed"),
            (Some((nodes, bounds, child)), _) => {
                pass.orders.extend_from_slice(&child.orders);
                let at = out.len();
                if at + nodes.len() > LEAF_REF as usize {
                    return Err(too_large());
                }
                out.extend(nodes.iter().map(|n| moved(n, at as u32)));
                (at as u32, bounds)
            }
        };
        out[0][REFS + k] = reference;
        set_slot_box(&mut out[0], k, bounds);
        all = union(all, bounds);
    }
    Ok((out, all, pass))
}

/// `node` with its references to wide nodes moved by `at` (leaf references and unused slots,
/// 0, unchanged: a subtree's own root is never referenced within it).
fn moved(node: &WideNode, at: u32) -> WideNode {
    let mut n = *node;
    for r in &mut n[REFS..REFS + WIDTH] {
        if *r != 0 && *r & LEAF_REF == 0 {
            *r += at;
        }
    }
    n
}

/// The box of `prims` (a leaf or a part of one) in cell `cell`: their boxes clipped to the cell,
/// united.
fn leaf_box(scene: &Scene, prims: LeafPrims, cell: Bounds) -> Bounds {
    prims
        .ids()
        .filter_map(|p| clipped_box(scene, p, cell))
        .fold(EMPTY_BOX, union)
}

/// Primitive `p`'s box clipped to `cell`, or `None` where it misses the cell or no kernel hits it.
fn clipped_box(scene: &Scene, p: u32, cell: Bounds) -> Option<Bounds> {
    prim_box(scene, p).and_then(|b| intersection(b, cell))
}

/// Appends the wide node standing for binary node `b` with cell `cell`, then its wide children
/// depth first; returns the union of its boxes.
fn emit(
    scene: &Scene,
    b: u32,
    cell: Bounds,
    out: &mut Vec<WideNode>,
    pass: &mut Pass,
) -> Result<Bounds, String> {
    if out.len() >= LEAF_REF as usize {
        return Err(too_large());
    }
    let f = slots(scene, &frontier(|i| scene.node(i), b, cell), pass);
    let index = out.len();
    out.push(f.skeleton());
    let mut all = EMPTY_BOX;
    for k in 0..f.count {
        let (reference, bounds) = match f.children[k] {
            Child::Leaf(part) => (part.encode(), f.boxes[k]),
            Child::Wide(node) => {
                let child = out.len() as u32;
                (child, emit(scene, node, f.cells[k], out, pass)?)
            }
        };
        let node = &mut out[index];
        node[REFS + k] = reference;
        set_slot_box(node, k, bounds);
        all = union(all, bounds);
    }
    Ok(all)
}

/// The smallest box holding `a` and `b` (the empty box is the identity).
fn union(a: Bounds, b: Bounds) -> Bounds {
    [a[0].min(b[0]), a[1].max(b[1])]
}
