//! Packets over wide nodes: the rays of one direction octant (4 or 8 lanes, [`Lanes`]) walk the
//! wide nodes together, each child box tested against every lane at once, as wide BVHs are walked
//! by coherent packets (Wald, Boulos & Shirley 2007, "Ray Tracing Deformable Scenes Using
//! Dynamic Bounding Volume Hierarchies", §4, there on binary nodes).
//!
//! At a node, the children are taken in the octant's stored front-to-back order (the packet's
//! lanes share their direction signs, so one order serves them all); each child's box is
//! clipped against every lane's interval, with the single-ray slab test's conservative rules
//! (fast mode: exit raised by `2γ₃` of its magnitude; watertight: both distances widened; a NaN
//! from a ray lying in a face counts as inside), and the children that some lane enters are
//! pushed farthest first with each lane's entry distance (NaN for a lane that misses the box).
//! A popped child is entered by the lanes whose entry still lies before their closest hit (with
//! the walk's `ENTRY_SLACK`), a leaf tested by exactly those lanes.
//!
//! Why each lane gets its single-ray walk's hit, ties included: a lane tests a leaf exactly when
//! its ray enters the leaf's box no farther than its closest hit so far, and it meets the leaves
//! in the same front-to-back order as the single-ray walk ([`super::walk`]), which tests the
//! same leaves by the same rule; the kernels are the same, lane by lane. Tested against the
//! single-ray walk, bit for bit (tests/tests/wide_packet.rs).

use super::{BOXES, LEAF_REF, ORDERS, REFS, STACK, WIDTH, WideNode};
use crate::format::Scene;
use crate::simd::lanes::Lanes;
use crate::simd::packet::{HitPacket, RayPacket};
use crate::simd::watertight::ShearX;
use crate::traverse::packet::widen_lanes;
use crate::traverse::{Contents, ENTRY_SLACK, GAMMA3};

/// A pending child: its reference and each lane's entry distance (NaN where the lane does not
/// enter it: no comparison holds for NaN, while `+∞` is a distance a ray with an empty
/// interval may have).
#[derive(Clone, Copy)]
struct Item<L> {
    child: u32,
    entry: L,
}

/// Each lane's entry distance into `slot`'s box of `node`, or NaN where the lane misses it or
/// enters it beyond `limit` (its closest hit so far, with slack): lane by lane the single-ray
/// slab test ([`super::walk::slab`]), the same operations in the same order, so that a lane
/// enters exactly the boxes its ray enters alone. `octant` picks each axis's near plane.
#[inline(always)]
fn enter<C: Contents, L: Lanes>(
    node: &WideNode,
    slot: usize,
    octant: usize,
    rays: &RayPacket<L>,
    limit: L,
) -> L {
    let inf = L::splat(f32::INFINITY);
    let missed = L::splat(f32::NAN);
    let axes = [
        (rays.origin.x, rays.inv_dir.x),
        (rays.origin.y, rays.inv_dir.y),
        (rays.origin.z, rays.inv_dir.z),
    ];
    let mut near = [rays.tmin; 3];
    let mut far = [inf; 3];
    for (axis, (o, inv)) in axes.into_iter().enumerate() {
        let neg = octant >> axis & 1;
        let plane = |side: usize| f32::from_bits(node[BOXES + 8 * (2 * axis + side) + slot]);
        let (mut n, mut f) = (
            (L::splat(plane(neg)) - o) * inv,
            (L::splat(plane(1 - neg)) - o) * inv,
        );
        // A ray lying in a face (`0 · ∞`): inside.
        n = n.is_nan().select(-inf, n);
        f = f.is_nan().select(inf, f);
        if C::CONSERVATIVE {
            (n, f) = (widen_lanes(n).0, widen_lanes(f).1);
        }
        (near[axis], far[axis]) = (n, f);
    }
    let entry = near[0].max(near[1]).max(near[2]).max(rays.tmin);
    let mut exit = far[0].min(far[1]).min(far[2]);
    if !C::CONSERVATIVE {
        let c = 2.0 * GAMMA3;
        exit = (exit * L::splat(1.0 + c)).max(exit * L::splat(1.0 - c));
    }
    entry.le(exit.min(limit)).select(entry, missed)
}

