//! The single-ray walk over wide nodes: one ray against a node's eight boxes in one 8-wide slab
//! test (`f32x8`: one AVX register, two SSE or WASM simd128 halves, an array on Cortex-M), a hit
//! mask, the hit children in the octant's stored front-to-back order, the nearest taken at once
//! and the others pushed with their entry distance, skipped when popped beyond the closest hit.
//!
//! # The slab test, and why it loses no hit
//! Per axis, the near and far planes are picked once per ray by the direction's sign (low plane
//! near for a positive component), so that an unused slot (low `+∞`, high `−∞`) has entry `+∞`
//! and exit `−∞` and is never entered. A slot is entered when `max(near distances, tmin) ≤
//! min(far distances, limit)`, `limit` the closest hit so far raised by [`ENTRY_SLACK`] (as the
//! kd walk compares entry distances, see there). The distances are made conservative:
//! - fast mode: the exit distance is raised by `2γ₃` of its magnitude (pbrt-v3's robust
//!   `Bounds3::IntersectP`), so rounding does not drop a box the ray grazes (as conservative
//!   for a slab test as widening both ends, and cheaper: widening them in fast mode too cost
//!   11.6 % more instructions on the dragon's primary rays, issue 39);
//! - watertight mode ([`Contents::WATERTIGHT`]): each distance is [`widen`](crate::traverse::widen)ed outward (Ize 2013,
//!   "Robust BVH Ray Traversal"), so every box the ray touches, if only at a corner, is entered.
//!
//! A direction component that is `±0` or so small that its reciprocal overflows makes `1/d`
//! infinite, and a plane through the origin then gives `0 · ∞ = NaN`: such a ray takes a
//! branch (predicted: it is the same for the whole walk) that reads a NaN entry as `−∞` and a NaN
//! exit as `+∞`, i.e. a ray lying in a box's face is inside it.

use super::{BOXES, LEAF_REF, LeafRef, ORDERS, PART_REF, REFS, STACK, WIDTH, WideNode};
use crate::format::Scene;
use crate::ray::Ray;
use crate::simd::{Lanes, f32x8};
use crate::traverse::steps::Query;
use crate::traverse::{Contents, ENTRY_SLACK, GAMMA3, TINY, WIDEN};
use glam::Vec3;
use wide::u32x8;

/// What a ray's slab tests need, set up once per ray.
#[derive(Clone, Copy, Debug)]
pub struct RaySetup {
    origin: [f32x8; 3],
    inv: [f32x8; 3],
    /// Word offsets of each axis's near and far planes in a node.
    near: [usize; 3],
    far: [usize; 3],
    tmin: f32x8,
    /// The direction's octant (see the [module doc](super)).
    pub octant: usize,
    /// Whether `1/d` is infinite on some axis (the NaN-safe slab test).
    parallel: bool,
}

impl RaySetup {
    /// The setup for `ray` (finite: the caller checked).
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip();
        let neg = ray.dir.to_array().map(|d| d.is_sign_negative() as usize);
        Self {
            origin: ray.origin.to_array().map(f32x8::splat),
            inv: inv.to_array().map(f32x8::splat),
            near: core::array::from_fn(|a| BOXES + 8 * (2 * a + neg[a])),
            far: core::array::from_fn(|a| BOXES + 8 * (2 * a + 1 - neg[a])),
            tmin: f32x8::splat(ray.tmin),
            octant: neg[0] | neg[1] << 1 | neg[2] << 2,
            parallel: !inv.is_finite(),
        }
    }
}

/// The eight lanes of `node` starting at word `at`.
#[inline(always)]
pub(crate) fn lanes(node: &WideNode, at: usize) -> f32x8 {
    let w: [u32; 8] = node[at..at + 8].try_into().unwrap_or([0; 8]);
    f32x8::from(w.map(f32::from_bits))
}

