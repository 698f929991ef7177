//! The scalar walk over blocks: the walk of [`crate::traverse`] (pbrt-v3's, with its exact rules)
//! on the blocked layout, one cache line per three levels.
//!
//! On entering a block, one ray computes the distances to all seven of its planes at once
//! ([`plane_distances`]: 8-wide, the same `(split − o) · (1/d)[axis]` f32 operations as the
//! node walk, so the same bits), then descends up to three levels from those without another
//! load. Every decision is the node walk's, in the same order: near and far by the sign of
//! `1/d`, both children for a NaN plane distance, empty children only clipping the interval, the
//! closest-candidate skip with [`entry_with_slack`], and in conservative mode the [`widen`]ed
//! distances. Validation makes the blocked tree the node tree, so both walks visit the same
//! leaves in the same order with the same intervals, and return the same hits bit for bit
//! (ties included); `tests/tests/blocked.rs` checks it.

use super::{AXES_WORD, Block, is_empty_at, is_interior, kind, reference_at};
use crate::format::{MAX_DEPTH, Scene};
use crate::ray::Ray;
use crate::traverse::{Contents, entry_interval, entry_with_slack, widen};
use crate::walk::Query;
use wide::{f32x8, u32x8};

/// One pending far child: block, position in it, and its `(tmin, tmax)`.
type Pending = (u32, u32, f32, f32);

/// Bit 0 and bit 1 of slot `k`'s axis field (lane `k`; lane 7 holds no slot).
const AXIS_BIT0: [u32; 8] = [1, 1 << 2, 1 << 4, 1 << 6, 1 << 8, 1 << 10, 1 << 12, 0];
const AXIS_BIT1: [u32; 8] = [2, 2 << 2, 2 << 4, 2 << 6, 2 << 8, 2 << 10, 2 << 12, 0];

/// The distance along the ray to each slot's plane, `(split − o[axis]) · inv_dir[axis]`, in
/// lanes 0..7 (lane 7 and slots that are not interior nodes hold values nobody reads). The
/// origin and inverse direction are picked per lane by the axis bits (x when both are 0, y for
/// bit 0 alone, z for bit 1), then one subtraction and one multiplication, rounded as the scalar
/// ones are.
#[inline(always)]
pub fn plane_distances(block: &Block, origin: [f32; 3], inv_dir: [f32; 3]) -> [f32; 8] {
    let axes = u32x8::splat(block[AXES_WORD]);
    let zero = u32x8::ZERO;
    let bit0: f32x8 = bytemuck::cast((axes & u32x8::new(AXIS_BIT0)).simd_ne(zero));
    let bit1: f32x8 = bytemuck::cast((axes & u32x8::new(AXIS_BIT1)).simd_ne(zero));
    let pick = |v: [f32; 3]| {
        let [x, y, z] = v.map(f32x8::splat);
        bit1.select(z, bit0.select(y, x))
    };
    let planes: [u32; 8] = core::array::from_fn(|k| block[k]);
    let planes: f32x8 = bytemuck::cast(planes);
    ((planes - pick(origin)) * pick(inv_dir)).to_array()
}

/// Asks the cache for the child blocks of `block` as the walk enters it, so that the one it
/// descends to (and the far ones it may come back to) are on their way while it decides the
/// block's three levels (Embree prefetches the children of a BVH node the same way). On the
/// dragon's diffuse rays: 661 → 621 ms (docs/BENCHMARKS.md, "Cache-line blocks").
#[inline(always)]
fn prefetch_children(blocks: &[Block], block: &Block) {
    for &r in &block[super::REFS_WORD..] {
        if r & 3 == kind::BLOCK
            && let Some(c) = blocks.get((r >> 5) as usize)
        {
            crate::prefetch::t0(c);
        }
    }
}

impl Scene<'_> {
    /// The front-to-back walk over the blocks section for `query`, the node walk's twin
    /// ([`crate::walk`]; see there for the conservative mode). The caller has checked that the
    /// section is present.
    #[inline(always)]
    pub(crate) fn walk_blocked<C: Contents, Q: Query>(&self, ray: &Ray, query: &mut Q) {
        let Some((mut tmin, mut tmax)) = entry_interval::<C>(ray, self.bounds()) else {
            return;
        };
        let blocks = self.blocks();
        let inv_dir = ray.dir.recip();
        let (origin, inv) = (ray.origin.to_array(), inv_dir.to_array());
        let mut best_t = ray.tmax;
        let mut stack: heapless::Vec<Pending, MAX_DEPTH> = heapless::Vec::new();
        let mut b = 0u32;
        let mut block = &blocks[0];
        let mut t = plane_distances(block, origin, inv);
        prefetch_children(blocks, block);
        let mut p = 0usize;
        loop {
            // The node walk's skip of a node entered beyond the closest candidate (see there).
            if !(best_t < entry_with_slack(tmin)) {
                if is_interior(block, p) {
                    let axis = super::axis(block, p) as usize;
                    let t_plane = t[p];
                    let (far_start, near_end) = if C::CONSERVATIVE {
                        widen(t_plane)
                    } else {
                        (t_plane, t_plane)
                    };
                    let (below, above) = (2 * p + 1, 2 * p + 2);
                    let (near, far) = if inv[axis] < 0.0 {
                        (above, below)
                    } else {
                        (below, above)
                    };
                    let visit_near = !(near_end < tmin) && !is_empty_at(block, near);
                    let visit_far = !(far_start > tmax) && !is_empty_at(block, far);
                    // At most one pending item per level, and validation bounds the depth by
                    // MAX_DEPTH: the push cannot fail.
                    match (visit_near, visit_far) {
                        (true, true) => {
                            let _ = stack.push((b, far as u32, tmin.max(far_start), tmax));
                            tmax = tmax.min(near_end);
                            p = near;
                            continue;
                        }
                        (true, false) => {
                            tmax = tmax.min(near_end);
                            p = near;
                            continue;
                        }
                        (false, true) => {
                            tmin = tmin.max(far_start);
                            p = far;
                            continue;
                        }
                        (false, false) => {}
                    }
                } else {
                    let r = reference_at(block, p);
                    let value = r >> 2;
                    let one = [value];
                    let leaf;
                    let prims: &[u32] = match r & 3 {
                        kind::BLOCK => {
                            b = value >> 3;
                            block = &blocks[b as usize];
                            prefetch_children(blocks, block);
                            t = plane_distances(block, origin, inv);
                            p = (value & 7) as usize;
                            continue;
                        }
                        kind::LEAF => {
                            leaf = self.leaf_prims(&self.node(value));
                            leaf.as_slice()
                        }
                        kind::ONE => &one[..],
                        _ => &[],
                    };
                    let (closest, stop) = query.leaf::<C>(self, prims);
                    best_t = closest;
                    if stop {
                        return;
                    }
                }
            }
            let Some((nb, np, a, c)) = stack.pop() else {
                return;
            };
            if nb != b {
                b = nb;
                block = &blocks[b as usize];
                t = plane_distances(block, origin, inv);
            }
            (p, tmin, tmax) = (np as usize, a, c);
        }
    }
}
