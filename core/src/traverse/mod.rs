//! Traversal of the kd-tree: every way of walking it, and what the walks share.
//!
//! # The walks, and when to use which
//! - [`single`]: one ray, closest hit ([`Scene::intersect`]) or any hit ([`Scene::occluded`]).
//!   The default, and the best for incoherent rays (bounces, shadow rays towards many lights):
//!   over the wide nodes when the scene has them, else over the binary nodes.
//! - [`steps`]: the binary-node walk as resumable steps over an explicit state
//!   ([`steps::Stepper`], [`steps::Query`]), for code that drives a walk itself: a custom query
//!   at the leaves, counting steps. [`single`] runs these steps on a scene without wide nodes.
//! - [`packet`]: 4 or 8 rays at once ([`Scene::intersect_packet`], over [`crate::simd::Lanes`]),
//!   Wald's coherent packet walk; for rays that share an origin region and a direction octant,
//!   such as a camera's tiles.
//! - [`frustum`]: several coherent packets of one octant (a camera's tile of 16 to 64 rays) as one
//!   beam ([`Scene::intersect_tile`]): an entry node found once for the tile by interval
//!   arithmetic, from which each packet walks on as [`packet`]'s walk would, with the same hits.
//!   Measured slower than plain packets on a camera's rays (docs/BENCHMARKS.md, "The frustum
//!   walk: measured, not wired"), so no other walk uses it.
//! - [`wide`]: the wide nodes (format v10's wide section): eight children a node, each with a
//!   tight box, tested in one 8-wide slab test; [`single`] walks them on its own when the scene
//!   has them and the `wide` feature is on.
//! - [`stream`]: many rays in one call, answers in input order: coherent runs as packets, the rest
//!   sorted, and what is still incoherent as single rays ([`single`]'s walk); for a renderer's
//!   rounds of rays.
//!
//! Every walk answers as the binary-node walk does: [`steps`] is that walk, the stream's single
//! rays are [`single`]'s, bit for bit, ties included; the wide walk and the packet walk give the
//! same `t` bits (where two primitives tie at exactly that `t`, either may be reported).
//!
//! Shared by the walks, here: the [`Contents`] a walk is monomorphized for and the run-time
//! [`Mode`]; the entry into the scene box ([`clip_to_box`]); the slack on a node's entry distance
//! ([`ENTRY_SLACK`]); and the watertight walk's bracket of a split distance ([`widen`]). No walk
//! takes these from another walk.
//!
//! # The rules every walk follows
//! pbrt-v3's `KdTreeAccel::Intersect` (PBR 3rd ed., §4.4.3) with a fixed stack, with the cases it
//! leaves to chance made exact.
//!
//! Deviations from pbrt-v3, each for a case it gets wrong or leaves undefined:
//! - near and far children follow the sign of the direction, not the side of the origin, and the
//!   split interval is clipped on both ends, so rays with `tmin < 0` are traced correctly (pbrt-v3
//!   assumes `tmin = 0` in its `tPlane <= 0` test); this is also exactly the rule of the packet
//!   traversal, so the two visit the same leaves;
//! - a direction component of `±0` gives `t_plane = ±∞`, so a ray parallel to a split plane
//!   visits only the side holding its origin, or, when the origin lies on the plane (`0 · ∞ =
//!   NaN`), both sides;
//! - the root box is entered with an explicit per-axis test for zero components and a far distance
//!   widened by `2γ₃` of its magnitude (pbrt-v3's robust `Bounds3::IntersectP`), so a ray grazing the box is
//!   not lost to rounding; a subnormal component, whose `1/d` overflows, is divided by instead
//!   (`0·∞` would make a ray starting on the box's face NaN there, and lost);
//! - non-finite rays are a miss before any arithmetic, so nothing can loop on NaN.
//!
//! Straddling primitives: a primitive in several leaves may be hit in an earlier leaf at a `t`
//! beyond that leaf's range. The hit is kept as a candidate, and a pending node is skipped only
//! when the closest candidate lies before its entry; so the reported hit is always the closest
//! (the argument of pbrt-v3's `ray.tMax < tMin` test, which stops the whole walk instead).

pub mod frustum;
pub mod packet;
pub mod single;
pub mod steps;
pub mod stream;
pub mod wide;

#[cfg(doc)]
use crate::format::Scene;
use crate::ray::Ray;
use glam::Vec3;

/// `γ₃ = 3ε / (1 − 3ε)`, with ε half an f32 ULP (PBR 3rd ed., §3.9.1).
pub(crate) const GAMMA3: f32 = crate::math::gamma(3);

