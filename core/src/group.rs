//! Triangle groups (format v9's optional groups section): a leaf's triangles stored inline in
//! struct-of-arrays groups of four, so that the single-ray walk tests one ray against four
//! triangles in one pass of the 4-wide kernels ([`crate::simd::group`]) with no index list in
//! between — Embree's `triangle4`, and what tinybvh's wide layouts do.
//!
//! # A group: 44 words (176 bytes)
//! ```text
//! words  0..12   v0: x of lanes 0..4, then y, then z (f32 bits)
//! words 12..24   v1, the same way
//! words 24..36   v2
//! words 36..40   each lane's parallel threshold (Triangle::min_det2, f32 bits)
//! words 40..44   each lane's triangle id (storage order, below TRI_COUNT)
//! ```
//! (A 48-word group, padded to three cache lines, made the dragon's file 6 MB larger and its walks
//! no faster.)
//! A lane holds one triangle exactly as the triangles section stores it: the same vertex bits and
//! the same threshold, so a lane computes what the scalar kernels compute for that triangle, bit
//! for bit. A leaf of `n ≥ 2` triangles owns `⌈n/4⌉` consecutive groups holding its triangles in
//! its order; the lanes past `n` in its last group are *padding*: vertices `0.0`, threshold `+inf`
//! (never hit, in either mode), id [`PAD_ID`]. Validation rebuilds each group from the ids and the
//! triangles section with [`pack`] and requires the stored words (`format::validate`).

use glam::Vec3;

/// Triangles per group.
pub const WIDTH: usize = 4;
/// Words per group.
pub const GROUP_WORDS: usize = 44;
/// One stored group.
pub type Group = [u32; GROUP_WORDS];

/// The id of a padding lane.
pub const PAD_ID: u32 = u32::MAX;

/// Word offsets inside a group.
pub mod slot {
    /// Vertex `k`'s component `c` of the four lanes starts at `VERTICES + 12·k + 4·c`.
    pub const VERTICES: usize = 0;
    pub const MIN_DET2: usize = 36;
    pub const IDS: usize = 40;
}

/// Groups a leaf of `n` primitives owns: `⌈n/4⌉` for `n ≥ 2`; one- and no-primitive leaves have
/// none (their one id, if any, is in the node).
#[inline(always)]
pub const fn groups_for(n: u32) -> u32 {
    if n < 2 { 0 } else { n.div_ceil(WIDTH as u32) }
}

/// One lane's contents: triangle id, vertices and threshold, as the triangles section has them.
pub type Lane = (u32, [Vec3; 3], f32);

/// The group holding `lanes` (at most [`WIDTH`]; the rest are padding).
pub fn pack(lanes: &[Lane]) -> Group {
    let mut g = [0u32; GROUP_WORDS];
    for j in 0..WIDTH {
        let (id, verts, min_det2) =
            lanes
                .get(j)
                .copied()
                .unwrap_or((PAD_ID, [Vec3::ZERO; 3], f32::INFINITY));
        for (k, v) in verts.iter().enumerate() {
            for (c, x) in v.to_array().into_iter().enumerate() {
                g[slot::VERTICES + 12 * k + 4 * c + j] = x.to_bits();
            }
        }
        g[slot::MIN_DET2 + j] = min_det2.to_bits();
        g[slot::IDS + j] = id;
    }
    g
}

/// The four lanes' ids (padding lanes are [`PAD_ID`]).
#[inline(always)]
pub fn ids(g: &Group) -> [u32; WIDTH] {
    core::array::from_fn(|j| g[slot::IDS + j])
}

/// Four consecutive words of `g` from `at` as f32 lanes.
#[inline(always)]
pub(crate) fn floats(g: &Group, at: usize) -> [f32; WIDTH] {
    core::array::from_fn(|j| f32::from_bits(g[at + j]))
}

/// Lane `j`'s vertices.
#[inline(always)]
pub fn lane_vertices(g: &Group, j: usize) -> [Vec3; 3] {
    let f = |k: usize, c: usize| f32::from_bits(g[slot::VERTICES + 12 * k + 4 * c + j]);
    // Written out: `[0, 1, 2].map(…)` was left as an out-of-line call in the packet walk.
    [
        Vec3::new(f(0, 0), f(0, 1), f(0, 2)),
        Vec3::new(f(1, 0), f(1, 1), f(1, 2)),
        Vec3::new(f(2, 0), f(2, 1), f(2, 2)),
    ]
}

/// Lane `j`'s threshold ([`crate::Triangle::min_det2`]).
#[inline(always)]
pub fn lane_threshold(g: &Group, j: usize) -> f32 {
    f32::from_bits(g[slot::MIN_DET2 + j])
}
