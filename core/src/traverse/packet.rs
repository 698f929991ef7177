//! Packet traversal of the kd-tree, closest hit and occlusion: Wald's coherent packet traversal
//! (Wald, Slusallek, Benthin & Wagner 2001, "Interactive Rendering with Coherent Ray Tracing";
//! Wald's PhD thesis 2004, §7.3), written once over [`Lanes`] for 4 and 8 rays.
//!
//! All lanes of a traversal share the signs of their directions (the sign of `1/d`, so that `−0`
//! is negative, as in the scalar walk), so one near/far order serves the packet. Per interior
//! node each lane's `t_split` cuts its interval; the packet descends the near child if any lane
//! needs it, the far child if any lane needs that, and both (far pushed) when some lane needs each.
//! A lane's interval at a node is exactly the scalar walk's, so a lane visits at least the leaves
//! the scalar walk visits for that ray, and the closest-hit result is the same.
//!
//! Packets whose lanes do not share signs are traced as one sub-packet per sign octant (inactive
//! lanes masked), which keeps partly coherent packets in SIMD; fully incoherent rays are better
//! served by the scalar walk ([`Scene::intersect`]), which is what `kdray trace --packet 1` and
//! the renderer's secondary bounces use.

use super::{Contents, ENTRY_SLACK, GAMMA3, Mode, TINY, WIDEN, by_contents};
use crate::format::{LeafPrims, MAX_DEPTH, Scene};
use crate::group;
use crate::simd::kernels::{
    PrimHits, intersect_sphere, intersect_triangle_in_range, record_closest,
};
use crate::simd::lanes::{Lanes, set_lanes};
use crate::simd::packet::{HitPacket, RayPacket};
use crate::simd::watertight::{ShearX, intersect_triangle_watertight_prepared};
use glam::Vec3;

/// A pending far child with its lanes' intervals.
#[derive(Clone, Copy)]
struct Item<L> {
    node: u32,
    tmin: L,
    tmax: L,
}

