//! The SIMD packet kernels (`kdray_core::simd`) against their scalar twins, lane by lane.
//!
//! Every test is written once, generic over the lane type, and instantiated for 4 and 8 lanes by
//! `lane_tests!` (the pattern of wide's `tests/simd_float.rs`). Each compares, for every lane:
//! hit or miss, then `t`, `u`, `v` to within [`MAX_ULPS`]; and checks that the closest-hit update
//! and the write-back touch active lanes only (outputs are pre-filled with [`SENTINEL`]).
//!
//! Inputs: first every edge value ([`EDGES`]: ±0, ±inf, NaN, denormals, tiny, huge) put in turn
//! into each float of a base triangle, sphere and ray, plus named special cases (parallel rays,
//! degenerate triangles, origins on the surface, tangent rays, `t == tmax`); then random inputs
//! from proptest, both arbitrary bit patterns and rays aimed at the primitive. The watertight
//! kernel (`kdray_core::watertight`, packet `intersect_triangle_watertight`) is fed the triangle
//! inputs as vertices (`v0, v0 + e1, v0 + e2`), and the same random ones.

use glam::Vec3;
use kdray_core::simd::{
    HitPacket, Lanes, PrimHits, RayPacket, ShearX, f32x4, f32x8, f32x16, intersect_sphere,
    intersect_triangle, intersect_triangle_watertight, record_closest,
};
use kdray_core::{Hit, Ray, Sphere, Triangle, math, watertight};
use kdray_tests::EDGES;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Largest distance in ULPs allowed between a packet lane's `t`, `u`, `v` and the scalar's.
///
/// 0: the packet kernels use no FMA and evaluate the scalar formulas operation for operation, so
/// every lane is bit-identical to the scalar result (±0 are counted equal). Were a kernel to use
/// `mul_add`, the fused rounding would move `t` by a few ULPs and this would have to grow.
const MAX_ULPS: u32 = 0;

/// A hit that no kernel produces: lanes that must not be written keep it.
const SENTINEL: Hit = Hit {
    t: -12_345.0,
    prim: 0xDEAD_BEEF,
    u: 99.0,
    v: -99.0,
};

/// Distance in units in the last place, with `+0 == −0`; NaN is 0 from NaN and `u32::MAX` from
/// anything else.
fn ulps(a: f32, b: f32) -> u32 {
    if a.is_nan() || b.is_nan() {
        return if a.is_nan() && b.is_nan() {
            0
        } else {
            u32::MAX
        };
    }
    // Map the floats onto a line of integers in their order, both zeros at 0.
    let key = |x: f32| {
        let bits = x.to_bits();
        if bits >> 31 == 1 {
            -i64::from(bits & 0x7FFF_FFFF)
        } else {
            i64::from(bits)
        }
    };
    u32::try_from((key(a) - key(b)).unsigned_abs()).unwrap_or(u32::MAX)
}

/// A primitive of either kind, with its scalar and packet kernels.
#[derive(Clone, Copy, Debug)]
enum Prim {
    Tri(Triangle),
    Sphere(Sphere),
    /// A triangle by its vertices, for the watertight kernel.
    Watertight([Vec3; 3]),
}

/// The watertight kernel's view of `tri`: its vertices.
fn watertight_prim(tri: Triangle) -> Prim {
    Prim::Watertight(tri.vertices())
}

impl Prim {
    /// The scalar reference: `(t, u, v)`, with `u = v = 0` for a sphere.
    fn scalar(&self, ray: &Ray) -> Option<(f32, f32, f32)> {
        match self {
            Prim::Tri(tri) => tri.intersect(ray),
            Prim::Sphere(s) => s.intersect(ray).map(|t| (t, 0.0, 0.0)),
            Prim::Watertight(v) => watertight::intersect(v, ray),
        }
    }

    fn packet<L: Lanes>(&self, rays: &RayPacket<L>) -> PrimHits<L> {
        match self {
            Prim::Tri(tri) => intersect_triangle(tri, rays),
            Prim::Sphere(s) => intersect_sphere(s, rays),
            Prim::Watertight(v) => intersect_triangle_watertight(v, rays, &ShearX::new(rays)),
        }
    }
}

fn lane<L: Lanes>(x: L, i: usize) -> f32 {
    x.to_array().as_ref()[i]
}

