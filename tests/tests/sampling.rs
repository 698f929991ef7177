//! Hemisphere samplers (`uniform_hemisphere`, Rukin's equation (56); `cosine_hemisphere`) and
//! the orthonormal basis they are taken to world space with (`Onb`, Duff et al. 2017).
//!
//! The statistical tests use a fixed LCG sequence, so they are reproducible: a failure is a
//! change in the code, not bad luck.

use glam::Vec3;
use kdray_core::sampling::{
    Onb, UNIFORM_HEMISPHERE_PDF, cosine_hemisphere, cosine_hemisphere_pdf, uniform_hemisphere,
};
use kdray_tests::Lcg;
use kdray_tests::f64ref::dv;
use proptest::prelude::*;

type Sampler = fn(f32, f32) -> Vec3;

const SAMPLERS: [(&str, Sampler); 2] = [
    ("uniform", uniform_hemisphere),
    ("cosine", cosine_hemisphere),
];

/// The largest f32 below 1.
const ONE_MINUS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A uniform number in [0, 1), with its ends (0 and the largest f32 below 1) often.
fn unit_interval() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => 0.0f32..1.0,
        1 => prop::sample::select(&[0.0f32, -0.0, 1e-45, 1e-30, 0.5, ONE_MINUS][..]),
    ]
}

fn unit_vec3() -> impl Strategy<Value = Vec3> {
    (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
        .prop_map(|(x, y, z)| Vec3::new(x, y, z))
        .prop_filter("not too short to normalize", |v| v.length() > 0.1)
        .prop_map(Vec3::normalize)
}

fn check_onb(n: Vec3) -> Result<(), TestCaseError> {
    let b = Onb::from_normal(n);
    let (x, y, nn) = (dv(b.x), dv(b.y), dv(b.n));
    prop_assert_eq!(b.n, n);
    for (name, v) in [("x", x), ("y", y)] {
        prop_assert!(
            (v.length() - 1.0).abs() <= 1e-6,
            "|{}| = {} for n = {}",
            name,
            v.length(),
            n
        );
    }
    prop_assert!(x.dot(y).abs() <= 1e-6, "x·y = {} for n = {}", x.dot(y), n);
    prop_assert!(x.dot(nn).abs() <= 1e-6, "x·n = {} for n = {}", x.dot(nn), n);
    prop_assert!(y.dot(nn).abs() <= 1e-6, "y·n = {} for n = {}", y.dot(nn), n);
    // Right-handed: x × y = n.
    prop_assert!(
        x.cross(y).max_abs_diff(nn) <= 2e-6,
        "x × y ≠ n for n = {}",
        n
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(1000)))]

    /// Both samplers give unit vectors in the upper hemisphere (z ≥ 0) of their local frame.
    #[test]
    fn samplers_give_unit_vectors_with_nonnegative_z(u1 in unit_interval(), u2 in unit_interval()) {
        for (name, sample) in SAMPLERS {
            let v = sample(u1, u2);
            prop_assert!((dv(v).length() - 1.0).abs() <= 1e-6, "{}: |v| = {}", name, v.length());
            prop_assert!(v.z >= 0.0, "{}: z = {}", name, v.z);
        }
    }

    /// Taken to world space around a unit normal, samples lie in that normal's hemisphere and
    /// stay unit vectors.
    #[test]
    fn world_samples_lie_in_the_normals_hemisphere(
        n in unit_vec3(), u1 in unit_interval(), u2 in unit_interval(),
    ) {
        let b = Onb::from_normal(n);
        for (name, sample) in SAMPLERS {
            let local = sample(u1, u2);
            let w = b.to_world(local);
            // The local z is the cosine to n; rounding may move a horizon sample (z = 0) below it
            // by an ulp or so, never more.
            prop_assert!(dv(w).dot(dv(n)) >= -1e-6, "{}: w·n = {}", name, w.dot(n));
            prop_assert!((dv(w).dot(dv(n)) - f64::from(local.z)).abs() <= 2e-6, "{}: cosine changed", name);
            prop_assert!((dv(w).length() - 1.0).abs() <= 2e-6, "{}: |w| = {}", name, w.length());
        }
    }

    /// `Onb::from_normal` is orthonormal and right-handed for random unit normals.
    #[test]
    fn onb_is_orthonormal_for_random_normals(n in unit_vec3()) {
        check_onb(n)?;
    }
}

