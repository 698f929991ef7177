//! The cancellation-free sphere test (`Sphere::roots`, `Sphere::intersect`; Ray Tracing Gems
//! ch. 7) against an f64 reference, on the two cases the textbook quadratic of the seed's
//! equation (32) gets wrong in f32 (a small sphere far away; an origin close to the surface), and
//! on edge-value inputs.

use glam::Vec3;
use kdray_core::{Ray, Sphere};
use kdray_tests::f64ref::{self, dv};
use kdray_tests::strategies::*;
use kdray_tests::{EDGES, Lcg};
use proptest::prelude::*;

/// Rukin's textbook quadratic (equation (32)) in f32, `d` normalized: `t = −p/2 − sqrt(p²/4 −
/// q)` with `p/2 = d·(o − c)`, `q = |o − c|² − R²`. Only here to show the far-sphere case is stiff.
fn textbook_near_root(ray: &Ray, s: &Sphere) -> Option<f32> {
    let f = ray.origin - s.center;
    let half_p = ray.dir.dot(f);
    let q = f.dot(f) - s.radius * s.radius;
    let disc = half_p * half_p - q;
    (disc >= 0.0).then(|| -half_p - disc.sqrt())
}

/// A sphere (centre in ±100, radius 0.01–10), an origin outside or inside it, and a unit
/// direction aimed within 0.95 R of the centre, so most lines cross it well away from grazing.
fn sphere_and_ray() -> impl Strategy<Value = (Sphere, Ray)> {
    (
        vec3(-100.0, 100.0),
        -2.0f32..1.0,
        prop::bool::weighted(0.2),
        vec3(-100.0, 100.0),
        unit_vec3(),
        0.0f32..1.0,
        unit_vec3(),
        0.0f32..0.95,
    )
        .prop_filter_map(
            "direction too short",
            |(center, log_r, inside, far, u, depth, w, aim)| {
                let radius = 10f32.powf(log_r);
                let origin = if inside {
                    center + 0.99 * depth * radius * u
                } else {
                    far
                };
                let dir = (center + aim * radius * w - origin).try_normalize()?;
                Some((Sphere { center, radius }, Ray::new(origin, dir)))
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(1000)))]

    /// Both roots agree with the f64 reference when the line crosses the sphere at least 0.1 R
    /// from grazing (half chord `h ≥ 0.1 R`).
    ///
    /// Bound: `|Δt| ≤ 16·u·(|o − c| + R)·(R / h)`, u = 2⁻²⁴. Rounding `b = f·d`, `f − b·d` and
    /// the squares costs a few `u·(|f| + R)` in the squared half chord's scale; the square root
    /// divides that by `2h/R` — so the bound grows only at grazing incidence, where the roots are
    /// ill-conditioned in any precision. Measured over 3·10⁵ cases: worst 6.7 (in units of
    /// `u·(|f|+R)·R/h`), i.e. |Δt| ≤ 4.4e-7·(|f| + R).
    #[test]
    fn sphere_roots_match_f64((s, ray) in sphere_and_ray()) {
        let h2 = f64ref::sphere_half_chord2(ray.origin, ray.dir, s.center, s.radius);
        let r = f64::from(s.radius);
        prop_assume!(h2 >= 0.01 * r * r);
        let (near64, far64) = f64ref::sphere_roots(ray.origin, ray.dir, s.center, s.radius).unwrap();
        let (near, far) = s.roots(&ray).expect("missed a sphere the f64 reference hits");
        let f = (dv(ray.origin) - dv(s.center)).length();
        let bound = 16.0 * U * (f + r) * r / h2.sqrt();
        prop_assert!((f64::from(near) - near64).abs() <= bound, "near {near} vs {near64}");
        prop_assert!((f64::from(far) - far64).abs() <= bound, "far {far} vs {far64}");
        // intersect picks the nearest root in (0, inf): the near one from outside, the far one
        // from inside, nothing for a sphere behind.
        let want = if near64 > 0.0 { Some(near64) } else if far64 > 0.0 { Some(far64) } else { None };
        match (s.intersect(&ray), want) {
            (Some(t), Some(w)) => prop_assert!((f64::from(t) - w).abs() <= bound, "t {t} vs {w}"),
            (None, None) => {}
            (got, want) => prop_assert!(false, "intersect {got:?}, f64 {want:?}"),
        }
    }

    /// Hit or miss agrees with f64 whenever the line is clearly in or out: `|R² − dist²|` above the
    /// f32 rounding of the half chord, `64·u·(|f| + R)²`.
    #[test]
    fn sphere_hit_or_miss_matches_f64(
        center in vec3(-100.0, 100.0),
        log_r in -2.0f32..1.0,
        origin in vec3(-100.0, 100.0),
        dir in unit_vec3(),
    ) {
        let s = Sphere { center, radius: 10f32.powf(log_r) };
        let ray = Ray::new(origin, dir);
        let h2 = f64ref::sphere_half_chord2(origin, dir, center, s.radius);
        let f = (dv(origin) - dv(center)).length();
        prop_assume!(h2.abs() > 64.0 * U * (f + f64::from(s.radius)).powi(2));
        prop_assert_eq!(s.roots(&ray).is_some(), h2 > 0.0);
    }

    /// The near root from an origin close outside the surface (a secondary ray leaving a surface)
    /// is accurate relative to its own small size — Gems ch. 7's second fix: `q = −b − sign(b)·h`
    /// never cancels and the small root comes from `(|f|² − R²)/q`, exact here because the inputs
    /// are integers. The textbook `−b − h` cancels: with the sign dropped the relative error
    /// reaches ~3·10⁶ u. Bound 32 u; measured worst over 10⁶ cases 3.9 u.
    #[test]
    fn sphere_near_root_is_relatively_accurate_near_the_surface(
        f in prop::array::uniform3(-1000i32..=1000),
        below in 0i32..3,
        w in unit_vec3(),
    ) {
        let f = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
        // An integer radius up to 3 below |f|: |f|² and R² are exact integers (< 2²⁴), the origin
        // is at most ~3 outside the surface.
        let radius = (f.length().floor() - below as f32).max(1.0);
        prop_assume!(f.dot(f) > radius * radius);
        // Towards the sphere, at least 10° off the tangent plane (cos ≥ 0.3/1.7 to −f).
        let dir = (-f.normalize() + 0.7 * w).normalize();
        let center = Vec3::new(7.0, -3.0, 11.0);
        let (s, ray) = (Sphere { center, radius }, Ray::new(center + f, dir));
        let (near64, _) = f64ref::sphere_roots(ray.origin, dir, center, radius).unwrap();
        let (near, _) = s.roots(&ray).unwrap();
        let rel = (f64::from(near) - near64).abs() / near64;
        prop_assert!(rel <= 32.0 * U, "near root {near} vs {near64}: {} u", rel / U);
    }

    /// For any inputs: `intersect` never returns NaN and stays in range, a NaN input is a miss, and
    /// `roots` never returns NaN for a finite sphere and ray.
    #[test]
    fn sphere_never_returns_nan(
        center in any_vec3(), radius in any_f32(),
        origin in any_vec3(), dir in any_vec3(),
        tmin in any_f32(), tmax in any_f32(),
    ) {
        check_no_nan(&Sphere { center, radius }, &Ray { origin, dir, tmin, tmax })?;
    }

    /// The same with components of an ordinary hitting configuration replaced by edge values.
    #[test]
    fn sphere_edge_values_in_a_hitting_configuration(
        (s, ray) in sphere_and_ray(),
        subs in prop::collection::vec((0usize..12, prop::sample::select(&EDGES[..])), 1..4),
    ) {
        let mut x = [
            s.center.x, s.center.y, s.center.z, s.radius, ray.origin.x, ray.origin.y,
            ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z, ray.tmin, ray.tmax,
        ];
        for (i, e) in subs {
            x[i] = e;
        }
        let s = Sphere { center: Vec3::new(x[0], x[1], x[2]), radius: x[3] };
        let ray = Ray {
            origin: Vec3::new(x[4], x[5], x[6]),
            dir: Vec3::new(x[7], x[8], x[9]),
            tmin: x[10],
            tmax: x[11],
        };
        check_no_nan(&s, &ray)?;
    }
}

