//! Stiff cases of refraction (`optics::refract`, `optics::fresnel_dielectric`): grazing incidence,
//! index ratios 1.0001 and 4.0, and total internal reflection at the critical angle ± 1 ulp.

use glam::Vec3;
use kdray_core::optics::{fresnel_dielectric, refract};
use kdray_tests::Lcg;
use kdray_tests::f64ref::{self, dv};
use kdray_tests::strategies::U;

/// The f64 transmitted direction for unit `r`, `n` (Snell's law, `n` turned to face `r`), or
/// `None` under total internal reflection.
fn refract64(r: Vec3, n: Vec3, eta1: f32, eta2: f32) -> Option<f64ref::DVec3> {
    let n = if dv(r).dot(dv(n)) > 0.0 { -n } else { n };
    refract64_through(r, n, eta1, eta2)
}

/// [`refract64`] with `n` taken as the side the ray comes from, as given.
fn refract64_through(r: Vec3, n: Vec3, eta1: f32, eta2: f32) -> Option<f64ref::DVec3> {
    let (r, n) = (dv(r), dv(n));
    let ratio = f64::from(eta1) / f64::from(eta2);
    let tx = (r - r.dot(n) * n) * ratio;
    let sin2 = tx.dot(tx);
    (sin2 <= 1.0).then(|| tx - n * (1.0 - sin2).sqrt())
}

/// `r` at angle `θ` (by its cosine) to the normal `n = +z`, coming down onto the surface, turned
/// by `phi` about `z`.
fn incident(cos: f64, phi: f64) -> Vec3 {
    let sin = (1.0 - cos * cos).sqrt();
    Vec3::new(
        (sin * phi.cos()) as f32,
        (sin * phi.sin()) as f32,
        -cos as f32,
    )
}

/// Refraction at grazing incidence (`cos θ` from 10⁻¹ down to 10⁻⁷ and exactly 0, i.e. `r` in
/// the surface) for index ratios 1.0001, 1.5 and 4 in both directions, under arbitrary rotations.
///
/// Expected: total internal reflection exactly when the f64 `sin²θt` exceeds `1 + 16u`, a
/// transmitted ray when it is below `1 − 16u`; a transmitted ray is unit to `8u`, goes into the far
/// side (`t·n ≤ 0`; where `|r·n| ≤ 4u`, within the f32 rounding of `r·n`, the ray lies in the
/// surface as far as f32 can tell and either side is right), and matches the f64 direction to `16u / cos θt + 8u`: the tangential part
/// `(η1/η2)(r − (r·n)n)` is accurate to a few `u`, and the normal part `sqrt(1 − |tx|²)` magnifies
/// the error of `|tx|²` by `1 / (2 cos θt)`.
#[test]
fn refraction_at_grazing_incidence() {
    let mut rng = Lcg::new(21);
    let mut checked = 0;
    for k in 0..=8 {
        let cos = if k == 8 { 0.0 } else { 10f64.powi(-k - 1) };
        for ratio in [1.0001f32, 1.5, 4.0] {
            for (eta1, eta2) in [(1.0, ratio), (ratio, 1.0)] {
                for _ in 0..200 {
                    // A random rotation: a random unit normal and a random tangent frame.
                    let n = random_unit(&mut rng);
                    let t1 = n.any_orthonormal_vector();
                    let t2 = n.cross(t1);
                    let local = incident(cos, f64::from(rng.next_f32()) * core::f64::consts::TAU);
                    let r = (t1 * local.x + t2 * local.y + n * local.z).normalize();
                    let got = refract(r, n, eta1, eta2);
                    let mut want = refract64(r, n, eta1, eta2);
                    // Within the f32 error of `r·n` (3u) the side the ray comes from is not
                    // determined: either side's transmitted ray is right, and the kernel takes the
                    // side its own `r·n` says.
                    let ambiguous = dv(r).dot(dv(n)).abs() <= 4.0 * U;
                    if let (true, Some(t)) = (ambiguous, got) {
                        let flipped = refract64_through(r, facing(n, r), eta1, eta2);
                        if let Some(f) = flipped.filter(|f| f.max_abs_diff(dv(t)) < 1e-3) {
                            want = Some(f);
                        }
                    }
                    let sin2_t = sin2_transmitted(r, n, eta1, eta2);
                    if (sin2_t - 1.0).abs() <= 16.0 * U {
                        // At the critical angle itself either verdict is right; no NaN.
                        assert!(got.is_none_or(|t| t.is_finite()), "{got:?}");
                        continue;
                    }
                    checked += 1;
                    match (got, want) {
                        (None, None) => {}
                        (Some(t), Some(w)) => {
                            let t64 = dv(t);
                            assert!(
                                (t64.length() - 1.0).abs() <= 8.0 * U,
                                "|t| = {}",
                                t64.length()
                            );
                            if !ambiguous {
                                assert!(t.dot(facing(n, r)) <= 0.0, "{t} on the incident side");
                            }
                            let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
                            let bound = 16.0 * U / cos_t.max(1e-30) + 8.0 * U;
                            let err = t64.max_abs_diff(w);
                            assert!(
                                err <= bound.min(2.0),
                                "cos θ {cos}, η {eta1}/{eta2}: {t} vs {w:?}, {err} > {bound}"
                            );
                        }
                        (got, want) => panic!(
                            "cos θ {cos}, η {eta1}/{eta2}, sin²θt {sin2_t}: got {got:?}, f64 {want:?}"
                        ),
                    }
                }
            }
        }
    }
    assert!(checked > 8000);
}