/// The poles, where Frisvad's original construction divides by zero at n = (0, 0, −1) and which
/// Duff et al.'s sign fix must handle: exact bases at ±z, orthonormal ones right next to them.
#[test]
fn onb_is_orthonormal_at_and_near_the_poles() {
    let up = Onb::from_normal(Vec3::Z);
    assert_eq!((up.x, up.y), (Vec3::X, Vec3::Y));
    let down = Onb::from_normal(-Vec3::Z);
    assert_eq!((down.x, down.y), (Vec3::X, -Vec3::Y));
    let near = [
        Vec3::new(1e-7, 0.0, -1.0).normalize(),
        Vec3::new(0.0, -1e-4, -1.0).normalize(),
        Vec3::new(1e-20, 1e-20, -1.0),
        Vec3::new(1e-4, 1e-4, 1.0).normalize(),
        Vec3::X,
        -Vec3::Y,
    ];
    for n in [Vec3::Z, -Vec3::Z].into_iter().chain(near) {
        check_onb(n).unwrap_or_else(|e| panic!("{e}"));
    }
    // (0, 0, −0) is no unit vector, but it takes the negative branch (sign_not_zero) without
    // dividing by zero.
    let b = Onb::from_normal(Vec3::new(0.0, 0.0, -0.0));
    assert!(b.x.is_finite() && b.y.is_finite());
}

/// Means over `N` LCG samples of `f(sample(u1, u2))`.
fn mean(sample: Sampler, seed: u64, f: impl Fn(Vec3) -> f64) -> f64 {
    let mut rng = Lcg::new(seed);
    let total: f64 = (0..N)
        .map(|_| f(sample(rng.next_f32(), rng.next_f32())))
        .sum();
    total / N as f64
}

const N: usize = 1 << 16;

/// Standard error of a mean of `N` samples of variance `var`.
fn se(var: f64) -> f64 {
    (var / N as f64).sqrt()
}

/// Uniform: z = cosθ is uniform on [0, 1]: E[z] = 1/2, Var = 1/12, E[z²] = 1/3 (Var 4/45); the
/// azimuth is uniform: E[x] = E[y] = 0 (Var 1/3 each). Each mean within 5 standard errors.
#[test]
fn uniform_hemisphere_mean_cosine_is_one_half() {
    let s = uniform_hemisphere as Sampler;
    let m = mean(s, 1, |v| v.z.into());
    eprintln!(
        "uniform: mean cosθ = {m:.5} (5 SE = {:.5})",
        5.0 * se(1.0 / 12.0)
    );
    assert!((m - 0.5).abs() <= 5.0 * se(1.0 / 12.0), "mean cosθ = {m}");
    let m2 = mean(s, 2, |v| (v.z * v.z).into());
    assert!(
        (m2 - 1.0 / 3.0).abs() <= 5.0 * se(4.0 / 45.0),
        "mean cos²θ = {m2}"
    );
    for (axis, m) in [
        ("x", mean(s, 3, |v| v.x.into())),
        ("y", mean(s, 4, |v| v.y.into())),
    ] {
        assert!(m.abs() <= 5.0 * se(1.0 / 3.0), "mean {axis} = {m}");
    }
}

/// Cosine-weighted: pdf cosθ/π gives E[z] = 2/3 (E[z²] = 1/2, Var = 1/18), E[z²] = 1/2 (E[z⁴] =
/// 1/3, Var = 1/12); azimuth uniform, E[x] = E[y] = 0 (Var 1/4). Each within 5 standard errors.
#[test]
fn cosine_hemisphere_mean_cosine_is_two_thirds() {
    let s = cosine_hemisphere as Sampler;
    let m = mean(s, 5, |v| v.z.into());
    eprintln!(
        "cosine: mean cosθ = {m:.5} (5 SE = {:.5})",
        5.0 * se(1.0 / 18.0)
    );
    assert!(
        (m - 2.0 / 3.0).abs() <= 5.0 * se(1.0 / 18.0),
        "mean cosθ = {m}"
    );
    let m2 = mean(s, 6, |v| (v.z * v.z).into());
    assert!(
        (m2 - 0.5).abs() <= 5.0 * se(1.0 / 12.0),
        "mean cos²θ = {m2}"
    );
    for (axis, m) in [
        ("x", mean(s, 7, |v| v.x.into())),
        ("y", mean(s, 8, |v| v.y.into())),
    ] {
        assert!(m.abs() <= 5.0 * se(0.25), "mean {axis} = {m}");
    }
}

