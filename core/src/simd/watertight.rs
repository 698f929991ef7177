//! The packet watertight kernel: [`crate::watertight`] (Woop, Benthin & Wald 2013) transcribed
//! lane by lane over [`Lanes`], as [`super::kernels`] does for Möller–Trumbore.
//!
//! Each lane has its own axis permutation `[kx, ky, kz]` (paper §3.2). The lanes pick their
//! vertex and origin components with masks ([`ShearX`]) instead of indexing, which changes no
//! arithmetic: a lane computes `v[kx] − o[kx]`, the same f32 subtraction as the scalar kernel's
//! `(v − o)[kx]`. After that every operation is the scalar's in the same order, with no FMA, so a
//! lane hits exactly when [`crate::watertight::intersect_sheared`] hits its ray, with
//! bit-identical `t`, `u`, `v` (tested in `tests/tests/simd_kernels.rs`). The paper's f64 rerun
//! (§3.5) is done lane by lane in scalar code, only for lanes with an edge function of exactly 0,
//! and so is the hit's `t` ([`crate::distance::hit_t`], f64), only for lanes that pass the inside
//! test: the same function as the scalar kernel's, so the same bits.

use super::kernels::PrimHits;
use super::lanes::{Lanes, set_lanes};
use super::packet::RayPacket;
use crate::triangle::Triangle;
use crate::watertight::{Shear, edge_functions_f64};
use glam::Vec3;

/// Each lane's shear (paper §3.1–3.2): component-picking masks for `kx` and `ky` (which of x, y;
/// else z) and `kz`, the origin's components in the permuted order, and `Sx, Sy, Sz`.
#[derive(Clone, Copy, Debug)]
pub struct ShearX<L> {
    /// `[kx, ky, kz]` each as `[is_x, is_y]` masks (neither: z).
    pick: [[L; 2]; 3],
    /// `[o[kx], o[ky], o[kz]]`.
    origin: [L; 3],
    /// `[Sx, Sy, Sz]`.
    s: [L; 3],
}

impl<L: Lanes> ShearX<L> {
    /// The shear of each lane of `rays`, as [`crate::watertight::Shear::new`] computes it.
    #[inline]
    pub fn new(rays: &RayPacket<L>) -> Self {
        let d = rays.dir;
        let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
        // `major_axis`: x if it is at least both others, else y if at least z, else z.
        let kz_x = ax.ge(ay) & ax.ge(az);
        let kz_y = !kz_x & ay.ge(az);
        let kz_z = !kz_x & !kz_y;
        let dkz = kz_x.select(d.x, kz_y.select(d.y, d.z));
        let neg = dkz.lt(L::splat(0.0));
        let pos = !neg;
        // `axes`: kx = kz + 1, ky = kz + 2 (mod 3), swapped where d[kz] < 0.
        let kx = [(kz_z & pos) | (kz_y & neg), (kz_x & pos) | (kz_z & neg)];
        let ky = [(kz_y & pos) | (kz_z & neg), (kz_z & pos) | (kz_x & neg)];
        let pick = [kx, ky, [kz_x, kz_y]];
        let o = rays.origin;
        let origin = pick.map(|[is_x, is_y]| is_x.select(o.x, is_y.select(o.y, o.z)));
        let dk = pick.map(|[is_x, is_y]| is_x.select(d.x, is_y.select(d.y, d.z)));
        Self {
            pick,
            origin,
            s: [dk[0] / dk[2], dk[1] / dk[2], dk[2].recip()],
        }
    }

    /// `[v[kx] − o[kx], v[ky] − o[ky], v[kz] − o[kz]]` in each lane: the vertex relative to the
    /// origin, permuted.
    #[inline(always)]
    fn relative(&self, v: Vec3) -> [L; 3] {
        let (x, y, z) = (L::splat(v.x), L::splat(v.y), L::splat(v.z));
        let comp = |k: usize| {
            let [is_x, is_y] = self.pick[k];
            is_x.select(x, is_y.select(y, z)) - self.origin[k]
        };
        [comp(0), comp(1), comp(2)]
    }
}

/// The watertight test of the triangle with vertices `verts` against every lane of `rays`: the
/// lanes where [`crate::watertight::intersect`] hits the lane's ray (with its current `tmax`),
/// and there `t`, `u`, `v`. `shear` is [`ShearX::new`] of `rays`. A degenerate triangle
/// ([`Triangle::min_det2`] is `+inf`) is hit by no lane.
#[inline]
pub fn intersect_triangle_watertight<L: Lanes>(
    verts: &[Vec3; 3],
    rays: &RayPacket<L>,
    shear: &ShearX<L>,
) -> PrimHits<L> {
    let [v0, v1, v2] = *verts;
    let min_det2 = Triangle::from_vertices(v0, v1, v2).min_det2();
    intersect_triangle_watertight_prepared(verts, min_det2, rays, shear)
}

