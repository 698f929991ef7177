//! Software prefetch: a hint that asks the cache hierarchy for a line before a load needs it, so
//! that other work can run while it arrives. On x86 and x86-64 (with SSE) it is `prefetcht0`
//! through `safe_arch` (safe: a prefetch never faults and has no effect on results); on every
//! other target it compiles to nothing, so thumbv7em and wasm32 run the same walks without it.

/// Asks for the cache line holding `*x` in every cache level.
#[inline(always)]
pub fn t0<T>(x: &T) {
    #[cfg(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse"
    ))]
    safe_arch::prefetch_t0(x);
    #[cfg(not(all(
        any(target_arch = "x86", target_arch = "x86_64"),
        target_feature = "sse"
    )))]
    let _ = x;
}
