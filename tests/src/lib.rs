//! Shared helpers of kdray's cross-crate integration tests (`tests/tests/*.rs`).
//!
//! This crate is never published; its items are public only so the test binaries can share them.
//! - [`closed`]: closed meshes (icosphere, skinny box) and rays aimed at their seams.
//! - [`f64ref`]: f64 references of the core's f32 kernels, the yardstick the tests measure the
//!   core's rounding against (it lives in the host crate, `kdray::f64ref`, which `kdray accuracy`
//!   measures with too).
//! - [`Lcg`]: a fixed pseudo-random sequence, so the statistical tests are reproducible.
//! - [`EDGES`]: the edge values every kernel is fed (±0, ±inf, NaN, denormals, huge, tiny).
//! - [`strategies`]: proptest strategies for vectors, edge values and grid-snapped scenes.
//! - [`wt_bound`]: what the watertight kernel must do on a ray and triangle, from its error bound.
//! - [`walks`]: every walk of a scene (wide, nodes, packets of 4 and 8, the stream) over the same
//!   rays.

pub use kdray::closed;
pub use kdray::f64ref;
pub mod strategies;
pub mod walks;
pub mod wt_bound;

/// Edge values for kernel inputs, in the spirit of wide's `tests/simd_float.rs`: signed zeros,
/// infinities, NaN, the smallest denormal and a mid-range one, the smallest normal, tiny and huge
/// finite values, and a few ordinary ones so that edge values meet sane neighbours.
pub const EDGES: [f32; 19] = [
    0.0,
    -0.0,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    1.0e-45,  // smallest positive denormal
    -1.0e-45, // its negative
    1.0e-40,  // a mid-range denormal
    f32::MIN_POSITIVE,
    1.0e-30,
    -1.0e-30,
    1.0e30,
    -1.0e30,
    f32::MAX,
    f32::MIN,
    1.0,
    -1.0,
    0.5,
    -3.0,
];

/// Knuth's MMIX linear congruential generator: a deterministic, dependency-free sequence for the
/// statistical tests (good enough for means over 10⁵ samples; not for anything cryptographic).
#[derive(Clone, Debug)]
pub struct Lcg(u64);

impl Lcg {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next raw state.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0
    }

    /// Uniform in `[0, 1)` on the 2⁻²⁴ grid: the high 24 bits, whose period is the longest.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// A property test's case count: `n` times `KDRAY_PROPTEST_SCALE` (a whole number, default 1),
/// so that every suite can be run once with many more cases than CI's
/// (`KDRAY_PROPTEST_SCALE=20 cargo test --workspace`) without editing the tests.
///
/// # Panics
/// When `KDRAY_PROPTEST_SCALE` is set but not a positive whole number: a typo must not quietly
/// run the usual count.
pub fn cases(n: u32) -> u32 {
    match std::env::var("KDRAY_PROPTEST_SCALE") {
        Err(_) => n,
        Ok(v) => match v.trim().parse::<u32>() {
            Ok(k) if k > 0 => n.saturating_mul(k),
            _ => panic!("KDRAY_PROPTEST_SCALE={v:?} is not a positive whole number"),
        },
    }
}

/// The closest hit along `ray` by testing every primitive of `scene` with `C`'s kernels: the
/// reference the walks are held to.
pub fn brute_force<C: kdray_core::traverse::Contents>(
    scene: &kdray_core::Scene,
    ray: &kdray_core::Ray,
) -> kdray_core::Hit {
    let mut best = kdray_core::Hit::MISS;
    for prim in 0..scene.prim_count() {
        if let Some((t, u, v)) = scene.intersect_prim::<C>(prim, ray)
            && t < best.t
        {
            best = kdray_core::Hit { t, prim, u, v };
        }
    }
    best
}
