//! Traversal on arbitrary rays through one small valid scene (`kdray_fuzz::traversal`, where the
//! scene, the decoding and the checks live):
//!
//! - scalar, 4-wide and 8-wide packets must agree exactly (the same `t` bits; a different
//!   primitive only as a tie at that `t`), for closest hits and for occlusion, whatever the rays;
//!   so must the ray-stream API (bit for bit, ties included, where no packet traces; the rays, up
//!   to 64, are one stream);
//! - the scene's triangles alone, stored with triangle groups (format v9), must give the hits of
//!   the same tree stored with an index list, bit for bit, single rays and packets, both modes;
//! - fast and watertight mode must agree on rays whose nearer hit is not near an edge, not
//!   grazing and not at the ends of the ray's range (both hit, `t` within 1e-4 relative).
//!
//! The scene is a closed box of 12 triangles, a fan of triangles sharing edges and vertices on a
//! split-prone plane, and two spheres, all with coordinates on a grid of 1/2. Each ray takes 8
//! bytes: an origin on a grid of 1/8 in [-16, 16), a direction with integer components in
//! [-8, 8] (zeros of both signs, normalized or not by a flag bit), and a choice of `tmin/tmax`
//! band; snapping to these grids makes rays through vertices, along edges and in split planes
//! common instead of measure-zero. NaN and infinite rays come from one flag value too.
//!
//! Run: `bash fuzz/run.sh 600 traversal` (from the repository root). Findings are replayed by
//! `cargo test --manifest-path fuzz/Cargo.toml` from `fuzz/seeds/traversal/regression-*`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| kdray_fuzz::traversal::check(data));
