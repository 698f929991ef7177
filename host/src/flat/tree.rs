//! The node section and index list from a built tree: flattening it in pre-order (below child
//! first, the order `Scene::from_words` requires), the subtrees of its top levels at once on
//! rayon's pool for a parallel build; renumbering the triangles in leaf order; moving leaves into
//! triangle groups.

use crate::build::BuildNode;
use crate::geometry::Geometry;
use crate::par;
use kdray_core::Triangle;
use kdray_core::group;
use kdray_core::node::Node;

/// A subtree's nodes and index list, its references counted from its own first node and index.
struct Flat {
    nodes: Vec<Node>,
    indices: Vec<u32>,
    depth: u32,
}

/// Levels below the root whose subtrees a parallel flatten takes on apart (up to 16 of them),
/// then appends in pre-order, renumbered.
const PARALLEL_LEVELS: u32 = 4;

fn too_big() -> String {
    "tree too large for the node fields (2^28 nodes, 2^30 per leaf)".to_string()
}

/// The tree under `root` in pre-order: its nodes, index list and depth. With `parallel` the
/// subtrees of the top [`PARALLEL_LEVELS`] levels are flattened at once; the words are the same.
///
/// # Errors
/// A tree too large for the node fields.
pub(super) fn flatten(
    root: &BuildNode,
    parallel: bool,
) -> Result<(Vec<Node>, Vec<u32>, u32), String> {
    let levels = if parallel { PARALLEL_LEVELS } else { 0 };
    let f = flatten_at(root, levels)?;
    Ok((f.nodes, f.indices, f.depth))
}

fn flatten_at(node: &BuildNode, levels: u32) -> Result<Flat, String> {
    match node {
        BuildNode::Interior {
            axis,
            split,
            children,
        } if levels > 0 => {
            let (below, above) = par::join(
                true,
                || flatten_at(&children[0], levels - 1),
                || flatten_at(&children[1], levels - 1),
            );
            let (below, above) = (below?, above?);
            let n = 1 + below.nodes.len() + above.nodes.len();
            let mut nodes = Vec::with_capacity(n);
            let mut indices = Vec::with_capacity(below.indices.len() + above.indices.len());
            let above_at = u32::try_from(1 + below.nodes.len())
                .ok()
                .filter(|&i| i <= Node::MAX_CHILD)
                .ok_or_else(too_big)?;
            let empty = children
                .each_ref()
                .map(|c| matches!(c, BuildNode::Leaf(p) if p.is_empty()));
            nodes.push(Node::interior(*axis as u32, *split, above_at, empty));
            append(&mut nodes, &mut indices, &below)?;
            append(&mut nodes, &mut indices, &above)?;
            Ok(Flat {
                nodes,
                indices,
                depth: 1 + below.depth.max(above.depth),
            })
        }
        _ => {
            let (mut nodes, mut indices) = (Vec::new(), Vec::new());
            let depth = flatten_serial(node, &mut nodes, &mut indices)?;
            Ok(Flat {
                nodes,
                indices,
                depth,
            })
        }
    }
}

/// Appends `sub` after `nodes` and `indices`, its above-child indices and index-list offsets
/// moved by where it lands.
fn append(nodes: &mut Vec<Node>, indices: &mut Vec<u32>, sub: &Flat) -> Result<(), String> {
    let (at, at_index) = (nodes.len() as u32, indices.len() as u32);
    let last_above = Node::MAX_CHILD - at.min(Node::MAX_CHILD);
    for n in &sub.nodes {
        let [w0, w1] = n.words();
        let moved = if !n.is_leaf() {
            if n.above_child() > last_above {
                return Err(too_big());
            }
            [w0, w1 + (at << 4)]
        } else if n.prim_count() > 1 {
            [w0 + at_index, w1]
        } else {
            [w0, w1]
        };
        nodes.push(Node::from_words(moved));
    }
    indices.extend_from_slice(&sub.indices);
    Ok(())
}

