//! Direction sampling for diffuse bounces, and the orthonormal frame they are expressed in.
//!
//! Samplers map two uniform numbers `u1, u2 ∈ [0, 1)` to a unit vector in the local frame whose
//! `z` axis is the surface normal; [`Onb::to_world`] takes it to world space.

use crate::math;
use core::f32::consts::{FRAC_1_PI, PI, TAU};
use glam::Vec3;

/// An orthonormal basis `(x, y, n)` around a unit normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Onb {
    pub x: Vec3,
    pub y: Vec3,
    pub n: Vec3,
}

impl Onb {
    /// Duff et al. 2017, "Building an Orthonormal Basis, Revisited" (JCGT 6(1)), listing 3:
    /// branchless apart from the sign, and exact for `n = (0, 0, −1)` where Frisvad's original
    /// breaks down.
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = math::sign_not_zero(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, n }
    }

    /// A local-frame vector `(x, y, z)` in world space.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.x + v.y * self.y + v.z * self.n
    }
}

/// Rukin's diffuse direction (equation (56)):
/// `(sqrt(1 − u2²) cos 2πu1, sqrt(1 − u2²) sin 2πu1, u2)`. Since `z = cosθ = u2` is uniform, this
/// is uniform over the hemisphere (correcting Rukin): pdf `1/2π`, mean `cosθ = 1/2`.
#[inline]
pub fn uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = math::sqrt((1.0 - u2 * u2).max(0.0));
    let (s, c) = math::sin_cos(TAU * u1);
    Vec3::new(r * c, r * s, u2)
}

/// The pdf of [`uniform_hemisphere`].
pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Cosine-weighted direction by Malley's method: a uniform point on the unit disk
/// (`r = sqrt(u1)`, `φ = 2πu2`) lifted to the hemisphere. pdf `cosθ/π`, mean `cosθ = 2/3`; lower
/// variance than [`uniform_hemisphere`] for Lambertian surfaces, with the same expected value.
#[inline]
pub fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = math::sqrt(u1);
    let (s, c) = math::sin_cos(TAU * u2);
    Vec3::new(r * c, r * s, math::sqrt((1.0 - u1).max(0.0)))
}

/// The pdf of [`cosine_hemisphere`] for a direction with `cosθ = cos_theta`.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// PCG32 (O'Neill 2014, `pcg32_random_r`): a small, fast, reproducible generator for sampling.
/// The renderer gives every sample its own stream; the host's benchmark ray sets use it too.
#[derive(Clone, Copy, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator in a fixed state, as a placeholder where one is needed before any seeding.
    pub const IDLE: Self = Self { state: 0, inc: 1 };

    /// The generator for `seed` on stream `stream` (streams are independent sequences).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `[0, 1)`: the top 24 bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
}
