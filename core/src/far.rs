//! The triangle kernels again in f64, for the rays whose f32 products overflow.
//!
//! Möller–Trumbore's `t = e2·(s × e1) / det` is a product of three lengths, `|e1|·|e2|·|o − v0|`,
//! and the watertight kernel's edge functions products of two. Past f32's `3.4·10³⁸` (a triangle
//! of edges `6·10¹²` seen from `10¹³`, one of `10⁹` seen from `10²⁰`) they overflow, and the ray
//! missed a triangle it passes through (issue 29). The f32 kernels call these functions for
//! exactly those tests — Möller–Trumbore: `α`, `β` or `t` not finite although the ray is not
//! parallel to the triangle; watertight: `det` or `1/det` not finite although `det ≠ 0`; both
//! only for a non-empty interval — so the common path pays one finiteness test and nothing else.
//! The packet and group kernels call them lane by lane, with each lane's own ray and triangle,
//! so a lane still returns exactly what the scalar kernel returns.
//!
//! In f64 every product of f32 inputs stays finite (`(6.8·10³⁸)³ ≈ 3·10¹¹⁶`), and every f32
//! value is exact, so these compute the same formulas with far smaller rounding; the result is
//! rounded back to f32 (`t` past f32's range is `inf`, which no interval `t < tmax` holds).
//!
//! Watertight: the edge functions are computed from the f32 kernel's own sheared vertex
//! coordinates wherever those are finite. Their products are exact in f64, so each edge
//! function's sign is the exact sign for those coordinates — which is also the sign the f32
//! kernel gives a nonzero edge function (rounding is monotone: `fl(a·b) > fl(c·d)` implies
//! `a·b > c·d`), and what its f64 rerun (paper §3.5) gives a zero one. So a triangle computed
//! here and its neighbour computed in f32 still see their shared edge with opposite signs: no
//! crack opens where the two paths meet. Only when a vertex relative to the origin itself
//! overflows f32 (`|v − o|` past `3.4·10³⁸`, both near f32's largest values with opposite signs)
//! is everything computed in f64 from the inputs, without that guarantee.
//!
//! These are the lowest of the triangle kernels: [`crate::triangle`] and [`crate::watertight`]
//! call them, so they take the triangle's vectors and the shear's fields, not the two types, and
//! import neither.

use crate::distance::hit_t;
use crate::ray::Ray;
use glam::Vec3;

/// Möller–Trumbore ([`Triangle::intersect_prepared`](crate::triangle::Triangle::intersect_prepared))
/// in f64 on the triangle's `v0`, `e1`, `e2` (its [`Triangle`](crate::triangle::Triangle)
/// fields), for a ray already known not to be parallel to the triangle (`det² > min_det2` in f32):
/// the hit `(t, α, β)` rounded to f32, with the f32 kernel's tests (`0 ≤ α ≤ 1`, `β ≥ 0`,
/// `α + β ≤ 1`, `tmin < t < tmax` on the rounded `t`), or `None`.
///
/// The vectors by reference: by value, the three of them lengthened the callers' hot paths
/// (scripts/icount.sh: fast mode's stream +3.1 % instructions per ray, its one-ray walks ±1.5 %);
/// references leave every row of that count as it was with `&Triangle`.
#[cold]
#[inline(never)]
pub fn intersect_moller_trumbore(
    v0: &Vec3,
    e1: &Vec3,
    e2: &Vec3,
    ray: &Ray,
) -> Option<(f32, f32, f32)> {
    let (v0, e1, e2) = (f64s(*v0), f64s(*e1), f64s(*e2));
    let (o, d) = (f64s(ray.origin), f64s(ray.dir));
    let p = cross(d, e2);
    let det = dot(e1, p);
    let s = [o[0] - v0[0], o[1] - v0[1], o[2] - v0[2]];
    let a = dot(s, p) / det;
    let q = cross(s, e1);
    let b = dot(d, q) / det;
    let t = (dot(e2, q) / det) as f32;
    let hit = (det != 0.0)
        & (0.0..=1.0).contains(&a)
        & (b >= 0.0)
        & (a + b <= 1.0)
        & (t > ray.tmin)
        & (t < ray.tmax);
    hit.then_some((t, a as f32, b as f32))
}

/// The watertight test ([`crate::watertight::intersect_sheared`]) in f64, with the ray's f32
/// shear `k = [kx, ky, kz]`, `s = [Sx, Sy]` (the fields of its
/// [`Shear`](crate::watertight::Shear)): the edge functions' signs and `det ≠ 0` in f64, then the
/// hit's `t` as the f32 kernel takes it ([`crate::distance::hit_t`], already f64) and the
/// barycentrics rounded to f32, or `None`. The caller has checked that the triangle is not
/// degenerate.
#[cold]
#[inline(never)]
pub fn intersect_watertight(
    verts: &[Vec3; 3],
    ray: &Ray,
    k: [usize; 3],
    s: [f32; 2],
) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = k;
    let [sx, sy] = s;
    // The f32 kernel's sheared coordinates, bit for bit (module doc).
    let rel32 = verts.map(|v| v - ray.origin);
    let sheared32 = rel32.map(|a| [a[kx] - sx * a[kz], a[ky] - sy * a[kz]]);
    let sheared = if sheared32.iter().flatten().all(|x| x.is_finite()) {
        sheared32.map(|p| p.map(f64::from))
    } else {
        let (sx, sy) = (f64::from(sx), f64::from(sy));
        let o = f64s(ray.origin);
        verts.map(|v| {
            let v = f64s(v);
            let a = [v[kx] - o[kx], v[ky] - o[ky], v[kz] - o[kz]];
            [a[0] - sx * a[2], a[1] - sy * a[2]]
        })
    };
    let [[ax, ay], [bx, by], [cx, cy]] = sheared;
    let [u, v, w] = [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax];
    let inside = (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
    let det = u + v + w;
    if !(inside & (det.abs() > 0.0)) {
        return None;
    }
    let t = hit_t(verts, ray.origin, ray.dir, ray.tmin, ray.tmax)?;
    Some((t, (v / det) as f32, (w / det) as f32))
}

/// `v` in f64 (exact).
fn f64s(v: Vec3) -> [f64; 3] {
    v.to_array().map(f64::from)
}

/// `a × b`, in glam's order.
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

/// `a · b`.
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