/// A compile-time choice of which primitive kinds a kernel handles, so that a triangles-only
/// scene runs no sphere code (and firmware naming one variant links only it), and of the triangle
/// kernel: Möller–Trumbore, or with [`Watertight`] the watertight kernel and the conservative walk.
pub trait Contents {
    const TRIANGLES: bool;
    const SPHERES: bool;
    /// Triangles by the watertight kernel ([`crate::watertight`]), and split-plane distances
    /// rounded outward in the walk ([`widen`]): no ray escapes a closed mesh between its
    /// triangles, nor through a cell the walk skipped. Off (Möller–Trumbore, plain distances)
    /// unless wrapped in [`Watertight`]; a program that never names `Watertight` links none of it.
    const WATERTIGHT: bool = false;
    /// The conservative binary-node walk ([`widen`]): on in both modes since issue 39, so that
    /// every walk enters every cell the ray touches (the wide walk's slab test is conservative in
    /// both modes already, [`wide::walk`]) and one ray's answer does not depend on the walk that
    /// carried it. Off only in types the tests define to count which of kernel and walk loses a
    /// ray (docs/ROBUSTNESS.md).
    const CONSERVATIVE: bool = true;
    /// Leaves may hold triangle groups ([`crate::group`]), which the format allows in
    /// triangles-only scenes: kernels for any other contents link no group code (and would see a
    /// grouped leaf as empty; [`crate::render::kernel_fits`] refuses such a scene), nor does a
    /// build without the `groups` feature (which refuses grouped scenes on load).
    const GROUPS: bool = cfg!(feature = "groups") && Self::TRIANGLES && !Self::SPHERES;
}

/// Triangles only.
pub struct Triangles;
/// Spheres only.
pub struct Spheres;
/// Triangles and spheres.
pub struct Mixed;
/// The contents `C` traced in watertight mode (see [`Contents::WATERTIGHT`]), e.g.
/// `scene.intersect_with::<Watertight<Triangles>>(&ray)`.
pub struct Watertight<C>(core::marker::PhantomData<C>);

impl Contents for Triangles {
    const TRIANGLES: bool = true;
    const SPHERES: bool = false;
}
impl Contents for Spheres {
    const TRIANGLES: bool = false;
    const SPHERES: bool = true;
}
impl Contents for Mixed {
    const TRIANGLES: bool = true;
    const SPHERES: bool = true;
}
impl<C: Contents> Contents for Watertight<C> {
    const TRIANGLES: bool = C::TRIANGLES;
    const SPHERES: bool = C::SPHERES;
    const WATERTIGHT: bool = true;
}

/// Which triangle kernel a query uses, chosen at run time ([`Scene::intersect_in`] and the other
/// `_in` methods); code that knows its mode at compile time names a [`Contents`] instead.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Möller–Trumbore and plain split distances: the faster, and not watertight.
    #[default]
    Fast,
    /// The watertight kernel and the conservative walk ([`Watertight`]).
    Watertight,
}

/// Runs `$body` with the type `$c` set to the [`Contents`] that matches `$scene`'s content bits,
/// wrapped in [`Watertight`] when `$mode` is [`Mode::Watertight`].
macro_rules! by_contents {
    ($scene:expr, $mode:expr, |$c:ident| $body:expr) => {{
        use $crate::format::contents as bits;
        use $crate::traverse::{Mixed, Mode, Spheres, Triangles, Watertight};
        let kinds = $scene.contents() & (bits::TRIANGLES | bits::SPHERES);
        match ($mode, kinds) {
            (Mode::Fast, bits::TRIANGLES) => {
                type $c = Triangles;
                $body
            }
            (Mode::Fast, bits::SPHERES) => {
                type $c = Spheres;
                $body
            }
            (Mode::Fast, _) => {
                type $c = Mixed;
                $body
            }
            (Mode::Watertight, bits::TRIANGLES) => {
                type $c = Watertight<Triangles>;
                $body
            }
            (Mode::Watertight, bits::SPHERES) => {
                type $c = Watertight<Spheres>;
                $body
            }
            (Mode::Watertight, _) => {
                type $c = Watertight<Mixed>;
                $body
            }
        }
    }};
}
pub(crate) use by_contents;

/// Margin by which [`widen`] moves a computed split-plane or slab distance: `2γ₃`, twice the
/// bound on its relative rounding error (see [`widen`]).
pub(crate) const WIDEN: f32 = 2.0 * GAMMA3;
/// The smallest positive f32 (a subnormal): [`widen`]'s absolute term, which matters only when
/// the distance is subnormal (or 0), where a relative bound does not hold.
pub(crate) const TINY: f32 = f32::from_bits(1);