/// Correcting Rukin: the two samplers must give the same mean. The Monte Carlo estimate of
/// `∫ cosθ dω = π` over the hemisphere, `mean(cosθ / pdf)`, agrees for both with their pdfs:
/// uniform `2π·cosθ` (Var π²/3) within 5 SE; cosine-weighted `cosθ/(cosθ/π) = π` for every
/// sample (zero variance, up to rounding).
#[test]
fn both_samplers_estimate_the_same_integral() {
    let pi = core::f64::consts::PI;
    assert!((f64::from(UNIFORM_HEMISPHERE_PDF) - 0.5 / pi).abs() <= 1e-8);
    let u = mean(uniform_hemisphere, 9, |v| {
        f64::from(v.z) / f64::from(UNIFORM_HEMISPHERE_PDF)
    });
    assert!((u - pi).abs() <= 5.0 * se(pi * pi / 3.0), "uniform: {u}");
    let c = mean(cosine_hemisphere, 10, |v| {
        f64::from(v.z) / f64::from(cosine_hemisphere_pdf(v.z))
    });
    assert!((c - pi).abs() <= 1e-5, "cosine: {c}");
    assert_eq!(cosine_hemisphere_pdf(-0.5), 0.0);
}

/// The two samplers give the same mean for a Lambertian surface under a sky that is not
/// uniform, `L(ω) = 1 + x + z²` (local frame, z the normal): the reflected radiance over albedo,
/// `(1/π)∫ L cosθ dω = 1 + 0 + 2·∫₀^{π/2} cos³θ sinθ dθ = 3/2`, estimated as `mean(L·2cosθ)`
/// with uniform directions (pdf 1/2π) and `mean(L)` with cosine-weighted ones (pdf cosθ/π). Both
/// within 5 standard errors (from the samples' own variance) of 3/2 and of each other.
#[test]
fn both_samplers_give_the_same_mean_under_a_varying_sky() {
    let sky = |v: Vec3| 1.0 + f64::from(v.x) + f64::from(v.z).powi(2);
    let stats = |sample: Sampler, seed: u64, f: &dyn Fn(Vec3) -> f64| {
        let mut rng = Lcg::new(seed);
        let xs: Vec<f64> = (0..N)
            .map(|_| f(sample(rng.next_f32(), rng.next_f32())))
            .collect();
        let m = xs.iter().sum::<f64>() / N as f64;
        let var = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (N - 1) as f64;
        (m, se(var))
    };
    let (u, u_se) = stats(uniform_hemisphere, 11, &|v| sky(v) * 2.0 * f64::from(v.z));
    let (c, c_se) = stats(cosine_hemisphere, 12, &|v| sky(v));
    eprintln!("uniform {u:.5} ± {u_se:.5}, cosine {c:.5} ± {c_se:.5}");
    assert!((u - 1.5).abs() <= 5.0 * u_se, "uniform: {u} ± {u_se}");
    assert!((c - 1.5).abs() <= 5.0 * c_se, "cosine: {c} ± {c_se}");
    assert!((u - c).abs() <= 5.0 * u_se.hypot(c_se), "{u} against {c}");
    // The cosine-weighted estimate has the lower variance, which is why the renderer uses it.
    assert!(c_se < u_se, "{c_se} against {u_se}");
}

/// The domain ends map where the formulas say: u2 = 0 is the horizon for the uniform sampler,
/// u1 = 0 the pole for the cosine one.
#[test]
fn sampler_endpoints() {
    assert_eq!(uniform_hemisphere(0.0, 0.0), Vec3::X);
    assert_eq!(uniform_hemisphere(0.3, 1.0).z, 1.0);
    assert_eq!(cosine_hemisphere(0.0, 0.7), Vec3::Z);
    assert_eq!(cosine_hemisphere(1.0, 0.0).z, 0.0);
    // Azimuth 2πu: a quarter turn is +y for both.
    assert!(uniform_hemisphere(0.25, 0.0).abs_diff_eq(Vec3::Y, 1e-6));
    assert!(cosine_hemisphere(1.0, 0.25).abs_diff_eq(Vec3::Y, 1e-6));
}
