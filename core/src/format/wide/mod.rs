//! Wide nodes (the format's optional wide section, since v10): their encoding, the cut that
//! chooses their children (the writer's, `kdray::wide`; validation no longer recomputes it) and
//! the validation; the walk is [`crate::traverse::wide`]. The kd-tree collapsed into nodes
//! of up to eight children, each child a cell of the binary tree with a conservative **tight box**, so
//! that one ray decides a node's eight children in one 8-wide slab test, as wide BVHs are walked
//! (Wald et al. 2008, "Getting rid of packets"; Ylitie et al. 2017, "Efficient incoherent ray
//! traversal on GPUs through compressed wide BVHs"), while keeping what the kd-tree has: its SAH
//! partition, perfect splits, disjoint cells and an exact front-to-back order.
//!
//! # A wide node: 64 words (256 bytes, four cache lines when the words are 64-byte aligned)
//! ```text
//! words  0..48   boxes, struct of arrays: word 8·(2·axis + side) + slot, side 0 = low, 1 = high
//!                (f32 bits); a slot past the node's count holds low = +∞, high = −∞
//! words 48..56   references of slots 0..8: bit 31 set, a leaf: with bit 30 clear, bits 0..30
//!                index the leaf in the node section (its count and payload, as there); with
//!                bit 30 set, a part of a leaf (see "Parts of a leaf"): bits 27..30 the part k,
//!                bits 24..27 the parts m − 1, bits 0..24 the leaf; bit 31 clear, the index of
//!                a wide node; 0 in a slot past the count
//! words 56..64   one word per direction octant o (bit a of o set when the direction's component
//!                a is negative, its sign bit, so −0 counts as negative): bits 3k..3k+3 are the
//!                slot visited k-th front to back (k < count), 0 past it; bits 24..28 the count
//!                (0..=8); bits 28..32 are 0
//! ```
//!
//! # Which children: a greedy cut of up to eight
//! Wide node `w` stands for an interior node `b` of the binary tree (the root for node 0) and its
//! cell. Its children are a *cut* of `b`'s subtree ([`frontier`]): starting from `b` alone, the
//! cut grows by opening one of its interior nodes at a time — replacing it by its children,
//! empty leaves dropped — first those whose opening adds no child (the other child is an empty
//! leaf: the empty-space cut-offs of the SAH), then the one with the largest cell (as Embree
//! collapses a binary BVH into wide nodes, the child likeliest to be entered opened first), while
//! the cut has at most eight children. Format v10 took the cut three levels down: on the
//! dragon's grouped tree, whose SAH cuts off empty space at a third of its interior nodes, that
//! made 152,753 wide nodes of 1.98 children on average; the greedy cut makes 45,289 of 4.32, and
//! a diffuse ray takes 9.4 wide steps instead of 196 (docs/BENCHMARKS.md, "Wide nodes"). A child that is a leaf is
//! referenced as one; a child that is an interior node becomes the next wide node. Wide nodes are
//! numbered in the order a depth-first walk (slot order) first enters them, so every reference
//! points forward, as the node section's above-child indices do.
//!
//! The slots follow the subtree's depth-first walk, below child first, which is the
//! front-to-back order for a direction with no negative component; the cells being disjoint and
//! the split planes axis-aligned, the front-to-back order for any octant is the same walk with
//! the near child first at each plane, the same for every ray of the octant. It is stored, not
//! derived per node.
//!
//! # Parts of a leaf (since v13)
//! A cut of fewer than eight children leaves slots free; a leaf child holding more than
//! [`PART_ITEMS`] items (index-list entries, or groups of four triangles: [`PART_GROUPS`]) then
//! takes several slots, as parts `0..m` of it, each holding the leaf's items `k·n/m ..
//! (k+1)·n/m` with a box of its own — a box for every eight triangles or so, which a ray tests
//! in the same 8-wide slab test as its siblings, as a BVH's leaves of a few triangles are
//! (the builder orders a leaf's items along its longest axis, so the parts are slabs of it). The
//! parts of a leaf fill consecutive slots of one wide node, all in the leaf's place in slot order; the
//! per-octant order puts them where the leaf would be, nearest corner first. They lie in one cell
//! and their boxes may overlap, which the walk allows (it skips a pending slot only when it is
//! entered beyond the closest hit so far).
//!
//! # The boxes
//! A slot's box lies inside its cell and contains what its child holds: for a leaf, the part of
//! each primitive's bounding box inside the cell (a sphere's box is rounded outward by one ulp,
//! [`sphere_box`]); for a wide node, every box of that node. The builder stores the tightest such
//! box: for a leaf, the union over its primitives of their boxes clipped to the cell; for a wide
//! node, the union of its boxes. Any hit point of a primitive lies in a cell holding it, hence in
//! that leaf's box, hence in every box on the way down: a walk that enters every box the ray
//! touches (the slab test made conservative, [`crate::traverse::wide::walk`]) cannot miss it.
//!
//! # Validation
//! [`validate`] checks what the walk's answers rest on, in time linear in the words: one tree of
//! wide nodes entered in index order, no deeper than the walk's stack, whose leaves are the node
//! section's non-empty leaves in pre-order; orders that name every used slot once; boxes finite,
//! inside their parent's and around what their child holds (a leaf's primitives clipped to its
//! cell). It does not recompute the cut, the orders or the cells of the wide nodes (it did until
//! issue 38, at two thirds of the dragon's load): they make the walk fast, not right, and the
//! checksum catches random damage to them. [`validate`]'s module doc says why each is safe.

