//! Stiff cases of the ray/triangle kernels, scalar and 4-/8-wide: grazing rays, rays lying in the
//! triangle's plane, degenerate and needle triangles, and triangles so small that their area
//! approaches the f32 limit. Every case runs through each kernel in [`KERNELS`], Möller–Trumbore
//! (fast mode) and watertight (Woop, Benthin & Wald 2013); the packet kernels must also agree with
//! the scalar one of their family lane by lane. The watertight expectations come from the
//! rounding-error bound derived in `kdray_tests::wt_bound` (where the kernel must hit, how far its
//! `t` may be off, where `T` must underflow); each test also asserts that the bound covers the
//! rays its doc says it does, so that the expectation is not vacuous.

use glam::Vec3;
use kdray_core::simd::{
    Lanes, RayPacket, ShearX, f32x4, f32x8, intersect_triangle_watertight, kernels,
};
use kdray_core::triangle::PARALLEL_SIN;
use kdray_core::{Ray, Triangle, watertight};
use kdray_tests::Lcg;
use kdray_tests::f64ref::{self, dv};
use kdray_tests::strategies::U;
use kdray_tests::wt_bound::{self, Expect};

/// A triangle kernel as the cases see it: `(t, α, β)` of a hit of the triangle with vertices `v`.
type Kernel = fn(&[Vec3; 3], &Ray) -> Option<(f32, f32, f32)>;

/// The two kernel families: Möller–Trumbore (fast mode) and watertight (Woop et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Family {
    Mt,
    Wt,
}

/// Möller–Trumbore, scalar.
fn mt(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    Triangle::from_vertices(v[0], v[1], v[2]).intersect(ray)
}

/// Watertight, scalar.
fn wt(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    watertight::intersect(v, ray)
}

/// Lane `lane` of a packet kernel of `family`, with the ray in that lane and the others filled
/// with it too.
fn packet<L: Lanes>(
    family: Family,
    v: &[Vec3; 3],
    ray: &Ray,
    lane: usize,
) -> Option<(f32, f32, f32)> {
    let rays = RayPacket::<L>::from_rays(&vec![*ray; L::WIDTH]);
    let hits = match family {
        Family::Mt => {
            kernels::intersect_triangle(&Triangle::from_vertices(v[0], v[1], v[2]), &rays)
        }
        Family::Wt => intersect_triangle_watertight(v, &rays, &ShearX::new(&rays)),
    };
    let at = |x: L| x.to_array().as_ref()[lane];
    (hits.mask.bitmask() >> lane & 1 == 1).then(|| (at(hits.t), at(hits.u), at(hits.v)))
}

fn mt4(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    packet::<f32x4>(Family::Mt, v, ray, 3)
}

fn mt8(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    packet::<f32x8>(Family::Mt, v, ray, 5)
}

fn wt4(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    packet::<f32x4>(Family::Wt, v, ray, 2)
}

fn wt8(v: &[Vec3; 3], ray: &Ray) -> Option<(f32, f32, f32)> {
    packet::<f32x8>(Family::Wt, v, ray, 6)
}

/// Every kernel under test, by name and family.
const KERNELS: [(&str, Family, Kernel); 6] = [
    ("mt scalar", Family::Mt, mt),
    ("mt x4", Family::Mt, mt4),
    ("mt x8", Family::Mt, mt8),
    ("wt scalar", Family::Wt, wt),
    ("wt x4", Family::Wt, wt4),
    ("wt x8", Family::Wt, wt8),
];

/// Runs `case` for each kernel, checking that the packet kernels return exactly what the scalar
/// kernel of their family returns (the same `t` bits).
fn each_kernel(
    v: &[Vec3; 3],
    ray: &Ray,
    mut case: impl FnMut(Family, &str, Option<(f32, f32, f32)>),
) {
    let scalar = |family| {
        if family == Family::Mt {
            mt(v, ray)
        } else {
            wt(v, ray)
        }
    };
    for (name, family, kernel) in KERNELS {
        let got = kernel(v, ray);
        assert_eq!(
            got.map(|h| h.0.to_bits()),
            scalar(family).map(|h| h.0.to_bits()),
            "{name} differs from its scalar kernel on {v:?}, {ray:?}"
        );
        case(family, name, got);
    }
}

