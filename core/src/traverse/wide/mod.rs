//! Wide nodes (format v10's optional wide section): the kd-tree collapsed into nodes of up to
//! eight children, each child a cell of the binary tree with a conservative **tight box**, so
//! that one ray decides a node's eight children in one 8-wide slab test, as wide BVHs are walked
//! (Wald et al. 2008, "Getting rid of packets"; Ylitie et al. 2017, "Efficient incoherent ray
//! traversal on GPUs through compressed wide BVHs"), while keeping what the kd-tree has: its SAH
//! partition, perfect splits, disjoint cells and an exact front-to-back order.
//!
//! # A wide node: 64 words (256 bytes, four cache lines when the words are 64-byte aligned)
//! ```text
//! words  0..48   boxes, struct of arrays: word 8·(2·axis + side) + slot, side 0 = low, 1 = high
//!                (f32 bits); a slot past the node's count holds low = +∞, high = −∞
//! words 48..56   references of slots 0..8: bit 31 set, a leaf: bits 0..31 index the leaf in the
//!                node section (its count and payload, as there); clear, the index of a wide node;
//!                0 in a slot past the count
//! words 56..64   one word per direction octant o (bit a of o set when the direction's component
//!                a is negative, its sign bit, so −0 counts as negative): bits 3k..3k+3 are the
//!                slot visited k-th front to back (k < count), 0 past it; bits 24..28 the count
//!                (0..=8); bits 28..32 are 0
//! ```
//!
//! # Which children: the cut three levels down
//! Wide node `w` stands for an interior node `b` of the binary tree (the root for node 0) and its
//! cell. Its children are the *cut* of `b`'s subtree three levels down ([`frontier`]): walking
//! the subtree depth first, below child first, each node at depth 3 below `b`, and each leaf
//! above that depth, is a child; empty leaves are dropped. A child that is a leaf is referenced
//! as one; a child that is an interior node becomes the next wide node. Wide nodes are numbered
//! in the order a depth-first walk (slot order) first enters them, so every reference points
//! forward, as the node section's above-child indices do.
//!
//! The slots follow that walk, which is the front-to-back order for a direction with no negative
//! component; the cells being disjoint and the split planes axis-aligned, the front-to-back
//! order for any octant is the same walk with the near child first at each plane, the same for
//! every ray of the octant. It is stored, not derived per node.
//!
//! # The boxes
//! A slot's box lies inside its cell and contains what its child holds: for a leaf, the part of
//! each primitive's bounding box inside the cell (a sphere's box is rounded outward by one ulp,
//! [`sphere_box`]); for a wide node, every box of that node. The builder stores the tightest such
//! box: for a leaf, the union over its primitives of their boxes clipped to the cell; for a wide
//! node, the union of its boxes. Any hit point of a primitive lies in a cell holding it, hence in
//! that leaf's box, hence in every box on the way down: a walk that enters every box the ray
//! touches (the slab test made conservative, [`walk`]) cannot miss it.
//!
//! # Validation
//! [`validate`] recomputes each node's cut, references, counts and orders from the node section
//! and requires the stored words bit for bit; it checks each box against its cell, its child's
//! boxes or primitives, so in time linear in the words.

use crate::format::Scene;
use crate::node::Node;
use glam::Vec3;

pub mod validate;
pub mod walk;

/// Children per wide node.
pub const WIDTH: usize = 8;
/// Words per wide node.
pub const NODE_WORDS: usize = 64;
/// The first box word.
pub const BOXES: usize = 0;
/// The first reference word.
pub const REFS: usize = 48;
/// The first order word.
pub const ORDERS: usize = 56;
/// A reference's leaf bit.
pub const LEAF_REF: u32 = 1 << 31;
/// Binary levels one wide node spans.
pub const LEVELS: usize = 3;
/// The deepest wide tree: each level but the last spans [`LEVELS`] binary levels, so a binary
/// tree of [`crate::format::MAX_DEPTH`] levels needs at most this many.
pub const MAX_WIDE_DEPTH: usize = crate::format::MAX_DEPTH.div_ceil(LEVELS) + 1;
/// Entries of a walk's stack: at most `WIDTH − 1` pending children per level.
pub const STACK: usize = (WIDTH - 1) * MAX_WIDE_DEPTH;

/// One wide node as stored.
pub type WideNode = [u32; NODE_WORDS];

const _: () = assert!(ORDERS + WIDTH == NODE_WORDS && REFS + WIDTH == ORDERS);

/// An axis-aligned box `[min, max]`.
pub type Bounds = [Vec3; 2];

/// The box no ray enters (an unused slot): low `+∞`, high `−∞`.
pub const EMPTY_BOX: Bounds = [Vec3::INFINITY, Vec3::NEG_INFINITY];

/// The children of one wide node, in slot order: the cut three levels down, see the module doc.
#[derive(Clone, Copy, Debug)]
pub struct Frontier {
    /// How many children (0 only for a tree that is one empty leaf).
    pub count: usize,
    /// Each child's node index in the node section.
    pub nodes: [u32; WIDTH],
    /// Each child's cell.
    pub cells: [Bounds; WIDTH],
    /// Whether each child is a leaf.
    pub leaves: [bool; WIDTH],
    /// The order words, one per octant (see the module doc).
    pub orders: [u32; WIDTH],
}

