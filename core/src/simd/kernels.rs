//! Packet kernels: one primitive against the `W` rays of a [`RayPacket`], and the closest-hit
//! update.
//!
//! Each kernel is its scalar twin ([`Triangle::intersect`], [`Sphere::intersect`]) transcribed
//! lane by lane: the same operations in the same order, no FMA, branches turned into masks. Since
//! every lane operation rounds as the scalar one does (see [`lanes`](super::lanes)), a lane hits
//! exactly when the scalar kernel hits that ray, with bit-identical `t`, `α`, `β` — the tests in
//! `tests/tests/simd_kernels.rs` check this over edge values and random inputs.
//!
//! A kernel computes every lane, active or not, and its mask is *not* restricted to the packet's
//! active lanes: [`record_closest`] does that. (An absent lane can never hit anyway; see
//! [`RayPacket::from_rays`].)

use super::lanes::{Lanes, Vec3x, set_lanes};
use super::packet::{HitPacket, RayPacket};
use crate::sphere::Sphere;
use crate::triangle::Triangle;

/// What one primitive does to a packet: the mask of lanes it hits in `(tmin, tmax)`, and there
/// the hit's `t` and barycentrics `u`, `v` (0 for a sphere). Lanes outside `mask` hold garbage.
#[derive(Clone, Copy, Debug)]
pub struct PrimHits<L> {
    pub mask: L,
    pub t: L,
    pub u: L,
    pub v: L,
}

impl<L: Lanes> PrimHits<L> {
    /// No lane hit.
    #[inline]
    pub(crate) fn none() -> Self {
        let zero = L::splat(0.0);
        Self {
            mask: zero,
            t: zero,
            u: zero,
            v: zero,
        }
    }

    /// These hits with lane `i` of each bit of `lanes` replaced by `far(i)`: the scalar f64
    /// kernel of [`crate::far`] for that lane's ray and triangle, where the lane's f32 products
    /// overflowed. Rare (rays that far from the triangles), so out of line.
    #[cold]
    #[inline(never)]
    pub(crate) fn redo_far(
        self,
        lanes: u32,
        far: impl Fn(usize) -> Option<(f32, f32, f32)>,
    ) -> Self {
        let mut bits = self.mask.bitmask();
        let (mut t, mut u, mut v) = (self.t.to_array(), self.u.to_array(), self.v.to_array());
        for i in set_lanes(lanes) {
            bits &= !(1 << i);
            if let Some((ti, ui, vi)) = far(i) {
                bits |= 1 << i;
                (t.as_mut()[i], u.as_mut()[i], v.as_mut()[i]) = (ti, ui, vi);
            }
        }
        Self {
            mask: L::mask_from_bits(bits),
            t: L::from_array(t),
            u: L::from_array(u),
            v: L::from_array(v),
        }
    }
}

/// Möller–Trumbore (Möller & Trumbore 1997, as in [`crate::triangle`]) for one triangle against
/// every lane: the lanes where [`Triangle::intersect`] would return `Some((t, α, β))` for the
/// lane's ray (with its current `tmax`), and those values.
///
/// The triangle's threshold [`Triangle::min_det2`] is computed once, as a scalar, exactly as the
/// scalar kernel does (or taken from the flat format by [`intersect_triangle_prepared`]); a
/// degenerate triangle (`+inf`) or a NaN one returns at once with no lane hit. The lane tests then
/// follow the scalar's: `det² > min_det2` (NaN counts as parallel),
/// `0 ≤ α ≤ 1`, `β ≥ 0 ∧ α + β ≤ 1`, `tmin < t < tmax`, every one false on NaN. Like the scalar
/// kernel it has no early exits: whether any lane survives a test is unpredictable, and on the
/// dragon's primary rays the mispredicted branches cost more than the work they skip (14.0 → 16.4
/// Mrays/s for 8-wide packets, AVX2).
#[inline]
pub fn intersect_triangle<L: Lanes>(tri: &Triangle, rays: &RayPacket<L>) -> PrimHits<L> {
    intersect_triangle_prepared(tri, tri.min_det2(), rays)
}