fn check_no_nan(s: &Sphere, ray: &Ray) -> Result<(), TestCaseError> {
    // `roots` ignores the ray's range, `intersect` does not.
    let geometry_nan =
        s.center.is_nan() || s.radius.is_nan() || ray.origin.is_nan() || ray.dir.is_nan();
    if let Some(t) = s.intersect(ray) {
        let any_nan = geometry_nan || ray.tmin.is_nan() || ray.tmax.is_nan();
        prop_assert!(!any_nan, "hit at {t} with a NaN input");
        prop_assert!(
            t > ray.tmin && t < ray.tmax,
            "t = {t} outside the ray's range"
        );
    }
    // `roots` is NaN-free while its squares cannot overflow: with `R²` or `|f|²` = +inf it
    // returns `(∓inf, inf/inf = NaN)` (e.g. R = 1e30), which `intersect` then rejects. That is the
    // f32 overflow domain (|f|, R ≳ 1.8e19), not a geometry a scene can hold, so it is allowed.
    let f = dv(ray.origin) - dv(s.center);
    let in_range = f.length() * (1.0 + dv(ray.dir).dot(dv(ray.dir))) < 1e18
        && f64::from(s.radius).abs() < 1e18;
    if let Some((near, far)) = s.roots(ray) {
        prop_assert!(!geometry_nan, "roots {near}, {far} with a NaN input");
        if in_range {
            prop_assert!(!near.is_nan() && !far.is_nan(), "roots {near}, {far}");
        }
    }
    Ok(())
}