use crate::format::Scene;
use crate::node::Node;
use glam::Vec3;

pub mod validate;

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
/// A leaf reference's bit for a part of the leaf ("Parts of a leaf" in the module doc).
pub const PART_REF: u32 = 1 << 30;
/// The most parts a leaf is cut into (one wide node's slots).
pub const MAX_PARTS: u32 = WIDTH as u32;
/// Leaves that can be cut into parts: their node index is below this (24 bits of the reference).
pub const PART_LEAVES: u32 = 1 << 24;
/// Index-list entries a part holds at most, where the builder has the slots (one 8-wide test).
pub const PART_ITEMS: usize = 8;
/// Groups of four triangles a part holds at most, where the builder has the slots (two groups,
/// one paired test).
pub const PART_GROUPS: usize = 2;

/// A leaf reference: the leaf's node index, the part `k` and the parts `m` (`0` and `1` for the
/// whole leaf).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LeafRef {
    /// The leaf's index in the node section.
    pub leaf: u32,
    /// Which part, `0..parts`.
    pub part: u32,
    /// How many parts the leaf is cut into (1: whole).
    pub parts: u32,
}

impl LeafRef {
    /// The leaf reference `r` (bit 31 set) decoded.
    #[inline(always)]
    pub fn decode(r: u32) -> Self {
        if r & PART_REF == 0 {
            Self {
                leaf: r & !LEAF_REF,
                part: 0,
                parts: 1,
            }
        } else {
            Self {
                leaf: r & (PART_LEAVES - 1),
                part: r >> 27 & 7,
                parts: (r >> 24 & 7) + 1,
            }
        }
    }

    /// The reference word: whole leaves as before v13, parts with [`PART_REF`]. `leaf` must be
    /// below [`PART_LEAVES`] when `parts > 1`, and `part < parts ≤ MAX_PARTS` (the writer checks).
    #[inline]
    pub fn encode(self) -> u32 {
        if self.parts == 1 {
            LEAF_REF | self.leaf
        } else {
            LEAF_REF | PART_REF | self.part << 27 | (self.parts - 1) << 24 | self.leaf
        }
    }
}
/// The deepest a wide node's cut reaches below the binary node it stands for: a node this deep
/// in the subtree is never opened ([`frontier`]), which bounds a cut's path keys to this many bits.
pub const MAX_OPEN_DEPTH: usize = 16;
/// The deepest wide tree: every wide node spans at least one binary level, so a binary tree of
/// [`crate::format::MAX_DEPTH`] levels needs at most this many.
pub const MAX_WIDE_DEPTH: usize = crate::format::MAX_DEPTH + 1;
/// Entries of a walk's stack: at most `WIDTH − 1` pending children per level.
pub const STACK: usize = (WIDTH - 1) * MAX_WIDE_DEPTH;

/// One wide node as stored.
pub type WideNode = [u32; NODE_WORDS];

const _: () = assert!(ORDERS + WIDTH == NODE_WORDS && REFS + WIDTH == ORDERS);
const _: () = assert!(MAX_OPEN_DEPTH <= 32);

/// An axis-aligned box `[min, max]`.
pub type Bounds = [Vec3; 2];

/// The box no ray enters (an unused slot): low `+∞`, high `−∞`.
pub const EMPTY_BOX: Bounds = [Vec3::INFINITY, Vec3::NEG_INFINITY];

/// The children of one wide node, in slot order: the greedy cut, see the module doc.
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

