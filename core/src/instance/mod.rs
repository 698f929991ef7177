//! The top level of a scene of many meshes: instances of bottom-level scenes (today's word arrays,
//! each a [`Scene`]), each placed by an affine transform, under a small tree over the instances'
//! world boxes. Its own word array, validated once by [`InstancedScene::from_words`] against the
//! bottom scenes it names; a scene of one mesh keeps the single-mesh format unchanged.
//!
//! The top level refers to its bottom scenes by index into the slice the caller passes, so that
//! no copy of a mesh is stored per instance and the core needs no allocation: a firmware keeps
//! the bottom scenes' words and the top level's in flash, side by side. Moving instances rebuilds
//! or refits the top level alone (the host's `kdray::instances`); the bottom scenes stay as they
//! are.
//!
//! Compiled with the core's `instances` feature (on by default; the firmware and WASM builds,
//! which take no default features, leave it out), so that a program without instances links none
//! of it.
//!
//! # Header (word index: meaning)
//! ```text
//!  0  MAGIC           0x4952_444B, the bytes "KDRI" read as a little-endian u32 (a single-mesh
//!                     scene's "KDRY" is refused with `InstanceError::SingleMesh`, and the
//!                     single-mesh reader refuses "KDRI" with `FormatError::TopLevel`)
//!  1  VERSION         2 (version 1, a binary tree of 8-word nodes, is refused: rebuild it)
//!  2  TOTAL_WORDS     length of the whole array in words
//!  3  INSTANCE_COUNT  instance records (≥ 1)
//!  4  NODE_COUNT      wide nodes of the tree over the instances (≥ 1)
//!  5  BOTTOM_COUNT    bottom scenes the records index: the length of the slice passed in
//!  6  DEPTH           depth of the tree (root alone = 0), at most [`MAX_DEPTH`]
//!  7  RESERVED        0
//!  8..14 BOUNDS       world box of every instance: min x, y, z, max x, y, z (f32 bits)
//! 14..24 RESERVED     0
//! 24..26 CHECKSUM     [`crate::format::checksum`] of all words, low word first: the words and
//!                     the function of a single-mesh scene's header
//! 26..32 RESERVED     0
//! ```
//! Then the sections, with no offsets stored: they follow in this order and size, so that
//! `TOTAL_WORDS = 32 + 64·NODE_COUNT + 32·INSTANCE_COUNT` (each section starts on a multiple of
//! 8 words, 32 bytes).
//!
//! # Nodes (64 words each, from word 32)
//! A bounding volume hierarchy over the instances' world boxes, eight children a node (format
//! version 2; version 1's binary nodes tested two boxes a level, one axis at a time, three
//! quarters of a single ray's instructions through 100 bunnies), in pre-order. Each child, a
//! *slot*, is another node or one instance record, and its box is stored in its parent, struct
//! of arrays as the single-mesh wide nodes store theirs ([`crate::traverse::wide`]), so that one
//! ray tests a node's eight boxes in one 8-wide slab test.
//! ```text
//!  0..48  BOXES   word 8·(2·axis + side) + slot, side 0 = min, 1 = max (f32 bits): the slot's
//!                 box, containing its node's slots' boxes or its record's box; a slot past
//!                 COUNT holds min = +∞, max = −∞
//! 48..56  REFS    slot's child: bit 31 set ([`node::RECORD_REF`]), the index of an instance
//!                 record in bits 0..31; clear, the index of a node (> this node); 0 past COUNT
//! 56      COUNT   slots used, 1..=8: slots 0..COUNT
//! 57..64  RESERVED 0
//! ```
//! A depth-first walk in slot order meets the nodes in index order and the records in index
//! order, each once: every node but the root is referenced by exactly one slot, every record by
//! exactly one slot.
//!
//! Why a BVH and not a kd-tree: instances overlap one another, so a kd-tree over them would
//! reference one instance from many leaves; a BVH over whole boxes references each once, is
//! built by sorting in `O(n log n)` (median splits into eight, the host's `kdray::instances`) and
//! is cheap to rebuild or refit when instances move.
//!
//! # Instance records (32 words each, after the nodes)
//! ```text
//!  0..12  TRANSFORM   object → world, 3×4 row-major f32: rows (a₀₀ a₀₁ a₀₂ b₀), (a₁₀ …), (a₂₀ …)
//! 12..24  INVERSE     world → object, same layout: the transform's inverse, rounded to f32
//! 24      BOTTOM      index of the bottom scene in the slice passed to `from_words`
//! 25      USER_ID     any u32, reported with each hit on this instance ([`InstanceHit`])
//! 26..32  BOX         world box: min x, y, z, max x, y, z (f32 bits), containing the image of
//!                     the bottom scene's box
//! ```
//!
//! # Validation
//! [`InstancedScene::from_words`] costs time linear in the top level's words, constant memory
//! (a stack of [`MAX_DEPTH`] entries), and refuses, with an [`InstanceError`]: a short, long or
//! damaged array (checksum), another magic or version, counts that overflow, a bottom-scene count
//! other than the slice's; per record, a bottom index out of range, a transform or inverse not
//! finite, a transform that is singular or nearly so ([`affine::MIN_DET_RATIO`]), an inverse
//! that is not the transform's within [`affine::INVERSE_TOLERANCE`], a box not finite, not
//! containing the image of its bottom scene's box (checked in f64) or outside the header's
//! bounds; for the tree, a count outside 1..=8, a slot past it not empty, a reserved word set,
//! nodes or records not met in index order by the depth-first walk (so a reference backwards,
//! out of range, shared or missing), a depth above [`MAX_DEPTH`] or other than DEPTH, a slot's
//! box not finite or outside its parent's slot's (the root's outside the header's bounds), a
//! record's box outside its slot's.
//!
//! What a crafted top level that passes can still do: place instances where its writer did not
//! mean them. Every walk stays in range and ends (the tree's children point forward, the bottom
//! scenes were validated on their own).
//!
//! A top level this process's own builder has just written (instances moved in a frame) is
//! opened with [`InstancedScene::from_built_words`] instead: the header, the records' bottom
//! indices and the tree's checks above (what keeps every walk in range), not the checksum, the
//! reserved words or the records' transforms, inverses and boxes in f64, which the builder
//! makes true (a tenth of the instructions for 10,000 instances). Whatever the words, its walks
//! stay in range and end all the same: a non-finite or singular transform moves a ray to no
//! instance (see [`walk`]).
//!
//! # The walk
//! [`InstancedScene::intersect_in`] and [`InstancedScene::occluded_in`] ([`walk`]): the tree in
//! front-to-back order over the world ray (a node's entered slots nearest first, the others
//! pending with their entry distances), each instance entered with the ray moved into it by
//! the inverse, direction not normalized, so that `t` stays the world ray's and closest hits
//! compare across instances; the bottom scene's own walk runs with `tmax` the closest hit so far.
//!
//! Packets of 4 or 8 world rays ([`InstancedScene::intersect_packet_in`],
//! [`InstancedScene::occluded_packet_in`], [`packet`]) walk the tree together, lanes masked by
//! each slot's box test (each lane's the single ray's, bit for bit); the lanes that enter an instance
//! are moved into it together and run the bottom scene's packet walk with each lane's closest
//! hit so far as its `tmax` (one or two lanes go in by the single-ray steps instead). A whole
//! array of rays: [`stream::intersect`], [`stream::occluded`] (coherent runs as packets, the
//! rest one by one, answers in input order, as the single-mesh stream). Each lane's answer is the
//! single-ray walk's: the same `t` bits, and the same instance and primitive unless two tie at
//! that `t`.