/// [`intersect_triangle`] with the triangle's [`Triangle::min_det2`] already known (the flat
/// format stores it).
#[inline(always)]
pub fn intersect_triangle_prepared<L: Lanes>(
    tri: &Triangle,
    min_det2: f32,
    rays: &RayPacket<L>,
) -> PrimHits<L> {
    splat_triangle::<L, true>(tri, min_det2, rays)
}

/// [`intersect_triangle_prepared`] for a packet that [`super::range::cannot_overflow`] has
/// cleared against the scene holding `tri`: no lane can overflow, so the check that would send it
/// to the f64 kernel is left out. The same hits, bit for bit, for such a packet.
#[inline(always)]
pub fn intersect_triangle_in_range<L: Lanes>(
    tri: &Triangle,
    min_det2: f32,
    rays: &RayPacket<L>,
) -> PrimHits<L> {
    splat_triangle::<L, false>(tri, min_det2, rays)
}

/// One triangle in every lane against the packet, with or without the overflow check.
#[inline(always)]
fn splat_triangle<L: Lanes, const CHECKED: bool>(
    tri: &Triangle,
    min_det2: f32,
    rays: &RayPacket<L>,
) -> PrimHits<L> {
    // A degenerate (+inf) or NaN threshold fails the `det²` test in every lane: skip the triangle.
    if !(min_det2 < f32::INFINITY) {
        return PrimHits::none();
    }
    let tri_lanes = TriangleLanes {
        v0: Vec3x::splat(tri.v0),
        e1: Vec3x::splat(tri.e1),
        e2: Vec3x::splat(tri.e2),
        min_det2: L::splat(min_det2),
    };
    moller_trumbore_lanes::<L, CHECKED>(
        &tri_lanes,
        &rays.origin,
        &rays.dir,
        rays.tmin,
        rays.tmax,
        |i| crate::far::intersect_moller_trumbore(&tri.v0, &tri.e1, &tri.e2, &rays.ray(i)),
    )
}

/// Triangles in Möller–Trumbore's layout, one per lane (or one in every lane), with their
/// thresholds [`Triangle::min_det2`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriangleLanes<L> {
    pub v0: Vec3x<L>,
    pub e1: Vec3x<L>,
    pub e2: Vec3x<L>,
    pub min_det2: L,
}

/// Möller–Trumbore lane by lane: lane `i`'s ray (`origin`, `dir`, `(tmin, tmax)`) against lane
/// `i`'s triangle, the operations of [`Triangle::intersect_prepared`] in its order. Serves both a
/// packet of rays against one triangle (the triangle splat) and one ray against a group of
/// triangles (the ray splat, [`super::group`]). `far(i)` is the scalar f64 kernel for lane `i`
/// ([`crate::far::intersect_moller_trumbore`] of its ray and triangle), called for the lanes
/// where the scalar kernel calls it ([`crate::triangle::overflowed`]); without `CHECKED` (lanes
/// that cannot overflow, [`super::range`]) never.
#[inline(always)]
pub(crate) fn moller_trumbore_lanes<L: Lanes, const CHECKED: bool>(
    tri: &TriangleLanes<L>,
    origin: &Vec3x<L>,
    dir: &Vec3x<L>,
    tmin: L,
    tmax: L,
    far: impl Fn(usize) -> Option<(f32, f32, f32)>,
) -> PrimHits<L> {
    let TriangleLanes {
        v0,
        e1,
        e2,
        min_det2,
    } = *tri;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    let not_parallel = (det * det).gt(min_det2);
    let inv = det.recip();
    let s = *origin - v0;
    let a = s.dot(p) * inv;
    let one = L::splat(1.0);
    let zero = L::splat(0.0);
    let mut mask = not_parallel & a.ge(zero) & a.le(one);
    let q = s.cross(e1);
    let b = dir.dot(q) * inv;
    let a_plus_b = a + b;
    mask = mask & b.ge(zero) & a_plus_b.le(one);
    let t = e2.dot(q) * inv;
    mask = mask & t.gt(tmin) & t.lt(tmax);
    let hits = PrimHits {
        mask,
        t,
        u: a,
        v: b,
    };
    if CHECKED {
        // `triangle::overflowed`, lane by lane.
        let redo = (not_parallel & tmin.lt(tmax) & !(a_plus_b + t).is_finite()).bitmask();
        if redo != 0 {
            return hits.redo_far(redo, far);
        }
    }
    hits
}

