//! The flat scene format: one `&[u32]` of little-endian words, built by the host and validated
//! once by [`Scene::from_words`]; every later access relies on what was validated here. Words
//! this process's own builder just wrote may be opened with [`Scene::from_built_words`] instead,
//! which keeps the checks every access and walk needs to stay in range and end, and trusts the
//! rest (what and why: its doc).
//!
//! # Header (word index: meaning)
//! ```text
//!  0  MAGIC           0x5952_444B, the bytes "KDRY" read as a little-endian u32 (a top level
//!                     of instances, "KDRI", is refused with `FormatError::TopLevel`)
//!  1  VERSION         13 (12 could not cut a leaf into parts in the wide section; 11 could
//!                     carry a blocks section, retired since; 10 cut wide nodes
//!                     three levels down, not greedily; 9 had no wide section; 8 had no groups section; 7 stored `+inf` as the threshold of a
//!                     triangle whose `|e1 × e2|²` overflows f32, so fast mode never hit it; 6 had
//!                     no blocks section, 5 stored edges, not vertices, 4 had no checksum: files
//!                     written before are refused, rebuild them)
//!  2  CONTENTS        bit set, see `contents::*`: which sections are present
//!  3  TOTAL_WORDS     length of the whole array in words (catches truncation and trailing data)
//!  4  NODE_COUNT      kd-tree nodes (≥ 1; 2 words each)
//!  5  TRI_COUNT       triangles; primitives 0 .. TRI_COUNT are triangles in storage order
//!  6  SPHERE_COUNT    spheres; primitives TRI_COUNT .. TRI_COUNT + SPHERE_COUNT
//!  7  INDEX_COUNT     words in the leaf primitive-index list
//!  8  DEPTH           depth of the tree (root alone = 0), at most `MAX_DEPTH`
//!  9..15 BOUNDS       scene box: min x, y, z, max x, y, z (f32 bits)
//! 15  NODES_OFFSET    word offset of the nodes section
//! 16  INDICES_OFFSET  … of the primitive-index list (0 when INDEX_COUNT = 0)
//! 17  TRIS_OFFSET     … of the triangles (0 when absent)
//! 18  SPHERES_OFFSET  … of the spheres (0 when absent)
//! 19  NORMALS_OFFSET  … of per-vertex normals (0 when absent)
//! 20  UVS_OFFSET      … of texture coordinates (0 when absent)
//! 21  MATERIALS_OFFSET … of per-primitive material ids (0 when absent)
//! 22  BUILD_MS        build time in milliseconds (f32 bits): information only, not validated
//! 23  INPUT_IDS_OFFSET … of the triangles' input indices (0 when absent)
//! 24..26 CHECKSUM     [`checksum`] of all words, low word first (see "Corruption" below)
//! 26..28 UNUSED      0 (formats 7 to 11: the count and offset of the blocks section, retired)
//! 28  GROUP_COUNT     triangle groups (0 when absent)
//! 29  GROUPS_OFFSET   … of the groups section (0 when absent)
//! 30  WIDE_COUNT      wide nodes (0 when absent)
//! 31  WIDE_OFFSET     … of the wide section (0 when absent; a multiple of 16 words)
//! ```
//! Sections start on multiples of 8 words (32 bytes), lie inside `HEADER_WORDS .. TOTAL_WORDS`
//! and do not overlap. A section the scene does not need is absent (offset 0, bit clear), not
//! filled with zeros.
//!
//! # Sections
//! - **Nodes**, 2 words each, pbrt-v3's `KdAccelNode` layout plus two bits marking empty children
//!   ([`Node`]).
//! - **Indices**: `u32` primitive ids, referenced by leaves with more than one primitive (in a
//!   file without groups; with them, INDEX_COUNT is 0 and the list absent). The
//!   leaves with an index list use it in turn: in node order, each one's range starts where the
//!   previous one's ended, the first at 0, and the last ends at INDEX_COUNT (what the serializer
//!   has always written: it appends a leaf's ids as it flattens the tree in pre-order). So no two
//!   leaves share an entry, and a walk reads each entry at most once.
//! - **Triangles**: 10 f32 each, the vertices `v0, v1, v2` exactly as the input gave them, then
//!   the triangle's parallel threshold [`Triangle::min_det2`] (`+inf` for a degenerate triangle,
//!   which no kernel hits, in either mode; finite, from the scaled normal, where `|e1 × e2|²`
//!   overflows, since version 8), so the kernels need not recompute `|e1 × e2|²` per test. Möller–Trumbore's edges
//!   `e1 = v1 − v0`, `e2 = v2 − v0` are computed at load ([`Scene::prepared_triangle`]) with the
//!   same f32 subtractions the builder's [`Triangle::from_vertices`] makes, so its results are bit
//!   for bit those of version 5, which stored the edges. Version 6 stores the vertices because the
//!   watertight kernel ([`crate::watertight`]) needs two triangles sharing an edge to see
//!   bit-identical vertices: `v0 + e1` is not `v1` in f32. Validation requires the vertices and
//!   both edges finite, recomputes the threshold and requires the stored bits, and refuses a
//!   triangle with area whose threshold still overflows ([`Triangle::is_too_large`]).
//! - **Spheres**: 4 f32 each, centre and radius (> 0).
//! - **Normals**: 9 f32 per triangle, the normals at `v0, v1, v2`.
//! - **UVs**: 6 f32 per triangle, the texture coordinates at `v0, v1, v2`.
//! - **Materials**: one `u32` per primitive (triangles, then spheres).
//! - **Input ids**: one `u32` per triangle, its index in the input (what a hit reports, see
//!   [`Scene::input_id`]); absent when storage order is input order. The builder stores
//!   triangles in the order the leaves first reference them, depth first, so that a leaf's
//!   triangles, and those of its neighbours, share cache lines (8-wide packets on the dragon:
//!   about 9 % faster). Normals, texture coordinates and materials follow storage order.
//!   Validation checks each id is below TRI_COUNT, not that they are a permutation (that would
//!   need memory): a repeated id can only mislabel a hit, never make an access fail.
//! - **Blocks** (formats 7 to 11, CONTENTS bit 6, [`contents::RETIRED_BLOCKS`]): the tree cut into
//!   64-byte blocks of three levels, walked by single rays. Retired in format 12: the wide nodes
//!   below take fewer steps and instructions per ray (docs/BENCHMARKS.md, "Retired: blocks and
//!   interleaved walks"). A file with the bit is refused with [`FormatError::BlocksRetired`].
//! - **Groups** (CONTENTS bit `GROUPS`, version 9; only in a scene of triangles alone): a leaf's
//!   triangles stored inline, four to a 44-word group in struct-of-arrays lanes
//!   ([`crate::group`], where the layout is documented), so that the single-ray walk tests one ray
//!   against four triangles at once with no index list in between. A leaf of `n ≥ 2` triangles
//!   then has as payload the first of its `⌈n/4⌉` groups instead of an index-list offset, and the
//!   leaves' groups tile the section in node order, as index-list ranges do. A core built without
//!   its `groups` feature (firmware and WASM builds that link no group code) refuses such a scene
//!   on load ([`FormatError::GroupsLeftOut`]). Each lane is a
//!   triangle of the triangles section, bit for bit (validation rebuilds every group from its ids),
//!   so the walks return the hits of the index-list layout; the packet walks read the same ids
//!   and test the triangles section.
//! - **Wide nodes** (CONTENTS bit `WIDE`, version 10; the greedy cut since 11): the same tree collapsed into nodes of up
//!   to eight children, each with a conservative tight box and a front-to-back order per
//!   direction octant ([`crate::format::wide`], where the encoding is documented). Leaves stay
//!   in the node section (a reference names the leaf node). Validation checks what the wide walk
//!   needs to return the closest hit as the node walk does (since issue 38, not the writer's cut
//!   bit for bit): the wide nodes form one tree entered in index order, their leaves are the node
//!   section's non-empty leaves in pre-order, each order word names every used slot once, and
//!   every box is finite, inside its parent's and around its child's primitives clipped to the
//!   leaf's cell ([`crate::format::wide::validate`]). When
//!   present (and the core's `wide` feature is on), [`Scene::intersect`], [`Scene::occluded`]
//!   and the stream's single rays walk it; the packet walks use the nodes. The section starts on
//!   a multiple of [`LINE_WORDS`], so its nodes are whole cache lines when the words are 64-byte
//!   aligned (the host aligns them, `kdray::flat::Aligned`).
//!
//! # Cost of validation
//! [`Scene::from_words`] takes time linear in the number of words `W`, whatever they say, and
//! constant memory (a stack of at most [`MAX_DEPTH`] entries): the checksum reads each word once;
//! each triangle, sphere, normal, texture coordinate, material and input id is checked once; the
//! tree walk visits each node once (the pre-order rule) and does O(1) work per node, because the
//! index-list entries are checked once in one pass and a leaf only compares its range with where
//! the previous leaf's ended (the tiling rule under **Indices**; a leaf's groups the same way,
//! each group rebuilt from four triangle records and compared once); the wide section's check
//! ([`crate::format::wide::validate`]) enters each wide node once, passes the node section once
//! more for the leaves' cells and checks each leaf's primitives once. In all about `c · W` word reads with a small constant `c` (the tests count them:
//! `tests/tests/format.rs`). Before the tiling rule, 131,072 leaves naming one 500,000-entry range
//! (a 4 MB file) cost 6.5·10¹⁰ checks; now it is refused at its second leaf with
//! [`FormatError::IndexOrder`]. The same rule bounds a walk: the primitives one ray tests number at
//! most INDEX_COUNT plus the leaf count.
//!
//! # Corruption: what a damaged or crafted file can and cannot do
//! - **Damage** (a flipped bit, a torn write, a bad sector) is caught by the checksum: 64-bit
//!   FNV-1a (Fowler, Noll, Vo) run over the words in four interleaved lanes (word `i` feeds lane
//!   `i mod 4`; the two checksum words count as 0), the lanes and the length then folded by
//!   the same step. Each step `h ← (h ⊕ w)·p` is a bijection of `h` for a fixed word and of `w`
//!   for a fixed `h`, so a file that differs from what was written in any **one** word (any
//!   single-bit flip among them) never matches; random damage to several words goes unnoticed
//!   with a chance of about 2⁻⁶⁴. Checking it costs one multiply per word, less than the
//!   validation pass below. [`Scene::from_words`] checks it right after the magic, version and
//!   length, so a damaged file fails with [`FormatError::Checksum`] before anything else is read.
//! - **A crafted file** can carry a matching checksum (it is not a signature: anyone can
//!   recompute it with [`seal`]). What validation then still guarantees: no access out of range,
//!   no panic, no walk longer than the node count, no NaN or infinite geometry, no threshold that
//!   lets a degenerate triangle be hit, no hittable triangle (finite threshold) or sphere outside
//!   the header's bounds (a sphere by more than 4 ulp of the bounds' magnitude, the rounding of
//!   `c ± r`), no split plane outside them. What it cannot rule out: any
//!   other geometry, tree or ids than the ones the writer meant. Such a file traces, in bounded
//!   time, to hits that are wrong for the intended scene but consistent for the one stored.

