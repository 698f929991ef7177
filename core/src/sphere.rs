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

use crate::math;
use crate::ray::Ray;
use glam::Vec3;

/// A sphere by centre and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    /// The two roots `(t_near, t_far)` of the ray's line with the sphere, or `None` when the line
    /// misses it (or any input is NaN). Assumes a normalized direction.
    #[inline]
    pub fn roots(&self, ray: &Ray) -> Option<(f32, f32)> {
        let f = ray.origin - self.center;
        let b = f.dot(ray.dir);
        let r2 = self.radius * self.radius;
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
        Some((near, far))
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
