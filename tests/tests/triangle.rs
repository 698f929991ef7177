//! Möller–Trumbore (`Triangle::intersect`) against an f64 Cramer's-rule solution of the seed's
//! equation (16), `o − e = [−d, f − e, g − e]·(t, α, β)ᵀ`; rejection of parallel rays and
//! degenerate triangles; and the NaN guarantee on arbitrary and edge-value inputs.

use glam::Vec3;
use kdray_core::triangle::PARALLEL_SIN;
use kdray_core::{Ray, Triangle};
use kdray_tests::EDGES;
use kdray_tests::f64ref::{self, dv};
use kdray_tests::strategies::*;
use proptest::prelude::*;

/// A well-conditioned hit: edges 0.1–2 long at ≥ 14.5° to each other (`|e1×e2| ≥ ¼|e1||e2|`), a
/// unit direction at ≥ 11.5° to the plane (`|d·n̂| ≥ 0.2`), a target point with barycentrics at
/// least 0.02 inside every edge, and an origin 0.05–50 before it. So `|d||e1||e2| / |det| ≤ 20`.
fn well_conditioned_hit() -> impl Strategy<Value = (Triangle, Ray)> {
    (
        vec3(-10.0, 10.0),
        unit_vec3(),
        0.1f32..2.0,
        unit_vec3(),
        0.1f32..2.0,
        unit_vec3(),
        (0.0f32..1.0, 0.0f32..1.0),
        0.05f32..50.0,
    )
        .prop_filter_map("ill-conditioned", |(v0, u1, l1, u2, l2, d, (a, b), t)| {
            let (e1, e2) = (u1 * l1, u2 * l2);
            let n = e1.cross(e2);
            let ok = n.length() >= 0.25 * l1 * l2 && d.dot(n).abs() >= 0.2 * n.length();
            // Fold the unit square onto the triangle a + b ≤ 1, then shrink it 0.02 inside.
            let (a, b) = if a + b > 1.0 {
                (1.0 - a, 1.0 - b)
            } else {
                (a, b)
            };
            let (a, b) = (0.02 + 0.94 * a, 0.02 + 0.94 * b);
            ok.then(|| {
                let origin = v0 + a * e1 + b * e2 - t * d;
                (Triangle { v0, e1, e2 }, Ray::new(origin, d))
            })
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(1000)))]

    /// t, α, β agree with f64 Cramer's rule to a normwise relative bound.
    ///
    /// Bound, from first-order error analysis of the three triple products (a cross product and a
    /// dot product: a few roundings each) and of `det`, each off by at most a small multiple `k` of
    /// the unit roundoff `u = 2⁻²⁴` times the product of its operands' lengths:
    ///
    /// ```text
    /// |Δα| ≤ k·u·(|s||d||e2| + |α|·|d||e1||e2|) / |det|
    /// |Δβ| ≤ k·u·(|s||d||e1| + |β|·|d||e1||e2|) / |det|
    /// |Δt| ≤ k·u·(|s||e1||e2| + |t|·|d||e1||e2|) / |det|        with s = o − v0, k = 8
    /// ```
    ///
    /// This is relative to the data's scale rather than to α itself, because α and β come from
    /// cancellation in `s·p` when the origin is far from the triangle (|s| ≫ |e|): there even an
    /// exactly rounded `s` moves α by `u|s|/|e|`. Measured over 3·10⁵ such cases: the worst error is
    /// 2.5 times the bound's `k = 1` value, so `k = 8` leaves room without hiding a wrong formula
    /// (a swapped α/β or a wrong column is off by O(1)). In plain numbers on these cases: max
    /// |Δt|/t = 4.3e-6, max |Δα| = 3.1e-4, max |Δβ| = 3.5e-4 (the large ones at |s|/|e| ≈ 500).
    #[test]
    fn mt_matches_f64_cramer_on_well_conditioned_hits((tri, ray) in well_conditioned_hit()) {
        let want = f64ref::mt_solve(ray.origin, ray.dir, tri.v0, tri.e1, tri.e2).unwrap();
        let (t, a, b) = tri
            .intersect(&ray)
            .unwrap_or_else(|| panic!("missed a well-conditioned hit, f64 says {want:?}"));
        let (s, d, e1, e2) = (
            (dv(ray.origin) - dv(tri.v0)).length(),
            dv(ray.dir).length(),
            dv(tri.e1).length(),
            dv(tri.e2).length(),
        );
        let k = 8.0 * U / want.det.abs();
        let bound_a = k * (s * d * e2 + want.alpha.abs() * d * e1 * e2);
        let bound_b = k * (s * d * e1 + want.beta.abs() * d * e1 * e2);
        let bound_t = k * (s * e1 * e2 + want.t.abs() * d * e1 * e2);
        prop_assert!((f64::from(a) - want.alpha).abs() <= bound_a, "α {a} vs {}", want.alpha);
        prop_assert!((f64::from(b) - want.beta).abs() <= bound_b, "β {b} vs {}", want.beta);
        prop_assert!((f64::from(t) - want.t).abs() <= bound_t, "t {t} vs {}", want.t);
    }

    /// The hit point `o + t·d` is the barycentric point `v0 + α·e1 + β·e2` (a check independent
    /// of the f64 reference's algebra).
    #[test]
    fn mt_hit_point_matches_barycentric_point((tri, ray) in well_conditioned_hit()) {
        let (t, a, b) = tri.intersect(&ray).unwrap();
        let on_ray = dv(ray.origin) + f64::from(t) * dv(ray.dir);
        let on_tri = dv(tri.v0) + f64::from(a) * dv(tri.e1) + f64::from(b) * dv(tri.e2);
        let scale = dv(ray.origin).length() + dv(tri.v0).length() + f64::from(t);
        prop_assert!(on_ray.max_abs_diff(on_tri) <= 1e-4 * scale, "{on_ray:?} vs {on_tri:?}");
    }

    /// Rays exactly parallel to the plane, both in the plane and offset from it, never hit.
    ///
    /// Exactly parallel in f32 needs exact arithmetic: vertices snapped to a 1/8 grid, directions
    /// small integer combinations of the edges, so every product and sum below is exact and
    /// `det = e1·(d × e2)` is exactly 0 (the `bvh` crate's grid-snapping idea).
    #[test]
    fn mt_rejects_exactly_parallel_rays_on_a_grid(
        v in prop::array::uniform3(prop::array::uniform3(-32i32..=32)),
        (i, j) in (-3i32..=3, 1i32..=3), // j ≠ 0, and −dir is tried too
        (a, b) in (-8i32..=8, -8i32..=8),
        offset in prop::sample::select(&[0.0f32, 0.25, -0.25, 1.0, -3.0][..]),
    ) {
        let g = |p: [i32; 3]| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 8.0;
        let tri = Triangle::from_vertices(g(v[0]), g(v[1]), g(v[2]));
        let dir = i as f32 * tri.e1 + j as f32 * tri.e2;
        prop_assume!(!tri.is_degenerate() && dir != Vec3::ZERO);
        // In the plane (offset 0: also inside the triangle for small a, b) or shifted off it.
        let origin = tri.v0 + (a as f32 / 4.0) * tri.e1 + (b as f32 / 4.0) * tri.e2
            + offset * tri.geometric_normal();
        for dir in [dir, -dir] {
            let ray = Ray::new(origin, dir).with_range(f32::NEG_INFINITY, f32::INFINITY);
            prop_assert_eq!(tri.intersect(&ray), None);
        }
        // A normalized direction is parallel only up to rounding, and on sliver triangles the
        // rounding of `det` (~u·|d||e1||e2|) can exceed `PARALLEL_SIN·|e1×e2|`: with an unbounded
        // range an in-plane origin then "hits" at t = ±0 (seen: t = α = β = −0). On the tracer's
        // default range (0, +inf) such a ray must still miss: t is exactly ±0 for an in-plane
        // origin and α is huge for an offset one.
        prop_assert_eq!(tri.intersect(&Ray::new(origin, dir.normalize())), None);
    }

    /// Same, for arbitrary (non-grid) triangles in an axis plane: a direction with a zero
    /// component along the plane's axis gives an exactly zero determinant for any floats.
    #[test]
    fn mt_rejects_rays_parallel_to_an_axis_plane(
        p in prop::array::uniform3((-10.0f32..10.0, -10.0f32..10.0)),
        plane in -10.0f32..10.0,
        (dx, dy) in (-1.0f32..1.0, -1.0f32..1.0),
        (ox, oy, oz) in (-10.0f32..10.0, -10.0f32..10.0, prop::sample::select(&[0.0f32, 1e-3, -2.0][..])),
        axis in 0usize..3,
    ) {
        prop_assume!(dx != 0.0 || dy != 0.0);
        // Build in the z = plane frame, then rotate the coordinates so the plane is x, y or z.
        let rot = |v: Vec3| match axis {
            0 => v,
            1 => Vec3::new(v.z, v.x, v.y),
            _ => Vec3::new(v.y, v.z, v.x),
        };
        let vert = |(x, y): (f32, f32)| rot(Vec3::new(x, y, plane));
        let tri = Triangle::from_vertices(vert(p[0]), vert(p[1]), vert(p[2]));
        let ray = Ray::new(rot(Vec3::new(ox, oy, plane + oz)), rot(Vec3::new(dx, dy, 0.0)))
            .with_range(f32::NEG_INFINITY, f32::INFINITY);
        prop_assert_eq!(tri.intersect(&ray), None);
    }

    /// Zero-area triangles (a repeated vertex, or three collinear grid points) are never hit, even
    /// by rays aimed straight at their points.
    #[test]
    fn mt_rejects_degenerate_triangles(
        p in prop::array::uniform3(-64i32..=64),
        q in prop::array::uniform3(-64i32..=64),
        k in -4i32..=4,
        which in 0usize..4,
        d in unit_vec3(),
        t in 0.1f32..10.0,
        w in 0.0f32..1.0,
    ) {
        let g = |p: [i32; 3]| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 8.0;
        let (a, b) = (g(p), g(q));
        // a + k(b − a) is exact on this grid, so the third vertex is exactly collinear.
        let c = a + k as f32 * (b - a);
        let tri = match which {
            0 => Triangle::from_vertices(a, a, b),
            1 => Triangle::from_vertices(a, b, b),
            2 => Triangle::from_vertices(b, a, b),
            _ => Triangle::from_vertices(a, b, c),
        };
        prop_assert!(tri.is_degenerate());
        let target = a + w * (b - a);
        let ray = Ray::new(target - t * d, d);
        prop_assert_eq!(tri.intersect(&ray), None);
        prop_assert_eq!(tri.intersect(&ray.with_range(f32::NEG_INFINITY, f32::INFINITY)), None);
    }

    /// For any inputs (NaN, ±inf, denormals, huge): a reported hit is in range and NaN-free, and
    /// a NaN anywhere is a miss.
    #[test]
    fn mt_never_returns_nan(
        v0 in any_vec3(), e1 in any_vec3(), e2 in any_vec3(),
        origin in any_vec3(), dir in any_vec3(),
        tmin in any_f32(), tmax in any_f32(),
    ) {
        let tri = Triangle { v0, e1, e2 };
        let ray = Ray { origin, dir, tmin, tmax };
        check_no_nan(&tri, &ray)?;
    }

    /// The same with a few components of a well-conditioned hit replaced by edge values, so edge
    /// values meet otherwise sane inputs (pure `ANY` inputs are almost always a plain miss).
    #[test]
    fn mt_edge_values_in_a_hitting_configuration(
        (tri, ray) in well_conditioned_hit(),
        subs in prop::collection::vec((0usize..17, prop::sample::select(&EDGES[..])), 1..4),
    ) {
        let mut x = [
            tri.v0.x, tri.v0.y, tri.v0.z, tri.e1.x, tri.e1.y, tri.e1.z, tri.e2.x, tri.e2.y,
            tri.e2.z, ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z,
            ray.tmin, ray.tmax,
        ];
        for (i, e) in subs {
            x[i] = e;
        }
        let tri = Triangle {
            v0: Vec3::new(x[0], x[1], x[2]),
            e1: Vec3::new(x[3], x[4], x[5]),
            e2: Vec3::new(x[6], x[7], x[8]),
        };
        let ray = Ray {
            origin: Vec3::new(x[9], x[10], x[11]),
            dir: Vec3::new(x[12], x[13], x[14]),
            tmin: x[15],
            tmax: x[16],
        };
        check_no_nan(&tri, &ray)?;
    }
}

