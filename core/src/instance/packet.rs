//! The two-level walk for 4 or 8 rays at once ([`InstancedScene::intersect_packet_in`],
//! [`InstancedScene::occluded_packet_in`]), over [`Lanes`], with each lane's answer the
//! single-ray walk's ([`super::walk`]): the same `t` bits, the same instance and primitive but
//! where two tie at exactly that `t`.
//!
//! The tree over the instances is walked once for the packet: each box is tested by every live
//! lane at once, with the arithmetic of the single-ray walk's `Slabs` lane by lane (so a lane
//! enters exactly the boxes its single ray would enter with the same `tmax`), slot by slot of a
//! node; the packet goes down the slot some lane enters first (the least entry distance of its
//! lanes), the other slots entered pending with their lanes and entry distances, and a pending
//! slot is taken only by the lanes whose closest hit so far lies beyond their entry. Before the
//! lane tests, one 8-wide test of the packet's bounds against the node's eight boxes
//! (`instance/cull.rs`) leaves out the slots no lane can enter. At an
//! instance, the lanes that enter its box are moved into it together (origin by the stored
//! inverse, direction by its linear part, each lane rounded as [`into_instance`] rounds, the same
//! per-lane power-of-two rescale where the moved direction is far from unit length), and the
//! bottom scene's own packet walk ([`Scene::intersect_packet_in`], [`Scene::occluded_packet_in`])
//! runs with each lane's `tmax` its closest hit so far.
//!
//! Why the answers agree with the single-ray walk: a lane's closest hit is the least `t` over the
//! instances whose boxes it enters before a closer hit is known, and every hit lies inside its
//! instance's box ([`super::affine::BOX_PADDING`]), so the order in which a lane meets the
//! instances changes which ones it skips, not the least `t`; each instance's bottom walk gives a
//! lane the `t` bits its single ray gets (the packet walks' own guarantee). Any hit: a lane
//! enters the same boxes as its single ray (its `tmax` never shrinks), so it finds a hit if and
//! only if the single ray does.

use super::cull::{Cull, least};
use super::walk::{into_instance, unit_scale};
use super::{
    Affine, InstanceHit, InstancedScene, Node, STACK, WIDTH, affine_at, node, push_in_order,
    record, slot_words,
};
use crate::format::Scene;
use crate::simd::lanes::{Lanes, Vec3x, set_lanes};
use crate::simd::packet::RayPacket;
use crate::traverse::Mode;
use crate::traverse::packet::widen_lanes;

/// The closest hits of a packet through a top level, lane by lane; a lane with no hit holds
/// [`InstanceHit::MISS`].
#[derive(Clone, Copy, Debug)]
pub struct InstanceHitPacket<L: Lanes> {
    pub t: L,
    pub prim: L::Index,
    pub u: L,
    pub v: L,
    pub instance: L::Index,
    pub user_id: L::Index,
}

impl<L: Lanes> InstanceHitPacket<L> {
    /// Every lane a miss.
    #[inline]
    pub fn miss() -> Self {
        let m = InstanceHit::MISS;
        Self {
            t: L::splat(m.t),
            prim: L::splat_index(m.prim),
            u: L::splat(m.u),
            v: L::splat(m.v),
            instance: L::splat_index(m.instance),
            user_id: L::splat_index(m.user_id),
        }
    }

    /// Lane `i` as an [`InstanceHit`].
    ///
    /// # Panics
    /// If `i >= W`.
    #[inline]
    pub fn hit(&self, i: usize) -> InstanceHit {
        InstanceHit {
            t: self.t.to_array().as_ref()[i],
            prim: L::index_to_array(self.prim).as_ref()[i],
            u: self.u.to_array().as_ref()[i],
            v: self.v.to_array().as_ref()[i],
            instance: L::index_to_array(self.instance).as_ref()[i],
            user_id: L::index_to_array(self.user_id).as_ref()[i],
        }
    }