#[allow(
    clippy::absurd_extreme_comparisons,
    reason = "MAX_ULPS is 0 today; `<=` keeps the test right if it is raised"
)]
fn close(what: &str, i: usize, got: f32, want: f32) -> Result<(), TestCaseError> {
    prop_assert!(
        ulps(got, want) <= MAX_ULPS,
        "lane {i}: {what} = {got:e} ({:#010x}), scalar {want:e} ({:#010x})",
        got.to_bits(),
        want.to_bits()
    );
    Ok(())
}

fn same_hit(i: usize, got: &Hit, want: &Hit) -> Result<(), TestCaseError> {
    prop_assert_eq!(
        got.prim,
        want.prim,
        "lane {}: {:?} vs scalar {:?}",
        i,
        got,
        want
    );
    close("t", i, got.t, want.t)?;
    close("u", i, got.u, want.u)?;
    close("v", i, got.v, want.v)
}

/// One primitive against `rays` (at most `W`) in one packet:
/// - the raw kernel: each present lane hits exactly when the scalar does, with the same `t`, `u`,
///   `v`; absent lanes never hit;
/// - [`record_closest`] and [`HitPacket::write_active`]: finite rays get the scalar's answer (hit
///   or [`Hit::MISS`]) and a hit shrinks the lane's `tmax` to `t`; non-finite rays and absent lanes
///   leave their [`SENTINEL`] untouched, even with an output longer than the packet.
fn check_one<L: Lanes>(prim: &Prim, rays: &[Ray]) -> Result<(), TestCaseError> {
    assert!(rays.len() <= L::WIDTH);
    let mut packet = RayPacket::<L>::from_rays(rays);
    let found = prim.packet(&packet);
    let bits = found.mask.bitmask();
    for i in 0..L::WIDTH {
        let Some(ray) = rays.get(i) else {
            prop_assert_eq!(bits >> i & 1, 0, "absent lane {} hit", i);
            continue;
        };
        let want = prim.scalar(ray);
        prop_assert_eq!(
            bits >> i & 1 == 1,
            want.is_some(),
            "lane {}: packet hit mask {:#b}, scalar {:?}; {:?} vs {:?}",
            i,
            bits,
            want,
            prim,
            ray
        );
        if let Some((t, u, v)) = want {
            close("t", i, lane(found.t, i), t)?;
            close("u", i, lane(found.u, i), u)?;
            close("v", i, lane(found.v, i), v)?;
        }
    }

    let mut hits = HitPacket::<L>::miss();
    let recorded = record_closest(&mut hits, &mut packet, &found, 42);
    prop_assert_eq!(recorded, bits & packet.active.bitmask());
    let mut out = [SENTINEL; 9];
    hits.write_active(&packet, &mut out);
    for (i, got) in out.iter().enumerate() {
        match rays.get(i) {
            Some(ray) if ray.is_finite() => {
                let want = match prim.scalar(ray) {
                    Some((t, u, v)) => Hit { t, prim: 42, u, v },
                    None => Hit::MISS,
                };
                same_hit(i, got, &want)?;
                let tmax = lane(packet.tmax, i);
                if want.is_hit() {
                    close("tmax", i, tmax, want.t)?;
                } else {
                    prop_assert_eq!(tmax.to_bits(), ray.tmax.to_bits());
                }
            }
            _ => prop_assert_eq!(*got, SENTINEL, "lane {} was written", i),
        }
    }
    Ok(())
}

/// Closest hit over several primitives: the packet loop (kernel, then [`record_closest`], for
/// each primitive in order) against the scalar loop that shrinks `tmax` after each hit.
fn check_closest<L: Lanes>(prims: &[Prim], rays: &[Ray]) -> Result<(), TestCaseError> {
    let mut packet = RayPacket::<L>::from_rays(rays);
    let mut hits = HitPacket::<L>::miss();
    for (k, prim) in prims.iter().enumerate() {
        let found = prim.packet(&packet);
        record_closest(&mut hits, &mut packet, &found, k as u32);
    }
    let mut out = [SENTINEL; 16];
    hits.write_active(&packet, &mut out[..rays.len()]);
    for (i, ray) in rays.iter().enumerate() {
        if !ray.is_finite() {
            prop_assert_eq!(out[i], SENTINEL, "lane {} was written", i);
            continue;
        }
        let mut r = *ray;
        let mut want = Hit::MISS;
        for (k, prim) in prims.iter().enumerate() {
            if let Some((t, u, v)) = prim.scalar(&r) {
                want = Hit {
                    t,
                    prim: k as u32,
                    u,
                    v,
                };
                r.tmax = t;
            }
        }
        same_hit(i, &out[i], &want)?;
        same_hit(i, &hits.hit(i), &want)?;
    }
    for slot in &out[rays.len()..] {
        prop_assert_eq!(*slot, SENTINEL);
    }
    Ok(())
}