use self::wide::WideNode;
use crate::group::{self, Group};
use crate::node::{LEAF, Node};
use crate::simd::group::Gathered;
use crate::simd::range::SceneRange;
use crate::simd::{f32x4, f32x8};
use crate::sphere::Sphere;
use crate::triangle::Triangle;
use glam::Vec3;

/// "KDRY" as a little-endian word.
pub const MAGIC: u32 = u32::from_le_bytes(*b"KDRY");
/// "KDRI": the magic of a top level of instances (`crate::instance`, with the `instances`
/// feature), a word array of another format that names single-mesh scenes like this one; here so
/// that [`Scene::from_words`] can say what such an array is ([`FormatError::TopLevel`]).
pub const TOP_LEVEL_MAGIC: u32 = u32::from_le_bytes(*b"KDRI");
/// The format version this core reads and the host writes.
pub const VERSION: u32 = 13;
/// Words before the first section.
pub const HEADER_WORDS: usize = 32;
/// Sections are aligned to this many words (32 bytes).
pub const SECTION_ALIGN: usize = 8;
/// Words in a 64-byte cache line: the wide section starts on a multiple of this.
pub const LINE_WORDS: usize = 16;
/// The deepest tree the fixed traversal stacks accept. pbrt-v3's depth rule
/// `8 + 1.3·log2(N)` reaches 48 only at N ≈ 2³¹ primitives.
pub const MAX_DEPTH: usize = 64;

