//! Reflection, refraction and Fresnel (Rukin §5, as corrected here).
//!
//! Conventions: `r` is the incident direction (pointing towards the surface), `n` a unit surface
//! normal, both unit vectors. Functions that need the normal to face the incoming ray flip it
//! themselves, so either orientation of `n` may be passed.

use crate::math;
use glam::Vec3;

/// Mirror reflection `d_r = r − 2(r·n)n` (equations (34)–(36)). Keeps the length of `r` and the
/// angle to the normal; either orientation of `n` gives the same result.
#[inline]
pub fn reflect(r: Vec3, n: Vec3) -> Vec3 {
    r - 2.0 * r.dot(n) * n
}

/// Refraction from a medium of index `eta1` into one of index `eta2` (equations (40)–(54)).
///
/// With `n` turned to face the incoming ray, `t_x = (η1/η2)(r − (r·n)n)` is the tangential part
/// and `t_y = −n·sqrt(1 − |t_x|²)` the normal part. Returns `None` under total internal reflection
/// (`|t_x|² > 1`), when no transmitted ray exists.
#[inline]
pub fn refract(r: Vec3, n: Vec3, eta1: f32, eta2: f32) -> Option<Vec3> {
    let n = if r.dot(n) > 0.0 { -n } else { n };
    let tx = (eta1 / eta2) * (r - r.dot(n) * n);
    let sin2 = tx.length_squared();
    if !(sin2 <= 1.0) {
        return None;
    }
    Some(tx - n * math::sqrt(1.0 - sin2))
}

/// The cosine of the transmitted angle for incidence cosine `cos_i` (in `[0, 1]`), or `None` under
/// total internal reflection; from Snell's law `η1 sinθ1 = η2 sinθ2`.
#[inline]
pub fn cos_transmitted(cos_i: f32, eta1: f32, eta2: f32) -> Option<f32> {
    let ratio = eta1 / eta2;
    let sin2_t = ratio * ratio * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        None
    } else {
        Some(math::sqrt(1.0 - sin2_t))
    }
}

/// Schlick's approximation of the Fresnel reflectance (equations (57)–(58), exponent 5, correcting
/// Rukin): `R = R0 + (1 − R0)(1 − cosθ)⁵`, `R0 = ((η1 − η2)/(η1 + η2))²`.
///
/// `cos_i` is `|r·n|`. Going into a less dense medium (`η1 > η2`) the cosine of the transmitted
/// side is used, and `R = 1` under total internal reflection. The transmittance is `1 − R`.
#[inline]
pub fn schlick(cos_i: f32, eta1: f32, eta2: f32) -> f32 {
    let r0 = (eta1 - eta2) / (eta1 + eta2);
    let r0 = r0 * r0;
    let cos = if eta1 > eta2 {
        match cos_transmitted(cos_i, eta1, eta2) {
            Some(c) => c,
            None => return 1.0,
        }
    } else {
        cos_i
    };
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    r0 + (1.0 - r0) * m2 * m2 * m
}

/// The exact Fresnel reflectance of a smooth dielectric for unpolarized light: the mean of the
/// squared s- and p-polarized amplitude ratios (Fresnel equations; pbrt-v3 `FrDielectric`).
/// `R = 1` under total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta1: f32, eta2: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let Some(cos_t) = cos_transmitted(cos_i, eta1, eta2) else {
        return 1.0;
    };
    let rs = (eta1 * cos_i - eta2 * cos_t) / (eta1 * cos_i + eta2 * cos_t);
    let rp = (eta2 * cos_i - eta1 * cos_t) / (eta2 * cos_i + eta1 * cos_t);
    0.5 * (rs * rs + rp * rp)
}
