//! A packet's rays bounded together, to rule out most of a node's eight slots in one 8-wide test
//! before the packet walk tests the rest lane by lane ([`super::packet`]): interval arithmetic
//! over the packet (Wald, Boulos & Shirley 2007, "Ray tracing deformable scenes using dynamic
//! bounding volume hierarchies", where large packets are culled against boxes this way).
//!
//! Per axis, the lanes' origins lie in `[o_min, o_max]` and their reciprocal directions in
//! `[i_min, i_max]`, all of one sign (else no [`Cull`]). A lane's near distance to a slot is
//! `(near plane − o)·i`, rounded, with the near plane the same for every lane (the sign picks
//! it); rounding is monotone, so it is at least `min(n·i_min, n·i_max)` with `n` the near plane
//! minus the origin bound that makes it least (`o_max` for a positive direction), and likewise
//! the far distance at most `max(f·i_min, f·i_max)`. Widened as the lane test widens its
//! distances (a monotone map), the largest lower bound over the axes and `tmin`'s least is at
//! most every lane's entry, the least upper bound and `tmax`'s largest at least every lane's
//! exit: a slot whose bounds do not meet is entered by no lane, and is skipped. The others go
//! to the lane test, which decides; the answers do not change, only how many slots are tested.
//!
//! Lanes with a `±0` or subnormal direction component (the lane test's other branches) leave the
//! packet without a [`Cull`], as do lanes of mixed signs on an axis.

use super::{Node, WIDTH, node};
use crate::simd::lanes::Lanes;
use crate::simd::packet::RayPacket;
use crate::traverse::wide::walk::lanes;
use crate::traverse::{TINY, WIDEN};
use wide::f32x8;

/// The packet's bounds, set up once a packet.
pub(super) struct Cull {
    /// Per axis, the origin bound subtracted from the near plane and from the far plane.
    origin: [[f32; 2]; 3],
    /// Per axis, the least and the largest reciprocal.
    inv: [[f32; 2]; 3],
    /// Per axis, the word offsets of the near and the far plane's lanes in a node.
    planes: [[usize; 2]; 3],
    tmin: f32,
    tmax: f32,
}

impl Cull {
    /// The bounds of the lanes `live` of `rays` (finite, and at least one), or `None` when a
    /// lane has a direction component of zero or so small its reciprocal overflows, or the
    /// lanes' signs differ on an axis.
    #[inline(always)]
    pub(super) fn new<L: Lanes>(rays: &RayPacket<L>, live: u32) -> Option<Self> {
        let live = L::mask_from_bits(live);
        // Each lane's value where it is live, else one that does not move the bound.
        let least = |x: L| least(live.select(x, L::splat(f32::INFINITY)));
        let largest = |x: L| -least(live.select(-x, L::splat(f32::INFINITY)));
        let span = |x: L| (least(x), largest(x));
        let o = [rays.origin.x, rays.origin.y, rays.origin.z];
        let i = [rays.inv_dir.x, rays.inv_dir.y, rays.inv_dir.z];
        let (tmin, tmax) = (least(rays.tmin), largest(rays.tmax));
        let mut cull = Self {
            origin: [[0.0; 2]; 3],
            inv: [[0.0; 2]; 3],
            planes: [[0; 2]; 3],
            tmin,
            tmax,
        };
        for a in 0..3 {
            let (o_min, o_max) = span(o[a]);
            let (i_min, i_max) = span(i[a]);
            if !(i_min.is_finite() && i_max.is_finite()) {
                return None;
            }
            // Boxes' low planes are words 8·(2·axis) + slot, high planes 8·(2·axis + 1) + slot.
            let (low, high) = (node::BOXES + 16 * a, node::BOXES + 16 * a + 8);
            (cull.planes[a], cull.origin[a]) = if i_min > 0.0 {
                ([low, high], [o_max, o_min])
            } else if i_max < 0.0 {
                ([high, low], [o_min, o_max])
            } else {
                return None;
            };
            cull.inv[a] = [i_min, i_max];
        }
        Some(cull)
    }

    /// The slots of `nd` (among its first `count`) that some lane may enter.
    #[inline(always)]
    pub(super) fn slots(&self, nd: &Node) -> u32 {
        let (mut entry, mut exit) = (f32x8::splat(self.tmin), f32x8::splat(self.tmax));
        for a in 0..3 {
            let [i0, i1] = self.inv[a].map(f32x8::splat);
            let near = lanes(nd, self.planes[a][0]) - f32x8::splat(self.origin[a][0]);
            let far = lanes(nd, self.planes[a][1]) - f32x8::splat(self.origin[a][1]);
            let near = (near * i0).fast_min(near * i1);
            let far = (far * i0).fast_max(far * i1);
            // The lane test's widening, outward.
            let near = (near * f32x8::splat(1.0 - WIDEN))
                .fast_min(near * f32x8::splat(1.0 + WIDEN))
                - f32x8::splat(TINY);
            let far = (far * f32x8::splat(1.0 - WIDEN)).fast_max(far * f32x8::splat(1.0 + WIDEN))
                + f32x8::splat(TINY);
            entry = entry.fast_max(near);
            exit = exit.fast_min(far);
        }
        let count = nd[node::COUNT].min(WIDTH as u32);
        entry.le(exit).to_bitmask() & ((1u32 << count) - 1)
    }
}

/// The least of `x`'s lanes, none of them NaN: plain comparisons, where `f32::min` adds a NaN
/// check to each (the packet walk's bounds were a tenth of its instructions that way).
#[inline(always)]
pub(super) fn least<L: Lanes>(x: L) -> f32 {
    let a = x.to_array();
    let a = a.as_ref();
    a[1..].iter().fold(a[0], |m, &v| if v < m { v } else { m })
}