impl Scene<'_> {
    /// The closest hit of each active lane of `rays` in its `(tmin, tmax)`; inactive lanes stay
    /// [`HitPacket::miss`]. Fast mode; picks the kernel monomorphized for the scene's contents.
    #[inline]
    pub fn intersect_packet<L: Lanes>(&self, rays: &RayPacket<L>) -> HitPacket<L> {
        self.intersect_packet_in(Mode::Fast, rays)
    }

    /// A mask of the active lanes of `rays` that hit anything in their `(tmin, tmax)`, in fast
    /// mode.
    #[inline]
    pub fn occluded_packet<L: Lanes>(&self, rays: &RayPacket<L>) -> L {
        self.occluded_packet_in(Mode::Fast, rays)
    }

    /// [`Scene::intersect_packet`] in `mode`.
    #[inline]
    pub fn intersect_packet_in<L: Lanes>(&self, mode: Mode, rays: &RayPacket<L>) -> HitPacket<L> {
        by_contents!(self, mode, |C| self.intersect_packet_with::<C, L>(rays))
    }

    /// [`Scene::occluded_packet`] in `mode`.
    #[inline]
    pub fn occluded_packet_in<L: Lanes>(&self, mode: Mode, rays: &RayPacket<L>) -> L {
        by_contents!(self, mode, |C| self.occluded_packet_with::<C, L>(rays))
    }

    /// [`Scene::intersect_packet`] for a fixed [`Contents`].
    pub fn intersect_packet_with<C: Contents, L: Lanes>(
        &self,
        rays: &RayPacket<L>,
    ) -> HitPacket<L> {
        if !C::WATERTIGHT && !self.packet_in_range(rays) {
            return self.intersect_lanes_alone::<C, L>(rays);
        }
        let mut hits = HitPacket::miss();
        let mut query = copy_packet(rays);
        let shear = C::WATERTIGHT.then(|| ShearX::new(rays));
        for group in sign_groups(rays) {
            self.walk_packet::<C, L, false>(&mut query, group, &mut hits, &shear);
        }
        hits
    }

    /// [`Scene::intersect_packet_with`] for a packet whose fast-mode tests could overflow f32
    /// ([`crate::simd::range`]: rays from very far, or huge or sliver triangles): each active lane
    /// by the single-ray walk over the nodes, whose kernel redoes such tests in f64, with the
    /// packet walk's closest hits. Rare, so out of line; the packet kernels then need no
    /// overflow check of their own.
    #[cold]
    #[inline(never)]
    fn intersect_lanes_alone<C: Contents, L: Lanes>(&self, rays: &RayPacket<L>) -> HitPacket<L> {
        let nodes = self.without_wide();
        let mut hits = HitPacket::miss();
        for i in set_lanes(rays.active.bitmask()) {
            let hit = nodes.intersect_with::<C>(&rays.ray(i));
            let lane = L::mask_from_bits(1 << i);
            hits.t = lane.select(L::splat(hit.t), hits.t);
            hits.u = lane.select(L::splat(hit.u), hits.u);
            hits.v = lane.select(L::splat(hit.v), hits.v);
            hits.prim = lane.select_index(L::splat_index(hit.prim), hits.prim);
        }
        hits
    }

    /// [`Scene::occluded_packet_with`] lane by lane, as [`Scene::intersect_lanes_alone`].
    #[cold]
    #[inline(never)]
    fn occluded_lanes_alone<C: Contents, L: Lanes>(&self, rays: &RayPacket<L>) -> L {
        let nodes = self.without_wide();
        let bits = set_lanes(rays.active.bitmask())
            .filter(|&i| nodes.occluded_with::<C>(&rays.ray(i)))
            .fold(0u32, |bits, i| bits | 1 << i);
        L::mask_from_bits(bits)
    }

    /// [`Scene::occluded_packet`] for a fixed [`Contents`].
    pub fn occluded_packet_with<C: Contents, L: Lanes>(&self, rays: &RayPacket<L>) -> L {
        if !C::WATERTIGHT && !self.packet_in_range(rays) {
            return self.occluded_lanes_alone::<C, L>(rays);
        }
        let mut hits = HitPacket::miss();
        let mut query = copy_packet(rays);
        let mut occluded = 0u32;
        let shear = C::WATERTIGHT.then(|| ShearX::new(rays));
        for group in sign_groups(rays) {
            occluded |= self.walk_packet::<C, L, true>(&mut query, group, &mut hits, &shear);
        }
        L::mask_from_bits(occluded)
    }

    /// Tests one primitive against the live lanes of `rays` (`shear`: the rays' [`ShearX`] when
    /// `C` is watertight).
    #[inline(always)]
    fn intersect_prim_packet<C: Contents, L: Lanes>(
        &self,
        prim: u32,
        rays: &RayPacket<L>,
        shear: &Option<ShearX<L>>,
    ) -> PrimHits<L> {
        let n_tris = self.tri_count();
        if C::SPHERES && (!C::TRIANGLES || prim >= n_tris) {
            return intersect_sphere(&self.sphere(prim - n_tris), rays);
        }
        let (tri, min_det2) = self.prepared_triangle(prim);
        intersect_stored_packet::<C, L>(&self.vertices(prim), &tri, min_det2, rays, shear)
    }

    /// Tests a leaf's primitives against the packet in the leaf's order: closest hits recorded
    /// (or, with `ANY`, lanes that hit added to `done` and retired). A grouped leaf's triangles
    /// are read from its groups' lanes, the same bits as the triangles section.
    #[inline(always)]
    fn leaf_packet<C: Contents, L: Lanes, const ANY: bool>(
        &self,
        node: &crate::node::Node,
        rays: &mut RayPacket<L>,
        hits: &mut HitPacket<L>,
        done: &mut u32,
        shear: &Option<ShearX<L>>,
    ) {
        // Records one primitive's lanes; true when no lane is left to serve (occlusion).
        let mut record = |found: PrimHits<L>, prim: u32, rays: &mut RayPacket<L>| {
            if ANY {
                *done |= (found.mask & rays.active).bitmask();
                rays.active = rays.active & !found.mask;
                rays.active.none()
            } else {
                record_closest(hits, rays, &found, prim);
                false
            }
        };
        match self.leaf_prims(node) {
            LeafPrims::Groups(groups) if C::GROUPS => {
                for g in groups {
                    for (j, prim) in group::ids(g).into_iter().enumerate() {
                        if prim == group::PAD_ID {
                            break;
                        }
                        let verts = group::lane_vertices(g, j);
                        let tri = crate::Triangle::from_vertices(verts[0], verts[1], verts[2]);
                        let min_det2 = group::lane_threshold(g, j);
                        let found =
                            intersect_stored_packet::<C, L>(&verts, &tri, min_det2, rays, shear);
                        if record(found, prim, rays) {
                            return;
                        }
                    }
                }
            }
            leaf => {
                for &prim in leaf.listed() {
                    let found = self.intersect_prim_packet::<C, L>(prim, rays, shear);
                    if record(found, prim, rays) {
                        return;
                    }
                }
            }
        }
    }

    /// Walks the tree with the lanes in `group` (all of one sign octant). Closest-hit results
    /// go to `hits` and shrink `rays.tmax`; with `ANY`, returns the lanes that hit something as
    /// soon as they do, and stops once all have. In watertight mode, split distances are widened
    /// lane by lane as in the scalar walk ([`crate::traverse::widen`]), which argues why no cell
    /// holding a hit is skipped.
    #[inline(always)]
    fn walk_packet<C: Contents, L: Lanes, const ANY: bool>(
        &self,
        rays: &mut RayPacket<L>,
        group: u32,
        hits: &mut HitPacket<L>,
        shear: &Option<ShearX<L>>,
    ) -> u32 {
        let (tmin, tmax) = clip_packet_to_box::<C, L>(rays, self.bounds());
        let live = live_lanes(tmin, tmax) & group;
        if live == 0 {
            return 0;
        }
        self.walk_from::<C, L, ANY>(rays, group, live, hits, shear, (0, tmin, tmax))
    }

    /// [`Scene::walk_packet`] from `start`, a node and the lanes' intervals there: the root and
    /// the lanes' intervals in the scene box, or a deeper node that the packet walk from the root
    /// would reach with no other node pending and exactly these intervals (the frustum walk's
    /// entry point, [`super::frustum`]). `live`: the lanes of `group` with a non-empty interval
    /// in the box, and no hit yet. Returns, with `ANY`, the lanes that hit something.
    #[inline(always)]
    pub(super) fn walk_from<C: Contents, L: Lanes, const ANY: bool>(
        &self,
        rays: &mut RayPacket<L>,
        group: u32,
        live: u32,
        hits: &mut HitPacket<L>,
        shear: &Option<ShearX<L>>,
        start: (u32, L, L),
    ) -> u32 {
        let original_active = rays.active;
        let (mut index, mut tmin, mut tmax) = start;
        let mut done = 0u32; // ANY: lanes that found a hit
        let is_negative = |inv: L| inv.lt(L::splat(0.0)).bitmask() & group != 0;
        let negative = [
            is_negative(rays.inv_dir.x),
            is_negative(rays.inv_dir.y),
            is_negative(rays.inv_dir.z),
        ];
        let origin = [rays.origin.x, rays.origin.y, rays.origin.z];
        let inv_dir = [rays.inv_dir.x, rays.inv_dir.y, rays.inv_dir.z];
        let group_mask = L::mask_from_bits(group);
        let mut stack: heapless::Vec<Item<L>, MAX_DEPTH> = heapless::Vec::new();
        loop {
            // Lanes still to be served here: a non-empty interval that starts before their
            // closest hit so far (and, for occlusion, no hit yet).
            // (`ENTRY_SLACK`: see the scalar walk.)
            let entry = tmin - tmin.abs() * L::splat(ENTRY_SLACK);
            let mut alive = group_mask & tmin.le(tmax) & entry.le(rays.tmax);
            if ANY {
                alive = alive & !L::mask_from_bits(done);
            }
            let node = self.node(index);
            if alive.any() && node.is_leaf() {
                rays.active = alive;
                self.leaf_packet::<C, L, ANY>(&node, rays, hits, &mut done, shear);
                rays.active = original_active;
                if ANY && done & group == group & live {
                    return done;
                }
            } else if alive.any() {
                let axis = node.axis();
                let t_split = (L::splat(node.split()) - origin[axis]) * inv_dir[axis];
                let (far_start, near_end) = if C::CONSERVATIVE {
                    widen_lanes(t_split)
                } else {
                    (t_split, t_split)
                };
                let [below_empty, above_empty] = node.empty_children();
                let ((near, near_empty), (far, far_empty)) = if negative[axis] {
                    ((node.above_child(), above_empty), (index + 1, below_empty))
                } else {
                    ((index + 1, below_empty), (node.above_child(), above_empty))
                };
                // `!(a < b)` so that NaN (origin on the plane, parallel direction) needs both.
                // An empty child is never entered: the split only clips the intervals.
                let none = L::splat(0.0);
                let need_near = if near_empty {
                    none
                } else {
                    alive & !near_end.lt(tmin)
                };
                let need_far = if far_empty {
                    none
                } else {
                    alive & !far_start.gt(tmax)
                };
                match (need_near.any(), need_far.any()) {
                    (true, false) => {
                        tmax = tmax.min(near_end);
                        index = near;
                        continue;
                    }
                    (false, true) => {
                        tmin = tmin.max(far_start);
                        index = far;
                        continue;
                    }
                    (true, true) => {
                        // Validation bounds the depth by MAX_DEPTH and one item per level is
                        // pending.
                        let _ = stack.push(Item {
                            node: far,
                            tmin: tmin.max(far_start),
                            tmax,
                        });
                        tmax = tmax.min(near_end);
                        index = near;
                        continue;
                    }
                    // Nothing left here but empty children: take the next pending node.
                    (false, false) => {}
                }
            }
            match stack.pop() {
                Some(item) => (index, tmin, tmax) = (item.node, item.tmin, item.tmax),
                None => return done,
            }
        }
    }
}

