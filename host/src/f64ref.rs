//! f64 references for the core's f32 kernels: the yardstick of the tests (`tests/`) and of
//! `kdray accuracy`.
//!
//! Every function takes the f32 inputs the core sees, widened exactly to f64, and evaluates the
//! seed's formulas directly in f64, so a difference to the core measures the core's f32 rounding
//! (and any mistake in it), not a difference of inputs. With 29 more mantissa bits than f32 these
//! references are exact for the tests' purposes on the inputs the tests feed them.

use core::ops::{Add, Mul, Neg, Sub};
use glam::Vec3;
use kdray_core::{Ray, Sphere};

/// A minimal f64 3-vector with just what the references need (kept apart from glam's `DVec3` so
/// the references read like the formulas they transcribe and depend on nothing the core uses).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DVec3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl DVec3 {
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    pub fn dot(self, o: Self) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    pub fn length(self) -> f64 {
        self.dot(self).sqrt()
    }

    pub fn normalize(self) -> Self {
        self * (1.0 / self.length())
    }

    /// The largest componentwise absolute difference.
    pub fn max_abs_diff(self, o: Self) -> f64 {
        let d = self - o;
        d.x.abs().max(d.y.abs()).max(d.z.abs())
    }
}

impl Add for DVec3 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for DVec3 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Neg for DVec3 {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

impl Mul<f64> for DVec3 {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self::new(self.x * k, self.y * k, self.z * k)
    }
}

impl Mul<DVec3> for f64 {
    type Output = DVec3;
    fn mul(self, v: DVec3) -> DVec3 {
        v * self
    }
}

/// `v` widened exactly.
#[inline]
pub fn dv(v: Vec3) -> DVec3 {
    DVec3::new(v.x.into(), v.y.into(), v.z.into())
}

/// The scalar triple product `det[a, b, c] = a · (b × c)`.
#[inline]
pub fn det3(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    a.dot(b.cross(c))
}

/// The unconstrained solution of Rukin's equation (16) with the corrected sign:
/// `o − e = [−d, e1, e2]·(t, α, β)ᵀ`, `e1 = f − e`, `e2 = g − e`, by Cramer's rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MtSolution {
    pub t: f64,
    pub alpha: f64,
    pub beta: f64,
    /// `det[−d, e1, e2]`.
    pub det: f64,
}

