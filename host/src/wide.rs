//! Collapsing the serialized kd-tree into the format's wide nodes
//! (`kdray_core::format::wide`, where the encoding is documented): each wide node takes the greedy
//! cut of its binary subtree (`kdray_core::format::wide::frontier`; validation checks what the
//! walk's answers need, not the cut itself, which `tests/tests/wide_cut.rs` checks), and each child's box is computed bottom up: a leaf's, the union of its
//! primitives' boxes clipped to its cell; a wide node's, the union of its own boxes. Wide nodes are
//! numbered in the order a depth-first walk in slot order first enters them.

use kdray_core::Scene;
use kdray_core::format::wide::{
    Bounds, EMPTY_BOX, LEAF_REF, REFS, WideNode, frontier, intersection, prim_box, set_slot_box,
    skeleton,
};

/// The wide nodes of `scene`'s tree (a scene validated without them).
///
/// # Errors
/// More wide nodes than a reference can number (2³¹).
pub fn to_wide(scene: &Scene) -> Result<Vec<WideNode>, String> {
    let mut out = Vec::with_capacity(scene.node_count() as usize / 8 + 1);
    emit(scene, 0, scene.bounds(), &mut out)?;
    Ok(out)
}

/// Appends the wide node standing for binary node `b` with cell `cell`, then its wide children
/// depth first; returns the union of its boxes.
fn emit(scene: &Scene, b: u32, cell: Bounds, out: &mut Vec<WideNode>) -> Result<Bounds, String> {
    if out.len() >= LEAF_REF as usize {
        return Err("tree too large for the wide layout (2^31 wide nodes)".to_string());
    }
    let f = frontier(|i| scene.node(i), b, cell);
    let index = out.len();
    out.push(skeleton(&f));
    let mut all = EMPTY_BOX;
    for k in 0..f.count {
        let (reference, bounds) = if f.leaves[k] {
            let leaf = scene.node(f.nodes[k]);
            let bounds = scene
                .leaf_prims(&leaf)
                .ids()
                .filter_map(|p| prim_box(scene, p).and_then(|b| intersection(b, f.cells[k])))
                .fold(EMPTY_BOX, union);
            (LEAF_REF | f.nodes[k], bounds)
        } else {
            let child = out.len() as u32;
            (child, emit(scene, f.nodes[k], f.cells[k], out)?)
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
