//! The two-level walk: closest hit ([`InstancedScene::intersect_in`]) and any hit
//! ([`InstancedScene::occluded_in`]) of one world ray, in fast or watertight mode.
//!
//! The tree over the instances is walked front to back (of a node's slots entered, the nearest
//! first, the others pending with their entry distances and skipped once the closest hit lies
//! before them), each box entered as the watertight walk enters the scene box
//! ([`crate::traverse::clip_to_box_in`], both slab distances widened outward; here with the
//! direction's reciprocals computed once a ray, `Slabs`, and a node's eight boxes tested in one
//! pass of eight lanes where the reciprocals are finite and not zero). At an instance, the ray
//! is moved into the bottom scene: origin by the stored inverse ([`Affine::point`]), direction
//! by its linear part ([`Affine::vector`]), **not normalized**, so a point at parameter `t` on
//! the moved ray is the image of the world ray's point at the same `t`: `t` stays in world units
//! and the closest hits of different instances compare as they are. The bottom scene's own walk
//! ([`Scene::intersect_in`], [`Scene::occluded_in`]) then runs over `(tmin, closest so far)`.
//!
//! One deviation from moving the direction alone: the triangle kernels' parallel test is set for
//! unit directions (a direction of length `s` counts as parallel a ray within `PARALLEL_SIN / s`
//! of the plane, [`crate::Ray`]), so under a scale of 10⁶ a direction of length 10⁻⁶ would miss
//! everything. A moved direction whose largest component lies outside `[1/4, 4)` is therefore
//! scaled by the power of two `f` that brings that component into `[1, 2)`, and the interval by
//! `1/f`; scaling by a power of two is exact in every operation of the walks and kernels (bar
//! underflow to subnormals), so the bottom walk returns `t/f` exactly and `t` is recovered bit
//! for bit. Rotations and mild scales (`[1/4, 4)`) are left alone, so an identity or a
//! translation gives the bottom walk the world ray's own direction. A moved direction whose
//! largest component is outside `[2⁻¹²⁶, 2¹²⁶)` (a scale beyond 10³⁷) or not finite, or a moved
//! origin that overflows, enters no instance: a miss. A world range whose ends overflow when
//! scaled (`|tmin|` or `tmax` beyond `f32::MAX/f`, only with scales below 1/4 and ranges beyond
//! 10³⁴) is taken as unbounded on that side by the bottom walk; closest hits are then checked
//! against the world range again, any hit is not.

use super::{
    Affine, InstancedScene, Node, STACK, WIDTH, affine_at, node, push_in_order, record, slot_words,
};
use crate::format::Scene;
use crate::ray::{Hit, Ray};
use crate::traverse::wide::walk::{RaySetup, slab};
use crate::traverse::{Mode, Triangles, Watertight, widen};
use glam::Vec3;

/// The closest hit of a ray through a top level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceHit {
    /// Distance along the world ray, in its units.
    pub t: f32,
    /// The primitive in the bottom scene's storage order ([`Hit::prim`]);
    /// `bottom.input_id(prim)` is its index in the bottom mesh.
    pub prim: u32,
    /// Barycentric coordinates on the bottom scene's triangle ([`Hit`]).
    pub u: f32,
    pub v: f32,
    /// The instance record hit ([`InstancedScene::instance`]); [`Hit::MISS_PRIM`] for a miss.
    pub instance: u32,
    /// The record's user id.
    pub user_id: u32,
}

impl InstanceHit {
    /// No hit: `t = +inf`, `prim`, `instance` and `user_id` all `0xFFFF_FFFF`.
    pub const MISS: InstanceHit = InstanceHit {
        t: f32::INFINITY,
        prim: Hit::MISS_PRIM,
        u: 0.0,
        v: 0.0,
        instance: Hit::MISS_PRIM,
        user_id: Hit::MISS_PRIM,
    };

    /// True unless this is [`InstanceHit::MISS`].
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.instance != Hit::MISS_PRIM
    }
}

/// `ray` moved into an instance by `inverse`, and the power of two `f` by which its `t` must be
/// multiplied to be the world ray's (see the module doc), or `None` if it enters no instance.
#[inline]
pub fn into_instance(inverse: &Affine, ray: &Ray) -> Option<(Ray, f32)> {
    let (origin, dir) = (inverse.point(ray.origin), inverse.vector(ray.dir));
    let m = dir.abs().max_element();
    if !(0.25..4.0).contains(&m) {
        let (f, inv_f) = unit_scale(m)?;
        if !origin.is_finite() {
            return None;
        }
        let local = Ray {
            origin,
            dir: dir * inv_f,
            tmin: ray.tmin * f,
            tmax: ray.tmax * f,
        };
        return Some((local, inv_f));
    }
    origin.is_finite().then_some((
        Ray {
            origin,
            dir,
            ..*ray
        },
        1.0,
    ))
}