/// Header word indices.
pub mod header {
    pub const MAGIC: usize = 0;
    pub const VERSION: usize = 1;
    pub const CONTENTS: usize = 2;
    pub const TOTAL_WORDS: usize = 3;
    pub const NODE_COUNT: usize = 4;
    pub const TRI_COUNT: usize = 5;
    pub const SPHERE_COUNT: usize = 6;
    pub const INDEX_COUNT: usize = 7;
    pub const DEPTH: usize = 8;
    pub const BOUNDS: usize = 9;
    pub const NODES_OFFSET: usize = 15;
    pub const INDICES_OFFSET: usize = 16;
    pub const TRIS_OFFSET: usize = 17;
    pub const SPHERES_OFFSET: usize = 18;
    pub const NORMALS_OFFSET: usize = 19;
    pub const UVS_OFFSET: usize = 20;
    pub const MATERIALS_OFFSET: usize = 21;
    pub const BUILD_MS: usize = 22;
    pub const INPUT_IDS_OFFSET: usize = 23;
    /// Two words: the [`super::checksum`], low word first.
    pub const CHECKSUM: usize = 24;
    /// Two words, zero: formats 7 to 11 kept the retired blocks section's count and offset here.
    pub const UNUSED: core::ops::Range<usize> = 26..28;
    pub const GROUP_COUNT: usize = 28;
    pub const GROUPS_OFFSET: usize = 29;
    pub const WIDE_COUNT: usize = 30;
    pub const WIDE_OFFSET: usize = 31;
    /// First reserved word; `RESERVED .. HEADER_WORDS` must be zero (none are left).
    pub const RESERVED: usize = 32;
}

