//! Origins for rays that leave a surface (bounces, refraction, shadow rays) placed so that they
//! never hit the surface they leave, by a distance derived from floating-point error bounds rather
//! than a fixed epsilon.
//!
//! The method is pbrt-v4's (Pharr, Jakob, Humphreys, *Physically Based Rendering*, 4th ed.,
//! §6.8 "Managing Rounding Error", `OffsetRayOrigin`), itself a rigorous form of Wächter & Binder,
//! "A Fast and Robust Method for Avoiding Self-Intersection" (Ray Tracing Gems, ch. 6):
//!
//! 1. Compute the hit point from the primitive, not from the ray, together with a componentwise
//!    bound `error` on its distance to a point exactly on the surface ([`SurfacePoint::on_triangle`]
//!    from the barycentrics, [`SurfacePoint::on_sphere`] by reprojection onto the sphere).
//! 2. Move it along the surface normal `n` by `|n|·error`, the farthest the true point can lie
//!    along `n` inside that error box, plus a `margin`, and round each component of the result
//!    away from the point, so the rounding of the addition cannot take any of the offset back.
//!
//! Differs from pbrt-v4: pbrt-v4's triangle test rejects `t` below its own error bound, so an
//! origin just outside the error box suffices there. kdray's Möller–Trumbore and its
//! cancellation-free sphere accept any `t > tmin` (only the watertight kernel rejects a `t` within
//! its bound of `tmin`, [`crate::distance::plane_t`]), so the origin must also lie far enough off the
//! surface that the kernel, evaluated in f32 at that origin, sees it on the right side: that
//! distance is `margin`, derived for each primitive below with Higham's `γ(n) = n·u / (1 − n·u)`
//! (u = 2⁻²⁴, *Accuracy and Stability of Numerical Algorithms*, §3.1; pbrt-v4 §6.8.1).

use crate::format::Scene;
use crate::math::{self, gamma};
use crate::ray::{Hit, Ray};
use crate::sphere::Sphere;
use crate::triangle::Triangle;
use glam::Vec3;

/// A point on a primitive's surface as computed in f32, with what it takes to leave from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The point as computed.
    pub p: Vec3,
    /// A componentwise bound on `|p − p_exact|` for some `p_exact` exactly on the surface.
    pub error: Vec3,
    /// How far off the surface (along its normal) an origin must lie for the primitive's own
    /// intersection kernel to place it on the correct side, whatever the direction.
    pub margin: f32,
}

impl SurfacePoint {
    /// The point of `tri` at barycentrics `(u, v)`, `p = v0 + u·e1 + v·e2` (pbrt-v4 §6.8.5 also
    /// rebuilds triangle hits from their barycentrics: the error no longer depends on `t`).
    ///
    /// `error`: the exact `v0 + u·e1 + v·e2` (with the rounded `u`, `v`) lies exactly in the
    /// triangle's plane, and f32 evaluates it with at most 3 roundings per term:
    /// `γ(3)·(|v0| + |u·e1| + |v·e2|)`.
    ///
    /// `margin`: Möller–Trumbore decides the side of an origin `o` by the sign of
    /// `N = e2·((o − v0) × e1)` (then `t = N / det`), whose exact value is `dist·|e1 × e2|`.
    /// Evaluated in f32 (one rounding for `s = o − v0`, two per cross-product component, three
    /// in the dot product) it errs by at most `γ(6)·(|e2|·(|s| × |e1|))`, the products taken on
    /// absolute values. With `|s| ≤ |u·e1| + |v·e2| + 4·error` (the point, its error and the
    /// error-box part of the offset) this gives `margin = γ(7)·(|e2|·(|s| × |e1|)) / |e1 × e2|`:
    /// γ(7) rather than γ(6) also covers the part of `s` that is the margin itself, unless the
    /// triangle is a needle whose `|e1|·|e2| / |e1 × e2|` passes about 10⁵. It
    /// grows like `1 / sin` of the triangle's smallest angle, as it must: a needle triangle's side
    /// is uncertain in f32 well away from it. `+inf` for a degenerate triangle.
    #[inline]
    pub fn on_triangle(tri: &Triangle, u: f32, v: f32) -> Self {
        let (ue1, ve2) = (tri.e1 * u, tri.e2 * v);
        let p = tri.v0 + ue1 + ve2;
        let error = gamma(3) * (tri.v0.abs() + ue1.abs() + ve2.abs());
        let n = tri.geometric_normal();
        let n_len = n.length();
        // The origin's offset is at most about twice `error` along each axis.
        let s = ue1.abs() + ve2.abs() + 4.0 * error;
        let e1 = tri.e1.abs();
        let s_cross_e1 = Vec3::new(
            s.y * e1.z + s.z * e1.y,
            s.z * e1.x + s.x * e1.z,
            s.x * e1.y + s.y * e1.x,
        );
        let margin = if n_len > 0.0 {
            gamma(7) * tri.e2.abs().dot(s_cross_e1) / n_len
        } else {
            f32::INFINITY
        };
        Self { p, error, margin }
    }

