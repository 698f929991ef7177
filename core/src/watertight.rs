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
//! 5. §3.6 (differs from the paper): the barycentrics of the hits contract are the paper's,
//!    `u = V / det` (weight of `v1`), `v = W / det` (weight of `v2`), but `t` is not the paper's
//!    `(U·Sz·A[kz] + V·Sz·B[kz] + W·Sz·C[kz]) / det`, whose error grows with the triangle's extent
//!    along the ray: it is the plane's `t`, in f64, for the triangles that pass the test
//!    ([`crate::distance`], issue 39).
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
//! The `t` test is `tmin < t < tmax` on the rounded `t`, as Möller–Trumbore's, and every test
//! is written so that NaN fails it.
//!
//! # Hits at the origin (differs from the paper)
//! An origin within rounding of a triangle's plane is on neither side: a ray leaving the plane
//! got hits at small positive `t` (issue 29). As pbrt-v3 §3.9.6 does, a hit is reported only
//! where `t` is beyond `tmin` by more than a bound `δt` on its error: `t − δt > tmin`. Since issue
//! 39 that bound is the f64 plane distance's ([`crate::distance`]), about `2⁻⁵³·|v − o| / h`
//! relative, so it drops only hits whose exact `t` may really be at or before `tmin`.
//!
//! Triangles whose edge functions overflow f32 (far from the origin: `|e1|·|o − v0|` past about
//! `3.4·10³⁸`) are computed again in f64 ([`crate::far`]).

use crate::distance::hit_t;
use crate::ray::Ray;
use crate::triangle::Triangle;
use glam::Vec3;

/// A ray's precomputed shear (paper §3.1–3.2): the permuted axes and `Sx, Sy, Sz`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shear {
    /// `[kx, ky, kz]`.
    pub k: [usize; 3],
    /// `[Sx, Sy, Sz]` (the kernels use `Sx`, `Sy`; `t` comes from the plane, [`crate::distance`]).
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
    let [sx, sy, _] = shear.s;
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
    let inv = 1.0 / det;
    // `det != 0` as `|det| > 0`, so NaN fails; `&` without short circuit, as Möller–Trumbore.
    if inside & (det.abs() > 0.0) & finite(det, inv) {
        let t = hit_t(verts, ray.origin, ray.dir, ray.tmin, ray.tmax)?;
        Some((t, v * inv, w * inv))
    } else if overflowed(det, inv, ray.tmin, ray.tmax) {
        crate::far::intersect_watertight(verts, ray, shear.k, [sx, sy])
    } else {
        None
    }
}

/// Whether `det` and `1/det` are both finite: the edge functions did not overflow and `det` is
/// not so small that its reciprocal does.
#[inline(always)]
pub fn finite(det: f32, inv: f32) -> bool {
    (det.abs() < f32::INFINITY) & (inv.abs() < f32::INFINITY)
}

/// Whether the f32 test must be done again in f64 ([`crate::far`]): `det` or `1/det` is not
/// finite although the ray's interval is not empty and `det` is not 0 (a ray in the triangle's
/// plane, or a triangle seen edge-on). Then some edge function overflowed, or `det` is subnormal
/// and `1/det` did, and the f32 signs or barycentrics cannot be trusted.
#[inline(always)]
pub fn overflowed(det: f32, inv: f32, tmin: f32, tmax: f32) -> bool {
    (tmin < tmax) & (det != 0.0) & !finite(det, inv)
}