/// The CONTENTS bits.
pub mod contents {
    pub const TRIANGLES: u32 = 1 << 0;
    pub const SPHERES: u32 = 1 << 1;
    pub const NORMALS: u32 = 1 << 2;
    pub const UVS: u32 = 1 << 3;
    pub const MATERIALS: u32 = 1 << 4;
    /// Triangles are stored in another order than the input's (the input-ids section).
    pub const INPUT_IDS: u32 = 1 << 5;
    /// Formats 7 to 11: the tree was also stored in cache-line blocks. Retired in format 12; a
    /// file with this bit is refused ([`super::FormatError::BlocksRetired`]).
    pub const RETIRED_BLOCKS: u32 = 1 << 6;
    /// Leaves hold their triangles in groups of four (the groups section, [`crate::group`]).
    pub const GROUPS: u32 = 1 << 7;
    /// The tree is also stored as wide nodes (the wide section, [`crate::format::wide`]).
    pub const WIDE: u32 = 1 << 8;
    /// Every bit this version defines.
    pub const ALL: u32 =
        TRIANGLES | SPHERES | NORMALS | UVS | MATERIALS | INPUT_IDS | GROUPS | WIDE;
}

/// Words per element of each section.
pub mod stride {
    pub const NODE: usize = 2;
    pub const TRIANGLE: usize = 10;
    pub const SPHERE: usize = 4;
    pub const NORMALS: usize = 9;
    pub const UVS: usize = 6;
    pub const GROUP: usize = crate::group::GROUP_WORDS;
    pub const WIDE: usize = super::wide::NODE_WORDS;
}