/// A copy of `rays` for the walk to shrink and mask, made field by field. Measured against
/// `*rays` (scripts/icount.sh): the same instructions for fast packets, and 1.4 % fewer for
/// watertight 8-wide packets, whose walk the plain copy compiles worse.
#[inline(always)]
pub(super) fn copy_packet<L: Lanes>(rays: &RayPacket<L>) -> RayPacket<L> {
    RayPacket {
        origin: rays.origin,
        dir: rays.dir,
        inv_dir: rays.inv_dir,
        tmin: rays.tmin,
        tmax: rays.tmax,
        active: rays.active,
    }
}

/// Each lane's interval inside the box, clipped to its own range: the slab test of
/// [`crate::traverse::clip_to_box`] in lanes, with the same operations in the same order. A zero
/// direction component gives `±∞` bounds, or NaN when the origin lies on the slab's face, which
/// counts as inside (the scalar test's closed slab). In watertight mode both distances are
/// widened ([`crate::traverse::clip_to_box_in`]).
#[inline(always)]
pub(super) fn clip_packet_to_box<C: Contents, L: Lanes>(
    rays: &RayPacket<L>,
    bounds: [Vec3; 2],
) -> (L, L) {
    let (mut t0, mut t1) = (rays.tmin, rays.tmax);
    let inf = L::splat(f32::INFINITY);
    let widen = L::splat(2.0 * GAMMA3);
    let axes = [
        (rays.origin.x, rays.inv_dir.x),
        (rays.origin.y, rays.inv_dir.y),
        (rays.origin.z, rays.inv_dir.z),
    ];
    for (axis, (o, inv)) in axes.into_iter().enumerate() {
        let a = (L::splat(bounds[0][axis]) - o) * inv;
        let b = (L::splat(bounds[1][axis]) - o) * inv;
        let (a_nan, b_nan) = (a.is_nan(), b.is_nan());
        let near = a_nan.select(-inf, a).min(b_nan.select(-inf, b));
        let far = a_nan.select(inf, a).max(b_nan.select(inf, b));
        let (near, far) = if C::CONSERVATIVE {
            (widen_lanes(near).0, widen_lanes(far).1)
        } else {
            (near, far + far.abs() * widen)
        };
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    (t0, t1)
}

/// The lanes whose interval `(tmin, tmax)` in the scene box is not empty (as a bit set).
#[inline(always)]
pub(super) fn live_lanes<L: Lanes>(tmin: L, tmax: L) -> u32 {
    (tmin.le(tmax) & tmin.lt(L::splat(f32::INFINITY))).bitmask()
}

/// The active lanes of `rays` split by the sign octant of their directions (sign of `1/d`).
pub(super) fn sign_groups<L: Lanes>(rays: &RayPacket<L>) -> impl Iterator<Item = u32> {
    let zero = L::splat(0.0);
    let (sx, sy, sz) = (
        rays.inv_dir.x.lt(zero).bitmask(),
        rays.inv_dir.y.lt(zero).bitmask(),
        rays.inv_dir.z.lt(zero).bitmask(),
    );
    let active = rays.active.bitmask();
    let mut remaining = active;
    core::iter::from_fn(move || {
        if remaining == 0 {
            return None;
        }
        let first = remaining.trailing_zeros();
        let pick = |s: u32| if s >> first & 1 == 1 { s } else { !s };
        let group = remaining & pick(sx) & pick(sy) & pick(sz);
        remaining &= !group;
        Some(group)
    })
}

/// [`crate::traverse::widen`] lane by lane: `(lo, hi)` bracketing each lane's exact distance.
#[inline(always)]
pub(crate) fn widen_lanes<L: Lanes>(t: L) -> (L, L) {
    let tiny = L::splat(TINY);
    let (a, b) = (t * L::splat(1.0 - WIDEN), t * L::splat(1.0 + WIDEN));
    (a.min(b) - tiny, a.max(b) + tiny)
}

/// One stored triangle (its vertices, Möller–Trumbore's form of them, its threshold) against a
/// packet in `C`'s mode; in fast mode, a packet [`Scene::packet_in_range`] has cleared.
#[inline(always)]
fn intersect_stored_packet<C: Contents, L: Lanes>(
    verts: &[Vec3; 3],
    tri: &crate::Triangle,
    min_det2: f32,
    rays: &RayPacket<L>,
    shear: &Option<ShearX<L>>,
) -> PrimHits<L> {
    if let (true, Some(shear)) = (C::WATERTIGHT, shear) {
        return intersect_triangle_watertight_prepared(verts, min_det2, rays, shear);
    }
    // Fast mode walks only packets that cannot overflow (`intersect_packet_with`).
    intersect_triangle_in_range(tri, min_det2, rays)
}
