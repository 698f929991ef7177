//! Which instruction set this build's SIMD (`wide`) compiles to. `wide` chooses at compile time
//! from the enabled target features, so this is a constant of the build, not of the machine.

/// A short name: `avx512f` (with AVX2 and FMA: 16-wide packets in one register), `avx2+fma`,
/// `avx2`, `avx`, `sse4.1`, `sse2` on x86-64, `neon` on AArch64,
/// `simd128` on wasm32, otherwise `scalar` (wide's portable fallback).
pub const fn name() -> &'static str {
    if cfg!(all(
        target_feature = "avx512f",
        target_feature = "avx2",
        target_feature = "fma"
    )) {
        "avx512f"
    } else if cfg!(all(target_feature = "avx2", target_feature = "fma")) {
        "avx2+fma"
    } else if cfg!(target_feature = "avx2") {
        "avx2"
    } else if cfg!(target_feature = "avx") {
        "avx"
    } else if cfg!(target_feature = "sse4.1") {
        "sse4.1"
    } else if cfg!(target_feature = "sse2") {
        "sse2"
    } else if cfg!(target_feature = "neon") {
        "neon"
    } else if cfg!(target_feature = "simd128") {
        "simd128"
    } else {
        "scalar"
    }
}

/// How many `f32` lanes this build's SIMD registers hold: 8 with AVX (x86-64), otherwise 4 (SSE2,
/// NEON, simd128, and wide's scalar fallback, which emulates either).
pub const fn lanes() -> usize {
    if cfg!(target_feature = "avx") { 8 } else { 4 }
}
