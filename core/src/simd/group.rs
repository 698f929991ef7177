//! One ray against a group of four triangles ([`crate::group`]) in one pass of the 4-wide
//! kernels: the ray splat, the triangles in the lanes. The lane arithmetic is the packet kernels'
//! (`moller_trumbore_lanes`, `watertight_lanes`), which
//! round as the scalar kernels do, so lane `j` hits exactly when the scalar kernel hits the ray
//! with triangle `j`, with bit-identical `t`, `u`, `v` (`tests/tests/groups.rs`).
//!
//! [`closest_in_group`] then picks what testing the lanes one after another would have kept: the
//! nearest hit, the lowest lane among equals (a later triangle must be strictly nearer to replace
//! one). Applied to a leaf's groups in order, the single-ray walk gets the hits of the index-list
//! layout, ties included.

use super::f32x4;
use super::kernels::{PrimHits, TriangleLanes, moller_trumbore_lanes};
use super::lanes::{Lanes, Vec3x, set_lanes};
use super::watertight::watertight_lanes;
use crate::group::{Group, floats, ids, lane_vertices, slot};
use crate::ray::Ray;
use crate::triangle::Triangle;
use crate::watertight::Shear;

/// Vertex `k` (0, 1, 2) of the four lanes.
#[inline(always)]
fn vertex(g: &Group, k: usize) -> Vec3x<f32x4> {
    let at = slot::VERTICES + 12 * k;
    Vec3x {
        x: f32x4::from(floats(g, at)),
        y: f32x4::from(floats(g, at + 4)),
        z: f32x4::from(floats(g, at + 8)),
    }
}

/// The stored thresholds of the four lanes.
#[inline(always)]
fn thresholds(g: &Group) -> f32x4 {
    f32x4::from(floats(g, slot::MIN_DET2))
}

/// Möller–Trumbore of `ray` against the four triangles: lane `j` as
/// [`crate::Triangle::intersect_prepared`] of triangle `j` with its stored threshold (padding
/// lanes, `+inf`, never hit). The edges are the subtractions [`crate::Triangle::from_vertices`]
/// makes.
#[inline(always)]
pub fn intersect_group(g: &Group, ray: &Ray) -> PrimHits<f32x4> {
    let v0 = vertex(g, 0);
    let tri = TriangleLanes {
        v0,
        e1: vertex(g, 1) - v0,
        e2: vertex(g, 2) - v0,
        min_det2: thresholds(g),
    };
    let splat = |x: f32| f32x4::splat(x);
    moller_trumbore_lanes::<f32x4, true>(
        &tri,
        &Vec3x::splat(ray.origin),
        &Vec3x::splat(ray.dir),
        splat(ray.tmin),
        splat(ray.tmax),
        |j| {
            let [v0, v1, v2] = lane_vertices(g, j);
            let Triangle { v0, e1, e2 } = Triangle::from_vertices(v0, v1, v2);
            crate::far::intersect_moller_trumbore(&v0, &e1, &e2, ray)
        },
    )
}

/// The watertight test of `ray` (its [`Shear`]) against the four triangles: lane `j` as
/// [`crate::watertight::intersect_sheared`] of triangle `j` with its stored threshold (`+inf`,
/// a degenerate triangle or padding, is never hit).
#[inline(always)]
pub fn intersect_group_watertight(g: &Group, ray: &Ray, shear: &Shear) -> PrimHits<f32x4> {
    let o = ray.origin.to_array();
    let [kx, ky, kz] = shear.k;
    let origin = [
        f32x4::splat(o[kx]),
        f32x4::splat(o[ky]),
        f32x4::splat(o[kz]),
    ];
    // `(v − o)[k]` of the scalar kernel: the same subtraction, component k only. (Written out:
    // array `map`s here were left as out-of-line calls.)
    let relative = |v: Vec3x<f32x4>| {
        let comp = [v.x, v.y, v.z];
        [
            comp[kx] - origin[0],
            comp[ky] - origin[1],
            comp[kz] - origin[2],
        ]
    };
    let rel = [
        relative(vertex(g, 0)),
        relative(vertex(g, 1)),
        relative(vertex(g, 2)),
    ];
    let valid = thresholds(g).lt(f32x4::splat(f32::INFINITY));
    watertight_lanes(
        rel,
        [
            f32x4::splat(shear.s[0]),
            f32x4::splat(shear.s[1]),
            f32x4::splat(shear.s[2]),
        ],
        f32x4::splat(ray.tmin),
        f32x4::splat(ray.tmax),
        valid,
        |j| {
            crate::distance::hit_t(
                &lane_vertices(g, j),
                ray.origin,
                ray.dir,
                ray.tmin,
                ray.tmax,
            )
        },
        |j| {
            let [sx, sy, _] = shear.s;
            crate::far::intersect_watertight(&lane_vertices(g, j), ray, shear.k, [sx, sy])
        },
    )
}

/// The hit that testing the lanes of `found` in order would keep — the nearest, the lowest lane
/// among equals — as `(t, u, v, id)`, or `None` when no lane hit.
#[inline(always)]
pub fn closest_in_group(g: &Group, found: &PrimHits<f32x4>) -> Option<(f32, f32, f32, u32)> {
    let bits = found.mask.bitmask();
    if bits == 0 {
        return None;
    }
    let t = found.t.to_array();
    let mut best = bits.trailing_zeros() as usize;
    for j in set_lanes(bits & (bits - 1)) {
        if t[j] < t[best] {
            best = j;
        }
    }
    let (u, v) = (found.u.to_array(), found.v.to_array());
    Some((t[best], u[best], v[best], ids(g)[best]))
}