/// For a moved direction whose largest component `m` lies outside `[1/4, 4)`: the power of two
/// `f` that divides the direction into `[1, 2)`, and `1/f`; `None` if `m` is outside
/// `[2⁻¹²⁶, 2¹²⁶)` or not a number (see the module doc).
#[inline]
pub(super) fn unit_scale(m: f32) -> Option<(f32, f32)> {
    /// 2¹²⁶: `f` and `1/f` stay normal below it.
    const LARGEST: f32 = f32::from_bits(253 << 23);
    if !(f32::MIN_POSITIVE..LARGEST).contains(&m) {
        return None;
    }
    // m = 2^e·(1.x): f = 2^e, and the direction divided by it (times 2^-e).
    let e = ((m.to_bits() >> 23) & 0xff) as i32 - 127;
    let f = f32::from_bits(((127 + e) as u32) << 23);
    let inv_f = f32::from_bits(((127 - e) as u32) << 23);
    Some((f, inv_f))
}

/// The world ray prepared for the walk's many box tests: each direction component's reciprocal
/// computed once, where [`crate::traverse::clip_to_box_in`] divides per box; otherwise the same
/// arithmetic (so the same entry distances, bit for bit).
struct Slabs {
    origin: [f32; 3],
    dir: [f32; 3],
    inv: [f32; 3],
    tmin: f32,
}

impl Slabs {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let dir = ray.dir.to_array();
        let inv = dir.map(|d| 1.0 / d);
        Self {
            origin: ray.origin.to_array(),
            dir,
            inv,
            tmin: ray.tmin,
        }
    }

    /// The entry distance over `(tmin, tmax)` into the box stored in `b`'s first six words,
    /// both slab distances [`widen`]ed outward, or `None` for a miss.
    #[inline(always)]
    fn enter(&self, b: &[u32], tmax: f32) -> Option<f32> {
        let (mut t0, mut t1) = (self.tmin, tmax);
        for a in 0..3 {
            let (lo, hi) = (f32::from_bits(b[a]), f32::from_bits(b[3 + a]));
            let (o, d, inv) = (self.origin[a], self.dir[a], self.inv[a]);
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let (mut near, mut far) = if inv.is_finite() {
                ((lo - o) * inv, (hi - o) * inv)
            } else {
                // A subnormal component: divided, as `clip_to_box_in` does (`0·∞` on a face).
                ((lo - o) / d, (hi - o) / d)
            };
            if near > far {
                core::mem::swap(&mut near, &mut far);
            }
            t0 = t0.max(widen(near).0);
            t1 = t1.min(widen(far).1);
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }

    /// [`Slabs::enter`] for each used slot of `nd`: the mask of slots entered and their entry
    /// distances, as [`slab`] returns them.
    fn enter_slots(&self, nd: &Node, tmax: f32) -> (u32, [f32; WIDTH]) {
        let (mut mask, mut entry) = (0u32, [f32::INFINITY; WIDTH]);
        let count = (nd[node::COUNT] as usize).min(WIDTH);
        for (s, e) in entry.iter_mut().enumerate().take(count) {
            if let Some(t) = self.enter(&slot_words(nd, s), tmax) {
                mask |= 1 << s;
                *e = t;
            }
        }
        (mask, entry)
    }
}

/// How the walk tests a node's boxes, chosen once a ray. One a walk, on the stack (the core has
/// no allocator to box the larger variant in).
#[allow(clippy::large_enum_variant)]
enum Test {
    /// All eight in lanes.
    Lanes(RaySetup),
    /// Slot by slot.
    Slots(Slabs),
}

/// What the walk does with each instance it enters; returns the closest `t` so far (the walk
/// skips a pending node entered beyond it) and whether to stop.
trait Visit {
    fn instance(&mut self, top: &InstancedScene, i: u32, ray: &Ray) -> (f32, bool);
}

/// The closest hit: the world ray's `tmax` shrinks to each hit found.
struct ClosestVisit {
    mode: Mode,
    best: InstanceHit,
    tmax: f32,
}

impl Visit for ClosestVisit {
    #[inline]
    fn instance(&mut self, top: &InstancedScene, i: u32, ray: &Ray) -> (f32, bool) {
        let inst = &top.records[i as usize];
        let inverse = affine_at(inst, record::INVERSE);
        let world = ray.with_range(ray.tmin, self.tmax);
        if let Some((local, f)) = into_instance(&inverse, &world) {
            let bottom: &Scene = &top.bottoms[inst[record::BOTTOM] as usize];
            let hit = bottom.intersect_in(self.mode, &local);
            let t = hit.t * f;
            if hit.is_hit() && t < self.tmax && t > ray.tmin {
                self.tmax = t;
                self.best = InstanceHit {
                    t,
                    prim: hit.prim,
                    u: hit.u,
                    v: hit.v,
                    instance: i,
                    user_id: inst[record::USER_ID],
                };
            }
        }
        (self.tmax, false)
    }
}