/// Runs [`check_one`] over `rays` in packets of 1, 2, …, `W` rays in turn, so that partly filled
/// packets are covered too.
fn check_all<L: Lanes>(prim: &Prim, rays: &[Ray]) {
    let mut rest = rays;
    let mut n = 1;
    while !rest.is_empty() {
        let (head, tail) = rest.split_at(n.min(rest.len()));
        if let Err(e) = check_one::<L>(prim, head) {
            panic!("{e}\n  prim {prim:?}\n  rays {head:?}");
        }
        rest = tail;
        n = n % L::WIDTH + 1;
    }
}

fn ray_floats(r: &Ray) -> [f32; 8] {
    let (o, d) = (r.origin, r.dir);
    [o.x, o.y, o.z, d.x, d.y, d.z, r.tmin, r.tmax]
}

fn ray_from_floats(f: [f32; 8]) -> Ray {
    Ray::new(Vec3::new(f[0], f[1], f[2]), Vec3::new(f[3], f[4], f[5])).with_range(f[6], f[7])
}

/// `base`, then each base ray with each of its 8 floats replaced by each edge value.
fn edge_rays(base: &[Ray]) -> Vec<Ray> {
    let mut rays = base.to_vec();
    for r in base {
        for slot in 0..8 {
            for e in EDGES {
                let mut f = ray_floats(r);
                f[slot] = e;
                rays.push(ray_from_floats(f));
            }
        }
    }
    rays
}

fn tri_floats(t: &Triangle) -> [f32; 9] {
    let (a, b, c) = (t.v0, t.e1, t.e2);
    [a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z]
}

fn tri_from_floats(f: [f32; 9]) -> Triangle {
    Triangle {
        v0: Vec3::new(f[0], f[1], f[2]),
        e1: Vec3::new(f[3], f[4], f[5]),
        e2: Vec3::new(f[6], f[7], f[8]),
    }
}

/// The unit right triangle in z = 0, and rays that hit it, miss it, graze it, start on it.
fn base_triangle() -> (Triangle, Vec<Ray>) {
    let tri = Triangle::from_vertices(Vec3::ZERO, Vec3::X, Vec3::Y);
    let down = Vec3::NEG_Z;
    let rays = vec![
        Ray::new(Vec3::new(0.25, 0.25, 1.0), down),
        Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.9, 0.9, 1.0), down),
        Ray::new(Vec3::new(0.5, 0.5, 1.0), down),
        Ray::new(
            Vec3::new(0.1, 0.2, 3.0),
            Vec3::new(0.1, 0.2, -1.0).normalize(),
        ),
        Ray::new(Vec3::new(0.25, 0.25, 0.0), down).with_range(-1.0, 1.0),
        Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X),
        Ray::new(Vec3::new(0.3, 0.3, 2.0), down).with_range(0.5, 2.0),
    ];
    (tri, rays)
}

/// `kernel` is `Prim::Tri` (Möller–Trumbore) or [`watertight_prim`].
fn triangle_edge_values<L: Lanes>(kernel: fn(Triangle) -> Prim) {
    let (base, base_rays) = base_triangle();
    let rays = edge_rays(&base_rays);
    check_all::<L>(&kernel(base), &rays);
    for slot in 0..9 {
        for e in EDGES {
            let mut f = tri_floats(&base);
            f[slot] = e;
            check_all::<L>(&kernel(tri_from_floats(f)), &rays);
        }
    }
}