/// Index ratio 1.0001 bends a ray by almost nothing, and 4.0 (into the denser medium) by a lot,
/// at every incidence: the deviation from the incident direction matches the f64 one (Snell's law
/// on the same f32 inputs) to 1e-6 rad away from grazing (`cos θ ≥ 0.01`). From the dense side
/// at 4.0 every ray past `asin(1/4)` is totally reflected.
#[test]
fn refraction_at_index_ratios_1_0001_and_4() {
    let mut rng = Lcg::new(22);
    for (eta1, eta2) in [(1.0f32, 1.0001f32), (1.0001, 1.0), (1.0, 4.0), (4.0, 1.0)] {
        for _ in 0..20_000 {
            let n = random_unit(&mut rng);
            let r = random_unit(&mut rng);
            let cos = f64::from(r.dot(n).abs());
            if cos < 0.01 {
                continue;
            }
            let sin2_t = sin2_transmitted(r, n, eta1, eta2);
            if (sin2_t - 1.0).abs() <= 1e-5 {
                continue;
            }
            match (refract(r, n, eta1, eta2), refract64(r, n, eta1, eta2)) {
                (None, None) => assert!(eta1 > eta2 && sin2_t > 1.0),
                (Some(t), Some(w)) => {
                    let deviation = f64ref::angle_deg(dv(r), dv(t)).to_radians();
                    let want = f64ref::angle_deg(dv(r), w).to_radians();
                    let cos_t = (1.0 - sin2_t).sqrt();
                    assert!(
                        (deviation - want).abs() <= 1e-6 / cos_t,
                        "η {eta1}/{eta2}: deviation {deviation} vs {want}"
                    );
                }
                (got, want) => panic!("η {eta1}/{eta2}: got {got:?}, f64 {want:?}"),
            }
        }
    }
}

/// Total internal reflection at the critical angle ± 1 ulp, where everything is exact: from
/// `η1 = 4` into `η2 = 1` (ratio exactly 4) with the normal `+z`, `r = (s, 0, −√(1 − s²))`, the
/// tangential part is `(4s, 0, 0)` with no rounding. So at `s = 1/4` (the critical angle)
/// `|tx|² = 1` exactly: a grazing transmitted ray `(1, 0, 0)`, with Fresnel reflectance 1; one ulp
/// above, `|tx|² > 1`: total internal reflection (`None`, reflectance 1); one ulp below: a
/// transmitted unit ray just under the surface, and reflectance below 1.
#[test]
fn total_internal_reflection_at_the_critical_angle_plus_minus_one_ulp() {
    let n = Vec3::Z;
    let ray = |s: f32| Vec3::new(s, 0.0, -(1.0 - s * s).sqrt());
    let critical = 0.25f32;
    assert_eq!(refract(ray(critical), n, 4.0, 1.0), Some(Vec3::X));
    assert_eq!(refract(ray(critical.next_up()), n, 4.0, 1.0), None);
    let below = refract(ray(critical.next_down()), n, 4.0, 1.0).expect("below the critical angle");
    assert!(below.z < 0.0 && below.x > 0.99, "{below}");
    assert!(
        (f64::from(below.length()) - 1.0).abs() <= 8.0 * U,
        "{below}"
    );
    // Snell, exactly: sin θt = 4·s.
    assert!((f64::from(below.x) - 4.0 * f64::from(critical.next_down())).abs() <= 2.0 * U);
    // Fresnel takes the angle as its cosine, `cos θi = √(1 − s²)` rounded to f32, which is the
    // critical angle only to within a few ulps; there the reflectance is as steep as
    // `1 − c·√(sin²θt − 1)`, so it is asserted to be the exact (f64) reflectance of an angle
    // whose cosine is within 4 ulps of the one given: at `s = 1/4` it is 0.991, not 1.
    let cos_i = |s: f32| (1.0 - s * s).sqrt();
    for s in [
        critical.next_down(),
        critical,
        critical.next_up(),
        0.2499,
        0.2501,
    ] {
        let c = f64::from(cos_i(s));
        let r = f64::from(fresnel_dielectric(cos_i(s), 4.0, 1.0));
        // Reflectance grows towards grazing (smaller cosine).
        let hi = f64ref::fresnel_dielectric(c * (1.0 - 4.0 * 2.0 * U), 4.0, 1.0);
        let lo = f64ref::fresnel_dielectric(c * (1.0 + 4.0 * 2.0 * U), 4.0, 1.0);
        assert!(
            r >= lo - 1e-6 && r <= hi + 1e-6,
            "s {s}: R {r} not in [{lo}, {hi}]"
        );
    }
    assert_eq!(fresnel_dielectric(cos_i(0.2501), 4.0, 1.0), 1.0);
    assert!(fresnel_dielectric(cos_i(0.2499), 4.0, 1.0) < 0.9);
    // The same three rays from the thin side never reflect totally.
    for s in [critical.next_down(), critical, critical.next_up()] {
        let t = refract(ray(s), n, 1.0, 4.0).expect("no total reflection into a denser medium");
        assert!((f64::from(t.length()) - 1.0).abs() <= 8.0 * U);
    }
}

/// `(η1/η2)² sin²θ1` in f64 for the f32 inputs: over 1 under total internal reflection.
fn sin2_transmitted(r: Vec3, n: Vec3, eta1: f32, eta2: f32) -> f64 {
    let c = dv(r).cross(dv(n));
    (f64::from(eta1) / f64::from(eta2)).powi(2) * c.dot(c)
}

fn random_unit(rng: &mut Lcg) -> Vec3 {
    loop {
        let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE;
        if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// `n` turned to face the incoming ray `r`.
fn facing(n: Vec3, r: Vec3) -> Vec3 {
    if r.dot(n) > 0.0 { -n } else { n }
}