pub mod affine;
mod cull;
#[cfg(test)]
mod cull_tests;
mod error;
pub mod packet;
pub mod stream;
mod validate;
pub mod walk;

pub use affine::Affine;
pub use error::InstanceError;
pub use packet::InstanceHitPacket;
pub use walk::InstanceHit;

use crate::format::Scene;
use glam::Vec3;

/// "KDRI" as a little-endian word (the single-mesh format knows it too, to name it in its error).
pub const MAGIC: u32 = crate::format::TOP_LEVEL_MAGIC;
/// The top level's format version this core reads and the host writes.
pub const VERSION: u32 = 2;
/// Words before the nodes.
pub const HEADER_WORDS: usize = 32;
/// Words of one node.
pub const NODE_WORDS: usize = 64;
/// Slots of one node.
pub const WIDTH: usize = 8;
/// Words of one instance record.
pub const RECORD_WORDS: usize = 32;
/// The deepest tree over the instances the walks' fixed stacks accept (the builder's median
/// splits into eight reach depth 11 for 2³² instances).
pub const MAX_DEPTH: usize = 32;
/// The walks' stacks: at most seven pending slots for each node on the way down, and the eighth
/// a node pushes before it pops the nearest ([`push_in_order`]).
pub(crate) const STACK: usize = (WIDTH - 1) * (MAX_DEPTH + 1) + 1;