/// Cramer's rule on `o − e = [−d, e1, e2]·(t, α, β)ᵀ`; `None` when the determinant is exactly 0
/// (ray parallel to the plane, or degenerate triangle).
pub fn mt_solve(origin: Vec3, dir: Vec3, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<MtSolution> {
    let (s, m, e1, e2) = (dv(origin) - dv(v0), -dv(dir), dv(e1), dv(e2));
    let det = det3(m, e1, e2);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    Some(MtSolution {
        t: det3(s, e1, e2) / det,
        alpha: det3(m, s, e2) / det,
        beta: det3(m, e1, s) / det,
        det,
    })
}

/// The two roots `t_near ≤ t_far` of `|o + t·d − c|² = R²` for any non-zero `d` (not assuming it
/// is normalized: the f32 direction the core gets is unit only to rounding), or `None` when the
/// line misses. Written in the cancellation-free form of Ray Tracing Gems ch. 7 so that it stays
/// exact far from the sphere too: with `a = d·d`, `b = f·d`, `f = o − c`,
/// `a·t² + 2b·t + (|f|² − R²) = 0`, the squared half chord `h² = R² − |f − (b/a)d|²`, and
/// `q = −b − sign(b)·sqrt(a·h²)`, the roots are `q/a` and `(|f|² − R²)/q`.
pub fn sphere_roots(origin: Vec3, dir: Vec3, center: Vec3, radius: f32) -> Option<(f64, f64)> {
    let (f, d, r) = (dv(origin) - dv(center), dv(dir), f64::from(radius));
    let a = d.dot(d);
    let b = f.dot(d);
    let h2 = sphere_half_chord2(origin, dir, center, radius);
    // NaN (from NaN inputs) is a miss too.
    if h2.is_nan() || h2 < 0.0 {
        return None;
    }
    let q = -b - b.signum() * (a * h2).sqrt();
    let c = f.dot(f) - r * r;
    let (t0, t1) = (q / a, if q != 0.0 { c / q } else { 0.0 });
    Some((t0.min(t1), t0.max(t1)))
}

/// `R² − (distance from the centre to the ray's line)²`: positive when the line crosses the
/// sphere, and how far from grazing it is.
pub fn sphere_half_chord2(origin: Vec3, dir: Vec3, center: Vec3, radius: f32) -> f64 {
    let (f, d, r) = (dv(origin) - dv(center), dv(dir), f64::from(radius));
    let perp = f - (f.dot(d) / d.dot(d)) * d;
    r * r - perp.dot(perp)
}

/// How far outside a triangle (in barycentric units) [`mt_hit`] still counts a hit: far below
/// what f32 can resolve (2⁻²⁴ ≈ 6·10⁻⁸), far above f64's rounding of the barycentrics (~10⁻¹⁵).
///
/// Without it the reference is not watertight either: a ray from the centre of a unit icosphere
/// whose f32 direction is exactly a vertex (a unit vertex normalizes to itself) passes exactly
/// through that vertex, and f64 rounding put it 10⁻¹⁶ outside all six triangles around it for
/// 108 of the 266,256 rays of `kdray accuracy`'s seam set.
pub const BARY_SLACK: f64 = 1e-12;

/// The f64 verdict of Möller–Trumbore on the exact vertices `v` (edges formed in f64, so triangles
/// that share an edge share it exactly): `t` of a hit with `α, β ≥ −ε`, `α + β ≤ 1 + ε`
/// (ε = [`BARY_SLACK`]) and `tmin < t < tmax`, or `None`. The reference `kdray accuracy` measures
/// the f32 kernels against.
pub fn mt_hit(ray: &Ray, v: &[Vec3; 3]) -> Option<f64> {
    let (v0, d) = (dv(v[0]), -dv(ray.dir));
    let (e1, e2, s) = (dv(v[1]) - v0, dv(v[2]) - v0, dv(ray.origin) - v0);
    let det = det3(d, e1, e2);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let (t, alpha, beta) = (
        det3(s, e1, e2) / det,
        det3(d, s, e2) / det,
        det3(d, e1, s) / det,
    );
    let inside = alpha >= -BARY_SLACK && beta >= -BARY_SLACK && alpha + beta <= 1.0 + BARY_SLACK;
    let in_range = t > f64::from(ray.tmin) && t < f64::from(ray.tmax);
    (inside && in_range).then_some(t)
}

/// The f64 verdict of a ray against a sphere: the nearest root in `(tmin, tmax)` of
/// [`sphere_roots`], or `+inf`.
pub fn sphere_hit(ray: &Ray, sphere: &Sphere) -> f64 {
    let (lo, hi) = (f64::from(ray.tmin), f64::from(ray.tmax));
    sphere_roots(ray.origin, ray.dir, sphere.center, sphere.radius)
        .and_then(|(near, far)| [near, far].into_iter().find(|&t| t > lo && t < hi))
        .unwrap_or(f64::INFINITY)
}

/// Exact unpolarized Fresnel reflectance of a smooth dielectric (mean of the squared s and p
/// amplitude ratios), `R = 1` under total internal reflection. `cos_i` in `[0, 1]`.
pub fn fresnel_dielectric(cos_i: f64, eta1: f64, eta2: f64) -> f64 {
    let sin2_t = (eta1 / eta2).powi(2) * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta1 * cos_i - eta2 * cos_t) / (eta1 * cos_i + eta2 * cos_t);
    let rp = (eta2 * cos_i - eta1 * cos_t) / (eta2 * cos_i + eta1 * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Rukin's equation (3) in degrees: `(sinθ cosφ, sinθ sinφ, cosθ)`.
pub fn spherical_dir(phi_deg: f64, theta_deg: f64) -> DVec3 {
    let (p, t) = (phi_deg.to_radians(), theta_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// Rukin's parallel-camera axes (equations (4)–(5)) in degrees:
/// `vec1 = (cosθ cosφ, cosθ sinφ, −sinθ)` (vertical) and `vec2 = (−sinφ, cosφ, 0)` (horizontal).
pub fn parallel_axes(phi_deg: f64, theta_deg: f64) -> (DVec3, DVec3) {
    let (p, t) = (phi_deg.to_radians(), theta_deg.to_radians());
    let vec1 = DVec3::new(t.cos() * p.cos(), t.cos() * p.sin(), -t.sin());
    let vec2 = DVec3::new(-p.sin(), p.cos(), 0.0);
    (vec1, vec2)
}

/// The angle between two directions, in degrees, computed with `atan2(|a×b|, a·b)` so it is
/// accurate near 0 too.
pub fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}
