//! One ray against a group of four triangles ([`crate::group`]) in one pass of the 4-wide
//! kernels, or against two groups in one pass of the 8-wide kernels: the ray splat, the
//! triangles in the lanes. The lane arithmetic is the packet kernels' (`moller_trumbore_lanes`,
//! `watertight_lanes`), which round as the scalar kernels do, so lane `j` hits exactly when the
//! scalar kernel hits the ray with triangle `j`, with bit-identical `t`, `u`, `v`
//! (`tests/tests/groups.rs`).
//!
//! [`closest_in_group`] then picks what testing the lanes one after another would have kept: the
//! nearest hit, the lowest lane among equals (a later triangle must be strictly nearer to replace
//! one). Applied to a leaf's groups in order, the single-ray walk gets the hits of the index-list
//! layout, ties included. Two groups in one test ([`Pair`]) keep that: their lanes are the first
//! group's then the second's, and a lane of the second that the sequential test would have missed
//! (not strictly nearer than the first group's hit) loses the tie or the comparison.

use super::kernels::{PrimHits, TriangleLanes, moller_trumbore_lanes};
use super::lanes::{Lanes, Vec3x, set_lanes};
use super::watertight::watertight_lanes;
use super::{f32x4, f32x8};
use crate::group::{Group, floats, ids, lane_vertices, slot};
use crate::ray::Ray;
use crate::triangle::Triangle;
use crate::watertight::Shear;
use glam::Vec3;

/// The triangles one test takes: a group in four lanes, or a [`Pair`] of groups in eight.
pub trait GroupLanes: Copy {
    /// The lanes of one test.
    type L: Lanes;
    /// Vertex `k` (0, 1, 2) of every lane.
    fn vertex(self, k: usize) -> Vec3x<Self::L>;
    /// The stored thresholds of every lane.
    fn thresholds(self) -> Self::L;
    /// Lane `j`'s vertices.
    fn lane_vertices(self, j: usize) -> [Vec3; 3];
    /// Lane `j`'s triangle id.
    fn id(self, j: usize) -> u32;
}

impl GroupLanes for &Group {
    type L = f32x4;
    #[inline(always)]
    fn vertex(self, k: usize) -> Vec3x<f32x4> {
        let at = slot::VERTICES + 12 * k;
        Vec3x {
            x: f32x4::from(floats(self, at)),
            y: f32x4::from(floats(self, at + 4)),
            z: f32x4::from(floats(self, at + 8)),
        }
    }
    #[inline(always)]
    fn thresholds(self) -> f32x4 {
        f32x4::from(floats(self, slot::MIN_DET2))
    }
    #[inline(always)]
    fn lane_vertices(self, j: usize) -> [Vec3; 3] {
        lane_vertices(self, j)
    }
    #[inline(always)]
    fn id(self, j: usize) -> u32 {
        ids(self)[j]
    }
}

/// Two groups tested at once: lanes 0..4 the first, 4..8 the second.
#[derive(Clone, Copy, Debug)]
pub struct Pair<'a>(pub &'a Group, pub &'a Group);

impl Pair<'_> {
    /// Four words of each group from `at`, side by side.
    #[inline(always)]
    fn floats(self, at: usize) -> f32x8 {
        let (a, b) = (floats(self.0, at), floats(self.1, at));
        f32x8::from([a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]])
    }
}

impl GroupLanes for Pair<'_> {
    type L = f32x8;
    #[inline(always)]
    fn vertex(self, k: usize) -> Vec3x<f32x8> {
        let at = slot::VERTICES + 12 * k;
        Vec3x {
            x: self.floats(at),
            y: self.floats(at + 4),
            z: self.floats(at + 8),
        }
    }
    #[inline(always)]
    fn thresholds(self) -> f32x8 {
        self.floats(slot::MIN_DET2)
    }
    #[inline(always)]
    fn lane_vertices(self, j: usize) -> [Vec3; 3] {
        if j < 4 {
            lane_vertices(self.0, j)
        } else {
            lane_vertices(self.1, j - 4)
        }
    }
    #[inline(always)]
    fn id(self, j: usize) -> u32 {
        if j < 4 {
            ids(self.0)[j]
        } else {
            ids(self.1)[j - 4]
        }
    }
}

/// The triangles of a listed leaf (at most a test's width, in order) gathered from the triangles
/// section straight into lanes ([`crate::Scene::gather4`], [`crate::Scene::gather8`]): lane `j`
/// the stored triangle `ids[j]`, bit for bit, the lanes past `ids.len()` padding (vertices 0,
/// threshold `+inf`, never hit). The same lanes as the group, or the [`Pair`] of groups, that
/// `group::pack` makes of those triangles, without writing them to memory and reading them back.
#[derive(Clone, Copy, Debug)]
pub struct Gathered<'a, L> {
    /// Word `m` of every lane's stored row: the vertices' coordinates (`3k + axis` for vertex
    /// `k`), then the threshold (word 9).
    pub words: [L; 10],
    /// The lanes' triangles.
    pub ids: &'a [u32],
}