/// Pushes `item` onto the entries a node has pushed so far (those from `below` on), keeping them
/// in order of `key`, the least on top: popped next. A push beyond the capacity is dropped, which
/// validation's depth bound rules out ([`STACK`]).
#[inline(always)]
fn push_in_order<T: Copy>(
    stack: &mut heapless::Vec<T, STACK>,
    below: usize,
    item: T,
    key: impl Fn(&T) -> f32,
) {
    let k = key(&item);
    let _ = stack.push(item);
    let mut j = stack.len() - 1;
    while j > below && key(&stack[j - 1]) < k {
        stack.swap(j - 1, j);
        j -= 1;
    }
}

/// Header word indices.
pub mod header {
    pub const MAGIC: usize = 0;
    pub const VERSION: usize = 1;
    pub const TOTAL_WORDS: usize = 2;
    pub const INSTANCE_COUNT: usize = 3;
    pub const NODE_COUNT: usize = 4;
    pub const BOTTOM_COUNT: usize = 5;
    pub const DEPTH: usize = 6;
    pub const BOUNDS: usize = 8;
    /// Two words, as in a single-mesh scene ([`crate::format::header::CHECKSUM`]).
    pub const CHECKSUM: usize = 24;
    /// The words that must be zero.
    pub const RESERVED: [core::ops::Range<usize>; 3] = [7..8, 14..24, 26..32];
}

/// Word indices within a node.
pub mod node {
    /// The first box word: slot `s`'s bound `side` (0 min, 1 max) on `axis` at
    /// `BOXES + 8·(2·axis + side) + s`.
    pub const BOXES: usize = 0;
    /// The first slot reference.
    pub const REFS: usize = 48;
    /// The number of slots used.
    pub const COUNT: usize = 56;
    /// The words that must be zero.
    pub const RESERVED: core::ops::Range<usize> = 57..64;
    /// A reference's record bit: set, the rest is a record's index; clear, a node's.
    pub const RECORD_REF: u32 = 1 << 31;
}

/// Word indices within an instance record.
pub mod record {
    pub const TRANSFORM: usize = 0;
    pub const INVERSE: usize = 12;
    pub const BOTTOM: usize = 24;
    pub const USER_ID: usize = 25;
    pub const BOX: usize = 26;
}

const _: () = assert!(header::CHECKSUM == crate::format::header::CHECKSUM);
const _: () = assert!(
    node::BOXES == crate::traverse::wide::BOXES && NODE_WORDS == crate::traverse::wide::NODE_WORDS
);
const _: () = assert!(HEADER_WORDS == crate::format::HEADER_WORDS);
const _: () = assert!(record::BOX + 6 == RECORD_WORDS && record::INVERSE == affine::AFFINE_WORDS);

/// One instance record, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Object → world.
    pub transform: Affine,
    /// World → object, as stored (within [`affine::INVERSE_TOLERANCE`] of the exact inverse).
    pub inverse: Affine,
    /// Index of the bottom scene.
    pub bottom: u32,
    /// The writer's id for this instance, reported with its hits.
    pub user_id: u32,
    /// The world box.
    pub bounds: [Vec3; 2],
}