/// One sphere against every lane: the lanes where [`Sphere::intersect`] would return `Some(t)` for
/// the lane's ray (with its current `tmax`), and that `t`; `u = v = 0`.
///
/// The same cancellation-free roots as [`Sphere::roots`] (Haines et al., Ray Tracing Gems ch. 7),
/// operation for operation: `disc = R² − |f − b·d|²`, `q = −b − sign(b)·√disc` with `sign(±0) =
/// ±1`, `t0 = cq / q` (0 where `q = 0`), near/far ordered by `t0 <= q`; then the near root if it
/// lies in `(tmin, tmax)`, else the far one. Lanes far from the origin are scaled as there
/// ([`crate::sphere::FAR`]).
#[inline]
pub fn intersect_sphere<L: Lanes>(sphere: &Sphere, rays: &RayPacket<L>) -> PrimHits<L> {
    let zero = L::splat(0.0);
    let o = rays.origin;
    let big = o.x.abs().max(o.y.abs()).max(o.z.abs());
    let c = sphere.center;
    let fixed = c.abs().max_element().max(sphere.radius);
    let scaled = big.max(L::splat(fixed)).gt(L::splat(crate::sphere::FAR));
    let k = scaled.select(L::splat(crate::sphere::FAR_SCALE), L::splat(1.0));
    let unscale = scaled.select(L::splat(1.0 / crate::sphere::FAR_SCALE), L::splat(1.0));
    let f = o.scale(k) - Vec3x::splat(c).scale(k);
    let b = f.dot(rays.dir);
    let radius = L::splat(sphere.radius) * k;
    let r2 = radius * radius;
    let perp = f - rays.dir.scale(b);
    let disc = r2 - perp.dot(perp);
    let real = disc.ge(zero);
    if real.none() {
        return PrimHits::none();
    }
    // `math::sign_not_zero`: 1.0 with the sign bit of b.
    let sign_b = (b & L::splat(-0.0)) | L::splat(1.0);
    let q = -b - sign_b * disc.sqrt();
    let cq = f.dot(f) - r2;
    let t0 = q.ne(zero).select(cq / q, zero);
    let t0_first = t0.le(q);
    let near = t0_first.select(t0, q) * unscale;
    let far = t0_first.select(q, t0) * unscale;
    let near_in = near.gt(rays.tmin) & near.lt(rays.tmax);
    let far_in = far.gt(rays.tmin) & far.lt(rays.tmax);
    PrimHits {
        mask: real & (near_in | far_in),
        t: near_in.select(near, far),
        u: zero,
        v: zero,
    }
}

/// The closest-hit update: in each lane that `found` hits and `rays` has active, records
/// primitive `prim` (its `t`, `u`, `v`) in `hits` and shrinks `rays.tmax` to `t`, so a later
/// primitive must be strictly nearer to replace it. Returns the bitmask of the lanes updated.
///
/// Applied to the primitives in order, this gives each active lane what scalar closest-hit
/// traversal would give its ray: the first of the nearest hits.
#[inline]
pub fn record_closest<L: Lanes>(
    hits: &mut HitPacket<L>,
    rays: &mut RayPacket<L>,
    found: &PrimHits<L>,
    prim: u32,
) -> u32 {
    let m = found.mask & rays.active;
    let bits = m.bitmask();
    // Branch-free: whether any lane hit is unpredictable, and the selects are cheap.
    hits.t = m.select(found.t, hits.t);
    hits.prim = m.select_index(L::splat_index(prim), hits.prim);
    hits.u = m.select(found.u, hits.u);
    hits.v = m.select(found.v, hits.v);
    rays.tmax = m.select(found.t, rays.tmax);
    bits
}
