//! Ray/triangle intersection: Möller & Trumbore 1997, "Fast, Minimum Storage Ray-Triangle
//! Intersection", in Rukin's cofactor form (§4, equations (13)–(27)).
//!
//! Rukin writes the hit condition `o + t·d = e + α(f − e) + β(g − e)` as the linear system
//! `o − e = [−d, f − e, g − e]·(t, α, β)ᵀ` (equation (16); this restores the lost sign of the
//! `−d` column) and solves it with the adjugate over the determinant (equations (17)–(23)). Each
//! cofactor of that 3×3 system is a scalar triple product, which is what Möller–Trumbore computes:
//! with `e1 = f − e`, `e2 = g − e`, `s = o − e`, `p = d × e2`, `q = s × e1`
//!
//! ```text
//! det = e1·p            (= det[−d, e1, e2], equation (23))
//! α   = s·p  / det      (Cramer's rule on the α column)
//! β   = d·q  / det      (… the β column)
//! t   = e2·q / det      (… the t column)
//! ```
//!
//! so the two forms are the same arithmetic ordered to share `p` and `q`.
//!
//! Triangles are stored as `(v0, e1, e2)`, the layout the kernels load.

use crate::ray::Ray;
use glam::Vec3;

/// Below this `|det| / |e1 × e2|` (the sine of the angle between the ray and the triangle's
/// plane) a ray counts as parallel to the triangle: its `t` would be dominated by rounding.
/// About 2⁻²² rad, a few ULPs of a unit vector.
pub const PARALLEL_SIN: f32 = 2.384_185_8e-7;

/// A triangle in the kernels' layout: `v0` and the two edges from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub v0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
}

impl Triangle {
    /// From the three vertices `e`, `f`, `g` of Rukin (`v0`, `v1`, `v2`).
    #[inline]
    pub fn from_vertices(v0: Vec3, v1: Vec3, v2: Vec3) -> Self {
        Self {
            v0,
            e1: v1 - v0,
            e2: v2 - v0,
        }
    }

    /// The vertices back: `(v0, v0 + e1, v0 + e2)`.
    #[inline]
    pub fn vertices(&self) -> [Vec3; 3] {
        [self.v0, self.v0 + self.e1, self.v0 + self.e2]
    }

    /// The unnormalized geometric normal `(f − e) × (g − e)` (correcting Rukin's
    /// equations (24)–(27)); its length is twice the area, zero for a degenerate triangle.
    #[inline]
    pub fn geometric_normal(&self) -> Vec3 {
        self.e1.cross(self.e2)
    }

    /// True when the triangle is degenerate: `|e1 × e2|²` rounds to 0 (no area, or too little
    /// for f32; see [`Triangle::min_det2`]). It is never hit.
    #[inline]
    pub fn is_degenerate(&self) -> bool {
        self.geometric_normal().length_squared() == 0.0
    }

    /// The parallel threshold `PARALLEL_SIN²·|e1 × e2|²` that [`Triangle::intersect`] compares
    /// `det²` with, or `+inf` for a degenerate triangle, so that no ray passes it. The flat format
    /// stores it with each triangle; NaN for a NaN triangle, which no ray passes either.
    ///
    /// A triangle is *degenerate* when `|e1 × e2|²` rounds to 0 in f32: no area (coincident or
    /// collinear vertices), or edges so short (about 1e-11 and below) that the squared area
    /// underflows. Such a triangle is never hit, by any kernel in any mode: the watertight kernels
    /// take this threshold too and reject `+inf`, and the builder leaves the triangle out of the
    /// tree.
    ///
    /// Where `|e1 × e2|²` overflows f32 (edges beyond about 4e9), the threshold is computed from
    /// the normal scaled by `PARALLEL_SIN` first (a power of two, so the scaling is exact) and
    /// stays finite while `|e1 × e2| < 7.7e25`; `det²` may then overflow to `+inf`, which passes
    /// the test, as it should for a ray that far from parallel. Past that the threshold is `+inf`
    /// as well: [`Triangle::is_too_large`] tells the two apart, and the builder and the flat
    /// format's validation refuse such a triangle rather than never hit it.
    #[inline]
    pub fn min_det2(&self) -> f32 {
        let n = self.geometric_normal();
        let n2 = n.length_squared();
        if n2 == 0.0 {
            f32::INFINITY
        } else if n2.is_finite() {
            PARALLEL_SIN * PARALLEL_SIN * n2
        } else {
            (n * PARALLEL_SIN).length_squared()
        }
    }