fn check_no_nan(tri: &Triangle, ray: &Ray) -> Result<(), TestCaseError> {
    let any_nan = [tri.v0, tri.e1, tri.e2, ray.origin, ray.dir]
        .iter()
        .any(|v| v.is_nan())
        || ray.tmin.is_nan()
        || ray.tmax.is_nan();
    match tri.intersect(ray) {
        None => {}
        Some((t, a, b)) => {
            prop_assert!(!any_nan, "hit {:?} with a NaN input", (t, a, b));
            prop_assert!(
                t > ray.tmin && t < ray.tmax,
                "t = {t} outside the ray's range"
            );
            prop_assert!(a >= 0.0 && b >= 0.0 && a + b <= 1.0, "α = {a}, β = {b}");
        }
    }
    Ok(())
}

/// A hand-checked case: the unit right triangle in z = 0, hit from both sides (Möller–Trumbore is
/// two-sided), on its edges (inclusive), missed just outside, and clipped by the ray's range.
#[test]
fn mt_hand_checked_unit_triangle() {
    let tri = Triangle::from_vertices(Vec3::ZERO, Vec3::X, Vec3::Y);
    let down = |x, y| Ray::new(Vec3::new(x, y, 2.0), -Vec3::Z);
    assert_eq!(tri.intersect(&down(0.25, 0.5)), Some((2.0, 0.25, 0.5)));
    let up = Ray::new(Vec3::new(0.25, 0.5, -1.0), Vec3::Z);
    assert_eq!(tri.intersect(&up), Some((1.0, 0.25, 0.5)));
    // α = 0, β = 0 and α + β = 1 are inside.
    assert_eq!(tri.intersect(&down(0.0, 0.5)), Some((2.0, 0.0, 0.5)));
    assert_eq!(tri.intersect(&down(0.5, 0.0)), Some((2.0, 0.5, 0.0)));
    assert_eq!(tri.intersect(&down(0.5, 0.5)), Some((2.0, 0.5, 0.5)));
    assert_eq!(tri.intersect(&down(0.0, 0.0)), Some((2.0, 0.0, 0.0)));
    // Just outside each edge.
    assert_eq!(tri.intersect(&down(-1e-6, 0.5)), None);
    assert_eq!(tri.intersect(&down(0.5, -1e-6)), None);
    assert_eq!(tri.intersect(&down(0.5, 0.5 + 1e-6)), None);
    // The range is open: t must be strictly inside (tmin, tmax).
    assert_eq!(tri.intersect(&down(0.25, 0.25).with_range(0.0, 2.0)), None);
    assert_eq!(tri.intersect(&down(0.25, 0.25).with_range(2.0, 3.0)), None);
    assert!(
        tri.intersect(&down(0.25, 0.25).with_range(1.9, 2.1))
            .is_some()
    );
    // Behind the origin.
    assert_eq!(
        tri.intersect(&Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::Z)),
        None
    );
}