/// Appends `node`'s subtree in pre-order; returns its depth.
fn flatten_serial(
    node: &BuildNode,
    nodes: &mut Vec<Node>,
    indices: &mut Vec<u32>,
) -> core::result::Result<u32, String> {
    match node {
        BuildNode::Leaf(prims) => {
            let count = u32::try_from(prims.len())
                .ok()
                .filter(|&n| n <= Node::MAX_COUNT)
                .ok_or_else(too_big)?;
            let payload = match prims.len() {
                0 => 0,
                1 => prims[0],
                _ => {
                    let at = indices.len() as u32;
                    indices.extend_from_slice(prims);
                    at
                }
            };
            nodes.push(Node::leaf(count, payload));
            Ok(0)
        }
        BuildNode::Interior {
            axis,
            split,
            children,
        } => {
            let at = nodes.len();
            nodes.push(Node::leaf(0, 0)); // patched below once the above child's index is known
            let d_below = flatten_serial(&children[0], nodes, indices)?;
            let above = u32::try_from(nodes.len())
                .ok()
                .filter(|&n| n <= Node::MAX_CHILD)
                .ok_or_else(too_big)?;
            let empty = children
                .each_ref()
                .map(|c| matches!(c, BuildNode::Leaf(p) if p.is_empty()));
            nodes[at] = Node::interior(*axis as u32, *split, above, empty);
            let d_above = flatten_serial(&children[1], nodes, indices)?;
            Ok(1 + d_below.max(d_above))
        }
    }
}

/// Renumbers the triangles (ids below `n_tris`; spheres keep theirs) in the order the leaves
/// first reference them, depth first, rewriting the leaves; returns each new id's input id, or
/// `None` when that order is the input order. See the input-ids section in
/// [`kdray_core::format`].
pub(super) fn leaf_order(
    nodes: &mut [Node],
    indices: &mut [u32],
    n_tris: usize,
) -> Option<Vec<u32>> {
    const NONE: u32 = u32::MAX;
    let mut new_id = vec![NONE; n_tris];
    let mut input_ids = Vec::with_capacity(n_tris);
    let mut renumber = |p: u32| -> u32 {
        match new_id.get_mut(p as usize) {
            Some(id) => {
                if *id == NONE {
                    *id = input_ids.len() as u32;
                    input_ids.push(p);
                }
                *id
            }
            None => p, // a sphere
        }
    };
    for node in nodes.iter_mut().filter(|n| n.is_leaf()) {
        match node.prim_count() {
            0 => {}
            1 => *node = Node::leaf(1, renumber(node.payload())),
            n => {
                let start = node.payload() as usize;
                for p in &mut indices[start..start + n as usize] {
                    *p = renumber(*p);
                }
            }
        }
    }
    // Triangles no leaf references (degenerate ones) go last, in input order.
    for p in 0..n_tris as u32 {
        renumber(p);
    }
    let identity = input_ids.iter().enumerate().all(|(i, &p)| i as u32 == p);
    (!identity).then_some(input_ids)
}

/// Moves the leaves' triangles from the index list (emptied) into groups of four, in node order,
/// each leaf of several triangles then naming its first group (`kdray_core::group`). `geom` is in
/// storage order, the order the ids name.
pub(super) fn to_groups(
    nodes: &mut [Node],
    indices: &mut Vec<u32>,
    geom: &Geometry,
) -> Vec<group::Group> {
    let mut groups = Vec::new();
    for node in nodes
        .iter_mut()
        .filter(|n| n.is_leaf() && n.prim_count() > 1)
    {
        let (start, n) = (node.payload() as usize, node.prim_count());
        *node = Node::leaf(n, groups.len() as u32);
        for chunk in indices[start..start + n as usize].chunks(group::WIDTH) {
            let lanes: Vec<group::Lane> = chunk
                .iter()
                .map(|&id| {
                    let v = geom.triangles[id as usize];
                    (id, v, Triangle::from_vertices(v[0], v[1], v[2]).min_det2())
                })
                .collect();
            groups.push(group::pack(&lanes));
        }
    }
    indices.clear();
    groups
}
