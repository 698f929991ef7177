//! Watertight ray/triangle intersection: Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1).
//!
//! # Why Möller–Trumbore leaks
//! Möller–Trumbore ([`crate::triangle`]) decides a hit from `α = s·p / det` and `β = d·q / det`,
//! numbers that depend on the whole triangle (`v0`, both edges) and so are rounded differently in
//! the two triangles that share an edge: a ray through the shared edge can get `α + β` a few ULPs
//! above 1 in one triangle and `β` a few ULPs below 0 in the other, and hit neither. On a closed
//! unit icosphere with rays from its centre aimed exactly at its vertices and at points of its
//! edges, that loses about a tenth of the rays (`docs/ROBUSTNESS.md` counts them).
//!
//! # The watertight test (paper §3, Listing 1)
//! 1. Per ray (§3.1–3.2, [`Shear::new`]): `kz` is the axis of the direction's largest component,
//!    `kx`, `ky` the next two in cyclic order, swapped when `d[kz] < 0` so the winding is kept;
//!    the shear `Sx = d[kx]/d[kz]`, `Sy = d[ky]/d[kz]`, `Sz = 1/d[kz]` maps the ray to the `+z`
//!    axis through the origin.
//! 2. Per triangle (§3.3): translate the vertices to the ray origin (`A = v0 − o`, …) and shear
//!    their `x, y`: `Ax = A[kx] − Sx·A[kz]`, `Ay = A[ky] − Sy·A[kz]`.
//! 3. The 2D edge functions (§3.4) `U = Cx·By − Cy·Bx`, `V = Ax·Cy − Ay·Cx`, `W = Bx·Ay − By·Ax`:
//!    the ray hits when all three have the same sign (no back-face culling), and misses when
//!    `det = U + V + W` is 0 (the ray lies in the triangle's plane).
//! 4. §3.5: where an edge function comes out exactly `0`, the ray may pass exactly through that
//!    edge or only seem to after rounding; all three are then recomputed in `f64` (a product of
//!    two f32 is exact in f64, so the sign of each difference is exact).
//! 5. §3.6: `t = (U·Sz·A[kz] + V·Sz·B[kz] + W·Sz·C[kz]) / det`, and the barycentrics of the
//!    hits contract are `u = V / det` (weight of `v1`), `v = W / det` (weight of `v2`).
//!
//! Why this is watertight (§3.4): the edge function of an edge depends only on the transformed
//! positions of that edge's two vertices, and a vertex's transformed position depends only on the
//! vertex and the ray. A triangle sharing that edge sees the same two vertices in the other
//! order, and IEEE arithmetic gives `Bx·Ay − By·Ax = −(Ay·Bx − Ax·By)` exactly, so the two
//! triangles get exactly opposite values: a ray can never be outside both. This needs the two
//! triangles to store bit-identical vertices, which is why the flat format stores the vertices,
//! not `v0` and two edges (see [`crate::format`], version 5). The paper's shear rounds, so the
//! hit is that of a ray a few ULPs away: watertight, not exact.
//!
//! The `t` test is `tmin < t < tmax` on the divided `t` (the paper's `T` against `det·tmax` avoids
//! the division, but the division keeps the same hit rule as Möller–Trumbore), and every test is
//! written so that NaN fails it.
//!
//! # Hits at the origin: the `t` error bound (differs from the paper)
//! An origin within rounding of a triangle's plane is on neither side in f32: the vertices
//! relative to it are rounded to about `u·|v − o|` (`u = 2⁻²⁴`), which for a triangle of edges
//! `4·10⁷` is several units, and a ray leaving the plane got hits at small positive `t` (issue
//! 29: 12–227 of 1,000–2,000 such rays). As pbrt-v3 §3.9.6 and pbrt-v4 §6.8.4 do, a hit is
//! reported only where `t` is beyond `tmin` by more than a bound [`t_error`] on its rounding
//! error: `t − δt > tmin`. The bound is needed only where the triangle reaches back to `tmin`:
//! when every vertex lies beyond it along the ray (`z_min`, the smallest sheared depth, is more
//! than `tmin` by its own rounding), every point of the triangle does, and so does the hit of
//! the nearby ray the kernel answers for ([`reaches_back`]); the bound is computed only for the
//! other hits, so it costs nothing on a ray that misses.
//!
//! Triangles whose products overflow f32 (far from the origin: `|e1|·|e2|·|o − v0|` past about
//! `3.4·10³⁸`) are computed again in f64 ([`crate::far`]).