/// The slab test of `ray` against `node`'s eight boxes, `limit` the farthest entry still of use:
/// the mask of slots entered (bit `slot`) and each slot's entry distance.
#[inline(always)]
pub fn slab<C: Contents>(node: &WideNode, ray: &RaySetup, limit: f32) -> (u32, [f32; WIDTH]) {
    let dist = |at: usize, a: usize| (lanes(node, at) - ray.origin[a]) * ray.inv[a];
    let mut near: [f32x8; 3] = core::array::from_fn(|a| dist(ray.near[a], a));
    let mut far: [f32x8; 3] = core::array::from_fn(|a| dist(ray.far[a], a));
    if ray.parallel {
        for a in 0..3 {
            near[a] = near[a]
                .is_nan()
                .select(f32x8::splat(f32::NEG_INFINITY), near[a]);
            far[a] = far[a].is_nan().select(f32x8::splat(f32::INFINITY), far[a]);
        }
    }
    if C::WATERTIGHT {
        for a in 0..3 {
            near[a] = widen_down(near[a]);
            far[a] = widen_up(far[a]);
        }
    }
    let entry = near[0]
        .fast_max(near[1])
        .fast_max(near[2])
        .fast_max(ray.tmin);
    let mut exit = far[0].fast_min(far[1]).fast_min(far[2]);
    if !C::WATERTIGHT {
        // Raised by 2γ₃ of its magnitude, whatever its sign; `−∞` stays `−∞` (no `∞ − ∞`).
        let c = 2.0 * GAMMA3;
        exit = (exit * f32x8::splat(1.0 + c)).fast_max(exit * f32x8::splat(1.0 - c));
    }
    let exit = exit.fast_min(f32x8::splat(limit));
    (entry.le(exit).bitmask(), entry.to_array())
}

/// [`crate::traverse::widen`]'s lower bound, lane by lane.
#[inline(always)]
fn widen_down(t: f32x8) -> f32x8 {
    let (a, b) = (t * f32x8::splat(1.0 - WIDEN), t * f32x8::splat(1.0 + WIDEN));
    a.fast_min(b) - f32x8::splat(TINY)
}

/// [`crate::traverse::widen`]'s upper bound, lane by lane.
#[inline(always)]
fn widen_up(t: f32x8) -> f32x8 {
    let (a, b) = (t * f32x8::splat(1.0 - WIDEN), t * f32x8::splat(1.0 + WIDEN));
    a.fast_max(b) + f32x8::splat(TINY)
}

/// The entered slots of `mask` in the octant's front-to-back `order`: bit `k` set when the
/// slot at position `k` of `order` is entered, for the positions below the node's count (bits
/// 24..28 of `order`; the positions past it read slot 0 and are left out, or a hit slot 0 would
/// be pushed again for each and its subtree walked as many times more).
///
/// In lanes rather than a loop over the eight positions (issue 40, ordering the hit children
/// with permutes): each position's slot is brought to bits 21..24 by a multiply (a per-lane
/// left shift that every lane width has), the slot-indexed hit lanes are permuted into
/// position order, and one move-mask gives the bits.
#[inline(always)]
pub fn in_order(order: u32, mask: u32) -> u32 {
    const BITS: u32x8 = u32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
    const ALIGN: u32x8 = u32x8::new([
        1 << 21,
        1 << 18,
        1 << 15,
        1 << 12,
        1 << 9,
        1 << 6,
        1 << 3,
        1,
    ]);
    let slots = (u32x8::splat(order) * ALIGN) >> 21 & u32x8::splat(7);
    let entered = (u32x8::splat(mask) & BITS).simd_eq(BITS);
    let count = order >> 24 & 15;
    entered.shuffle(slots).to_bitmask() & ((1u32 << count) - 1)
}

/// The farthest entry distance still of use when the closest candidate is at `best`.
#[inline(always)]
fn limit_for(best: f32) -> f32 {
    best + best.abs() * ENTRY_SLACK
}

