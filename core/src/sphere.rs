//! Ray/sphere intersection (Rukin §4 "Spheres", equations (28)–(33)) in the cancellation-free form
//! of Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7,
//! as the corrected equations prescribe.
//!
//! Rukin's textbook quadratic (equation (32)) computes `b² − (|o − c|² − R²)`: for a sphere of
//! radius 1 at distance 10⁴ both terms are about 10⁸ and f32 cancels the difference away, losing the
//! sphere. Instead, with `d` normalized, `f = o − c`, `b = f·d`:
//!
//! ```text
//! disc = R² − |f − b·d|²          (the squared half-chord; |f − b·d| is the ray's distance to c)
//! q    = −b − sign(b)·sqrt(disc)  (no cancellation: both terms have the same sign)
//! t0   = cq / q,  t1 = q          with cq = |f|² − R²  (Vieta: t0·t1 = cq)
//! ```
//!
//! **Far from the origin.** `|f|²` overflows f32 once `|f|` passes about 1.8·10¹⁹: `cq` became
//! `+inf`, `t0 = +inf`, and the far root `q` was reported as the near one (a sphere's far side,
//! issue 20). So when any of `|o|`, `|c|`, `R` exceeds [`FAR`] (2⁶⁰), everything is first
//! multiplied by [`FAR_SCALE`] (2⁻⁶⁸, exact: a power of two), which brings every square below
//! 2¹²⁴, and the roots are multiplied back. Below 2⁶⁰ the scale is 1 and the results are bit for
//! bit those of the plain form. Differs from Haines et al., whose form assumes `|f|²` finite.

use crate::math;
use crate::ray::Ray;
use glam::Vec3;

/// A sphere by centre and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

/// Above this magnitude of `o`, `c` or `R` the roots are computed scaled by [`FAR_SCALE`]: below
/// it every `|f_i| ≤ 2⁶¹`, so `|f|²`, `|f − b·d|²` and `R²` stay below 2¹²⁴ (f32's largest is
/// about 2¹²⁸).
pub const FAR: f32 = (1u64 << 60) as f32;
/// 2⁻⁶⁸: scales the largest finite f32 (below 2¹²⁸) under 2⁶⁰. Scaled, a radius below 2⁵ loses
/// bits when squared (a subnormal), but it is then under 2⁻⁵⁵ of the magnitude that asked for the
/// scale, far below that magnitude's ulp (2⁻²³ of it): such a sphere is beneath f32's resolution
/// there in any form.
pub const FAR_SCALE: f32 = 1.0 / (1u128 << 68) as f32;

impl Sphere {
    /// The two roots `(t_near, t_far)` of the ray's line with the sphere, or `None` when the line
    /// misses it (or any input is NaN). Assumes a normalized direction. Right for any finite
    /// origin, centre and radius (see "Far from the origin" in the [module doc](self)); a root
    /// beyond f32's range is `±inf`.
    #[inline]
    pub fn roots(&self, ray: &Ray) -> Option<(f32, f32)> {
        let big = ray
            .origin
            .abs()
            .max_element()
            .max(self.center.abs().max_element());
        let (k, unscale) = if big.max(self.radius) > FAR {
            (FAR_SCALE, 1.0 / FAR_SCALE)
        } else {
            (1.0, 1.0)
        };
        let f = ray.origin * k - self.center * k;
        let b = f.dot(ray.dir);
        let radius = self.radius * k;
        let r2 = radius * radius;
        let perp = f - b * ray.dir;
        let disc = r2 - perp.dot(perp);
        if !(disc >= 0.0) {
            return None;
        }
        let q = -b - math::sign_not_zero(b) * math::sqrt(disc);
        let cq = f.dot(f) - r2;
        // q = 0 only when the origin is the tangent point itself (b = 0 and disc = 0).
        let t0 = if q != 0.0 { cq / q } else { 0.0 };
        let (near, far) = if t0 <= q { (t0, q) } else { (q, t0) };
        Some((near * unscale, far * unscale))
    }

    /// The closest root in `tmin < t < tmax`: the near root, else the far one (origin inside).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let (near, far) = self.roots(ray)?;
        if near > ray.tmin && near < ray.tmax {
            Some(near)
        } else if far > ray.tmin && far < ray.tmax {
            Some(far)
        } else {
            None
        }
    }

    /// The outward unit normal `(p − c) / R` at a point `p` on the surface (equation (33)).
    #[inline]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        (p - self.center) / self.radius
    }
}
