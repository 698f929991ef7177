//! Benchmark support for kdray: the peers that kdray's figures are compared with, behind one
//! calling convention, and shared set-up for the criterion benches.
//!
//! Every peer is built over a triangle soup, `&[[Vec3; 3]]` (triangle `i` is `prim == i`), in a
//! build call that can be timed on its own, and traces `&[kdray_core::Ray]` into closest hits,
//! `kdray_core::Hit` per ray ([`Hit::MISS`](kdray_core::Hit::MISS) for a miss; `u`, `v` with
//! `p = v0 + u·(v1 − v0) + v·(v2 − v0)`), so that the same rays can be fed to every tracer and the
//! answers compared ray by ray (docs/BENCHMARKS.md, "Protocol"). Each `trace*` has a `*_into`
//! twin that writes into a caller's buffer, for timed loops that should not allocate.
//!
//! - [`peer_bvh::BvhPeer`]: the `bvh` crate (always available).
//! - `peer_embree::{EmbreeDevice, EmbreeScene}`: Embree 3 through a minimal hand-written FFI,
//!   `rtcIntersect1` and `rtcIntersect8`; feature `embree`, which links `libembree3` (Debian:
//!   `libembree-dev`, installed by `scripts/bench-setup.sh`).
//!
//! - [`front`]: the builder settings that `front` (docs/BUILD.md, "The front") measures, and
//!   [`knot`]: the npm benchmarks' torus knot, made natively.
//! - [`setup::Workload`]: the protocol's mesh, tree and ray sets, for each of the camera framings
//!   in [`framing`] (loose and tight).
//!
//! Peers build single-threaded, as the benchmark protocol asks. Rays must have `tmin >= 0`; rays
//! that are not finite are reported as misses without being traced. This crate is the only place
//! in the workspace with `unsafe` code (the Embree FFI); each block states why it is sound.

pub mod framing;
pub mod front;
pub mod knot;
pub mod peer_bvh;
#[cfg(feature = "embree")]
pub mod peer_embree;
pub mod setup;

/// The median of `v` (the upper one of an even count; NaN when empty), for timed rounds.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}
