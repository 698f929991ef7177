//! SIMD building blocks for 4- and 8-wide ray packets (ARCHITECTURE.md, "Packets written once over a lane trait").
//!
//! - [`lanes`]: the [`Lanes`] trait over `wide`'s [`f32x4`] and [`f32x8`], and [`Vec3x`], a
//!   struct-of-arrays 3-vector. Kernels are written once, generic over it.
//! - [`packet`]: [`RayPacket`] (rays with an active mask) and [`HitPacket`] (closest hits).
//! - [`kernels`]: packet Möller–Trumbore and packet sphere, each matching its scalar twin lane by
//!   lane bit for bit, and [`record_closest`], the closest-hit update.
//! - [`watertight`]: the packet watertight kernel, matching [`crate::watertight`] lane by lane.
//! - [`range`]: when a packet's Möller–Trumbore tests cannot overflow f32 in a scene, so that the
//!   packet walk leaves out the check that sends overflowing lanes to the f64 kernel.
//! - [`group`]: one ray against a group of four triangles ([`crate::group`]), the same lane
//!   arithmetic with the ray splat and the triangles in the lanes.
//!
//! The packet walk of the kd-tree, built on these, is [`crate::traverse::packet`].
//!
//! `wide` chooses SSE, AVX, NEON, simd128 or a portable fallback at compile time from the enabled
//! target features ([`crate::isa::name`] reports which); an 8-wide packet on a build without AVX
//! runs as two 4-wide halves.
//!
//! ```
//! use kdray_core::simd::{HitPacket, RayPacket, f32x8, intersect_triangle, record_closest};
//! use kdray_core::{Hit, Ray, Triangle};
//! use glam::Vec3;
//!
//! let tri = Triangle::from_vertices(Vec3::ZERO, Vec3::X, Vec3::Y);
//! let rays = [Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z); 3];
//! let mut packet = RayPacket::<f32x8>::from_rays(&rays);
//! let mut hits = HitPacket::miss();
//! let found = intersect_triangle(&tri, &packet);
//! assert_eq!(record_closest(&mut hits, &mut packet, &found, 7), 0b111);
//! let mut out = [Hit::MISS; 3];
//! hits.write_active(&packet, &mut out);
//! assert_eq!((out[2].t, out[2].prim), (1.0, 7));
//! ```

pub mod group;
pub mod kernels;
pub mod lanes;
pub mod packet;
pub mod range;
pub mod watertight;

pub use kernels::{PrimHits, intersect_sphere, intersect_triangle, record_closest};
pub use lanes::{Lanes, Vec3x};
pub use packet::{HitPacket, RayPacket};
pub use watertight::{
    ShearX, intersect_triangle_watertight, intersect_triangle_watertight_prepared,
};
pub use wide::{f32x4, f32x8, f32x16};

/// A 4-wide ray packet.
pub type RayPacket4 = RayPacket<f32x4>;
/// An 8-wide ray packet.
pub type RayPacket8 = RayPacket<f32x8>;
/// A 4-wide hit packet.
pub type HitPacket4 = HitPacket<f32x4>;
/// An 8-wide hit packet.
pub type HitPacket8 = HitPacket<f32x8>;