/// A node of the cut being grown: its index, cell and path from the cut's root.
#[derive(Clone, Copy)]
struct Item {
    node: u32,
    cell: Bounds,
    /// How many levels below the cut's root.
    depth: usize,
    /// Bit `31 − d` set where the path went above at depth `d` (most significant first, so that
    /// two paths compare as the walk below child first orders them).
    path: u32,
    /// Per axis, the bits of the depths whose split is along that axis.
    axis_bits: [u32; 3],
}

impl Item {
    /// The path's key for `octant`: each level's bit flipped where the direction is negative
    /// along that level's axis (the near child first).
    fn key(&self, octant: usize) -> u32 {
        (0..3).fold(self.path, |key, a| {
            if octant >> a & 1 != 0 {
                key ^ self.axis_bits[a]
            } else {
                key
            }
        })
    }
}

/// The surface area of `cell`, up to a factor 2 (the greedy cut's priority).
#[inline]
fn half_area(cell: &Bounds) -> f32 {
    let d = cell[1] - cell[0];
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// The children of the wide node standing for node `root` of the binary tree `node(i)` (a
/// validated tree: every child index in range), whose cell is `cell`: the **greedy cut** of its
/// subtree. Starting from `root` alone, it repeatedly opens one interior node of the cut —
/// replacing it by its children that are not empty leaves — as Embree collapses a binary BVH:
/// first any whose opening adds no child (one child an empty leaf), else the one with the largest
/// cell surface area (the likeliest to be entered; the first in slot order on a tie), as long as
/// the cut keeps at most [`WIDTH`] children and the node lies less than [`MAX_OPEN_DEPTH`] levels
/// below `root`. Deterministic in the node section alone (validation recomputed it until issue 38;
/// it now checks only what the walk's answers need, see [`validate`]).
pub fn frontier(node: impl Fn(u32) -> Node, root: u32, cell: Bounds) -> Frontier {
    let mut items: heapless::Vec<Item, WIDTH> = heapless::Vec::new();
    if !node(root).is_empty_leaf() {
        let _ = items.push(Item {
            node: root,
            cell,
            depth: 0,
            path: 0,
            axis_bits: [0; 3],
        });
    }
    loop {
        // The next node to open: (position, adds a child, area).
        let mut best: Option<(usize, bool, f32)> = None;
        for (k, item) in items.iter().enumerate() {
            let n = node(item.node);
            if n.is_leaf() || item.depth >= MAX_OPEN_DEPTH {
                continue;
            }
            let adds = n.empty_children() == [false, false];
            if adds && items.len() == WIDTH {
                continue;
            }
            let area = half_area(&item.cell);
            let better = match best {
                None => true,
                Some((_, best_adds, best_area)) => {
                    (best_adds && !adds) || (best_adds == adds && area > best_area)
                }
            };
            if better {
                best = Some((k, adds, area));
            }
        }
        let Some((k, _, _)) = best else { break };
        let item = items[k];
        let n = node(item.node);
        let (axis, split) = (n.axis(), n.split());
        let (mut below, mut above) = (item.cell, item.cell);
        below[1][axis] = split;
        above[0][axis] = split;
        let bit = 1u32 << (31 - item.depth);
        let mut axis_bits = item.axis_bits;
        axis_bits[axis] |= bit;
        let child = |node, cell, path| Item {
            node,
            cell,
            depth: item.depth + 1,
            path,
            axis_bits,
        };
        let [below_empty, above_empty] = n.empty_children();
        let mut children: heapless::Vec<Item, 2> = heapless::Vec::new();
        if !below_empty {
            let _ = children.push(child(item.node + 1, below, item.path));
        }
        if !above_empty {
            let _ = children.push(child(n.above_child(), above, item.path | bit));
        }
        // In slot order: the opened node's place taken by its children, below first. The count
        // was checked above, so the inserts cannot fail.
        items.remove(k);
        for (j, c) in children.into_iter().enumerate() {
            let _ = items.insert(k + j, c);
        }
    }
    let mut f = Frontier {
        count: items.len(),
        nodes: [0; WIDTH],
        cells: [EMPTY_BOX; WIDTH],
        leaves: [false; WIDTH],
        orders: [0; WIDTH],
    };
    for (k, item) in items.iter().enumerate() {
        (f.nodes[k], f.cells[k], f.leaves[k]) = (item.node, item.cell, node(item.node).is_leaf());
    }
    for (octant, order) in f.orders.iter_mut().enumerate() {
        let mut word = (f.count as u32) << 24;
        for (slot, item) in items.iter().enumerate() {
            let k = item.key(octant);
            let rank = items.iter().filter(|q| q.key(octant) < k).count();
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