/// Holds a watertight kernel's answer `got` to [`wt_bound::expect`]: where the bound says it
/// must hit (and its exact `t` is inside the ray's range by more than the `t` bound), a hit
/// with `|t − t_exact| ≤ t_err`; where `T` must underflow, a miss. Returns `|Δt| / t_err` of a
/// hit the bound covers, for the measured worst case.
fn check_wt(name: &str, e: &Expect, ray: &Ray, got: Option<(f32, f32, f32)>) -> Option<f64> {
    let (lo, hi) = (f64::from(ray.tmin), f64::from(ray.tmax));
    if e.normal && e.must_hit && e.t - e.t_err > lo && e.t + e.t_err < hi {
        let (t, _, _) =
            got.unwrap_or_else(|| panic!("{name}: lost a hit the bound requires, {ray:?}, {e:?}"));
        let dt = (f64::from(t) - e.t).abs();
        assert!(
            dt <= e.t_err,
            "{name}: t {t} vs {} (bound {}), {ray:?}",
            e.t,
            e.t_err
        );
        return Some(dt / e.t_err);
    }
    if e.must_miss_underflow && ray.tmin >= 0.0 {
        assert_eq!(got, None, "{name}: T underflows, yet a hit, {ray:?}");
    }
    None
}

/// `v` rotated by a random rotation about the origin, then moved by `offset`.
fn rotated(rng: &mut Lcg, v: [Vec3; 3], offset: Vec3) -> [Vec3; 3] {
    let a = random_unit(rng);
    let b = a.any_orthonormal_vector();
    let c = a.cross(b);
    v.map(|p| a * p.x + b * p.y + c * p.z + offset)
}