mod checksum;
mod error;
mod validate;
pub mod wide;

pub use checksum::{checksum, seal};
pub use error::FormatError;

/// A validated scene borrowing its words.
#[derive(Clone, Copy, Debug)]
pub struct Scene<'a> {
    contents: u32,
    build_ms: f32,
    depth: u32,
    bounds: [Vec3; 2],
    nodes: &'a [[u32; stride::NODE]],
    indices: &'a [u32],
    tris: &'a [[f32; stride::TRIANGLE]],
    spheres: &'a [f32],
    normals: &'a [f32],
    uvs: &'a [f32],
    materials: &'a [u32],
    input_ids: &'a [u32],
    groups: &'a [Group],
    wide: &'a [WideNode],
    /// What the packet walk needs to know that its tests cannot overflow
    /// ([`crate::simd::range`]): the box, and the smallest finite stored threshold.
    range: SceneRange,
}

impl<'a> Scene<'a> {
    /// Whether the packet walk may leave out the overflow check of its triangle tests for `rays`
    /// ([`crate::simd::range::cannot_overflow`] against this scene's box and thresholds).
    #[inline]
    pub fn packet_in_range<L: crate::simd::lanes::Lanes>(
        &self,
        rays: &crate::simd::RayPacket<L>,
    ) -> bool {
        crate::simd::range::cannot_overflow(rays, &self.range)
    }

    /// The CONTENTS bits.
    #[inline]
    pub fn contents(&self) -> u32 {
        self.contents
    }