/// The worst |Δt| against f64 of the stable and the textbook sphere forms over many rays, how
/// often the textbook form missed outright, and the stable form's worst |Δt| in units of
/// [`far_bound`].
#[derive(Default)]
struct FarErrors {
    worst_stable: f64,
    worst_textbook: f64,
    textbook_misses: u32,
    worst_of_bound: f64,
}

/// The derived bound on the stable form's |Δt| for a far sphere (`|f| ≫ R`, `f = o − c`, half
/// chord `h`): `8u·|f|·(1 + R/h)`.
///
/// `b = f·d` rounds by at most `γ(3)·|f|` (three products and two sums of terms bounded by
/// `|f|`, `d` unit); `perp = f − b·d` then errs by a few `u·|f|` per component, so the squared
/// half chord `R² − |perp|²` by `2|perp|·δperp ≤ 2R·γ(4)|f|`, and its square root `h` by
/// `R·γ(4)|f| / h`; `t = −b − h` (or Vieta's `cq / q`, as accurate) adds these and one final
/// rounding: `|Δt| ≤ γ(3)|f| + γ(4)|f|·R/h + u·t ≤ 8u·|f|·(1 + R/h)`. The point: the error
/// scales with the distance `|f|`, not with `|f|² / R²` as the textbook form's cancellation does.
fn far_bound(ray: &Ray, s: &Sphere) -> f64 {
    let f = (dv(ray.origin) - dv(s.center)).length();
    let h = f64ref::sphere_half_chord2(ray.origin, ray.dir, s.center, s.radius).sqrt();
    8.0 * U * f * (1.0 + f64::from(s.radius) / h)
}

impl FarErrors {
    fn add(&mut self, ray: &Ray, s: &Sphere) {
        let (want, _) = f64ref::sphere_roots(ray.origin, ray.dir, s.center, s.radius).unwrap();
        let t = s.intersect(ray).expect("the stable form lost the sphere");
        let err = (f64::from(t) - want).abs();
        self.worst_stable = self.worst_stable.max(err);
        self.worst_of_bound = self.worst_of_bound.max(err / far_bound(ray, s));
        match textbook_near_root(ray, s) {
            Some(t) => self.worst_textbook = self.worst_textbook.max((f64::from(t) - want).abs()),
            None => self.textbook_misses += 1,
        }
    }

    /// Prints the figures (run with `--nocapture` to see them) and hands them back.
    fn report(self, what: &str, rays: u32) -> Self {
        eprintln!(
            "{what}: stable max |Δt| = {:e} ({:.3} of the derived bound); textbook max |Δt| = {:e}, \
             misses {}/{rays}",
            self.worst_stable, self.worst_of_bound, self.worst_textbook, self.textbook_misses
        );
        assert!(
            self.worst_of_bound <= 1.0,
            "{what}: |Δt| {:.2} times the derived bound",
            self.worst_of_bound
        );
        self
    }
}