/// `kernel` as in [`triangle_edge_values`].
fn triangle_special_cases<L: Lanes>(kernel: fn(Triangle) -> Prim) {
    let tri = Triangle::from_vertices(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(3.0, -1.0, 2.0), {
        Vec3::new(-1.0, 2.0, 2.5)
    });
    let n = tri.geometric_normal().normalize();
    let centre = tri.v0 + (tri.e1 + tri.e2) / 3.0;
    let o = Vec3::new(0.1, 0.2, -3.0);
    let to = |p: Vec3| Ray::new(o, (p - o).normalize());
    let mut rays = vec![
        // Parallel to the plane, in it and off it, and nearly parallel on both sides of the
        // threshold.
        Ray::new(centre, tri.e1.normalize()),
        Ray::new(centre + n, tri.e1.normalize()),
        Ray::new(centre - tri.e2 * 0.5, (tri.e2 + n * 1.0e-7).normalize()),
        Ray::new(centre - tri.e2 * 0.5, (tri.e2 + n * 3.0e-7).normalize()),
        Ray::new(centre - tri.e2 * 0.5, (tri.e2 + n * 1.0e-3).normalize()),
        // Starting on the triangle: t = 0 is outside (0, tmax) but inside (−1, tmax).
        Ray::new(centre, -n),
        Ray::new(centre, -n).with_range(-1.0, 1.0),
        Ray::new(centre, n).with_range(-0.0, 1.0),
        // Through the vertices, edge midpoints and centre.
        to(tri.v0),
        to(tri.v0 + tri.e1),
        to(tri.v0 + tri.e2),
        to(tri.v0 + tri.e1 * 0.5),
        to(tri.v0 + tri.e2 * 0.5),
        to(tri.v0 + (tri.e1 + tri.e2) * 0.5),
        to(centre),
        // Huge and tiny scales, zero and denormal directions.
        Ray::new(centre - n * 1.0e30, n),
        Ray::new(centre - n * 1.0e-30, n),
        Ray::new(centre - n, n * 1.0e-30),
        Ray::new(centre - n, n * 1.0e30),
        Ray::new(centre - n, Vec3::ZERO),
        Ray::new(centre - n, Vec3::splat(1.0e-40)),
        Ray::new(centre - n, -Vec3::ZERO),
    ];
    // tmax exactly at the hit: the open interval excludes it.
    let t = tri.intersect(&to(centre)).expect("aimed at the centre").0;
    rays.push(to(centre).with_range(0.0, t));
    rays.push(to(centre).with_range(t, f32::INFINITY));
    rays.push(to(centre).with_range(0.0, f32::from_bits(t.to_bits() + 1)));

    let degenerate = [
        Triangle::from_vertices(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO),
        Triangle::from_vertices(Vec3::ZERO, Vec3::X, Vec3::X * 2.0),
        Triangle::from_vertices(Vec3::ZERO, Vec3::X, Vec3::ZERO),
        // Not degenerate, but `|e1 × e2|²` underflows to 0: rejected as the scalar does.
        Triangle::from_vertices(Vec3::ZERO, Vec3::X * 1.0e-25, Vec3::Y * 1.0e-25),
        // … and one that overflows to inf.
        Triangle::from_vertices(Vec3::ZERO, Vec3::X * 1.0e25, Vec3::Y * 1.0e25),
    ];
    // Axis-aligned rays exactly through a vertex and an edge of a grid triangle: edge functions
    // of exactly 0, the watertight kernel's f64 rerun (one lane or several).
    let grid = Triangle::from_vertices(Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::Y * 2.0);
    let grid_rays: Vec<Ray> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
        .iter()
        .flat_map(|&(x, y)| {
            [
                Ray::new(Vec3::new(x, y, 1.0), Vec3::NEG_Z),
                Ray::new(Vec3::new(x, y, -1.0), Vec3::Z),
                Ray::new(Vec3::new(x, y, 1.0), Vec3::new(0.0, 0.0, -0.5)),
            ]
        })
        .collect();
    check_all::<L>(&kernel(grid), &grid_rays);
    check_all::<L>(&kernel(tri), &rays);
    for d in degenerate {
        check_all::<L>(&kernel(d), &rays);
        check_all::<L>(&kernel(d), &edge_rays(&base_triangle().1));
    }
}

/// A sphere of radius 1 at (0, 0, −5), and rays from outside, inside, tangent, on the surface.
fn base_sphere() -> (Sphere, Vec<Ray>) {
    let s = Sphere {
        center: Vec3::new(0.0, 0.0, -5.0),
        radius: 1.0,
    };
    let rays = vec![
        Ray::new(Vec3::ZERO, Vec3::NEG_Z),
        Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::X),
        Ray::new(Vec3::new(1.0, 0.0, 0.0), Vec3::NEG_Z),
        Ray::new(Vec3::new(0.5, 0.5, 0.0), Vec3::NEG_Z),
        Ray::new(Vec3::new(0.0, 0.0, -4.0), Vec3::Z),
        Ray::new(Vec3::new(0.0, 0.0, -4.0), Vec3::NEG_Z).with_range(-5.0, 5.0),
        Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Z),
        Ray::new(Vec3::ZERO, Vec3::NEG_Z).with_range(4.5, 5.5),
    ];
    (s, rays)
}