    /// Writes lane `i` to `out[i]` for each active lane of `rays` with `i < out.len()`, leaving
    /// every other element of `out` as it was (as [`crate::simd::HitPacket::write_active`]).
    #[inline]
    pub fn write_active(&self, rays: &RayPacket<L>, out: &mut [InstanceHit]) {
        for i in set_lanes(rays.active.bitmask()) {
            if let Some(slot) = out.get_mut(i) {
                *slot = self.hit(i);
            }
        }
    }
}

/// The packet prepared for the walk's box tests: the single-ray walk's `Slabs` in lanes (the
/// reciprocals once a packet, a zero component a test of the origin alone, a subnormal one
/// divided by), so that each lane's entry distance is its single ray's, bit for bit.
pub(super) struct PacketSlabs<L> {
    origin: [L; 3],
    dir: [L; 3],
    inv: [L; 3],
    /// Lanes whose component is `±0`.
    zero: [L; 3],
    /// Whether any lane has a `±0` component (else the origin tests of `zero` are skipped).
    any_zero: bool,
    /// Lanes whose component is not zero but its reciprocal overflows (a subnormal).
    divide: [L; 3],
    any_divide: bool,
    tmin: L,
}

impl<L: Lanes> PacketSlabs<L> {
    #[inline(always)]
    pub(super) fn new(rays: &RayPacket<L>) -> Self {
        let origin = [rays.origin.x, rays.origin.y, rays.origin.z];
        let dir = [rays.dir.x, rays.dir.y, rays.dir.z];
        let inv = [rays.inv_dir.x, rays.inv_dir.y, rays.inv_dir.z];
        let zero = dir.map(|d| d.eq(L::splat(0.0)));
        let divide: [L; 3] = core::array::from_fn(|a| !inv[a].is_finite() & !zero[a]);
        let any_divide = (divide[0] | divide[1] | divide[2]).any();
        let any_zero = (zero[0] | zero[1] | zero[2]).any();
        Self {
            origin,
            dir,
            inv,
            zero,
            any_zero,
            divide,
            any_divide,
            tmin: rays.tmin,
        }
    }

    /// The lanes of `lanes` that enter the box in `b`'s first six words over `(tmin, tmax)`,
    /// and their entry distances (both slab distances widened outward, as the single-ray walk).
    #[inline(always)]
    pub(super) fn enter(&self, b: &[u32], tmax: L, lanes: L) -> (L, L) {
        let (mut t0, mut t1) = (self.tmin, tmax);
        let mut inside = lanes;
        let inf = L::splat(f32::INFINITY);
        for a in 0..3 {
            let lo = L::splat(f32::from_bits(b[a]));
            let hi = L::splat(f32::from_bits(b[3 + a]));
            let o = self.origin[a];
            let (mut near, mut far) = ((lo - o) * self.inv[a], (hi - o) * self.inv[a]);
            if self.any_divide {
                let d = self.dir[a];
                near = self.divide[a].select((lo - o) / d, near);
                far = self.divide[a].select((hi - o) / d, far);
            }
            // With no `±0` component in the packet, the selects below would keep `near` and
            // `far` in every lane: skipped (the same bits).
            let (near, far) = if self.any_zero {
                let zero = self.zero[a];
                inside = inside & !(zero & (o.lt(lo) | o.gt(hi)));
                (
                    zero.select(-inf, near.min(far)),
                    zero.select(inf, near.max(far)),
                )
            } else {
                (near.min(far), near.max(far))
            };
            t0 = t0.max(widen_lanes(near).0);
            t1 = t1.min(widen_lanes(far).1);
        }
        (inside & t0.le(t1), t0)
    }
}