/// Any hit: stops at the first instance that reports one.
struct AnyVisit {
    mode: Mode,
    found: bool,
}

impl Visit for AnyVisit {
    #[inline]
    fn instance(&mut self, top: &InstancedScene, i: u32, ray: &Ray) -> (f32, bool) {
        let inst = &top.records[i as usize];
        let inverse = affine_at(inst, record::INVERSE);
        if let Some((local, _)) = into_instance(&inverse, ray) {
            let bottom: &Scene = &top.bottoms[inst[record::BOTTOM] as usize];
            self.found = bottom.occluded_in(self.mode, &local);
        }
        (ray.tmax, self.found)
    }
}

impl InstancedScene<'_, '_> {
    /// The closest hit along the world `ray` in `(ray.tmin, ray.tmax)` over every instance, or
    /// [`InstanceHit::MISS`], in fast mode.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> InstanceHit {
        self.intersect_in(Mode::Fast, ray)
    }

    /// Whether any instance has a hit along `ray` in `(ray.tmin, ray.tmax)`, in fast mode.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_in(Mode::Fast, ray)
    }

    /// [`Self::intersect`] in `mode` (each bottom scene walked as [`Scene::intersect_in`]).
    /// Inlined where it is called, as [`Scene::intersect_in`] is, so that the bottom walk is
    /// compiled with the caller's code (in the core's own codegen unit a gather of the walk's
    /// listed leaves was left out of line: a third of the speed).
    #[inline]
    pub fn intersect_in(&self, mode: Mode, ray: &Ray) -> InstanceHit {
        let mut visit = ClosestVisit {
            mode,
            best: InstanceHit::MISS,
            tmax: ray.tmax,
        };
        self.walk(ray, &mut visit);
        visit.best
    }

    /// [`Self::occluded`] in `mode`.
    #[inline]
    pub fn occluded_in(&self, mode: Mode, ray: &Ray) -> bool {
        let mut visit = AnyVisit { mode, found: false };
        self.walk(ray, &mut visit);
        visit.found
    }

    /// The front-to-back walk of the tree (see the module doc): a node's eight boxes in one
    /// slab test of eight lanes for a ray whose reciprocals are all finite and not zero
    /// ([`slab`] in watertight mode: each lane the distances [`Slabs::enter`] computes, widened
    /// alike, with the near plane picked by the direction's sign instead of a comparison, the
    /// same plane for such a ray), slot by slot by [`Slabs::enter`] for the others (a `±0` or
    /// subnormal component: the lanes' `0·∞` would be NaN).
    fn walk<V: Visit>(&self, ray: &Ray, visit: &mut V) {
        if !ray.is_finite() {
            return;
        }
        let mut tmax = ray.tmax;
        let a = ray.dir.recip().abs();
        let test = if a.cmplt(Vec3::INFINITY).all() && a.cmpne(Vec3::ZERO).all() {
            Test::Lanes(RaySetup::new(ray))
        } else {
            Test::Slots(Slabs::new(ray))
        };
        let mut stack: heapless::Vec<(u32, f32), STACK> = heapless::Vec::new();
        let mut current = 0u32;
        loop {
            if current & node::RECORD_REF != 0 {
                let (t, stop) = visit.instance(self, current & !node::RECORD_REF, ray);
                if stop {
                    return;
                }
                tmax = t;
            } else {
                let nd: &Node = &self.nodes[current as usize];
                let (mask, entry) = match &test {
                    Test::Lanes(setup) => slab::<Watertight<Triangles>>(nd, setup, tmax),
                    Test::Slots(slabs) => slabs.enter_slots(nd, tmax),
                };
                if mask.is_power_of_two() {
                    current = nd[node::REFS + mask.trailing_zeros() as usize];
                    continue;
                }
                // Two or more: all pushed, ordered by entry, the nearest popped below.
                let below = stack.len();
                let mut m = mask;
                while m != 0 {
                    let s = m.trailing_zeros() as usize;
                    m &= m - 1;
                    push_in_order(&mut stack, below, (nd[node::REFS + s], entry[s]), |e| e.1);
                }
            }
            // The nearest pending slot entered before the closest hit so far.
            loop {
                match stack.pop() {
                    None => return,
                    Some((n, t)) if !(t > tmax) => {
                        current = n;
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }
}
