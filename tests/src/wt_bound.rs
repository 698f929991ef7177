//! What the watertight kernel (`kdray_core::watertight`, Woop, Benthin & Wald 2013) must do on
//! one ray and one triangle, derived in f64 from a rounding-error bound of its f32 steps: whether
//! it must hit, whether it must miss, and how far its `t` may be from the exact one. The stiff
//! tests (`tests/tests/stiff_triangles.rs`) hold the kernels to it.
//!
//! # The bound (`u = 2⁻²⁴`, `γₙ = nu / (1 − nu)`, PBR 3rd ed. §3.9.1)
//! The kernel permutes the axes so that `kz` is the direction's largest component (paper §3.2),
//! so `|Sx|, |Sy| ≤ 1`. With `A = v − o` per vertex:
//!
//! 1. A sheared coordinate, `fl(fl(A[kx]) − fl(fl(Sx)·fl(A[kz])))`, is within
//!    `γ₄·(|A[kx]| + |A[kz]|) ≤ δ = 2γ₄·a` of the exact `A[kx] − Sx·A[kz]`, where `a` is the
//!    largest `|A[k]|` over the three vertices (four roundings on any path, `|Sx| ≤ 1`).
//! 2. An edge function `U = Cx·By − Cy·Bx` of the computed coordinates differs from the exact one
//!    by at most `δ(|B|₁ + |C|₁) + 2δ²` (each coordinate off by `δ`), and its own f32 evaluation
//!    adds `γ₂·(|Cx·By| + |Cy·Bx|)` taken on the computed coordinates (two products, one
//!    difference; the paper's f64 rerun of §3.5, done only when the f32 value is exactly 0, has
//!    a smaller error). Call the sum `errᵢ` for edge `i`.
//! 3. Hence: when the three exact `Uᵢ` have one strict sign and `|Uᵢ| > errᵢ` for each, the
//!    computed ones have that sign too and the kernel hits (if `t` is in range) — [`Expect::must_hit`].
//! 4. `t`: the exact `t = Σ Uᵢzᵢ / Σ Uᵢ` with `zᵢ = A[kz] / d[kz]` (paper §3.6). Replacing `Uᵢ`
//!    by `Uᵢ + εᵢ`, `|εᵢ| ≤ errᵢ`, moves it by `|Σ εᵢ(zᵢ − t)| / |Σ(Uᵢ + εᵢ)|
//!    ≤ Σ errᵢ|zᵢ − t| / (|Σ Uᵢ| − Σ errᵢ)`; the remaining f32 steps (`zᵢ`: three roundings; `T`:
//!    three products and two sums of same-sign terms; `det`, `1/det`, `T·(1/det)`) add at most
//!    `γ₁₂·max|zᵢ|` ([`Expect::t_err`]).
//!
//! All of this assumes no underflow: [`Expect::normal`] says whether every nonzero intermediate
//! value the kernel forms is at least `f32::MIN_POSITIVE`. Below that, one bound still holds
//! exactly: when every `|Uᵢ·zᵢ|` the kernel can compute is below `2⁻¹⁵⁰` (half the smallest
//! subnormal), `T` rounds to 0, so `t = 0` and the kernel misses any ray with `tmin ≥ 0`
//! ([`Expect::must_miss_underflow`]).

use crate::f64ref::{DVec3, dv};
use glam::Vec3;
use kdray_core::Ray;

const U: f64 = f32::EPSILON as f64 / 2.0;

fn gamma(n: f64) -> f64 {
    n * U / (1.0 - n * U)
}

/// The watertight kernel's expected behaviour on one ray and triangle ([`expect`]).
#[derive(Clone, Copy, Debug)]
pub struct Expect {
    /// The exact edge functions have one strict sign, each beyond its error bound: a hit.
    pub must_hit: bool,
    /// Bound on `|t − t_exact|` when [`Expect::must_hit`].
    pub t_err: f64,
    /// The exact `t` of the ray's line with the triangle's plane (`Σ Uᵢzᵢ / Σ Uᵢ`).
    pub t: f64,
    /// No intermediate value of the kernel is subnormal: the bound applies.
    pub normal: bool,
    /// `T` rounds to 0 whatever the rounding: a miss for `tmin ≥ 0`.
    pub must_miss_underflow: bool,
}