/// The lanes of `rays` that `lanes` names moved into an instance by `inverse`, each as
/// [`into_instance`] moves its ray (the same operations in the same order), with `tmax` its
/// upper end; and each lane's factor from the moved ray's `t` back to the world's. Lanes that
/// [`into_instance`] sends into no instance are inactive.
#[inline(always)]
fn into_instance_packet<L: Lanes>(
    inverse: &Affine,
    rays: &RayPacket<L>,
    lanes: u32,
    tmax: L,
) -> (RayPacket<L>, L) {
    let m = &inverse.0;
    let s = |i: usize| L::splat(m[i]);
    let (o, d) = (&rays.origin, &rays.dir);
    let row = |r: usize, v: &Vec3x<L>| (s(4 * r) * v.x + s(4 * r + 1) * v.y) + s(4 * r + 2) * v.z;
    let origin = Vec3x {
        x: row(0, o) + s(3),
        y: row(1, o) + s(7),
        z: row(2, o) + s(11),
    };
    let mut dir = Vec3x {
        x: row(0, d),
        y: row(1, d),
        z: row(2, d),
    };
    let inf = L::splat(f32::INFINITY);
    let finite = |x: L| x.abs().lt(inf);
    let mut active = L::mask_from_bits(lanes)
        & finite(origin.x)
        & finite(origin.y)
        & finite(origin.z)
        & finite(dir.x)
        & finite(dir.y)
        & finite(dir.z);
    let (mut tmin, mut tmax, mut back) = (rays.tmin, tmax, L::splat(1.0));
    let largest = dir.x.abs().max(dir.y.abs()).max(dir.z.abs());
    let unit = largest.ge(L::splat(0.25)) & largest.lt(L::splat(4.0));
    if (active & !unit).any() {
        // Some lane's moved direction is far from unit length: rescale it by the power of two
        // the single-ray walk takes (rare: scales beyond 4 or below 1/4), lane by lane.
        let (mut f, mut inv_f) = (L::splat(1.0).to_array(), L::splat(1.0).to_array());
        let mut keep = 0u32;
        let m = largest.to_array();
        for i in set_lanes((active & !unit).bitmask()) {
            if let Some((fi, inv_fi)) = unit_scale(m.as_ref()[i]) {
                (f.as_mut()[i], inv_f.as_mut()[i]) = (fi, inv_fi);
                keep |= 1 << i;
            }
        }
        active = active & (unit | L::mask_from_bits(keep));
        let (f, inv_f) = (L::from_array(f), L::from_array(inv_f));
        dir = Vec3x {
            x: dir.x * inv_f,
            y: dir.y * inv_f,
            z: dir.z * inv_f,
        };
        (tmin, tmax, back) = (tmin * f, tmax * f, inv_f);
    }
    let local = RayPacket {
        origin,
        dir,
        inv_dir: dir.recip(),
        tmin,
        tmax,
        active,
    };
    (local, back)
}

/// At most this many lanes entering an instance go into it one by one, by the single-ray walk's
/// own steps ([`into_instance`], [`Scene::intersect_in`]): the packet's move into the instance
/// and the bottom packet walk's set-up cost more than they save for so few rays (incoherent
/// rays, such as diffuse bounces, meet most instances one or two lanes at a time).
const FEW_LANES: u32 = 2;

/// What the packet walk does at an instance, for the lanes that enter its box.
trait PacketVisit<L: Lanes> {
    /// Each lane's upper end for the box tests: its closest hit so far, or its `tmax`.
    fn tmax(&self) -> L;
    /// The lanes still to be served (any hit: those without one yet).
    fn open(&self) -> u32;
    /// Visits instance `i` with `lanes`; true when no lane is left to serve.
    fn instance(&mut self, top: &InstancedScene, i: u32, lanes: u32) -> bool;
}

/// Closest hits: each lane's `tmax` shrinks to its hits.
struct ClosestPacket<'r, L: Lanes> {
    mode: Mode,
    rays: &'r RayPacket<L>,
    tmax: L,
    hits: InstanceHitPacket<L>,
}