impl<L: Lanes> GroupLanes for Gathered<'_, L> {
    type L = L;
    #[inline(always)]
    fn vertex(self, k: usize) -> Vec3x<L> {
        Vec3x {
            x: self.words[3 * k],
            y: self.words[3 * k + 1],
            z: self.words[3 * k + 2],
        }
    }
    #[inline(always)]
    fn thresholds(self) -> L {
        self.words[9]
    }
    #[inline(always)]
    fn lane_vertices(self, j: usize) -> [Vec3; 3] {
        let w = |m: usize| self.words[m].to_array().as_ref()[j];
        [
            Vec3::new(w(0), w(1), w(2)),
            Vec3::new(w(3), w(4), w(5)),
            Vec3::new(w(6), w(7), w(8)),
        ]
    }
    #[inline(always)]
    fn id(self, j: usize) -> u32 {
        self.ids.get(j).copied().unwrap_or(crate::group::PAD_ID)
    }
}

/// Möller–Trumbore of `ray` against the four triangles: lane `j` as
/// [`crate::Triangle::intersect_prepared`] of triangle `j` with its stored threshold (padding
/// lanes, `+inf`, never hit). The edges are the subtractions [`crate::Triangle::from_vertices`]
/// makes.
#[inline(always)]
pub fn intersect_group<G: GroupLanes>(g: G, ray: &Ray) -> PrimHits<G::L> {
    let v0 = g.vertex(0);
    let tri = TriangleLanes {
        v0,
        e1: g.vertex(1) - v0,
        e2: g.vertex(2) - v0,
        min_det2: g.thresholds(),
    };
    let splat = |x: f32| G::L::splat(x);
    moller_trumbore_lanes::<G::L, true>(
        &tri,
        &Vec3x::splat(ray.origin),
        &Vec3x::splat(ray.dir),
        splat(ray.tmin),
        splat(ray.tmax),
        |j| {
            let [v0, v1, v2] = g.lane_vertices(j);
            let Triangle { v0, e1, e2 } = Triangle::from_vertices(v0, v1, v2);
            crate::far::intersect_moller_trumbore(&v0, &e1, &e2, ray)
        },
    )
}

/// The watertight test of `ray` (its [`Shear`]) against the four triangles: lane `j` as
/// [`crate::watertight::intersect_sheared`] of triangle `j` with its stored threshold (`+inf`,
/// a degenerate triangle or padding, is never hit).
#[inline(always)]
pub fn intersect_group_watertight<G: GroupLanes>(g: G, ray: &Ray, shear: &Shear) -> PrimHits<G::L> {
    let o = ray.origin.to_array();
    let [kx, ky, kz] = shear.k;
    let origin = [G::L::splat(o[kx]), G::L::splat(o[ky]), G::L::splat(o[kz])];
    // `(v − o)[k]` of the scalar kernel: the same subtraction, component k only. (Written out:
    // array `map`s here were left as out-of-line calls.)
    let relative = |v: Vec3x<G::L>| {
        let comp = [v.x, v.y, v.z];
        [
            comp[kx] - origin[0],
            comp[ky] - origin[1],
            comp[kz] - origin[2],
        ]
    };
    let rel = [
        relative(g.vertex(0)),
        relative(g.vertex(1)),
        relative(g.vertex(2)),
    ];
    let valid = g.thresholds().lt(G::L::splat(f32::INFINITY));
    watertight_lanes(
        rel,
        [
            G::L::splat(shear.s[0]),
            G::L::splat(shear.s[1]),
            G::L::splat(shear.s[2]),
        ],
        G::L::splat(ray.tmin),
        G::L::splat(ray.tmax),
        valid,
        |j| crate::distance::hit_t(&g.lane_vertices(j), ray.origin, ray.dir, ray.tmin, ray.tmax),
        |j| {
            let [sx, sy, _] = shear.s;
            crate::far::intersect_watertight(&g.lane_vertices(j), ray, shear.k, [sx, sy])
        },
    )
}

/// The hit that testing the lanes of `found` in order would keep — the nearest, the lowest lane
/// among equals — as `(t, u, v, id)`, or `None` when no lane hit.
#[inline(always)]
pub fn closest_in_group<G: GroupLanes>(
    g: G,
    found: &PrimHits<G::L>,
) -> Option<(f32, f32, f32, u32)> {
    let bits = found.mask.bitmask();
    if bits == 0 {
        return None;
    }
    let t = found.t.to_array();
    let t = t.as_ref();
    let mut best = bits.trailing_zeros() as usize;
    for j in set_lanes(bits & (bits - 1)) {
        if t[j] < t[best] {
            best = j;
        }
    }
    let (u, v) = (found.u.to_array(), found.v.to_array());
    Some((t[best], u.as_ref()[best], v.as_ref()[best], g.id(best)))
}