fn random_unit(rng: &mut Lcg) -> Vec3 {
    loop {
        let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE;
        if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// `|e1|·|e2| / |e1 × e2|` (f64): 1 / sine of the angle at `v0`, how much the triangle magnifies
/// rounding in its barycentrics and its plane.
fn shape_condition(v: &[Vec3; 3]) -> f64 {
    let (e1, e2) = (dv(v[1]) - dv(v[0]), dv(v[2]) - dv(v[0]));
    e1.length() * e2.length() / e1.cross(e2).length()
}

/// Grazing rays: aimed at an interior point (barycentrics 0.3, 0.3) of arbitrarily rotated
/// triangles at angles whose sine runs from 10⁻¹ down to 10⁻⁸ to the plane, from distance 1.
///
/// Expected: a hit while `sin θ ≥ 4·PARALLEL_SIN` (≈ 10⁻⁶), with
/// `|t − t₆₄| / t₆₄ ≤ 16u·c / sin θ` (`c` = [`shape_condition`]): `det` and the numerator of
/// `t` are triple products that round by a few `u·|e1||e2|` while their values shrink with
/// `|e1 × e2|·sin θ`; a miss (counted parallel) once `sin θ ≤ PARALLEL_SIN / 4`. At `sin θ = 10⁻⁶`
/// t may be off by a few percent — the cost of f32 at grazing incidence, not a kernel fault.
/// Measured worst: 1.6 u·c / sin θ.
///
/// Watertight: no parallel threshold — the kernel misses only when its three edge functions
/// disagree in sign or sum to exactly 0. Expected: a hit, with `t` within the bound, wherever the
/// bound says so, which is every ray down to `sin θ = 10⁻⁵`: the edge functions here are about
/// `0.3·0.9·sin θ` against an error bound of a few `10⁻⁶` (`δ ≈ 8u·1.5`, times `|B|₁ + |C|₁ ≲ 4`).
/// Below that, hit or miss, never asserted. Measured: every ray also hits at 10⁻⁶, 795 of 900
/// kernel runs at 10⁻⁷, 237 at 10⁻⁸; worst `|Δt|` 0.09 of the bound.
#[test]
fn grazing_rays_hit_until_the_parallel_threshold() {
    let mut rng = Lcg::new(31);
    let mut worst = 0.0f64;
    let (mut wt_worst, mut wt_sure, mut wt_hits) = (0.0f64, [0usize; 8], [0usize; 8]);
    for _ in 0..300 {
        let v = rotated(
            &mut rng,
            [
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.2, 0.9, 0.0),
            ],
            Vec3::new(0.3, -0.2, 0.1),
        );
        let (e1, e2) = (dv(v[1]) - dv(v[0]), dv(v[2]) - dv(v[0]));
        let n = e1.cross(e2).normalize();
        let target = dv(v[0]) + 0.3 * e1 + 0.3 * e2;
        let tangent = (e1 * 0.7 + e2 * 0.2).normalize();
        let c = shape_condition(&v);
        for k in 1..=8 {
            let sin = 10f64.powi(-k);
            let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            let d = tangent * (1.0 - sin * sin).sqrt() - n * (side * sin);
            let origin = target - d;
            let ray = Ray::new(
                Vec3::new(origin.x as f32, origin.y as f32, origin.z as f32),
                Vec3::new(d.x as f32, d.y as f32, d.z as f32),
            );
            let t64 = f64ref::mt_hit(&ray, &v);
            // The sine of the f32 ray's own angle to the plane.
            let sin_f32 = dv(ray.dir).dot(n).abs() / dv(ray.dir).length();
            let e = wt_bound::expect(&v, &ray);
            wt_sure[k as usize - 1] += usize::from(e.must_hit);
            each_kernel(&v, &ray, |family, name, got| {
                if family == Family::Wt {
                    if let Some(r) = check_wt(name, &e, &ray, got) {
                        wt_worst = wt_worst.max(r);
                    }
                    wt_hits[k as usize - 1] += usize::from(got.is_some());
                } else if sin_f32 >= 4.0 * f64::from(PARALLEL_SIN) {
                    let (t, _, _) = got.unwrap_or_else(|| panic!("{name}: lost at sin {sin}"));
                    let t64 = t64.expect("the f64 reference hits");
                    let rel = (f64::from(t) - t64).abs() / t64;
                    worst = worst.max(rel * sin_f32 / (U * c));
                    assert!(
                        rel <= 16.0 * U * c / sin_f32,
                        "{name}: sin {sin}: t {t} vs {t64}"
                    );
                } else if sin_f32 <= f64::from(PARALLEL_SIN) / 4.0 {
                    assert_eq!(got, None, "{name}: sin {sin_f32} counted as a hit");
                }
            });
        }
    }
    assert_eq!(wt_sure[..5], [300; 5], "the bound covers sin θ ≥ 10⁻⁵");
    eprintln!("grazing: worst |Δt|/t = {worst:.2} u·c / sin θ");
    eprintln!(
        "grazing, watertight: per sin θ = 10⁻¹…10⁻⁸ of 300 rays, bound says hit {wt_sure:?}, \
         hits (3 kernels) {wt_hits:?}; worst |Δt| = {wt_worst:.3} of the bound"
    );
}

/// Rays lying exactly in the triangle's plane — through its interior, along an edge, through a
/// vertex, from inside and outside, with direction components `+0.0` and `−0.0` off the plane —
/// never hit, even over the range `(−∞, ∞)`: the plane is `z = 0.5` or `x = y` (exact in f32, so
/// every direction with `dz = 0`, or `dx = dy`, lies in it exactly) and `det` is exactly 0.
///
/// Watertight, the same, exactly: in the plane `z = 0.5` every vertex has `A.z = v.z − o.z = 0`
/// and the shear factor of `z` is `dz / d[kz] = ±0`, so every sheared `z` coordinate is `±0`
/// and all three edge functions are products with a `±0` factor, differences of `±0`: `det = 0`.
/// In the plane `x = y`, `A.x = A.y` and `dx = dy` bit for bit: with `kz = x` the sheared `y` is
/// `A.y − 1·A.x = 0`; with `kz = z` the two sheared coordinates are computed by the same
/// operations on the same numbers, so `Cx·By − Cy·Bx = Cx·Bx − Cx·Bx = 0`. Either way `det = 0`
/// (and the f64 rerun of §3.5 gives the same zeros).
#[test]
fn rays_in_the_plane_never_hit() {
    let mut rng = Lcg::new(32);
    let z_plane = [
        Vec3::new(-1.0, -1.0, 0.5),
        Vec3::new(2.0, -0.5, 0.5),
        Vec3::new(0.0, 1.5, 0.5),
    ];
    let diagonal_plane = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    let mut n = 0;
    for (v, in_plane) in [
        (
            z_plane,
            (|a: f32, b: f32, z: f32| Vec3::new(a, b, z)) as fn(f32, f32, f32) -> Vec3,
        ),
        (diagonal_plane, |a, b, z| Vec3::new(a, a, b + z)),
    ] {
        let mut origins = vec![v[0], v[1], (v[0] + v[1]) * 0.5, (v[0] + v[1] + v[2]) / 3.0];
        for _ in 0..50 {
            let p = in_plane(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 0.0);
            origins.push(
                p + if v == z_plane {
                    Vec3::new(0.0, 0.0, 0.5)
                } else {
                    Vec3::ZERO
                },
            );
        }
        let mut dirs = vec![v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        for _ in 0..50 {
            let (a, b) = (rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            for zero in [0.0, -0.0] {
                dirs.push(in_plane(a, b, zero));
            }
        }
        for &o in &origins {
            for &d in &dirs {
                for range in [(0.0, f32::INFINITY), (f32::NEG_INFINITY, f32::INFINITY)] {
                    let ray = Ray::new(o, d).with_range(range.0, range.1);
                    each_kernel(&v, &ray, |_family, name, got| {
                        assert_eq!(got, None, "{name}: in-plane ray {ray:?} hit");
                    });
                    n += 1;
                }
            }
        }
    }
    assert!(n > 10_000);
}

/// Degenerate triangles — a repeated vertex, or three exactly collinear points — have no area and
/// are never hit, by any kernel in either mode, even by rays aimed exactly at the segment they
/// collapse to, from any direction: their threshold `min_det2` is `+inf`, which Möller–Trumbore's
/// parallel test and the watertight kernels both reject.
///
/// Why the watertight kernels need that test: the watertight test alone would hit three collinear
/// points. Each vertex's sheared position is rounded on its own, so the three projected points
/// are generally not collinear by a few ULPs, and a ray aimed at the segment then sees a sliver
/// of one sign (before the test: 111, 162 and 129 hits of 1,500 kernel runs on the three collinear
/// triangles below). The builder leaves degenerate triangles out of the tree, so a walk could
/// never find such a hit while a brute-force pass over the same kernels did: the two disagreed
/// (the regression in `tests/tests/kdtree.rs`).
#[test]
fn degenerate_triangles_are_never_hit() {
    let mut rng = Lcg::new(33);
    let a = Vec3::new(0.25, -0.5, 1.0);
    let d = Vec3::new(1.0, 2.0, -0.5);
    let triangles = [
        [a, a, a + d],
        [a, a + d, a + d],
        [a, a + d, a + 2.0 * d],
        [a + 2.0 * d, a, a + d],
        [Vec3::ZERO, Vec3::ONE, Vec3::splat(2.0)],
        // The collinear triangle of the kdtree regression, and a ray that the watertight test
        // alone hits.
        [
            Vec3::new(1.75, 1.25, 0.5),
            Vec3::new(-0.25, 1.25, 0.5),
            Vec3::new(0.25, 1.25, 0.5),
        ],
    ];
    for v in &triangles {
        assert!(
            Triangle::from_vertices(v[0], v[1], v[2]).is_degenerate(),
            "{v:?}"
        );
        for _ in 0..500 {
            let target = v[0] + (v[2] - v[0]) * rng.next_f32() + (v[1] - v[0]) * rng.next_f32();
            let origin = target + random_unit(&mut rng) * 3.0;
            let ray = Ray::new(origin, (target - origin).normalize());
            each_kernel(v, &ray, |_, name, got| {
                assert_eq!(got, None, "{name}: degenerate {v:?} hit by {ray:?}");
            });
        }
    }
}

/// Huge triangles: where `|e1 × e2|²` overflows f32 (edges beyond about 4e9), the threshold is
/// computed from the normal scaled by `PARALLEL_SIN` (exact: a power of two), so it stays finite,
/// and every kernel, fast and watertight, scalar and packet, hits them. Before, the threshold was
/// `+inf` and Möller–Trumbore never hit such a triangle while the watertight kernel did. Sizes
/// 4e9 (the triangle) to 1e12; rays straight down and tilted, from near and far.
#[test]
fn huge_triangles_are_hit_by_every_kernel() {
    let mut rng = Lcg::new(36);
    for scale in [4.0e9f32, 1.0e10, 1.0e11, 1.0e12] {
        let v = [
            Vec3::new(-scale, -scale, 0.0),
            Vec3::new(scale, -scale, 0.0),
            Vec3::new(0.0, scale, 0.0),
        ];
        let tri = Triangle::from_vertices(v[0], v[1], v[2]);
        assert!(tri.geometric_normal().length_squared().is_infinite());
        assert!(tri.min_det2().is_finite() && !tri.is_too_large(), "{scale}");
        for k in 0..40 {
            let height = if k % 2 == 0 { 1.0 } else { scale };
            let (a, b) = (0.1 + 0.3 * rng.next_f32(), 0.1 + 0.3 * rng.next_f32());
            let target = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
            let tilt = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 0.0);
            let dir = if k < 4 {
                Vec3::NEG_Z
            } else {
                (tilt - Vec3::Z).normalize()
            };
            let ray = Ray::new(target - dir * height, dir);
            let t64 = f64ref::mt_hit(&ray, &v).expect("the f64 reference hits");
            each_kernel(&v, &ray, |_, name, got| {
                let (t, _, _) = got.unwrap_or_else(|| panic!("{name}: missed {v:?} by {ray:?}"));
                let rel = (f64::from(t) - t64).abs() / t64;
                assert!(rel < 1e-5, "{name}: t {t} against {t64} ({scale})");
            });
        }
    }
}

/// Needle triangles, length 1 and width 10⁻¹ … 10⁻⁵ (condition `c` up to ~10⁵), arbitrarily
/// rotated, hit by rays from distance ~2 at least 6° off their plane, aimed at the interior point
/// with barycentrics (0.25, 0.5): always a hit, with `|t − t₆₄| / t₆₄ ≤ 16u·c / sin θ` as for
/// grazing rays (the needle's plane is as ill-determined as a grazing ray's crossing). Narrower
/// needles (`c` near 1/u) leave even the side of the plane undetermined in f32.
///
/// Watertight: a hit, with `t` within the bound, wherever the bound says so, which is every ray
/// down to width 10⁻⁴. The kernel rounds each vertex relative to the origin, at distance ~2, so
/// its error is `δ ≈ 8u·2` against edge functions of about `0.25·width·sin θ`: at 10⁻⁵ the bound
/// no longer covers every ray (measured: 325 of 360). Measured: every ray hits at every width;
/// worst `|Δt|` 0.17 of the bound.
#[test]
fn needle_triangles_are_hit_inside() {
    let mut rng = Lcg::new(34);
    let mut worst = 0.0f64;
    let (mut wt_worst, mut wt_sure, mut wt_hits, mut wt_rays) =
        (0.0f64, [0usize; 5], [0usize; 5], [0usize; 5]);
    for k in 1..=5 {
        let width = 10f32.powi(-k);
        for _ in 0..400 {
            let v = rotated(
                &mut rng,
                [Vec3::ZERO, Vec3::X, Vec3::new(0.5, width, 0.0)],
                Vec3::new(-0.4, 0.25, 0.6),
            );
            let target = v[0] + 0.25 * (v[1] - v[0]) + 0.5 * (v[2] - v[0]);
            let (e1, e2) = (dv(v[1]) - dv(v[0]), dv(v[2]) - dv(v[0]));
            let n = e1.cross(e2).normalize();
            let dir = random_unit(&mut rng);
            let sin = dv(dir).dot(n).abs();
            if sin < 0.1 {
                continue;
            }
            let ray = Ray::new(target - 2.0 * dir, dir);
            let c = shape_condition(&v);
            let t64 = f64ref::mt_hit(&ray, &v).expect("the f64 reference hits");
            let e = wt_bound::expect(&v, &ray);
            wt_sure[k as usize - 1] += usize::from(e.must_hit);
            wt_rays[k as usize - 1] += 1;
            each_kernel(&v, &ray, |family, name, got| {
                if family == Family::Wt {
                    if let Some(r) = check_wt(name, &e, &ray, got) {
                        wt_worst = wt_worst.max(r);
                    }
                    wt_hits[k as usize - 1] += usize::from(got.is_some());
                    return;
                }
                let (t, _, _) = got.unwrap_or_else(|| panic!("{name}: lost a needle of {width}"));
                let rel = (f64::from(t) - t64).abs() / t64;
                worst = worst.max(rel * sin / (U * c));
                assert!(
                    rel <= 16.0 * U * c / sin,
                    "{name}: width {width}: t {t} vs {t64}"
                );
            });
        }
    }
    assert_eq!(wt_sure[..4], wt_rays[..4], "the bound covers widths ≥ 10⁻⁴");
    eprintln!("needles: worst |Δt|/t = {worst:.3} u·c / sin θ");
    eprintln!(
        "needles, watertight: per width 10⁻¹…10⁻⁵, rays {wt_rays:?}, bound says hit {wt_sure:?}, \
         hits (3 kernels) {wt_hits:?}; worst |Δt| = {wt_worst:.3} of the bound"
    );
}

/// Triangles shrunk towards the f32 limit: a well-shaped triangle of size `s` = 10⁻³ … 10⁻²⁰
/// around the world origin, hit there by a ray from about `10·s` away (exact in f32: from
/// `−d·2^k` along `d`). The distance scales with the triangle: from a fixed distance `D`, f32
/// resolves nothing finer than `u·D` at the triangle (`o − v0` rounds by that much, in any
/// kernel), which says nothing about the triangle's own size.
///
/// Expected: a hit with `t` as accurate as for larger triangles (`16u·c / sin θ`, see
/// [`grazing_rays_hit_until_the_parallel_threshold`]) down to `s = 10⁻¹⁰`; from `s = 10⁻¹²` on a
/// miss (at 10⁻¹¹, either), although the area (~10⁻²⁴) is still far from f32's smallest normal
/// (10⁻³⁸): Möller–Trumbore's parallel test compares `det²` (~`s⁴`) with
/// `PARALLEL_SIN²·|e1 × e2|²`, and `|e1 × e2|² ~ s⁴` underflows to 0 near `s ≈ 10⁻¹¹`, where the
/// triangle counts as degenerate ([`Triangle::is_degenerate`]) — a miss, never a wrong hit. A
/// known limit of the squared threshold stored in the flat format (lifting it means storing
/// `PARALLEL_SIN·|e1 × e2|` instead: a format change), reported here rather than fixed.
///
/// Watertight: the same rule for degenerate triangles (a triangle whose `|e1 × e2|²` underflows
/// is never hit, in either mode: `degenerate_triangles_are_never_hit`), so the same miss from
/// `s ≈ 10⁻¹¹` on. Above it, its own limits: its edge functions are ~`s²` and `T = Σ Uᵢzᵢ`
/// ~`10·s³`, all in f32; a hit with `t` within the bound while every intermediate value is a
/// normal f32, which the bound checks and which holds for every ray that is not degenerate (the
/// bound alone would reach `s = 10⁻¹²`, `T` ~ 10⁻³⁵; without the degeneracy rule the kernel hit
/// down to `s = 10⁻¹⁵` with a subnormal `T`). Measured: worst `|Δt|` 0.16 of the bound.
#[test]
fn tiny_triangles_are_hit_until_f32_underflows() {
    let mut rng = Lcg::new(35);
    let (mut wt_worst, mut wt_sure, mut wt_under, mut wt_hits, mut wt_degenerate) = (
        0.0f64,
        [0usize; 18],
        [0usize; 18],
        [0usize; 18],
        [0usize; 18],
    );
    for k in 3..=20 {
        let s = 10f32.powi(-k);
        let dist = 2f32.powi((10.0 * s).log2().ceil() as i32);
        for _ in 0..20 {
            let v = rotated(
                &mut rng,
                [
                    Vec3::new(-s, -s, 0.0),
                    Vec3::new(s, -s, 0.0),
                    Vec3::new(0.0, s, 0.0),
                ],
                Vec3::ZERO,
            );
            // Through the world origin, exactly (`−dir·dist` is exact for a power of two),
            // which lies inside the triangle (up to its own rounding, relative to `s`).
            let dir = random_unit(&mut rng);
            let ray = Ray::new(-dir * dist, dir);
            let t64 = f64ref::mt_hit(&ray, &v).expect("the f64 reference hits");
            let (e1, e2) = (dv(v[1]) - dv(v[0]), dv(v[2]) - dv(v[0]));
            let sin = dv(dir).dot(e1.cross(e2).normalize()).abs();
            let bound = 16.0 * U * shape_condition(&v) / sin;
            let degenerate = Triangle::from_vertices(v[0], v[1], v[2]).is_degenerate();
            let e = wt_bound::expect(&v, &ray);
            let row = k as usize - 3;
            wt_sure[row] += usize::from(e.must_hit && e.normal && !degenerate);
            wt_under[row] += usize::from(e.must_miss_underflow);
            wt_degenerate[row] += usize::from(degenerate);
            each_kernel(&v, &ray, |family, name, got| {
                if degenerate {
                    assert_eq!(got, None, "{name}: degenerate size {s} hit");
                } else if family == Family::Wt {
                    if let Some(r) = check_wt(name, &e, &ray, got) {
                        wt_worst = wt_worst.max(r);
                    }
                    wt_hits[row] += usize::from(got.is_some());
                } else if k <= 10 {
                    assert!(!degenerate);
                    let (t, _, _) = got.unwrap_or_else(|| panic!("{name}: lost size {s}"));
                    let rel = (f64::from(t) - t64).abs() / t64;
                    assert!(rel <= bound, "{name}: t {t} for {t64}");
                } else if k >= 12 {
                    assert_eq!(got, None, "{name}: size {s}");
                }
            });
        }
    }
    assert_eq!(
        wt_sure[..8],
        [20; 8],
        "the bound covers sizes down to 10⁻¹⁰"
    );
    assert_eq!(wt_degenerate[..8], [0; 8], "not degenerate down to 10⁻¹⁰");
    assert_eq!(wt_degenerate[9..], [20; 9], "degenerate from 10⁻¹² on");
    assert_eq!(wt_under[13..], [20; 5], "T underflows from 10⁻¹⁶ on");
    eprintln!(
        "tiny, watertight: per size 10⁻³…10⁻²⁰ of 20 rays, bound says hit {wt_sure:?}, \
         T must underflow {wt_under:?}, degenerate {wt_degenerate:?}, hits (3 kernels) \
         {wt_hits:?}; worst |Δt| = {wt_worst:.3} of the bound"
    );
}