impl<L: Lanes> PacketVisit<L> for ClosestPacket<'_, L> {
    #[inline(always)]
    fn tmax(&self) -> L {
        self.tmax
    }

    #[inline(always)]
    fn open(&self) -> u32 {
        u32::MAX
    }

    #[inline(always)]
    fn instance(&mut self, top: &InstancedScene, i: u32, lanes: u32) -> bool {
        let inst = &top.records[i as usize];
        let inverse = affine_at(inst, record::INVERSE);
        let bottom: &Scene = &top.bottoms[inst[record::BOTTOM] as usize];
        if lanes.count_ones() <= FEW_LANES {
            for lane in set_lanes(lanes) {
                let ray = self.rays.ray(lane);
                let world = ray.with_range(ray.tmin, self.tmax.to_array().as_ref()[lane]);
                let Some((local, back)) = into_instance(&inverse, &world) else {
                    continue;
                };
                let hit = bottom.intersect_in(self.mode, &local);
                let t = hit.t * back;
                if hit.is_hit() && t < world.tmax && t > world.tmin {
                    let at = L::mask_from_bits(1 << lane);
                    let h = &mut self.hits;
                    self.tmax = at.select(L::splat(t), self.tmax);
                    h.t = at.select(L::splat(t), h.t);
                    h.u = at.select(L::splat(hit.u), h.u);
                    h.v = at.select(L::splat(hit.v), h.v);
                    h.prim = at.select_index(L::splat_index(hit.prim), h.prim);
                    h.instance = at.select_index(L::splat_index(i), h.instance);
                    let user = L::splat_index(inst[record::USER_ID]);
                    h.user_id = at.select_index(user, h.user_id);
                }
            }
            return false;
        }
        let (local, back) = into_instance_packet(&inverse, self.rays, lanes, self.tmax);
        if local.active.none() {
            return false;
        }
        let found = bottom.intersect_packet_in(self.mode, &local);
        let t = found.t * back;
        let accept = local.active
            & found.t.lt(L::splat(f32::INFINITY))
            & t.lt(self.tmax)
            & t.gt(self.rays.tmin);
        if accept.any() {
            let h = &mut self.hits;
            self.tmax = accept.select(t, self.tmax);
            h.t = accept.select(t, h.t);
            h.u = accept.select(found.u, h.u);
            h.v = accept.select(found.v, h.v);
            h.prim = accept.select_index(found.prim, h.prim);
            h.instance = accept.select_index(L::splat_index(i), h.instance);
            let user = L::splat_index(inst[record::USER_ID]);
            h.user_id = accept.select_index(user, h.user_id);
        }
        false
    }
}

/// Any hit: a lane is done at its first instance with a hit.
struct AnyPacket<'r, L: Lanes> {
    mode: Mode,
    rays: &'r RayPacket<L>,
    /// The lanes to answer.
    live: u32,
    done: u32,
}

impl<L: Lanes> PacketVisit<L> for AnyPacket<'_, L> {
    #[inline(always)]
    fn tmax(&self) -> L {
        self.rays.tmax
    }

    #[inline(always)]
    fn open(&self) -> u32 {
        !self.done
    }

    #[inline(always)]
    fn instance(&mut self, top: &InstancedScene, i: u32, lanes: u32) -> bool {
        let inst = &top.records[i as usize];
        let inverse = affine_at(inst, record::INVERSE);
        let bottom: &Scene = &top.bottoms[inst[record::BOTTOM] as usize];
        if lanes.count_ones() <= FEW_LANES {
            for lane in set_lanes(lanes) {
                let ray = self.rays.ray(lane);
                if let Some((local, _)) = into_instance(&inverse, &ray)
                    && bottom.occluded_in(self.mode, &local)
                {
                    self.done |= 1 << lane;
                }
            }
            return self.done & self.live == self.live;
        }
        let (local, _) = into_instance_packet(&inverse, self.rays, lanes, self.rays.tmax);
        if local.active.any() {
            self.done |= bottom.occluded_packet_in(self.mode, &local).bitmask() & lanes;
        }
        self.done & self.live == self.live
    }
}

/// The lanes of `rays` that are active and finite (the single-ray walk's [`crate::Ray::is_finite`]).
#[inline(always)]
pub(super) fn finite_lanes<L: Lanes>(rays: &RayPacket<L>) -> u32 {
    let inf = L::splat(f32::INFINITY);
    let finite = |x: L| x.abs().lt(inf);
    (rays.active
        & finite(rays.origin.x)
        & finite(rays.origin.y)
        & finite(rays.origin.z)
        & finite(rays.dir.x)
        & finite(rays.dir.y)
        & finite(rays.dir.z)
        & !rays.tmin.is_nan()
        & !rays.tmax.is_nan())
    .bitmask()
}

