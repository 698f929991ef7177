//! Linear radiance to 8-bit sRGB, in the core so that every target (the host's PNG, the WASM
//! module's RGBA canvas buffer, the firmware's checksum) rounds exactly alike: the transfer
//! function goes through the [`crate::math`] shim (`libm`), not the platform's `powf`.

use crate::math;

/// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to `[0, 1]`, as 8 bits
/// (rounded to nearest); NaN gives 0.
#[inline]
pub fn srgb8(linear: f32) -> u8 {
    let c = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * math::powf(c, 1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// An opaque RGBA pixel of `sum / samples`, a division as [`crate::render::render_rows`] does it,
/// so a sum of `n` samples resolved with `samples = n` gives the host's pixel bit for bit.
#[inline]
pub fn rgba8(sum: [f32; 3], samples: f32) -> [u8; 4] {
    let [r, g, b] = sum.map(|c| srgb8(c / samples));
    [r, g, b, 255]
}