    /// True when the triangle has area but its threshold [`Triangle::min_det2`] still overflows
    /// (`|e1 × e2| ≥ 7.7e25`, or an edge or the normal is not finite): f32 cannot trace it right,
    /// so it must be refused, not stored.
    #[inline]
    pub fn is_too_large(&self) -> bool {
        !self.is_degenerate() && !(self.min_det2() < f32::INFINITY)
    }

    /// Möller–Trumbore: the hit `(t, α, β)` with `tmin < t < tmax`, `α ≥ 0`, `β ≥ 0`, `α + β ≤ 1`.
    ///
    /// Returns `None` for a miss, a ray parallel to the plane (see [`PARALLEL_SIN`]), a degenerate
    /// triangle, and whenever any input is NaN: every test is written so that NaN fails it.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32, f32)> {
        self.intersect_prepared(ray, self.min_det2())
    }

    /// [`Triangle::intersect`] with the triangle's [`Triangle::min_det2`] already known.
    #[inline(always)]
    pub fn intersect_prepared(&self, ray: &Ray, min_det2: f32) -> Option<(f32, f32, f32)> {
        let p = ray.dir.cross(self.e2);
        let det = self.e1.dot(p);
        let inv = 1.0 / det;
        let s = ray.origin - self.v0;
        let a = s.dot(p) * inv;
        let q = s.cross(self.e1);
        let b = ray.dir.dot(q) * inv;
        let t = self.e2.dot(q) * inv;
        // All tests combined with `&` (no short circuit), then one branch: which test fails is
        // unpredictable, and the mispredictions of early exits cost more than the arithmetic
        // they skip. Every comparison is false on NaN, so NaN anywhere is a miss; a ray parallel
        // to the plane fails `det² > min_det2` (`+inf` for a degenerate triangle).
        let hit = (det * det > min_det2)
            & (0.0..=1.0).contains(&a)
            & (b >= 0.0)
            & (a + b <= 1.0)
            & (t > ray.tmin)
            & (t < ray.tmax);
        if hit {
            Some((t, a, b))
        } else if overflowed(det, min_det2, a + b, t, ray.tmin, ray.tmax) {
            crate::far::intersect_moller_trumbore(&self.v0, &self.e1, &self.e2, ray)
        } else {
            None
        }
    }
}

/// Whether a Möller–Trumbore test must be done again in f64 ([`crate::far`]): the ray is not
/// parallel to the triangle (`det² > min_det2`) and its interval is not empty, yet `α + β` or
/// `t` is not finite. Then some product overflowed (`|e1|·|e2|·|o − v0|` past f32's range), and
/// only then: with `det` past the threshold `1/det` is finite, and `inf` and NaN propagate.
/// (`α + β` finite but overflowing from two huge finite values only sends a miss there too.)
#[inline(always)]
pub fn overflowed(det: f32, min_det2: f32, a_plus_b: f32, t: f32, tmin: f32, tmax: f32) -> bool {
    (det * det > min_det2) & (tmin < tmax) & !(a_plus_b + t).is_finite()
}

/// Interpolates per-vertex values with barycentrics `(α, β)` (Rukin's note under equation (13)):
/// `a + α(b − a) + β(c − a)`, written as `(1 − α − β)·a + α·b + β·c` so that each vertex value is
/// reproduced exactly at its corner.
#[inline]
pub fn interpolate<T>(values: [T; 3], alpha: f32, beta: f32) -> T
where
    T: Copy + core::ops::Mul<f32, Output = T> + core::ops::Add<Output = T>,
{
    values[0] * (1.0 - alpha - beta) + values[1] * alpha + values[2] * beta
}

/// The shading normal at `(α, β)` from per-vertex normals, normalized; falls back to `fallback`
/// (normally the geometric normal) when the interpolated normal vanishes or is not finite.
#[inline]
pub fn shading_normal(normals: [Vec3; 3], alpha: f32, beta: f32, fallback: Vec3) -> Vec3 {
    interpolate(normals, alpha, beta)
        .try_normalize()
        .unwrap_or(fallback)
}