    /// The wide section ([`crate::format::wide`]); empty when the file has none.
    #[inline(always)]
    pub fn wide_nodes(&self) -> &'a [WideNode] {
        self.wide
    }

    /// The bytes a walk reads from: the wide nodes, the nodes, the index lists, the triangles,
    /// the spheres and the groups (not the normals, texture coordinates, materials or input ids,
    /// which answers read once a ray).
    #[inline]
    pub fn walked_bytes(&self) -> usize {
        core::mem::size_of_val(self.wide)
            + core::mem::size_of_val(self.nodes)
            + core::mem::size_of_val(self.indices)
            + core::mem::size_of_val(self.tris)
            + core::mem::size_of_val(self.spheres)
            + core::mem::size_of_val(self.groups)
    }

    /// This scene with its wide section set aside: the single-ray queries walk the nodes, to
    /// compare the walks on one file.
    #[inline]
    pub fn without_wide(&self) -> Self {
        Self { wide: &[], ..*self }
    }

    /// The input index of primitive `prim`, a storage-order id as [`Hit::prim`](crate::Hit)
    /// holds: its position in the builder's input (the mesh's triangle order) for a triangle
    /// stored out of input order, else `prim` itself (spheres, [`Hit::MISS`](crate::Hit::MISS)'s
    /// id, scenes stored in input order).
    #[inline]
    pub fn input_id(&self, prim: u32) -> u32 {
        self.input_ids.get(prim as usize).copied().unwrap_or(prim)
    }

    /// Whether triangles are stored out of input order (the input-ids section is present).
    #[inline]
    pub fn reorders_triangles(&self) -> bool {
        !self.input_ids.is_empty()
    }

    /// The build time recorded by the writer, in milliseconds (information only).
    #[inline]
    pub fn build_ms(&self) -> f32 {
        self.build_ms
    }

    /// The tree's depth (root alone = 0).
    #[inline]
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// The scene box `[min, max]`.
    #[inline]
    pub fn bounds(&self) -> [Vec3; 2] {
        self.bounds
    }

    #[inline]
    pub fn node_count(&self) -> u32 {
        self.nodes.len() as u32
    }

    #[inline]
    pub fn tri_count(&self) -> u32 {
        self.tris.len() as u32
    }

    #[inline]
    pub fn sphere_count(&self) -> u32 {
        (self.spheres.len() / stride::SPHERE) as u32
    }

    /// Triangles plus spheres.
    #[inline]
    pub fn prim_count(&self) -> u32 {
        self.tri_count() + self.sphere_count()
    }

    /// Node `i`. Callers pass indices that validation guaranteed, so this never goes out of range
    /// for a child or `0`.
    #[inline(always)]
    pub fn node(&self, i: u32) -> Node {
        Node::from_words(self.nodes[i as usize])
    }

    /// The primitives of a leaf: its one id, its run of the index list, or its groups.
    #[inline(always)]
    pub fn leaf_prims(&self, node: &Node) -> LeafPrims<'a> {
        match node.prim_count() {
            0 => LeafPrims::One(None),
            1 => LeafPrims::One(Some(node.payload())),
            n => {
                let start = node.payload() as usize;
                if self.groups.is_empty() {
                    LeafPrims::Many(&self.indices[start..start + n as usize])
                } else {
                    LeafPrims::Groups(&self.groups[start..start + group::groups_for(n) as usize])
                }
            }
        }
    }

    /// Whether leaves hold their triangles in groups (the groups section is present).
    #[inline]
    pub fn has_groups(&self) -> bool {
        !self.groups.is_empty()
    }

    /// Triangle `i` (`i < tri_count`).
    #[inline(always)]
    pub fn triangle(&self, i: u32) -> Triangle {
        self.prepared_triangle(i).0
    }

    /// Triangle `i` and its stored [`Triangle::min_det2`]; the edges are computed from the stored
    /// vertices as [`Triangle::from_vertices`] does.
    #[inline(always)]
    pub fn prepared_triangle(&self, i: u32) -> (Triangle, f32) {
        let s = &self.tris[i as usize];
        (stored_triangle(s), s[9])
    }

    /// The vertices `v0, v1, v2` of triangle `i` (`i < tri_count`), exactly as stored: a vertex
    /// shared by two triangles has the same bits in both (what the watertight kernel relies on).
    #[inline(always)]
    pub fn vertices(&self, i: u32) -> [Vec3; 3] {
        stored_vertices(&self.tris[i as usize])
    }

    /// The stored rows of triangles `ids` (at most eight, `< tri_count`), the rows past
    /// `ids.len()` the padding row (vertices 0, threshold `+inf`).
    #[inline(always)]
    fn gather_rows(&self, ids: &[u32]) -> [&[f32; stride::TRIANGLE]; 8] {
        /// A padding lane's row: vertices 0, threshold `+inf`.
        const PAD: [f32; stride::TRIANGLE] = {
            let mut r = [0.0; stride::TRIANGLE];
            r[stride::TRIANGLE - 1] = f32::INFINITY;
            r
        };
        let row = |j: usize| ids.get(j).map_or(&PAD, |&id| &self.tris[id as usize]);
        [
            row(0),
            row(1),
            row(2),
            row(3),
            row(4),
            row(5),
            row(6),
            row(7),
        ]
    }

    /// Triangles `ids` (one to four, `< tri_count`) in the four lanes of one group test
    /// ([`Gathered`]): what the 4-wide kernels test a listed leaf's last four or fewer triangles
    /// in. The stored triangle's ten words (vertices, threshold) are the lanes' rows, so this is
    /// a 10×4 transpose, in registers.
    #[inline(always)]
    pub fn gather4<'s>(&'s self, ids: &'s [u32]) -> Gathered<'s, f32x4> {
        let rows = self.gather_rows(ids);
        // Columns 0..4, 4..8 and 8..10 of the four rows, each chunk transposed: vector m holds
        // word m of the four rows. (No `array::map` here: where it was not inlined, as when the
        // core's code units grew, a single-ray stream of the dragon's random rays took twice the
        // time copying its arrays.)
        let t4 = |at: usize| {
            let c =
                |r: &[f32; stride::TRIANGLE]| f32x4::new([r[at], r[at + 1], r[at + 2], r[at + 3]]);
            f32x4::transpose([c(rows[0]), c(rows[1]), c(rows[2]), c(rows[3])])
        };
        let c2 = |r: &[f32; stride::TRIANGLE]| f32x4::new([r[8], r[9], 0.0, 0.0]);
        let t2 = f32x4::transpose([c2(rows[0]), c2(rows[1]), c2(rows[2]), c2(rows[3])]);
        let (a, b) = (t4(0), t4(4));
        Gathered {
            words: [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], t2[0], t2[1]],
            ids,
        }
    }

    /// Triangles `ids` (five to eight, `< tri_count`) in the eight lanes of one test of two
    /// groups ([`Gathered`]; lanes 0..4 the first four, as [`crate::simd::group::Pair`]): an
    /// 8×8 transpose of the rows' first eight words, the last two gathered lane by lane.
    #[inline(always)]
    pub fn gather8<'s>(&'s self, ids: &'s [u32]) -> Gathered<'s, f32x8> {
        let rows = self.gather_rows(ids);
        let c = |r: &[f32; stride::TRIANGLE]| {
            f32x8::new([r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]])
        };
        let head = f32x8::transpose([
            c(rows[0]),
            c(rows[1]),
            c(rows[2]),
            c(rows[3]),
            c(rows[4]),
            c(rows[5]),
            c(rows[6]),
            c(rows[7]),
        ]);
        let word = |m: usize| {
            f32x8::new([
                rows[0][m], rows[1][m], rows[2][m], rows[3][m], rows[4][m], rows[5][m], rows[6][m],
                rows[7][m],
            ])
        };
        Gathered {
            words: [
                head[0],
                head[1],
                head[2],
                head[3],
                head[4],
                head[5],
                head[6],
                head[7],
                word(8),
                word(9),
            ],
            ids,
        }
    }

    /// The geometric normal of primitive `prim` at a point `p` on it, not normalized: `e1 × e2`
    /// for a triangle ([`Triangle::geometric_normal`]), `(p − c) / R` for a sphere
    /// ([`Sphere::normal`]). Zero for a degenerate triangle.
    #[inline]
    pub fn geometric_normal(&self, prim: u32, p: Vec3) -> Vec3 {
        match prim.checked_sub(self.tri_count()) {
            None => self.triangle(prim).geometric_normal(),
            Some(sphere) => self.sphere(sphere).normal(p),
        }
    }

    /// Sphere `i`, counted among spheres (`i < sphere_count`), not among all primitives.
    #[inline(always)]
    pub fn sphere(&self, i: u32) -> Sphere {
        let s = &self.spheres[i as usize * stride::SPHERE..][..stride::SPHERE];
        Sphere {
            center: Vec3::new(s[0], s[1], s[2]),
            radius: s[3],
        }
    }

    /// Per-vertex normals of triangle `i`, when the scene has them.
    #[inline]
    pub fn vertex_normals(&self, i: u32) -> Option<[Vec3; 3]> {
        let s = self
            .normals
            .get(i as usize * stride::NORMALS..)?
            .get(..stride::NORMALS)?;
        Some([
            Vec3::new(s[0], s[1], s[2]),
            Vec3::new(s[3], s[4], s[5]),
            Vec3::new(s[6], s[7], s[8]),
        ])
    }

    /// Texture coordinates of triangle `i`, when the scene has them.
    #[inline]
    pub fn vertex_uvs(&self, i: u32) -> Option<[glam::Vec2; 3]> {
        let s = self
            .uvs
            .get(i as usize * stride::UVS..)?
            .get(..stride::UVS)?;
        Some([
            glam::Vec2::new(s[0], s[1]),
            glam::Vec2::new(s[2], s[3]),
            glam::Vec2::new(s[4], s[5]),
        ])
    }

    /// Material id of primitive `prim`, 0 when the scene has no materials section.
    #[inline]
    pub fn material(&self, prim: u32) -> u32 {
        self.materials.get(prim as usize).copied().unwrap_or(0)
    }
}

