//! The few float functions the core needs, in one place.
//!
//! `core` has no `f32::sqrt` or `f32::sin`: those live in `std` and a host `cargo test` would hide
//! their absence. Everything goes through `libm` here so the thumbv7em and wasm32 builds use exactly
//! the code the host tests exercise (the pattern of glam's `src/f32/math.rs`). Beside them, the
//! rounding-error constants the kernels and the walks share ([`gamma`]).

#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

#[inline]
pub fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

#[inline]
pub fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

/// `x` to the power `y`.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

/// Sine and cosine of the same angle.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// `1.0` with the sign bit of `x` (so `-0.0` gives `-1.0`), never 0: the `sign(b)` of
/// cancellation-free quadratic solvers.
#[inline]
pub fn sign_not_zero(x: f32) -> f32 {
    f32::from_bits(1.0f32.to_bits() | (x.to_bits() & 0x8000_0000))
}

/// Degrees to radians.
#[inline]
pub fn radians(deg: f32) -> f32 {
    deg * (core::f32::consts::PI / 180.0)
}

/// `x` rounded to the nearest integer, halves away from zero.
#[inline]
pub fn round(x: f32) -> f32 {
    libm::roundf(x)
}

/// The unit roundoff of f32, `u = 2⁻²⁴`.
pub const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// Higham's `γ(n) = n·u / (1 − n·u)`: `n` successive roundings multiply a value by at most
/// `1 ± γ(n)`.
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}