    /// The point of `sphere` nearest `p` (a hit point `o + t·d`, whose error grows with `t`),
    /// `c + R·(p − c)/|p − c|` (pbrt-v4 §6.8.5's reprojection).
    ///
    /// `error`: `p − c` (1 rounding), its length (3 for the dot product, 1 for the square root),
    /// `R / len` and the scaling (2) make `R·f̂` accurate to `γ(7)` per component, and adding `c`
    /// rounds once more: `γ(7)·|p' − c| + γ(1)·|p'|`.
    ///
    /// `margin`: the sphere kernel ([`Sphere::roots`]) puts an origin outside or inside by the
    /// sign of `cq = |f|² − R²` (`f = o − c`; the root nearest the origin is `cq / q`), whose exact
    /// value is `(2R + dist)·dist`. f32 evaluates it with error at most `γ(6)·(|f|² + R²)`
    /// (one rounding for `f`, three for the dot product, one for `R²`, one for the difference),
    /// about `2·γ(6)·R²`: so `margin = γ(7)·R`.
    #[inline]
    pub fn on_sphere(sphere: &Sphere, p: Vec3) -> Self {
        let f = p - sphere.center;
        let len = math::sqrt(f.dot(f));
        let radius = sphere.radius.abs();
        // A point exactly at the centre has no nearest surface point: keep it, with the radius as
        // its error (any surface point is that far).
        let (p, local) = if len > 0.0 {
            let local = f * (radius / len);
            (sphere.center + local, local)
        } else {
            (p, Vec3::splat(radius))
        };
        let error = gamma(7) * local.abs() + gamma(1) * p.abs();
        Self {
            p,
            error,
            margin: gamma(7) * radius,
        }
    }

    /// The origin of a ray that leaves the surface towards the side unit normal `n` points to.
    ///
    /// `p` moved along `n` by `|n|·error + margin`, then each component rounded one step further
    /// away from `p` (pbrt-v4 `OffsetRayOrigin`): the exact origin is then at least `margin` off
    /// the surface, on `n`'s side. A ray from it in any direction on that side (`d·n > 0`) does not
    /// hit the primitive it leaves, and one into the other side (a refraction) meets it only past
    /// the surface, never at `t ≈ 0`.
    #[inline]
    pub fn spawn_origin(&self, n: Vec3) -> Vec3 {
        let d = n.abs().dot(self.error) + self.margin;
        let offset = n * d;
        let o = self.p + offset;
        Vec3::new(
            away(o.x, offset.x),
            away(o.y, offset.y),
            away(o.z, offset.z),
        )
    }
}

/// `x` moved one representable step in the direction of `sign`'s sign (not at all for 0 or NaN).
#[inline]
fn away(x: f32, sign: f32) -> f32 {
    if sign > 0.0 {
        x.next_up()
    } else if sign < 0.0 {
        x.next_down()
    } else {
        x
    }
}

impl Scene<'_> {
    /// Where `ray` meets primitive `hit.prim` (a hit that traversal returned for `ray`), as a
    /// [`SurfacePoint`]: a triangle's point from the hit's barycentrics, a sphere's reprojected
    /// from `ray.at(hit.t)`.
    #[inline]
    pub fn surface_point(&self, hit: &Hit, ray: &Ray) -> SurfacePoint {
        match hit.prim.checked_sub(self.tri_count()) {
            None => SurfacePoint::on_triangle(&self.triangle(hit.prim), hit.u, hit.v),
            Some(i) => SurfacePoint::on_sphere(&self.sphere(i), ray.at(hit.t)),
        }
    }
}