/// Radius 1 at distance 10⁴ along an axis, lines across the whole disc (impact parameter up to
/// 0.9 R): the stable form keeps |Δt| ≤ 1e-3·R — measured 4.9e-4, i.e. half an f32 ulp of
/// t ≈ 10⁴ (2⁻¹⁰), the best f32 can represent — and within the derived bound [`far_bound`] on
/// every ray. The textbook quadratic of equation (32) computes
/// `b² − (|f|² − R²)` with both terms ≈ 10⁸, where an f32 ulp is 8 > R²: it loses the sphere
/// (misses, or tangent-like roots off by up to ~R).
#[test]
fn sphere_far_small_sphere_is_kept_by_the_stable_form() {
    let s = Sphere {
        center: Vec3::new(0.0, 0.0, 1.0e4),
        radius: 1.0,
    };
    let mut rng = Lcg::new(1);
    let (mut e, mut n) = (FarErrors::default(), 0);
    while n < 2000 {
        let (x, y) = (rng.next_f32() * 1.8 - 0.9, rng.next_f32() * 1.8 - 0.9);
        if x * x + y * y > 0.81 {
            continue;
        }
        n += 1;
        let ray = Ray::new(Vec3::new(x, y, 0.0), Vec3::Z);
        e.add(&ray, &s);
    }
    let FarErrors {
        worst_stable,
        worst_textbook,
        textbook_misses,
        ..
    } = e.report("far sphere", n);
    assert!(worst_stable <= 1e-3, "stable form: |Δt| = {worst_stable}");
    // The case is stiff: the textbook form is at least 100 times worse, or misses outright.
    assert!(
        textbook_misses > 0 || worst_textbook > 0.1,
        "textbook form did not lose the sphere: {worst_textbook}"
    );
    // The exact centre line, by hand: the textbook form sees a tangent (t = 10⁴, 1 R too far).
    let ray = Ray::new(Vec3::ZERO, Vec3::Z);
    assert_eq!(s.intersect(&ray), Some(9999.0));
    assert_eq!(textbook_near_root(&ray, &s), Some(1.0e4));
}

/// 2000 spheres of `radius` at `distance` from the origin in random directions (seed `seed`),
/// each crossed by a ray from the origin with impact parameter up to 0.9 R.
fn far_spheres_in_any_direction(seed: u64, distance: f32, radius: f32) -> FarErrors {
    let mut rng = Lcg::new(seed);
    let mut unit = || loop {
        let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        if v.length() > 0.1 && v.length() <= 1.0 {
            break v.normalize();
        }
    };
    let mut e = FarErrors::default();
    for _ in 0..2000 {
        let center = unit() * distance;
        let aim = unit() * 0.9 * radius * unit().x.abs();
        let s = Sphere { center, radius };
        let ray = Ray::new(Vec3::ZERO, (center + aim).normalize());
        e.add(&ray, &s);
    }
    e
}

/// Radius 1 at distance 10⁴ in arbitrary directions. Now `o − c` has three 10⁴-sized components
/// and the dot products alone round by about an ulp of 10⁴ (2⁻¹⁰ ≈ 9.8e-4), so 1e-3·R is beyond
/// f32 here; the stable form stays within 4 ulps of t (measured 2.4 ulps, |Δt| = 2.3e-3) and
/// within the derived bound [`far_bound`] on every ray, the textbook one does not come close.
#[test]
fn sphere_far_small_sphere_in_any_direction() {
    let e = far_spheres_in_any_direction(2, 1.0e4, 1.0);
    let FarErrors {
        worst_stable,
        worst_textbook,
        textbook_misses,
        ..
    } = e.report("far sphere, any direction", 2000);
    let ulp = f64::from(f32::EPSILON) * 8192.0; // f32 spacing in [8192, 16384)
    assert!(
        worst_stable <= 4.0 * ulp,
        "stable form: |Δt| = {worst_stable}"
    );
    assert!(textbook_misses > 0 && worst_textbook > 0.1);
}

/// Radius 10⁻³ at distance 10 in arbitrary directions, lines across the disc (impact parameter up
/// to 0.9 R): the stable form stays within the derived bound [`far_bound`] (`8u·|f|·(1 + R/h)`,
/// about 1.6·10⁻⁵ here, 1.6 % of R) on every ray; measured worst 2.2·10⁻⁶, 0.22 of it. The
/// textbook form computes `b² − (|f|² − R²)` with `|f|² = 100`, whose ulp (7.6·10⁻⁶) is larger
/// than `R² = 10⁻⁶`: it misses the sphere (640 of 2000 rays) or puts `t` off by more than R.
#[test]
fn sphere_small_sphere_at_distance_10() {
    let e = far_spheres_in_any_direction(3, 10.0, 1e-3);
    let FarErrors {
        worst_stable,
        worst_textbook,
        textbook_misses,
        ..
    } = e.report("radius 1e-3 at 10", 2000);
    assert!(worst_stable <= 2e-5, "stable form: |Δt| = {worst_stable}");
    assert!(
        textbook_misses > 0 || worst_textbook > 1e-3,
        "textbook form kept the sphere"
    );
}