/// Each lane's farthest entry still of use: its closest hit so far, with slack.
#[inline(always)]
fn limit<L: Lanes>(rays: &RayPacket<L>) -> L {
    rays.tmax + rays.tmax.abs() * L::splat(ENTRY_SLACK)
}

impl Scene<'_> {
    /// Walks the wide nodes with the lanes in `group` (all of one sign octant, `octant` its
    /// index as the order words number it). Closest hits go to `hits` and shrink `rays.tmax`;
    /// with `ANY`, returns the lanes that hit something as soon as they do.
    #[inline(always)]
    pub(crate) fn walk_packet_wide<C: Contents, L: Lanes, const ANY: bool>(
        &self,
        rays: &mut RayPacket<L>,
        group: u32,
        octant: usize,
        hits: &mut HitPacket<L>,
        shear: &Option<ShearX<L>>,
    ) -> u32 {
        let wide = self.wide_nodes();
        let original_active = rays.active;
        let group_mask = L::mask_from_bits(group);
        let mut done = 0u32;
        let mut stack: heapless::Vec<Item<L>, STACK> = heapless::Vec::new();
        // The root: every lane of the group (the root's boxes do the clipping).
        let mut current = Item {
            child: 0,
            entry: group_mask.select(rays.tmin, L::splat(f32::NAN)),
        };
        loop {
            let mut alive = group_mask & current.entry.le(limit(rays));
            if ANY {
                alive = alive & !L::mask_from_bits(done);
            }
            if alive.any() {
                if current.child & LEAF_REF != 0 {
                    let leaf = self.node(current.child & !LEAF_REF);
                    rays.active = alive;
                    self.leaf_packet::<C, L, ANY>(&leaf, rays, hits, &mut done, shear);
                    rays.active = original_active;
                    if ANY && done & group == group {
                        return done;
                    }
                } else {
                    // Validation made every reference a node index in range.
                    let node = &wide[current.child as usize];
                    let order = node[ORDERS + octant];
                    let count = (order >> 24) as usize;
                    let lim = alive.select(limit(rays), L::splat(f32::NEG_INFINITY));
                    // Front to back; pushed farthest first so that they pop in order. At most
                    // 8 per node on a stack of 7 per level plus one: see `STACK`.
                    let mut entered: heapless::Vec<Item<L>, WIDTH> = heapless::Vec::new();
                    for k in 0..count {
                        let slot = (order >> (3 * k) & 7) as usize;
                        let entry = enter::<C, L>(node, slot, octant, rays, lim);
                        if !entry.is_nan().all() {
                            let _ = entered.push(Item {
                                child: node[REFS + slot],
                                entry,
                            });
                        }
                    }
                    if let Some((first, rest)) = entered.split_first() {
                        for item in rest.iter().rev() {
                            let _ = stack.push(*item);
                        }
                        current = *first;
                        continue;
                    }
                }
            }
            match stack.pop() {
                Some(item) => current = item,
                None => return done,
            }
        }
    }
}

/// The index of the octant the lanes of `group` share (bit `a` set where their direction's
/// component `a` is negative, by the sign of `1/d` as [`super::walk::RaySetup`] takes it).
#[inline(always)]
pub(crate) fn group_octant<L: Lanes>(rays: &RayPacket<L>, group: u32) -> usize {
    let negative = |inv: L| (inv.lt(L::splat(0.0)).bitmask() & group != 0) as usize;
    negative(rays.inv_dir.x) | negative(rays.inv_dir.y) << 1 | negative(rays.inv_dir.z) << 2
}