/// [`intersect_triangle_watertight`] with the triangle's threshold [`Triangle::min_det2`] already
/// known (the flat format stores it): lane by lane [`crate::watertight::intersect_sheared`].
#[inline(always)]
pub fn intersect_triangle_watertight_prepared<L: Lanes>(
    verts: &[Vec3; 3],
    min_det2: f32,
    rays: &RayPacket<L>,
    shear: &ShearX<L>,
) -> PrimHits<L> {
    // A degenerate (+inf) or NaN threshold: no lane hits (see `intersect_sheared`).
    if !(min_det2 < f32::INFINITY) {
        return PrimHits::none();
    }
    let rel = verts.map(|v| shear.relative(v));
    let all = L::splat(0.0).eq(L::splat(0.0));
    watertight_lanes(
        rel,
        shear.s,
        rays.tmin,
        rays.tmax,
        all,
        |i| {
            let ray = rays.ray(i);
            crate::distance::hit_t(verts, ray.origin, ray.dir, ray.tmin, ray.tmax)
        },
        |i| {
            let ray = rays.ray(i);
            let Shear { k, s: [sx, sy, _] } = Shear::new(ray.dir);
            crate::far::intersect_watertight(verts, &ray, k, [sx, sy])
        },
    )
}

/// The watertight test lane by lane from each lane's vertices relative to its ray's origin,
/// permuted (`rel[vertex] = [v[kx] − o[kx], v[ky] − o[ky], v[kz] − o[kz]]`), and its ray's
/// `[Sx, Sy, Sz]`: the operations of [`crate::watertight::intersect_sheared`] after its
/// subtraction, in its order. Lanes outside `valid` never hit and are never rerun in f64 (a
/// group's padding lanes, [`super::group`]). Serves a packet against one triangle and one ray
/// against a group of triangles alike. `hit_t(i)` is [`crate::distance::hit_t`] of lane `i`'s
/// ray and triangle, called for the lanes that pass the inside test; `far(i)` the scalar f64
/// kernel for lane `i` ([`crate::far::intersect_watertight`] of its ray, shear and triangle),
/// called for the lanes where the scalar kernel calls it ([`crate::watertight::overflowed`]).
#[inline(always)]
pub(crate) fn watertight_lanes<L: Lanes>(
    rel: [[L; 3]; 3],
    s: [L; 3],
    tmin: L,
    tmax: L,
    valid: L,
    hit_t: impl Fn(usize) -> Option<f32>,
    far: impl Fn(usize) -> Option<(f32, f32, f32)>,
) -> PrimHits<L> {
    let [sx, sy, _] = s;
    let sheared = rel.map(|a| [a[0] - sx * a[2], a[1] - sy * a[2]]);
    let [[ax, ay], [bx, by], [cx, cy]] = sheared;
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    let zero = L::splat(0.0);
    let rerun = ((u.eq(zero) | v.eq(zero) | w.eq(zero)) & valid).bitmask();
    if rerun != 0 {
        // Paper §3.5, lane by lane: rare (a ray through an edge or a vertex in f32).
        let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
        let lanes = sheared.map(|p| p.map(L::to_array));
        for i in set_lanes(rerun) {
            let p = lanes.map(|[x, y]| [x.as_ref()[i], y.as_ref()[i]]);
            let [eu, ev, ew] = edge_functions_f64(p);
            ua.as_mut()[i] = eu;
            va.as_mut()[i] = ev;
            wa.as_mut()[i] = ew;
        }
        (u, v, w) = (L::from_array(ua), L::from_array(va), L::from_array(wa));
    }
    let inside = (u.ge(zero) & v.ge(zero) & w.ge(zero)) | (u.le(zero) & v.le(zero) & w.le(zero));
    let det = u + v + w;
    let inv = det.recip();
    let inf = L::splat(f32::INFINITY);
    // `watertight::finite`.
    let finite = det.abs().lt(inf) & inv.abs().lt(inf);
    let candidates = (valid & inside & det.abs().gt(zero) & finite).bitmask();
    let mut bits = 0;
    let mut t = zero.to_array();
    for i in set_lanes(candidates) {
        if let Some(ti) = hit_t(i) {
            bits |= 1 << i;
            t.as_mut()[i] = ti;
        }
    }
    let hits = PrimHits {
        mask: L::mask_from_bits(bits),
        t: L::from_array(t),
        u: v * inv,
        v: w * inv,
    };
    // `watertight::overflowed`, lane by lane.
    let redo = valid & tmin.lt(tmax) & det.ne(zero) & !finite;
    let redo = redo.bitmask();
    if redo != 0 {
        return hits.redo_far(redo, far);
    }
    hits
}
