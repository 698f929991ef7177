//! Triangle groups (format v9's optional groups section): a leaf's triangles stored inline in
//! struct-of-arrays groups of four, so that the single-ray walk tests one ray against four
//! triangles in one pass of the 4-wide kernels ([`crate::simd::group`]) with no index list in
//! between — Embree's `triangle4`, and what tinybvh's wide layouts do.
//!
//! # A group: 44 words (176 bytes)
//! ```text
//! words  0..12   v0: x of lanes 0..4, then y, then z (f32 bits)
//! words 12..24   e1 = v1 − v0, the same way
//! words 24..36   e2 = v2 − v0
//! words 36..40   each lane's parallel threshold (Triangle::min_det2, f32 bits)
//! words 40..44   each lane's triangle id (storage order, below TRI_COUNT)
//! ```
//! (A 48-word group, padded to three cache lines, made the dragon's file 6 MB larger and its walks
//! no faster.)
//! A lane holds one triangle as Möller–Trumbore takes it: the triangles section's `v0` and
//! threshold bit for bit, and the edges the f32 subtractions of [`Triangle::from_vertices`] make
//! of its vertices (format 14; 9 to 13 stored `v1`, `v2`, and each test subtracted), so a lane
//! computes what the scalar fast kernel computes for that triangle, bit for bit. The watertight
//! kernel needs the vertices themselves (`v0 + e1` is not `v1` in f32), so in watertight mode
//! the walks read a group's triangles from the triangles section by its ids.
//! A leaf of `n ≥ 2` triangles owns `⌈n/4⌉` consecutive groups holding its triangles in
//! its order; the lanes past `n` in its last group are *padding*: `v0` and edges `0.0`, threshold
//! `+inf` (never hit, in either mode), id [`PAD_ID`]. Validation rebuilds each group from the ids
//! and the triangles section with [`pack`] and requires the stored words (`format::validate`).

use crate::triangle::Triangle;
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
    /// `v0`'s component `c` of the four lanes starts at `V0 + 4·c`.
    pub const V0: usize = 0;
    /// Edge `k` (1, 2)'s component `c` of the four lanes starts at `EDGES + 12·(k − 1) + 4·c`.
    pub const EDGES: usize = 12;
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
        let (id, [v0, v1, v2], min_det2) =
            lanes
                .get(j)
                .copied()
                .unwrap_or((PAD_ID, [Vec3::ZERO; 3], f32::INFINITY));
        let tri = Triangle::from_vertices(v0, v1, v2);
        for (k, v) in [tri.v0, tri.e1, tri.e2].iter().enumerate() {
            for (c, x) in v.to_array().into_iter().enumerate() {
                g[slot::V0 + 12 * k + 4 * c + j] = x.to_bits();
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

/// Lane `j`'s triangle as Möller–Trumbore takes it: `v0` and the edges, bit for bit what
/// [`Triangle::from_vertices`] makes of the stored triangle's vertices.
#[inline(always)]
pub fn lane_triangle(g: &Group, j: usize) -> Triangle {
    let f = |k: usize, c: usize| f32::from_bits(g[slot::V0 + 12 * k + 4 * c + j]);
    // Written out: `[0, 1, 2].map(…)` was left as an out-of-line call in the packet walk.
    Triangle {
        v0: Vec3::new(f(0, 0), f(0, 1), f(0, 2)),
        e1: Vec3::new(f(1, 0), f(1, 1), f(1, 2)),
        e2: Vec3::new(f(2, 0), f(2, 1), f(2, 2)),
    }
}

/// Lane `j`'s threshold ([`crate::Triangle::min_det2`]).
#[inline(always)]
pub fn lane_threshold(g: &Group, j: usize) -> f32 {
    f32::from_bits(g[slot::MIN_DET2 + j])
}