fn sphere_edge_values<L: Lanes>() {
    let (base, base_rays) = base_sphere();
    let rays = edge_rays(&base_rays);
    check_all::<L>(&Prim::Sphere(base), &rays);
    for slot in 0..4 {
        for e in EDGES {
            let mut s = base;
            match slot {
                0 => s.center.x = e,
                1 => s.center.y = e,
                2 => s.center.z = e,
                _ => s.radius = e,
            }
            check_all::<L>(&Prim::Sphere(s), &rays);
        }
    }
}

fn sphere_special_cases<L: Lanes>() {
    let c = Vec3::new(1.0, -2.0, 3.0);
    let r = 0.75;
    let s = Sphere {
        center: c,
        radius: r,
    };
    let mut rays = vec![
        // Starting at the tangent point itself, b = 0 and disc = 0: the q = 0 branch.
        Ray::new(c + Vec3::X * r, Vec3::Y),
        Ray::new(c + Vec3::X * r, Vec3::Y).with_range(-1.0, 1.0),
        Ray::new(c + Vec3::X * r, -Vec3::Y).with_range(-1.0, 1.0),
        // Tangent from afar, just inside and just outside.
        Ray::new(c + Vec3::new(r, -10.0, 0.0), Vec3::Y),
        Ray::new(c + Vec3::new(r * 0.999_999, -10.0, 0.0), Vec3::Y),
        Ray::new(c + Vec3::new(r * 1.000_001, -10.0, 0.0), Vec3::Y),
        // On the surface going in and going out; at the centre.
        Ray::new(c - Vec3::Z * r, Vec3::Z),
        Ray::new(c - Vec3::Z * r, -Vec3::Z),
        Ray::new(c, Vec3::new(1.0, 2.0, 2.0) / 3.0),
        // Far away (the case the cancellation-free form exists for) and huge/tiny offsets.
        Ray::new(c + Vec3::Z * 1.0e4, -Vec3::Z),
        Ray::new(c + Vec3::new(0.5, 0.0, 1.0e4), -Vec3::Z),
        Ray::new(c + Vec3::Z * 1.0e30, -Vec3::Z),
        Ray::new(c + Vec3::Z * 1.0e-30, -Vec3::Z),
        Ray::new(c - Vec3::Z * 5.0, Vec3::ZERO),
        Ray::new(c - Vec3::Z * 5.0, -Vec3::ZERO),
        // b = ±0 exactly: direction perpendicular to f.
        Ray::new(c + Vec3::X * 0.5, Vec3::Z),
        Ray::new(c + Vec3::X * 0.5, -Vec3::Z),
    ];
    let t = s.intersect(&rays[9]).expect("aimed at the sphere");
    rays.push(rays[9].with_range(0.0, t));
    rays.push(rays[9].with_range(t, f32::INFINITY));
    let others = [
        s,
        Sphere { radius: 0.0, ..s },
        Sphere { radius: -r, ..s },
        Sphere {
            radius: 1.0e-30,
            ..s
        },
        Sphere {
            radius: 1.0e30,
            ..s
        },
    ];
    for s in others {
        check_all::<L>(&Prim::Sphere(s), &rays);
    }
}