impl InstancedScene<'_, '_> {
    /// The closest hit of each active lane of `rays` in its `(tmin, tmax)` over every instance;
    /// inactive lanes stay [`InstanceHit::MISS`]. Fast mode.
    #[inline]
    pub fn intersect_packet<L: Lanes>(&self, rays: &RayPacket<L>) -> InstanceHitPacket<L> {
        self.intersect_packet_in(Mode::Fast, rays)
    }

    /// A mask of the active lanes of `rays` that hit any instance in their `(tmin, tmax)`, in
    /// fast mode.
    #[inline]
    pub fn occluded_packet<L: Lanes>(&self, rays: &RayPacket<L>) -> L {
        self.occluded_packet_in(Mode::Fast, rays)
    }

    /// [`Self::intersect_packet`] in `mode` (each bottom scene walked by
    /// [`Scene::intersect_packet_in`]).
    pub fn intersect_packet_in<L: Lanes>(
        &self,
        mode: Mode,
        rays: &RayPacket<L>,
    ) -> InstanceHitPacket<L> {
        let mut visit = ClosestPacket {
            mode,
            rays,
            tmax: rays.tmax,
            hits: InstanceHitPacket::miss(),
        };
        self.walk_packet(rays, finite_lanes(rays), &mut visit);
        visit.hits
    }

    /// [`Self::occluded_packet`] in `mode`.
    pub fn occluded_packet_in<L: Lanes>(&self, mode: Mode, rays: &RayPacket<L>) -> L {
        let live = finite_lanes(rays);
        let mut visit = AnyPacket {
            mode,
            rays,
            live,
            done: 0,
        };
        self.walk_packet(rays, live, &mut visit);
        L::mask_from_bits(visit.done)
    }

    /// The walk of the tree over the instances with the lanes `live` (see the module doc).
    #[inline(always)]
    fn walk_packet<L: Lanes, V: PacketVisit<L>>(
        &self,
        rays: &RayPacket<L>,
        live: u32,
        visit: &mut V,
    ) {
        if live == 0 {
            return;
        }
        let slabs = PacketSlabs::new(rays);
        let cull = Cull::new(rays, live);
        let (mut current, mut lanes) = (0u32, live);
        // A pending slot, the lanes that entered it, their least entry distance and each one's.
        // The validated depth bounds the stack ([`STACK`]).
        let mut stack: heapless::Vec<(u32, u32, f32, L), STACK> = heapless::Vec::new();
        loop {
            if current & node::RECORD_REF != 0 {
                let open = lanes & visit.open();
                if open != 0 && visit.instance(self, current & !node::RECORD_REF, open) {
                    return;
                }
            } else {
                let nd: &Node = &self.nodes[current as usize];
                let here = L::mask_from_bits(lanes);
                let tmax = visit.tmax();
                // The slots some lane enters go on the stack, ordered among themselves by
                // the least entry of their lanes, the nearest on top: popped next.
                let below = stack.len();
                let slots = match &cull {
                    Some(cull) => cull.slots(nd),
                    None => (1u32 << nd[node::COUNT].min(WIDTH as u32)) - 1,
                };
                for s in set_lanes(slots) {
                    let (m, t) = slabs.enter(&slot_words(nd, s), tmax, here);
                    let bits = m.bitmask();
                    if bits == 0 {
                        continue;
                    }
                    let near = least(m.select(t, L::splat(f32::INFINITY)));
                    push_in_order(
                        &mut stack,
                        below,
                        (nd[node::REFS + s], bits, near, t),
                        |e| e.2,
                    );
                }
            }
            // The next pending slot that some lane enters before its closest hit so far.
            loop {
                let Some((n, l, _, t)) = stack.pop() else {
                    return;
                };
                let l = l & visit.open() & (!t.gt(visit.tmax())).bitmask();
                if l != 0 {
                    (current, lanes) = (n, l);
                    break;
                }
            }
        }
    }
}