/// The near-parallel cut-off is the documented one: a ray whose sine to the plane is half of
/// `PARALLEL_SIN` counts as parallel and misses, although it crosses the plane inside the
/// triangle (at t = 5); at twice `PARALLEL_SIN` it hits there. (Exactly parallel rays alone would
/// not pin this: with `det = 0` the division gives ±inf or NaN for α, which fails anyway.)
#[test]
fn mt_parallel_cutoff_is_parallel_sin() {
    let tri = Triangle::from_vertices(
        Vec3::new(-10.0, -10.0, 0.0),
        Vec3::new(10.0, -10.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
    );
    for (k, hits) in [(0.5, false), (2.0, true)] {
        let sin = k * PARALLEL_SIN;
        // From (−5, −5, 5·sin) along (1, 0, −sin): the plane z = 0 at t = 5, point (0, −5, 0),
        // which is α = 0.375, β = 0.25 inside the triangle.
        let ray = Ray::new(Vec3::new(-5.0, -5.0, 5.0 * sin), Vec3::new(1.0, 0.0, -sin));
        match tri.intersect(&ray) {
            Some((t, a, b)) => {
                assert!(hits, "sine {k}·PARALLEL_SIN hit at t = {t}");
                assert!(
                    (t - 5.0).abs() <= 1e-4
                        && (a - 0.375).abs() <= 1e-6
                        && (b - 0.25).abs() <= 1e-6
                );
            }
            None => assert!(!hits, "sine {k}·PARALLEL_SIN missed"),
        }
    }
}

/// Every edge value in every one of the 17 scalar inputs of a hitting configuration, one at a
/// time: no NaN out, NaN in is a miss.
#[test]
fn mt_each_input_at_each_edge_value() {
    let tri = Triangle::from_vertices(Vec3::new(-1.0, -1.0, 0.5), Vec3::X, Vec3::Y);
    let ray = Ray::new(
        Vec3::new(-0.2, -0.3, 3.0),
        Vec3::new(0.1, 0.05, -1.0).normalize(),
    );
    assert!(tri.intersect(&ray).is_some());
    for i in 0..17 {
        for e in EDGES {
            let (mut tri, mut ray) = (tri, ray);
            match i {
                0..3 => tri.v0[i] = e,
                3..6 => tri.e1[i - 3] = e,
                6..9 => tri.e2[i - 6] = e,
                9..12 => ray.origin[i - 9] = e,
                12..15 => ray.dir[i - 12] = e,
                15 => ray.tmin = e,
                _ => ray.tmax = e,
            }
            if let Err(err) = check_no_nan(&tri, &ray) {
                panic!("input {i} = {e}: {err}");
            }
        }
    }
}