/// Lane primitives against their scalar meaning over the edge values.
fn lane_ops<L: Lanes>() {
    let w = L::WIDTH;
    for chunk in EDGES.chunks(w) {
        let x = L::from_fn(|i| chunk.get(i).copied().unwrap_or(2.0));
        let y = L::from_fn(|i| EDGES[(i * 7 + 3) % EDGES.len()]);
        for i in 0..w {
            let (a, b) = (lane(x, i), lane(y, i));
            assert_eq!(
                lane(x.sqrt(), i).to_bits(),
                math::sqrt(a).to_bits(),
                "sqrt {a}"
            );
            assert_eq!(
                lane(x.recip(), i).to_bits(),
                (1.0 / a).to_bits(),
                "recip {a}"
            );
            assert_eq!(lane(x.abs(), i).to_bits(), a.abs().to_bits(), "abs {a}");
            assert_eq!(
                lane(x.min(y), i).to_bits(),
                a.min(b).to_bits(),
                "min {a} {b}"
            );
            assert_eq!(
                lane(x.max(y), i).to_bits(),
                a.max(b).to_bits(),
                "max {a} {b}"
            );
            let bit = |m: L| m.bitmask() >> i & 1 == 1;
            assert_eq!(bit(x.lt(y)), a < b);
            assert_eq!(bit(x.le(y)), a <= b);
            assert_eq!(bit(x.gt(y)), a > b);
            assert_eq!(bit(x.ge(y)), a >= b);
            assert_eq!(bit(x.eq(y)), a == b);
            assert_eq!(bit(x.ne(y)), a != b);
            assert_eq!(bit(x.is_nan()), a.is_nan());
            assert_eq!(bit(x.is_finite()), a.is_finite());
        }
    }
    let full = (1u32 << w) - 1;
    for bits in [0, 1, 0b1010, full >> 1, full] {
        let m = L::mask_from_bits(bits);
        assert_eq!(m.bitmask(), bits);
        assert_eq!(
            (m.any(), m.all(), m.none()),
            (bits != 0, bits == full, bits == 0)
        );
        let sel = m.select(L::splat(1.0), L::splat(-1.0));
        let idx = L::index_to_array(m.select_index(L::splat_index(7), L::splat_index(9)));
        for i in 0..w {
            let on = bits >> i & 1 == 1;
            assert_eq!(lane(sel, i), if on { 1.0 } else { -1.0 });
            assert_eq!(idx.as_ref()[i], if on { 7 } else { 9 });
        }
    }
    let a = L::from_fn(|i| i as f32);
    assert_eq!(
        L::from_array(a.to_array()).to_array().as_ref(),
        a.to_array().as_ref()
    );
}

/// [`RayPacket::from_rays`]: lanes, reciprocal directions (`±inf` for `±0`), the active mask.
fn packet_from_rays<L: Lanes>() {
    let w = L::WIDTH;
    let rays = [
        Ray::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, -0.0, 0.5)).with_range(0.25, 9.0),
        Ray::new(Vec3::X, Vec3::new(f32::NAN, 0.0, 1.0)),
        Ray::new(Vec3::X, Vec3::Z).with_range(f32::NAN, 1.0),
        Ray::new(Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::Z),
        Ray::new(Vec3::X, Vec3::Z).with_range(f32::NEG_INFINITY, f32::INFINITY),
    ];
    for n in 0..=w.min(rays.len()) {
        let p = RayPacket::<L>::from_rays(&rays[..n]);
        let want_active = [true, false, false, false, true]
            .iter()
            .take(n)
            .enumerate()
            .fold(0u32, |m, (i, &a)| m | u32::from(a) << i);
        assert_eq!(p.active.bitmask(), want_active, "{n} rays");
        for (i, r) in rays[..n].iter().enumerate() {
            assert_eq!(format!("{:?}", p.ray(i)), format!("{r:?}"));
        }
        if n > 0 {
            let inv = p.inv_dir.lane(0);
            assert_eq!(inv, Vec3::new(f32::INFINITY, f32::NEG_INFINITY, 2.0));
        }
    }
    // Whole packets (the transposing path) of every mix: each lane holds its own ray, and is
    // active exactly when the ray is finite.
    let odd = [
        Ray::new(Vec3::new(0.0, f32::NEG_INFINITY, 0.0), Vec3::Z),
        Ray::new(Vec3::new(0.0, 0.0, f32::NAN), Vec3::Z),
        Ray::new(Vec3::splat(f32::MAX), Vec3::new(1e-38, -1e-45, -0.0)).with_range(-0.0, f32::MAX),
        Ray::new(Vec3::Y, Vec3::new(0.0, f32::INFINITY, 0.0)),
    ];
    let pool: Vec<Ray> = rays.iter().chain(&odd).copied().collect();
    for start in 0..pool.len() {
        let full: Vec<Ray> = (0..w).map(|i| pool[(start + i * 3) % pool.len()]).collect();
        let p = RayPacket::<L>::from_rays(&full);
        for (i, r) in full.iter().enumerate() {
            assert_eq!(format!("{:?}", p.ray(i)), format!("{r:?}"), "lane {i}");
            assert_eq!(
                p.active.bitmask() >> i & 1 == 1,
                r.is_finite(),
                "lane {i}: {r:?}"
            );
            assert_eq!(
                format!("{:?}", p.inv_dir.lane(i)),
                format!("{:?}", r.dir.recip()),
                "lane {i}"
            );
        }
    }
    // More rays than lanes: the first W are taken, all active.
    let many = vec![rays[0]; w + 3];
    let p = RayPacket::<L>::from_rays(&many);
    assert!(p.active.all());
    assert_eq!(p.width(), w);
}