/// Counts of one walk, for reports ([`walk_counted`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkCounts {
    /// Wide nodes whose boxes were tested.
    pub nodes: u32,
    /// Leaves whose primitives were tested.
    pub leaves: u32,
}

/// Walks `ray` over `wide` to the end for `query` (what [`Scene::intersect`] runs with the core's
/// `wide` feature).
#[cfg(feature = "wide")]
#[inline(always)]
pub(crate) fn walk<C: Contents, Q: Query>(scene: &Scene, wide: &[WideNode], ray: &Ray, q: &mut Q) {
    walk_counted::<C, Q>(scene, wide, ray, q, &mut WalkCounts::default());
}

/// The single-ray walk over `wide`, counting wide nodes and leaves into `counts`.
#[inline(always)]
pub fn walk_counted<C: Contents, Q: Query>(
    scene: &Scene,
    wide: &[WideNode],
    ray: &Ray,
    q: &mut Q,
    counts: &mut WalkCounts,
) {
    if !ray.is_finite() || wide.is_empty() {
        return;
    }
    let setup = RaySetup::new(ray);
    let mut limit = limit_for(ray.tmax);
    let mut stack: Stack = heapless::Vec::new();
    let mut current = 0u32;
    loop {
        if current & LEAF_REF != 0 {
            counts.leaves += 1;
            let (best, stop) = visit_leaf::<C, Q>(scene, current, q);
            if stop {
                return;
            }
            limit = limit_for(best);
        } else {
            counts.nodes += 1;
            // Validation made every reference a node index in range.
            let node = &wide[current as usize];
            if let Some(next) = enter::<C>(node, &setup, limit, &mut stack) {
                current = next;
                continue;
            }
        }
        match pop(&mut stack, limit) {
            Some(next) => current = next,
            None => return,
        }
    }
}

/// A walk's pending children: a reference and its entry distance.
pub(crate) type Stack = heapless::Vec<(u32, f32), STACK>;

/// Tests the primitives of leaf reference `r` (a whole leaf or a part) for `q`.
#[inline(always)]
fn visit_leaf<C: Contents, Q: Query>(scene: &Scene, r: u32, q: &mut Q) -> (f32, bool) {
    let prims = if r & PART_REF == 0 {
        scene.leaf_prims(&scene.node(r & !LEAF_REF))
    } else {
        let r = LeafRef::decode(r);
        scene.leaf_prims(&scene.node(r.leaf)).part(r.part, r.parts)
    };
    q.leaf::<C>(scene, prims)
}

/// The slab test of `node` for the ray of `setup`: the nearest entered child to visit next, the
/// others pushed onto `stack` farthest first so that they pop in order (`None`: none entered).
#[inline(always)]
fn enter<C: Contents>(
    node: &WideNode,
    setup: &RaySetup,
    limit: f32,
    stack: &mut Stack,
) -> Option<u32> {
    let (mask, entry) = slab::<C>(node, setup, limit);
    if mask == 0 {
        return None;
    }
    let order = node[ORDERS + setup.octant];
    if mask.is_power_of_two() {
        return Some(node[REFS + mask.trailing_zeros() as usize]);
    }
    // The entered slots front to back. At most 7 pushed per level: the push cannot fail.
    // Validation made the count's positions name every used slot, and only used slots are
    // entered, so `front` is not empty; if it were, the walk would pop as for a miss.
    let mut front = in_order(order, mask);
    if front == 0 {
        return None;
    }
    let slot = |p: u32| (order >> (3 * p) & 7) as usize;
    let nearest = slot(front.trailing_zeros());
    front &= front - 1;
    while front != 0 {
        let p = 31 - front.leading_zeros();
        let s = slot(p);
        let _ = stack.push((node[REFS + s], entry[s]));
        front ^= 1 << p;
    }
    Some(node[REFS + nearest])
}