/// The hand-checkable cases of `intersect`: in front, inside, behind, tangent, range clipping, and
/// the unit normal.
#[test]
fn sphere_hand_checked_cases() {
    let s = Sphere {
        center: Vec3::new(0.0, 0.0, 5.0),
        radius: 2.0,
    };
    let ray = Ray::new(Vec3::ZERO, Vec3::Z);
    assert_eq!(s.roots(&ray), Some((3.0, 7.0)));
    assert_eq!(s.intersect(&ray), Some(3.0));
    // Inside: the far root.
    assert_eq!(
        s.intersect(&Ray::new(Vec3::new(0.0, 0.0, 4.0), Vec3::Z)),
        Some(3.0)
    );
    // Behind: both roots negative.
    assert_eq!(s.intersect(&Ray::new(Vec3::ZERO, -Vec3::Z)), None);
    // Tangent (x = 2 touches at one point) and a clear miss.
    assert_eq!(
        s.roots(&Ray::new(Vec3::new(2.0, 0.0, 0.0), Vec3::Z)),
        Some((5.0, 5.0))
    );
    assert_eq!(s.roots(&Ray::new(Vec3::new(2.5, 0.0, 0.0), Vec3::Z)), None);
    // The open range skips the near root or both.
    assert_eq!(s.intersect(&ray.with_range(3.0, 10.0)), Some(7.0));
    assert_eq!(s.intersect(&ray.with_range(0.0, 3.0)), None);
    assert_eq!(s.intersect(&ray.with_range(3.5, 7.0)), None);
    // Normal: unit and outward.
    assert_eq!(s.normal(Vec3::new(0.0, 0.0, 3.0)), -Vec3::Z);
    assert_eq!(s.normal(Vec3::new(0.0, 2.0, 5.0)), Vec3::Y);
}

/// Issue 20: a sphere far from the ray's origin (1e19 and beyond) reported its far side: `|o − c|²`
/// overflowed f32 to `+inf`, so did the near root `cq / q`, and the far root `q` came first.
/// Both roots are now right, to a few ulp, for spheres and origins anywhere in f32's range, in
/// the scalar kernel, the 4- and 8-wide kernels (lane for lane the scalar's bits), and a walk
/// through a built scene.
#[test]
fn far_spheres_report_their_near_side() {
    use kdray_core::simd::{RayPacket, f32x4, f32x8, intersect_sphere};
    for s in [1e3f32, 1e18, 1e19, 3e19, 1e20, 1e30, 1e37] {
        // The sphere ahead of an origin at 0, and an origin far out behind a sphere at 0; the
        // roots are s and 3s, exact in f64.
        let cases = [
            (Vec3::new(0.0, 0.0, -2.0 * s), Vec3::ZERO),
            (Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0 * s)),
        ];
        for (center, origin) in cases {
            let sphere = Sphere { center, radius: s };
            let ray = Ray::new(origin, Vec3::NEG_Z);
            let (near, far) = sphere.roots(&ray).expect("the line crosses the sphere");
            let close = |t: f32, want: f32| (t - want).abs() <= 4.0 * f32::EPSILON * want;
            assert!(
                close(near, s) && close(far, 3.0 * s),
                "s = {s:e}: {near:e}, {far:e}"
            );
            assert_eq!(sphere.intersect(&ray), Some(near), "s = {s:e}");
            let rays = [ray, ray.with_range(2.0 * s, f32::INFINITY)];
            let p4 = intersect_sphere(&sphere, &RayPacket::<f32x4>::from_rays(&rays));
            let p8 = intersect_sphere(&sphere, &RayPacket::<f32x8>::from_rays(&rays));
            assert_eq!(p4.t.to_array()[..2], [near, far], "s = {s:e}");
            assert_eq!(p8.t.to_array()[..2], [near, far], "s = {s:e}");
        }
    }
    // Through the builder, the format and the walks: the scene spans ±3e19.
    let geom = kdray::Geometry {
        spheres: vec![(Vec3::new(0.0, 0.0, -2e19), 1e19)],
        ..kdray::Geometry::default()
    };
    let params = kdray::build::BuildParams::default();
    let tree = kdray::build::build(&geom, &params, None).unwrap();
    let words = kdray::flat::serialize(&tree, &geom, 0.0).unwrap();
    let scene = kdray_core::Scene::from_words(&words).unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::NEG_Z);
    let hit = scene.intersect(&ray);
    assert_eq!((hit.prim, hit.t), (0, 1e19));
    let packet = scene.intersect_packet(&RayPacket::<f32x8>::from_rays(&[ray]));
    assert_eq!(packet.t.to_array()[0], 1e19);
}