fn finite_vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn unit_vec3() -> impl Strategy<Value = Vec3> {
    finite_vec3(-1.0, 1.0)
        .prop_filter("not too short to normalize", |v| v.length() > 0.1)
        .prop_map(Vec3::normalize)
}

/// Any f32 bit pattern (NaN, ±inf, denormals included), an edge value, or an ordinary one.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        prop::num::f32::ANY,
        prop::sample::select(&EDGES[..]),
        -4.0f32..4.0,
    ]
}

fn any_vec3() -> impl Strategy<Value = Vec3> {
    (any_f32(), any_f32(), any_f32()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn any_ray() -> impl Strategy<Value = Ray> {
    (any_vec3(), any_vec3(), any_f32(), any_f32())
        .prop_map(|(o, d, t0, t1)| Ray::new(o, d).with_range(t0, t1))
}

fn any_triangle() -> impl Strategy<Value = Triangle> {
    (any_vec3(), any_vec3(), any_vec3()).prop_map(|(v0, e1, e2)| Triangle { v0, e1, e2 })
}

fn any_sphere() -> impl Strategy<Value = Sphere> {
    (any_vec3(), any_f32()).prop_map(|(center, radius)| Sphere { center, radius })
}

/// A triangle in a 20-unit box, at a scale from 10⁻³⁰ to 10³⁰ (all inputs scaled alike).
fn scaled_triangle() -> impl Strategy<Value = (Triangle, f32)> {
    (
        finite_vec3(-10.0, 10.0),
        finite_vec3(-5.0, 5.0),
        finite_vec3(-5.0, 5.0),
        prop::sample::select(&[1.0f32, 1.0, 1.0, 1.0e-30, 1.0e-10, 1.0e10, 1.0e30][..]),
    )
        .prop_map(|(v0, e1, e2, k)| {
            (
                Triangle::from_vertices(v0 * k, (v0 + e1) * k, (v0 + e2) * k),
                k,
            )
        })
}

/// Rays from a 40-unit box towards a point `v0 + a·e1 + b·e2` with `a`, `b` in [−0.2, 1.2] (so
/// about half hit), unit direction, `tmin` 0 or a small negative, `tmax` inf or random.
fn aimed_rays(
    target: impl Fn(f32, f32) -> Vec3 + Clone + 'static,
    k: f32,
    n: usize,
) -> impl Strategy<Value = Vec<Ray>> {
    let ray = (
        finite_vec3(-20.0, 20.0),
        -0.2f32..1.2,
        -0.2f32..1.2,
        prop::sample::select(&[0.0f32, 0.0, -0.5][..]),
        prop_oneof![Just(f32::INFINITY), 0.0f32..60.0],
    )
        .prop_map(move |(o, a, b, tmin, tmax)| {
            let o = o * k;
            let d = (target(a, b) - o).normalize_or(Vec3::Z);
            Ray::new(o, d).with_range(tmin * k, tmax * k)
        });
    prop::collection::vec(ray, 1..=n)
}

fn aimed_at_triangle(w: usize) -> impl Strategy<Value = (Triangle, Vec<Ray>)> {
    scaled_triangle().prop_flat_map(move |(tri, k)| {
        let rays = aimed_rays(move |a, b| tri.v0 + tri.e1 * a + tri.e2 * b, k, w);
        (Just(tri), rays)
    })
}

fn aimed_at_sphere(w: usize) -> impl Strategy<Value = (Sphere, Vec<Ray>)> {
    (
        finite_vec3(-10.0, 10.0),
        0.01f32..5.0,
        prop::sample::select(&[1.0f32, 1.0, 1.0e-30, 1.0e-10, 1.0e10, 1.0e30][..]),
    )
        .prop_flat_map(move |(c, r, k)| {
            let s = Sphere {
                center: c * k,
                radius: r * k,
            };
            // a, b in [−0.2, 1.2] → a point within 1.4 R of the centre, in a fixed plane.
            let target = move |a: f32, b: f32| {
                s.center + Vec3::new(a - 0.5, b - 0.5, 0.0) * (2.8 * s.radius)
            };
            (Just(s), aimed_rays(target, k, w))
        })
}

/// A small scene of triangles and spheres around the origin, in random order.
fn scene() -> impl Strategy<Value = Vec<Prim>> {
    let tri = (
        finite_vec3(-3.0, 3.0),
        finite_vec3(-2.0, 2.0),
        finite_vec3(-2.0, 2.0),
    )
        .prop_map(|(v0, e1, e2)| Prim::Tri(Triangle { v0, e1, e2 }));
    let sphere = (finite_vec3(-3.0, 3.0), 0.1f32..1.5)
        .prop_map(|(center, radius)| Prim::Sphere(Sphere { center, radius }));
    prop::collection::vec(prop_oneof![3 => tri, 1 => sphere], 1..24)
}

fn scene_rays(w: usize) -> impl Strategy<Value = Vec<Ray>> {
    let ray = (finite_vec3(-8.0, 8.0), finite_vec3(-1.0, 1.0), unit_vec3()).prop_map(
        |(o, target, jitter)| {
            let d = (target - o + jitter * 0.3).normalize_or(Vec3::X);
            Ray::new(o, d)
        },
    );
    prop::collection::vec(prop_oneof![9 => ray, 1 => any_ray()], 1..=w)
}

macro_rules! lane_tests {
    ($name:ident, $lanes:ty) => {
        mod $name {
            use super::*;

            const W: usize = <$lanes as Lanes>::WIDTH;

            #[test]
            fn lane_ops_match_scalar() {
                lane_ops::<$lanes>();
            }

            #[test]
            fn packet_from_rays_lanes_and_active_mask() {
                packet_from_rays::<$lanes>();
            }

            #[test]
            fn triangle_edge_values_match_scalar() {
                triangle_edge_values::<$lanes>(Prim::Tri);
            }

            #[test]
            fn triangle_special_cases_match_scalar() {
                triangle_special_cases::<$lanes>(Prim::Tri);
            }

            #[test]
            fn watertight_edge_values_match_scalar() {
                triangle_edge_values::<$lanes>(watertight_prim);
            }

            #[test]
            fn watertight_special_cases_match_scalar() {
                triangle_special_cases::<$lanes>(watertight_prim);
            }

            #[test]
            fn sphere_edge_values_match_scalar() {
                sphere_edge_values::<$lanes>();
            }

            #[test]
            fn sphere_special_cases_match_scalar() {
                sphere_special_cases::<$lanes>();
            }

            proptest! {
                #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(2000)))]

                #[test]
                fn triangle_any_bits_matches_scalar(
                    tri in any_triangle(),
                    rays in prop::collection::vec(any_ray(), 1..=W),
                ) {
                    check_one::<$lanes>(&Prim::Tri(tri), &rays)?;
                }

                #[test]
                fn triangle_aimed_rays_match_scalar((tri, rays) in aimed_at_triangle(W)) {
                    check_one::<$lanes>(&Prim::Tri(tri), &rays)?;
                }

                #[test]
                fn watertight_any_bits_matches_scalar(
                    v in (any_vec3(), any_vec3(), any_vec3()),
                    rays in prop::collection::vec(any_ray(), 1..=W),
                ) {
                    check_one::<$lanes>(&Prim::Watertight([v.0, v.1, v.2]), &rays)?;
                }

                #[test]
                fn watertight_aimed_rays_match_scalar((tri, rays) in aimed_at_triangle(W)) {
                    check_one::<$lanes>(&watertight_prim(tri), &rays)?;
                }

                #[test]
                fn sphere_any_bits_matches_scalar(
                    s in any_sphere(),
                    rays in prop::collection::vec(any_ray(), 1..=W),
                ) {
                    check_one::<$lanes>(&Prim::Sphere(s), &rays)?;
                }

                #[test]
                fn sphere_aimed_rays_match_scalar((s, rays) in aimed_at_sphere(W)) {
                    check_one::<$lanes>(&Prim::Sphere(s), &rays)?;
                }

                #[test]
                fn closest_hit_matches_scalar_loop(prims in scene(), rays in scene_rays(W)) {
                    check_closest::<$lanes>(&prims, &rays)?;
                }
            }
        }
    };
}

lane_tests!(x4, f32x4);
lane_tests!(x8, f32x8);
lane_tests!(x16, f32x16);