/// The expectation for the watertight kernel on `ray` and the triangle with vertices `v`, from
/// the bound in the module doc. The ray's range is not looked at.
pub fn expect(v: &[Vec3; 3], ray: &Ray) -> Expect {
    let d = dv(ray.dir);
    let comp = |p: DVec3, k: usize| [p.x, p.y, p.z][k];
    // The kernel's permutation (`watertight::Shear::new`), in f64 on the same f32 direction.
    let kz = kdray_core::watertight::major_axis(ray.dir);
    let [kx, ky, _] = kdray_core::watertight::axes(kz, comp(d, kz) < 0.0);
    let (sx, sy) = (comp(d, kx) / comp(d, kz), comp(d, ky) / comp(d, kz));
    let rel = v.map(|p| dv(p) - dv(ray.origin));
    let a = rel
        .iter()
        .flat_map(|r| [r.x.abs(), r.y.abs(), r.z.abs()])
        .fold(0.0, f64::max);
    let delta = 2.0 * gamma(4.0) * a;
    let sheared = rel.map(|r| {
        [
            comp(r, kx) - sx * comp(r, kz),
            comp(r, ky) - sy * comp(r, kz),
        ]
    });
    let z = rel.map(|r| comp(r, kz) / comp(d, kz));
    // Edge i is the one opposite vertex i: U (B, C), V (C, A), W (A, B), as the kernel forms them.
    let [pa, pb, pc] = sheared;
    let edges = [(pc, pb), (pa, pc), (pb, pa)];
    let mut e = [0.0; 3];
    let mut err = [0.0; 3];
    let mut smallest = f64::INFINITY;
    let mut largest_product = 0.0f64;
    for (i, (p, q)) in edges.into_iter().enumerate() {
        // U = p.x·q.y − p.y·q.x.
        e[i] = p[0] * q[1] - p[1] * q[0];
        let l1 = |r: [f64; 2]| r[0].abs() + r[1].abs();
        let (x1, x2) = (
            (p[0].abs() + delta) * (q[1].abs() + delta),
            (p[1].abs() + delta) * (q[0].abs() + delta),
        );
        err[i] = delta * (l1(p) + l1(q)) + 2.0 * delta * delta + gamma(2.0) * (x1 + x2);
        for x in [p[0] * q[1], p[1] * q[0], e[i], e[i] * z[i], z[i]] {
            if x != 0.0 {
                smallest = smallest.min(x.abs());
            }
        }
        // The largest |U·z| the kernel can form: |U| at most x1 + x2 (rounded up), z rounded.
        largest_product = largest_product.max((x1 + x2) * (1.0 + gamma(2.0)) * z[i].abs());
    }
    for x in rel
        .iter()
        .flat_map(|r| [sx * comp(*r, kz), sy * comp(*r, kz)])
        .chain([sx, sy])
    {
        if x != 0.0 {
            smallest = smallest.min(x.abs());
        }
    }
    let det: f64 = e.iter().sum();
    let t = e.iter().zip(z).map(|(u, z)| u * z).sum::<f64>() / det;
    let one_sign = e.iter().all(|&x| x > 0.0) || e.iter().all(|&x| x < 0.0);
    let must_hit = one_sign && e.iter().zip(err).all(|(x, b)| x.abs() > b);
    let err_sum: f64 = err.iter().sum();
    let zmax = z.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    let spread: f64 = err.iter().zip(z).map(|(b, z)| b * (z - t).abs()).sum();
    Expect {
        must_hit,
        t_err: spread / (det.abs() - err_sum) + gamma(12.0) * zmax,
        t,
        normal: smallest >= f64::from(f32::MIN_POSITIVE),
        must_miss_underflow: largest_product * (1.0 + gamma(3.0)) < 2f64.powi(-150),
    }
}