/// `(lo, hi)` bracketing the exact distance `(p − o) / d` of which `t = (p − o) · (1/d)` is the
/// f32 evaluation: the conservative plane distance of the watertight walk (Ize 2013, "Robust BVH
/// Ray Traversal", §3, applied to split planes; PBR 3rd ed. §3.9.2 for the bound).
///
/// Argument: `p`, `o` and `d` are exact f32 inputs, and `t` is three correctly rounded operations
/// (`p − o`, `1/d`, the product) on them, so `t = t_exact · (1 + δ₁)(1 + δ₂)(1 + δ₃)` with
/// `|δᵢ| ≤ ε = 2⁻²⁴`, i.e. `|t − t_exact| ≤ γ₃·|t_exact|` (no cancellation is possible: `p − o`
/// is the difference of two exact numbers, rounded once). Scaling by `1 ± 2γ₃` (each product again
/// rounded by at most `ε`) therefore brackets `t_exact`, and `±TINY` covers the absolute error
/// when `t` is subnormal or has underflowed to 0. Infinities stay infinite (`∞ · (1 ± c) = ∞`,
/// never `∞ − ∞`), and NaN stays NaN, so a ray parallel to the plane is handled as before.
#[inline(always)]
pub fn widen(t: f32) -> (f32, f32) {
    let (a, b) = (t * (1.0 - WIDEN), t * (1.0 + WIDEN));
    (a.min(b) - TINY, a.max(b) + TINY)
}

/// The parametric interval `(t0, t1)` in which `ray` is inside the box, clipped to the ray's own
/// range, or `None`.
#[inline]
pub fn clip_to_box(ray: &Ray, bounds: [Vec3; 2]) -> Option<(f32, f32)> {
    clip_to_box_in::<false>(ray, bounds)
}

/// [`clip_to_box`]; with `ROBUST`, both slab distances are [`widen`]ed outward (the watertight
/// walk), not only the far one.
#[inline]
#[allow(clippy::needless_range_loop)]
pub fn clip_to_box_in<const ROBUST: bool>(ray: &Ray, bounds: [Vec3; 2]) -> Option<(f32, f32)> {
    let mut t0 = ray.tmin;
    let mut t1 = ray.tmax;
    for axis in 0..3 {
        let (o, d) = (ray.origin[axis], ray.dir[axis]);
        let (lo, hi) = (bounds[0][axis], bounds[1][axis]);
        // (indexing three Vec3s by axis reads better than zipping their arrays)
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d;
        let (mut near, mut far) = if inv.is_finite() {
            ((lo - o) * inv, (hi - o) * inv)
        } else {
            // `d` is subnormal and `1/d` overflowed: `(hi − o)·∞` would be `0·∞ = NaN` for an
            // origin on the face (and rule the ray out). Divided, each distance is rounded once
            // from the exact one (`0` on the face), which [`widen`]'s bound covers.
            ((lo - o) / d, (hi - o) / d)
        };
        if near > far {
            core::mem::swap(&mut near, &mut far);
        }
        if ROBUST {
            (near, far) = (widen(near).0, widen(far).1);
        } else {
            // Away from the origin's side whatever the sign (pbrt-v3 multiplies, which narrows
            // the slab when `far < 0`, possible with `tmin < 0`).
            far += far.abs() * (2.0 * GAMMA3);
        }
        t0 = t0.max(near);
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

/// Where a walk starts: `ray`'s interval inside the scene box, clipped as `C`'s walk does
/// (both slab distances widened outward with [`Contents::CONSERVATIVE`]); `None` for a ray that
/// misses the box or is not finite (so nothing can loop on NaN).
#[inline(always)]
pub(crate) fn entry_interval<C: Contents>(ray: &Ray, bounds: [Vec3; 2]) -> Option<(f32, f32)> {
    if !ray.is_finite() {
        return None;
    }
    if C::CONSERVATIVE {
        clip_to_box_in::<true>(ray, bounds)
    } else {
        clip_to_box(ray, bounds)
    }
}

/// Relative slack on a node's entry distance before the closest hit may rule the node out.
///
/// A split plane's `t` and Möller–Trumbore's `t` of a triangle lying on (or touching) that plane
/// are both correctly computed to a few ULPs, but not to the same bits: the triangle's hit can come
/// out below the plane's `t`. Without slack, a closer hit on a triangle in the plane of the far
/// child is skipped in favour of a farther one found in the near child (found by the
/// brute-force property test). 2⁻¹⁸ is 32 ULPs, far more than either rounding error; it only
/// makes traversal visit a node it could have skipped when two hits lie that close.
pub const ENTRY_SLACK: f32 = 1.0 / (1 << 18) as f32;

/// `tmin` moved towards −∞ by [`ENTRY_SLACK`] of its magnitude.
#[inline(always)]
pub fn entry_with_slack(tmin: f32) -> f32 {
    tmin - tmin.abs() * ENTRY_SLACK
}