/// The next pending child entered before the closest hit (the stack is ordered only within one
/// node's children), or `None` when none is left.
#[inline(always)]
fn pop(stack: &mut Stack, limit: f32) -> Option<u32> {
    loop {
        match stack.pop() {
            None => return None,
            Some((next, t)) if t <= limit => return Some(next),
            Some(_) => {}
        }
    }
}

/// One ray's walk in progress: its setup, the farthest entry still of use, the pending children
/// and the reference to visit next. [`Walk::step`] advances it by one wide node or one leaf, as
/// one turn of [`walk_counted`]'s loop, so that several rays can be walked in turns
/// ([`super::turns`]).
#[cfg(not(target_arch = "wasm32"))]
#[derive(Clone, Debug)]
pub(crate) struct Walk {
    setup: RaySetup,
    limit: f32,
    stack: Stack,
    current: u32,
}

#[cfg(not(target_arch = "wasm32"))]
impl Walk {
    /// The walk of `ray` (finite: the caller checked) from the root.
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> Self {
        Self {
            setup: RaySetup::new(ray),
            limit: limit_for(ray.tmax),
            stack: heapless::Vec::new(),
            current: 0,
        }
    }

    /// Starts this walk again for `ray` (finite), in place (the stack is not moved).
    #[inline(always)]
    pub(crate) fn restart(&mut self, ray: &Ray) {
        self.setup = RaySetup::new(ray);
        self.limit = limit_for(ray.tmax);
        self.stack.clear();
        self.current = 0;
    }

    /// Visits the next wide node or leaf for `q` over `wide` (not empty); `false` once the walk
    /// is over.
    #[inline(always)]
    pub(crate) fn step<C: Contents, Q: Query>(
        &mut self,
        scene: &Scene,
        wide: &[WideNode],
        q: &mut Q,
    ) -> bool {
        let current = self.current;
        if current & LEAF_REF != 0 {
            let (best, stop) = visit_leaf::<C, Q>(scene, current, q);
            if stop {
                return false;
            }
            self.limit = limit_for(best);
        } else if let Some(node) = wide.get(current as usize)
            && let Some(next) = enter::<C>(node, &self.setup, self.limit, &mut self.stack)
        {
            self.current = next;
            return true;
        }
        match pop(&mut self.stack, self.limit) {
            Some(next) => {
                self.current = next;
                true
            }
            None => false,
        }
    }
}

/// The slab test in scalar f32 for one box, the reference [`slab`]'s lanes are tested against:
/// whether `ray` enters `b` no farther than `limit`, and its entry distance (the same value as
/// the lane's, though a `±0` may differ in sign).
pub fn slab_scalar<C: Contents>(b: [Vec3; 2], ray: &Ray, limit: f32) -> (bool, f32) {
    let inv = ray.dir.recip();
    let parallel = !inv.is_finite();
    let (mut entry, mut exit) = (ray.tmin, f32::INFINITY);
    for a in 0..3 {
        let neg = ray.dir[a].is_sign_negative() as usize;
        let mut near = (b[neg][a] - ray.origin[a]) * inv[a];
        let mut far = (b[1 - neg][a] - ray.origin[a]) * inv[a];
        if parallel {
            near = if near.is_nan() {
                f32::NEG_INFINITY
            } else {
                near
            };
            far = if far.is_nan() { f32::INFINITY } else { far };
        }
        if C::WATERTIGHT {
            (near, far) = (
                crate::traverse::widen(near).0,
                crate::traverse::widen(far).1,
            );
        }
        entry = if near > entry { near } else { entry };
        exit = if far < exit { far } else { exit };
    }
    if !C::WATERTIGHT {
        let c = 2.0 * GAMMA3;
        let (a, b) = (exit * (1.0 + c), exit * (1.0 - c));
        exit = if a > b { a } else { b };
    }
    let exit = if exit < limit { exit } else { limit };
    (entry <= exit, entry)
}