use crate::math::gamma;
use crate::ray::Ray;
use crate::triangle::Triangle;
use core::ops::{Add, Mul, Sub};
use glam::Vec3;

/// A ray's precomputed shear (paper §3.1–3.2): the permuted axes and `Sx, Sy, Sz`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shear {
    /// `[kx, ky, kz]`.
    pub k: [usize; 3],
    /// `[Sx, Sy, Sz]`.
    pub s: [f32; 3],
}

/// `kz`, the axis of the largest `|d|` component, ties going to the lower axis. (`[kx, ky, kz]`
/// for each `kz` and whether `d[kz] < 0` is [`axes`].)
#[inline(always)]
pub fn major_axis(dir: Vec3) -> usize {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// `[kx, ky, kz]`: `kx = kz + 1`, `ky = kz + 2` (mod 3), swapped when `negative` (`d[kz] < 0`) so
/// that the winding of the triangle is kept (paper §3.2).
#[inline(always)]
pub fn axes(kz: usize, negative: bool) -> [usize; 3] {
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if negative { [ky, kx, kz] } else { [kx, ky, kz] }
}

impl Shear {
    /// The shear for a ray of direction `dir` (any length, not zero).
    #[inline]
    pub fn new(dir: Vec3) -> Self {
        let kz = major_axis(dir);
        let k = axes(kz, dir[kz] < 0.0);
        Self {
            k,
            s: [
                dir[k[0]] / dir[k[2]],
                dir[k[1]] / dir[k[2]],
                1.0 / dir[k[2]],
            ],
        }
    }
}

/// The three edge functions `[U, V, W]` of the sheared vertices `[(Ax, Ay), (Bx, By), (Cx, Cy)]`
/// in f32, each from the two vertices of its edge only.
#[inline(always)]
pub fn edge_functions(p: [[f32; 2]; 3]) -> [f32; 3] {
    let [[ax, ay], [bx, by], [cx, cy]] = p;
    [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax]
}

/// [`edge_functions`] in f64 (paper §3.5): each product of two f32 is exact, so each difference is
/// rounded once and its sign is exact; the results are rounded back to f32.
#[inline(never)]
#[cold]
pub fn edge_functions_f64(p: [[f32; 2]; 3]) -> [f32; 3] {
    let [[ax, ay], [bx, by], [cx, cy]] = p.map(|v| v.map(f64::from));
    [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax].map(|e| e as f32)
}

/// The watertight test of `ray` against the triangle with vertices `verts`: the hit `(t, u, v)`
/// with `tmin < t < tmax` (`u`, `v` the barycentrics of `v1`, `v2`), or `None`. A ray in the
/// triangle's plane, a degenerate triangle (no area: [`Triangle::min_det2`] is `+inf`) and NaN
/// anywhere are a miss.
#[inline]
pub fn intersect(verts: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    let [v0, v1, v2] = *verts;
    let min_det2 = Triangle::from_vertices(v0, v1, v2).min_det2();
    intersect_sheared(verts, min_det2, ray, &Shear::new(ray.dir))
}

/// [`intersect`] with the triangle's threshold [`Triangle::min_det2`] (the flat format stores it)
/// and the ray's [`Shear`] (traversal computes it once per ray) already known.
///
/// The threshold is used only to tell a degenerate triangle: `+inf` (or NaN) is a miss for every
/// ray. The watertight test alone would hit a zero-area triangle: its edge functions are exact
/// only up to the shear's rounding, which can give a collinear triangle a sliver of area seen
/// from the ray; Möller–Trumbore never hits one, and neither does this kernel, so the two modes
/// and the builder (which leaves degenerate triangles out of the tree) agree.
#[inline(always)]
pub fn intersect_sheared(
    verts: &[Vec3; 3],
    min_det2: f32,
    ray: &Ray,
    shear: &Shear,
) -> Option<(f32, f32, f32)> {
    if !(min_det2 < f32::INFINITY) {
        return None;
    }
    let [kx, ky, kz] = shear.k;
    let [sx, sy, sz] = shear.s;
    let rel = verts.map(|v| v - ray.origin);
    let sheared = rel.map(|a| [a[kx] - sx * a[kz], a[ky] - sy * a[kz]]);
    let mut e = edge_functions(sheared);
    if e[0] == 0.0 || e[1] == 0.0 || e[2] == 0.0 {
        e = edge_functions_f64(sheared);
    }
    let [u, v, w] = e;
    // Same sign for all three (zeros count as either), written so that NaN fails both.
    let inside = (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
    let det = u + v + w;
    let z = rel.map(|a| sz * a[kz]);
    let big_t = u * z[0] + v * z[1] + w * z[2];
    let inv = 1.0 / det;
    let t = big_t * inv;
    // `det != 0` as `|det| > 0`, so NaN fails; `&` without short circuit, as Möller–Trumbore.
    let hit = inside & (det.abs() > 0.0) & (t > ray.tmin) & (t < ray.tmax);
    if hit {
        let rel = rel.map(|a| [a[kx], a[ky], a[kz]]);
        if reaches_back(z, ray.tmin) && !(t - t_error(rel, sheared, z, e, inv) > ray.tmin) {
            return None;
        }
        Some((t, v * inv, w * inv))
    } else if overflowed(t, det, ray.tmin, ray.tmax) {
        crate::far::intersect_watertight(verts, ray, shear)
    } else {
        None
    }
}

/// Whether the f32 test must be done again in f64 ([`crate::far`]): `t` is not finite although
/// the ray's interval is not empty and `det` is not 0 (a ray in the triangle's plane, or a
/// triangle seen edge-on). Then some product overflowed (or `det` is subnormal and `1/det` did),
/// and only then: a finite `t` never comes from an overflow, since `inf` and NaN propagate.
#[inline(always)]
pub fn overflowed(t: f32, det: f32, tmin: f32, tmax: f32) -> bool {
    (tmin < tmax) & (det != 0.0) & !t.is_finite()
}

/// Numbers the [`t_error`] bound is computed in: `f32`, `f64` ([`crate::far`]) and the SIMD lanes,
/// so that one function, one order of operations, serves them all and every lane rounds as the
/// scalar kernel does.
pub trait Real: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// `x` in this type (every lane `x`).
    fn of(x: f32) -> Self;
    /// `|self|`.
    fn abs(self) -> Self;
    /// The larger; where one is NaN, the other (IEEE `maxNum`, as `f32::max` and the lanes').
    fn max(self, rhs: Self) -> Self;
    /// The smaller; where one is NaN, the other.
    fn min(self, rhs: Self) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn of(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        f32::max(self, rhs)
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        f32::min(self, rhs)
    }
}

impl Real for f64 {
    #[inline(always)]
    fn of(x: f32) -> Self {
        f64::from(x)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        f64::max(self, rhs)
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        f64::min(self, rhs)
    }
}

/// The largest of `f(0), f(1), f(2)`.
#[inline(always)]
fn max3<N: Real>(f: impl Fn(usize) -> N) -> N {
    f(0).max(f(1)).max(f(2))
}

/// Whether the triangle may reach back to `tmin` along the ray, so that a hit needs the
/// [`t_error`] test: false when every sheared depth `z`, lowered by its rounding (three roundings,
/// `γ₃·|z|`; `γ₅` leaves room for this test's own), is beyond `tmin`. A point of the triangle has
/// the depth of the ray point level with it, so then every hit of a ray from (nearly) this origin
/// in this direction is beyond `tmin` too. NaN counts as reaching back.
#[inline(always)]
pub fn reaches_back<N: Real + PartialOrd>(z: [N; 3], tmin: N) -> bool {
    let near = z[0].min(z[1]).min(z[2]);
    !(near - near.abs() * N::of(gamma(5)) > tmin)
}

/// A bound `δt` on `|t − t_exact|` at `t ≈ 0`, from the kernel's own values: `rel`, the vertices
/// relative to the origin, permuted (`[v[kx] − o[kx], v[ky] − o[ky], v[kz] − o[kz]]`);
/// `sheared`, their `x, y` after the shear; `z`, their sheared depths; `e`, the edge functions;
/// `inv = 1/det`. pbrt-v3 §3.9.6's bound (Higham's `γₙ = n·u/(1 − n·u)`), adapted to this kernel,
/// which shears `x, y` before it scales `z` (pbrt scales first), so its `x, y` errors grow with
/// the depth itself, not the scaled depth: an unnormalized direction changes nothing.
///
/// 1. A sheared `x = A[kx] − Sx·A[kz]` takes 4 roundings on any path (`A`, `Sx`, the product,
///    the difference) and `|Sx| ≤ 1`: it is within `δx = γ₅·(max|A[kx]| + max|A[kz]|)` of the
///    exact one (`γ₅` for `A`'s own rounding, from the rounded `A`); `δy` likewise.
/// 2. An edge function `Cx·By − Cy·Bx` (two products, a difference: `γ₂`, or less in the f64
///    rerun), with `X`, `Y` the largest `|x|`, `|y|`: within
///    `δe = 2·(γ₂·X·Y + X·δy + Y·δx + δx·δy)` of the exact one.
/// 3. A depth `z = Sz·A[kz]` (3 roundings): within `δz = γ₄·Z`, `Z` the largest `|z|`.
/// 4. `T = Σ e·z` (3 products, 2 sums: `γ₃`), with `E` the largest `|e|`:
///    `δT = 3·(γ₃·E·Z + E·δz + (Z + δz)·δe)`, and `δt = δT·|1/det|`.
///
/// `t − δt > 0` then means the exact `T` has the computed `T`'s sign, which with `det`'s makes
/// the exact `t` positive (as pbrt, the sign of `det`, a sum of three same-signed edge functions,
/// is taken as exact). Each `γ` below is one or two roundings larger than the count above: the
/// spare (20–50 % of each term) covers the bound's own f32 evaluation and the rounding of `t`
/// and `1/det`. `inf` where the bound overflows: then no hit near the origin is sure.
#[inline(always)]
pub fn t_error<N: Real>(rel: [[N; 3]; 3], sheared: [[N; 2]; 3], z: [N; 3], e: [N; 3], inv: N) -> N {
    let g = |n: u32| N::of(gamma(n));
    let (rx, ry, rz) = (
        max3(|i| rel[i][0].abs()),
        max3(|i| rel[i][1].abs()),
        max3(|i| rel[i][2].abs()),
    );
    let dx = g(6) * (rx + rz);
    let dy = g(6) * (ry + rz);
    let x = max3(|i| sheared[i][0].abs());
    let y = max3(|i| sheared[i][1].abs());
    let de = N::of(2.0) * (g(3) * x * y + x * dy + y * dx + dx * dy);
    let zmax = max3(|i| z[i].abs());
    let emax = max3(|i| e[i].abs());
    let dz = g(5) * zmax;
    let dt = N::of(3.0) * (g(4) * emax * zmax + emax * dz + (zmax + dz) * de);
    dt * inv.abs()
}