/// A validated top level borrowing its words and the bottom scenes it indexes.
#[derive(Clone, Copy, Debug)]
pub struct InstancedScene<'a, 'b> {
    nodes: &'a [Node],
    records: &'a [[u32; RECORD_WORDS]],
    bottoms: &'b [Scene<'b>],
    bounds: [Vec3; 2],
    depth: u32,
}

/// A node's words.
pub type Node = [u32; NODE_WORDS];

/// Slot `s`'s box in a node as six words, min x, y, z, max x, y, z (a record's layout).
#[inline(always)]
fn slot_words(nd: &Node, s: usize) -> [u32; 6] {
    let w = |axis: usize, side: usize| nd[node::BOXES + 8 * (2 * axis + side) + s];
    [w(0, 0), w(1, 0), w(2, 0), w(0, 1), w(1, 1), w(2, 1)]
}

/// A box from six f32 words.
#[inline(always)]
fn box_at(w: &[u32]) -> [Vec3; 2] {
    let f = |i: usize| f32::from_bits(w[i]);
    [Vec3::new(f(0), f(1), f(2)), Vec3::new(f(3), f(4), f(5))]
}

/// The transform stored at word `at` of a record.
#[inline(always)]
fn affine_at(r: &[u32; RECORD_WORDS], at: usize) -> Affine {
    let mut w = [0u32; affine::AFFINE_WORDS];
    w.copy_from_slice(&r[at..at + affine::AFFINE_WORDS]);
    Affine::from_words(&w)
}

impl<'a, 'b> InstancedScene<'a, 'b> {
    /// Instance records.
    #[inline]
    pub fn instance_count(&self) -> u32 {
        self.records.len() as u32
    }

    /// Nodes of the tree over the instances (eight slots each).
    #[inline]
    pub fn node_count(&self) -> u32 {
        self.nodes.len() as u32
    }

    /// The tree's depth (root alone = 0).
    #[inline]
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The world box of every instance.
    #[inline]
    pub fn bounds(&self) -> [Vec3; 2] {
        self.bounds
    }

    /// The bottom scenes, as passed to [`Self::from_words`].
    #[inline]
    pub fn bottoms(&self) -> &'b [Scene<'b>] {
        self.bottoms
    }

    /// Instance record `i` (`i < instance_count`; [`InstanceHit::instance`] is one).
    ///
    /// # Panics
    /// If `i` is out of range.
    #[inline]
    pub fn instance(&self, i: u32) -> Instance {
        let r = &self.records[i as usize];
        Instance {
            transform: affine_at(r, record::TRANSFORM),
            inverse: affine_at(r, record::INVERSE),
            bottom: r[record::BOTTOM],
            user_id: r[record::USER_ID],
            bounds: box_at(&r[record::BOX..]),
        }
    }

    /// The geometric normal at `hit` (from [`Self::intersect`] along `ray`) in world space, not
    /// normalized: the bottom scene's ([`Scene::geometric_normal`], at the hit point moved into
    /// the instance) carried by the inverse transpose and, under a mirroring transform
    /// (determinant < 0), negated, so that it is, up to a positive factor, `e1 × e2` of the
    /// triangle as placed: the winding mirrors with the mesh. Zero for a miss.
    pub fn geometric_normal(&self, hit: &InstanceHit, ray: &crate::Ray) -> Vec3 {
        if !hit.is_hit() {
            return Vec3::ZERO;
        }
        let inst = self.instance(hit.instance);
        let local = inst.inverse.point(ray.at(hit.t));
        let n = self
            .bottom_of(hit.instance)
            .geometric_normal(hit.prim, local);
        let m = &inst.inverse.0;
        // (A⁻¹)ᵀ·n: column j of A⁻¹ dotted with n.
        let col = |j: usize| m[j] * n.x + m[4 + j] * n.y + m[8 + j] * n.z;
        let world = Vec3::new(col(0), col(1), col(2));
        if inst.transform.determinant() < 0.0 {
            -world
        } else {
            world
        }
    }

    /// The bottom scene of instance `i`.
    ///
    /// # Panics
    /// If `i` is out of range.
    #[inline]
    pub fn bottom_of(&self, i: u32) -> &'b Scene<'b> {
        &self.bottoms[self.records[i as usize][record::BOTTOM] as usize]
    }
}
