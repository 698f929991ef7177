//! # kdray-core
//!
//! A `no_std`, allocation-free ray-tracing core: it traverses a prebuilt SAH kd-tree stored as one
//! flat array of words, and holds the scalar reference math of kdray (rays, Möller–Trumbore
//! triangles, cancellation-free spheres, reflection, refraction, Fresnel, hemisphere sampling,
//! cameras) against which the SIMD packet kernels are tested.
//!
//! ## Guarantees
//! - `#![no_std]`, never links `alloc`, `#![forbid(unsafe_code)]`. Float functions that `core`
//!   lacks come from `libm` through one shim module ([`math`]), so the thumbv7em and wasm32 builds
//!   run the same code the host tests run.
//! - [`Scene::from_words`] validates a word array once, in linear time, and never panics on any
//!   input; every later access relies on what it validated (see [`format`]).
//! - NaN conventions: every hit test is written so that a NaN anywhere makes it fail, so a NaN ray
//!   or primitive is a miss, never a hit with NaN `t`; a non-finite ray is a miss in traversal.
//!
//! ## Modules
//! - [`ray`]: [`Ray`] and [`Hit`].
//! - [`triangle`]: Möller–Trumbore (seed §4), barycentric interpolation, normals.
//! - [`watertight`]: the watertight triangle test (Woop, Benthin & Wald 2013).
//! - [`sphere`]: the cancellation-free sphere test (Ray Tracing Gems ch. 7).
//! - [`optics`]: reflection, refraction, Schlick and exact Fresnel (seed §5).
//! - [`sampling`]: hemisphere samplers and an orthonormal basis (Duff et al. 2017).
//! - [`camera`]: pinhole, the seed's fisheye and parallel cameras, its thick lens and lens array.
//! - [`format`], [`node`]: the flat scene format and its validation; [`blocked`]: the
//!   cache-line-blocked copy of the tree (three levels per 64-byte block) and its walk.
//! - [`traverse`]: scalar closest-hit and any-hit traversal; [`walk`]: its walk as resumable
//!   steps over an explicit state, shared by the one-ray walk and the interleaved one.
//! - [`stream`]: ray streams — many rays in one call, sorted into packets and interleaved single
//!   rays, answers in input order; [`prefetch`]: the cache hint the interleaved walk issues.
//! - [`render`]: the render kernel, a path tracer writing into a caller's buffer.
//! - [`description`]: the render description (camera, settings, materials, lights) that a target
//!   reads next to the scene's words; [`words`]: bytes (`include_bytes!`, a fetch) viewed as
//!   words without `unsafe`; [`color`]: linear radiance to 8-bit sRGB, alike on every target.
//! - [`spawn`]: origins of rays leaving a surface, offset by its floating-point error bounds.
//! - [`simd`]: 4- and 8-wide ray packets, the lane trait they are generic over, and the packet
//!   kernels, which match the scalar ones lane by lane.
//!
//! The seed document is `shared/seed/ray-tracing-equations.txt`; equation numbers in the docs
//! refer to it, with the corrections of its `NOTES.md`.
#![no_std]
#![forbid(unsafe_code)]
// Hit tests are written as `!(x > y)` on purpose: NaN must fail them (see the crate doc).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod blocked;
pub mod camera;
pub mod color;
pub mod description;
pub mod format;
pub mod isa;
pub mod math;
pub mod node;
pub mod optics;
pub mod prefetch;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod simd;
pub mod spawn;
pub mod sphere;
pub mod stream;
pub mod traverse;
pub mod triangle;
pub mod walk;
pub mod watertight;
pub mod words;

pub use format::{FormatError, Scene};
pub use ray::{Hit, Ray};
pub use sphere::Sphere;
pub use triangle::Triangle;