/// The cut three levels below node `root` of the binary tree `node(i)` (a validated tree: every
/// child index in range), whose cell is `cell`.
pub fn frontier(node: impl Fn(u32) -> Node, root: u32, cell: Bounds) -> Frontier {
    let mut f = Frontier {
        count: 0,
        nodes: [0; WIDTH],
        cells: [EMPTY_BOX; WIDTH],
        leaves: [false; WIDTH],
        orders: [0; WIDTH],
    };
    // Each child's path: bit (LEVELS − 1 − level) set where it went above, with the split axis
    // of each level, to order it for every octant.
    let mut paths = [(0u32, [0usize; LEVELS]); WIDTH];
    // (node, cell, depth, path bits, axes); at most one pending above child per level.
    let mut stack: heapless::Vec<(u32, Bounds, usize, u32, [usize; LEVELS]), LEVELS> =
        heapless::Vec::new();
    let mut current = Some((root, cell, 0usize, 0u32, [0usize; LEVELS]));
    while let Some((i, cell, depth, path, axes)) = current {
        let n = node(i);
        if n.is_leaf() || depth == LEVELS {
            if !n.is_empty_leaf() {
                let k = f.count;
                (f.nodes[k], f.cells[k], f.leaves[k]) = (i, cell, n.is_leaf());
                paths[k] = (path, axes);
                f.count += 1;
            }
            current = stack.pop();
            continue;
        }
        let (axis, split) = (n.axis(), n.split());
        let (mut below, mut above) = (cell, cell);
        below[1][axis] = split;
        above[0][axis] = split;
        let mut axes = axes;
        axes[depth] = axis;
        let bit = 1 << (LEVELS - 1 - depth);
        // At most one pending item per level below LEVELS: the push cannot fail.
        let _ = stack.push((n.above_child(), above, depth + 1, path | bit, axes));
        current = Some((i + 1, below, depth + 1, path, axes));
    }
    for (octant, order) in f.orders.iter_mut().enumerate() {
        // A child's key for the octant: its path with each level's bit flipped where the
        // direction is negative along that level's axis (the near child first).
        let key = |(path, axes): (u32, [usize; LEVELS])| {
            (0..LEVELS).fold(0, |key, level| {
                let bit = 1 << (LEVELS - 1 - level);
                let flip = if octant >> axes[level] & 1 != 0 {
                    bit
                } else {
                    0
                };
                key | ((path & bit) ^ flip)
            })
        };
        let mut word = (f.count as u32) << 24;
        for (slot, &p) in paths[..f.count].iter().enumerate() {
            let k = key(p);
            let rank = paths[..f.count].iter().filter(|&&q| key(q) < k).count();
            word |= (slot as u32) << (3 * rank);
        }
        *order = word;
    }
    f
}

/// A sphere's bounding box rounded outward by one ulp (`c ± r` is rounded to nearest), so it
/// contains the sphere.
#[inline]
pub fn sphere_box(center: Vec3, radius: f32) -> Bounds {
    [
        (center - radius).to_array().map(f32::next_down).into(),
        (center + radius).to_array().map(f32::next_up).into(),
    ]
}

/// The bounding box of primitive `prim` of `scene` (a triangle's vertices, a sphere's
/// [`sphere_box`]), or `None` for a triangle no kernel hits (an infinite threshold).
#[inline]
pub fn prim_box(scene: &Scene, prim: u32) -> Option<Bounds> {
    match prim.checked_sub(scene.tri_count()) {
        None => {
            if scene.prepared_triangle(prim).1 == f32::INFINITY {
                return None;
            }
            let [a, b, c] = scene.vertices(prim);
            Some([a.min(b).min(c), a.max(b).max(c)])
        }
        Some(s) => {
            let s = scene.sphere(s);
            Some(sphere_box(s.center, s.radius))
        }
    }
}

/// `a ∩ b`, or `None` when they do not meet (touching counts as meeting).
#[inline]
pub fn intersection(a: Bounds, b: Bounds) -> Option<Bounds> {
    let (lo, hi) = (a[0].max(b[0]), a[1].min(b[1]));
    lo.cmple(hi).all().then_some([lo, hi])
}

/// Whether `inner` lies inside `outer`.
#[inline]
pub fn contains(outer: Bounds, inner: Bounds) -> bool {
    outer[0].cmple(inner[0]).all() && inner[1].cmple(outer[1]).all()
}

/// The box of `slot`.
#[inline]
pub fn slot_box(node: &WideNode, slot: usize) -> Bounds {
    let w = |axis: usize, side: usize| f32::from_bits(node[BOXES + 8 * (2 * axis + side) + slot]);
    [
        Vec3::new(w(0, 0), w(1, 0), w(2, 0)),
        Vec3::new(w(0, 1), w(1, 1), w(2, 1)),
    ]
}

/// Writes `b` as the box of `slot`.
#[inline]
pub fn set_slot_box(node: &mut WideNode, slot: usize, b: Bounds) {
    for axis in 0..3 {
        for side in 0..2 {
            node[BOXES + 8 * (2 * axis + side) + slot] = b[side][axis].to_bits();
        }
    }
}

/// A wide node with `f`'s counts and orders, every box empty and every reference 0: the
/// writer fills in the references and the boxes of slots `0..f.count`.
pub fn skeleton(f: &Frontier) -> WideNode {
    let mut node = [0u32; NODE_WORDS];
    for slot in 0..WIDTH {
        set_slot_box(&mut node, slot, EMPTY_BOX);
    }
    node[ORDERS..].copy_from_slice(&f.orders);
    node
}
