//! The distance `t` of a watertight hit: from the triangle's plane, in f64, with a bound on its
//! error.
//!
//! # Why not the paper's `t`
//! Woop, Benthin & Wald 2013 (§3.6) take `t = (U·z₀ + V·z₁ + W·z₂) / det` from the vertices'
//! scaled depths `zᵢ = Sz·(vᵢ − o)[kz]`. Those depths span the whole triangle along the ray, and
//! the barycentric weights `U/det, …` carry the shear's rounding (`u·|v − o|` on each sheared
//! coordinate, divided by the triangle's width seen along the ray), so the error of `t` grows like
//! `u·(extent along the ray)·|v − o| / (width seen along the ray)`: for a long wall seen at a
//! grazing angle it was larger than `t` itself (issue 39: a 10⁵ × 1 × 1 box's wall gave
//! `t = 7.87` for an exact 9.38, and `t = −1221` at 10⁶, which the check for hits behind the
//! origin then dropped — 100 % of such rays escaped the closed box; a ground triangle of
//! half-size 4·10⁹ seen from one unit above at 5–30° was missed by every ray). No f32 formula can
//! fix it: `v − o` itself is rounded by `u·|v − o|`, and at a grazing angle that moves the hit
//! by `u·|v − o| / sin θ`.
//!
//! # What is computed instead
//! The watertight kernels keep the paper's inside/outside decision (the edge functions, exact on
//! shared edges, in f32); only for a triangle that passes it, `t` is taken from the plane:
//! `t = n·(v₀ − o) / (n·d)`, `n = (v₁ − v₀) × (v₂ − v₀)`, evaluated in f64, where every f32 input
//! is exact, every difference of two f32 almost always is, and the products cannot overflow
//! (`(6.8·10³⁸)³ ≈ 3·10¹¹⁶`). Its error is about `2⁻⁵³·|v₀ − o| / h` relative (`h` the distance
//! from the origin to the plane): `10⁻¹⁰` for the 10⁶ box, `10⁻⁶` for a triangle of 4·10⁹ seen
//! from one unit, far below f32's `6·10⁻⁸` in every other case.
//!
//! # The error bound and hits at `tmin`
//! With `u = 2⁻⁵³`, `γₙ = n·u / (1 − n·u)` (Higham §3.1; pbrt-v3 §3.9.1), `N` the cross product
//! taken on absolute values (`Nₓ = |e1y·e2z| + |e1z·e2y|`, …, so `|nᵢ| ≤ Nᵢ`):
//!
//! 1. `eₖ = vₖ − v₀` and `a = v₀ − o`: at most one rounding each. `nᵢ = e·e − e·e`: two from its
//!    edges, a product, a difference: within `γ₄·Nᵢ` of the exact one.
//! 2. `n·a`: three products, two sums on rounded `n` and `a`: within `γ₈·(N·|a|)`; `n·d` (`d` is
//!    exact) within `γ₇·(N·|d|)`. Call them `δnum` and `δden` (both taken with `γ₁₀`, the spare
//!    covering the bound's own evaluation).
//! 3. The exact `t = (num + εₙ)/(den + ε_d)` is then within
//!    `(δnum + |t|·δden) / (|den| − δden)` of `num/den`, plus `γ₂·|t|` for the division; `inf`
//!    when `|den| ≤ δden` (the ray parallel to the plane within rounding: no sure side).
//!
//! A hit is reported only when `t − δt > tmin` (pbrt-v3 §3.9.6's rule): then the exact `t` is
//! beyond `tmin` too. This is the only hit that accuracy may drop; it replaces issue 29's f32
//! bound on the paper's `t`, whose size (`~10²·u` of the triangle seen from the origin) made
//! long and large triangles unsure far from `tmin`. An origin exactly on the plane (`t = 0`)
//! gives `|t| ≤ δt`, so a ray leaving a surface from on it never hits that surface's plane.
//!
//! The barycentrics are still the paper's (`V/det`, `W/det`, from the edge functions in f32): they
//! are what the inside test decided, and a hit point rebuilt from them lies on the triangle.

use glam::Vec3;

/// `u` of f64.
const U64: f64 = f64::EPSILON / 2.0;

/// Higham's `γₙ = n·u / (1 − n·u)` for f64.
#[inline(always)]
fn gamma64(n: u32) -> f64 {
    let nu = f64::from(n) * U64;
    nu / (1.0 - nu)
}

/// `v` in f64 (exact).
#[inline(always)]
fn f64s(v: Vec3) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

/// `t = n·(v₀ − o) / (n·d)` for the plane of `verts` and the ray `(origin, dir)`, in f64, and the
/// bound `δt` on its distance to the exact `t` (module doc); `δt` is `inf` (and `t` possibly not
/// finite) when the ray is parallel to the plane within rounding.
#[inline]
pub fn plane_t(verts: &[Vec3; 3], origin: Vec3, dir: Vec3) -> (f64, f64) {
    let [v0, v1, v2] = verts.map(f64s);
    let (o, d) = (f64s(origin), f64s(dir));
    let e1 = [v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]];
    let e2 = [v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]];
    let a = [v0[0] - o[0], v0[1] - o[1], v0[2] - o[2]];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let num = n[0] * a[0] + n[1] * a[1] + n[2] * a[2];
    let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    let t = num / den;
    let big_n = [
        (e1[1] * e2[2]).abs() + (e1[2] * e2[1]).abs(),
        (e1[2] * e2[0]).abs() + (e1[0] * e2[2]).abs(),
        (e1[0] * e2[1]).abs() + (e1[1] * e2[0]).abs(),
    ];
    let g = gamma64(10);
    let d_num = g * (big_n[0] * a[0].abs() + big_n[1] * a[1].abs() + big_n[2] * a[2].abs());
    let d_den = g * (big_n[0] * d[0].abs() + big_n[1] * d[1].abs() + big_n[2] * d[2].abs());
    let room = den.abs() - d_den;
    let dt = if room > 0.0 {
        (d_num + t.abs() * d_den) / room + gamma64(2) * t.abs()
    } else {
        f64::INFINITY
    };
    (t, dt)
}

/// The `t` of a ray that passed the watertight inside test of the triangle `verts`: the plane's
/// `t` ([`plane_t`]) rounded to f32, when the exact `t` is surely beyond `tmin`
/// (`t − δt > tmin`) and the rounded one lies in `(tmin, tmax)`; else `None`. NaN anywhere fails.
#[inline]
pub fn hit_t(verts: &[Vec3; 3], origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
    let (t64, dt) = plane_t(verts, origin, dir);
    let t = t64 as f32;
    let sure = t64 - dt > f64::from(tmin);
    (sure & (t > tmin) & (t < tmax)).then_some(t)
}