/// The primitives of one leaf: none or one stored inline, a run of the index list, or the
/// leaf's triangle groups.
#[derive(Clone, Copy, Debug)]
pub enum LeafPrims<'a> {
    One(Option<u32>),
    Many(&'a [u32]),
    Groups(&'a [Group]),
}

impl<'a> LeafPrims<'a> {
    /// Whether the leaf has no primitive.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        matches!(self, LeafPrims::One(None))
    }

    /// The ids of a leaf stored as one id or a list (empty for groups: see [`LeafPrims::ids`]).
    #[inline(always)]
    pub fn listed(&self) -> &[u32] {
        match self {
            LeafPrims::One(Some(p)) => core::slice::from_ref(p),
            LeafPrims::Many(s) => s,
            LeafPrims::One(None) | LeafPrims::Groups(_) => &[],
        }
    }

    /// Part `part` of `parts` of the leaf (a wide node's reference, [`wide::LeafRef`]): its
    /// items — index-list entries or groups — `part·n/parts .. (part+1)·n/parts`; a leaf of
    /// one primitive is its last part's. `parts` ≥ 1 and `part < parts`.
    #[inline(always)]
    pub fn part(self, part: u32, parts: u32) -> Self {
        // In u64: `part · n` overflows a 32-bit usize for leaves past 2²⁹ items.
        let range = |n: usize| {
            let at = |k: u32| (u64::from(k) * n as u64 / u64::from(parts)) as usize;
            at(part)..at(part + 1)
        };
        match self {
            LeafPrims::Many(s) => LeafPrims::Many(&s[range(s.len())]),
            LeafPrims::Groups(g) => LeafPrims::Groups(&g[range(g.len())]),
            LeafPrims::One(_) if range(1).is_empty() => LeafPrims::One(None),
            one => one,
        }
    }

    /// The leaf's primitive ids in its order, whatever the storage (padding lanes left out).
    #[inline(always)]
    pub fn ids(self) -> impl Iterator<Item = u32> + 'a {
        let (one, list, groups): (Option<u32>, &'a [u32], &'a [Group]) = match self {
            LeafPrims::One(p) => (p, &[], &[]),
            LeafPrims::Many(s) => (None, s, &[]),
            LeafPrims::Groups(g) => (None, &[], g),
        };
        let grouped = groups
            .iter()
            .flat_map(group::ids)
            .filter(|&id| id != group::PAD_ID);
        one.into_iter().chain(list.iter().copied()).chain(grouped)
    }
}

/// The vertices of one stored triangle.
#[inline(always)]
fn stored_vertices(s: &[f32; stride::TRIANGLE]) -> [Vec3; 3] {
    [
        Vec3::new(s[0], s[1], s[2]),
        Vec3::new(s[3], s[4], s[5]),
        Vec3::new(s[6], s[7], s[8]),
    ]
}

/// One stored triangle in Möller–Trumbore's layout.
#[inline(always)]
fn stored_triangle(s: &[f32; stride::TRIANGLE]) -> Triangle {
    let [v0, v1, v2] = stored_vertices(s);
    Triangle::from_vertices(v0, v1, v2)
}

/// Whether `a` and `b` hold the same words: a fold over every word with no early exit, where
/// `a != b` on arrays calls `memcmp`, which on wasm32 compares byte by byte: that call was 5 % of
/// the npm package's `Scene.build` (the torus knot, `fast`; a profile in Node), here one SIMD
/// pass.
///
/// Here, in the format's own file: both validations use it, `validate` and `wide::validate`, and
/// the first calls the second, so in either one it would close a circle of imports
/// (scripts/core-imports.py).
#[inline]
fn same_words(a: &[u32], b: &[u32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0, |acc, (x, y)| acc | (x ^ y)) == 0
}

const _: () = assert!(LEAF == 3);
