//! # kdray-core
//!
//! A `no_std`, allocation-free ray-tracing core: it traverses a prebuilt SAH kd-tree stored as one
//! flat array of words, and holds the scalar reference math of kdray (rays, Möller–Trumbore
//! triangles, cancellation-free spheres, reflection, refraction, Fresnel, hemisphere sampling,
//! cameras) against which the SIMD packet kernels are tested.
//!
//! ## Getting started
//! This crate traces; it does not build trees. Trees come from the host crate, [`kdray`]: the
//! `kdray build MESH -o FILE.kdt` command (`cargo install --locked --path host` in the repository), or in
//! Rust `kdray::build::build` and `kdray::flat::serialize`, which give the same `Vec<u32>`. Hand
//! the words to [`Scene::from_words`], which checks them once, then trace:
//!
//! ```
//! use glam::Vec3;
//! use kdray_core::{Hit, Ray, Scene, include_words, words};
//!
//! // A unit cube ([0, 1]³, 12 triangles) built by `kdray build`, compiled into the program on a
//! // 4-byte boundary (examples/data/cube.kdt; `include_words!` takes a path like
//! // `include_bytes!`).
//! let bytes: &[u8] = include_words!(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/data/cube.kdt"));
//! let scene = Scene::from_words(words::from_bytes(bytes).unwrap()).unwrap();
//! assert_eq!(scene.tri_count(), 12);
//!
//! // Closest hit: down the z axis onto the cube's top face, z = 1, at t = 2.
//! let ray = Ray::new(Vec3::new(0.5, 0.5, 3.0), Vec3::NEG_Z);
//! let hit: Hit = scene.intersect(&ray);
//! assert!(hit.is_hit());
//! assert!((hit.t - 2.0).abs() < 1e-6);
//! // `hit.prim` numbers triangles in the scene's storage order (the leaves' order, which
//! // `scene.triangle(hit.prim)` and every accessor take); the mesh's own index is `input_id`:
//! let top_face = scene.input_id(hit.prim);
//! assert!(top_face < 12);
//! // A miss is `Hit::MISS`: t = inf, prim = 0xFFFFFFFF.
//! assert!(!scene.intersect(&Ray::new(Vec3::new(3.0, 3.0, 3.0), Vec3::X)).is_hit());
//! // Any hit (shadow rays): is anything within t < 1.5?
//! assert!(!scene.occluded(&ray.with_range(0.0, 1.5)));
//! ```
//!
//! Four or eight rays at once: [`simd`]; many rays, sorted into packets for you:
//! [`traverse::stream`]; images: [`render`] (with a camera from [`camera`] and the materials and
//! lights of a scene, or a render description from `kdray build --description`, [`description`]).
//! The examples (`cargo run -p kdray-core --example trace_kdt` for this crate; `triangles` and
//! `render_buffer` in `kdray`) show each way in a short program.
//!
//! [`kdray`]: https://docs.rs/kdray
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
//! - [`triangle`]: Möller–Trumbore (Rukin §4), barycentric interpolation, normals.
//! - [`watertight`]: the watertight triangle test (Woop, Benthin & Wald 2013); [`distance`]: the
//!   `t` of its hits, from the plane in f64; [`far`]: both triangle tests in f64 where f32
//!   overflows.
//! - [`sphere`]: the cancellation-free sphere test (Ray Tracing Gems ch. 7).
//! - [`optics`]: reflection, refraction, Schlick and exact Fresnel (Rukin §5).
//! - [`sampling`]: hemisphere samplers and an orthonormal basis (Duff et al. 2017).
//! - [`camera`]: pinhole, Rukin's fisheye and parallel cameras, its thick lens and lens array.
//! - [`format`], [`node`]: the flat scene format and its validation, the wide section's
//!   encoding included ([`format::wide`]).
//! - [`traverse`]: every walk of the tree, one module each, and what they share (its module doc
//!   says which to use when): [`traverse::single`], one ray's closest or any hit;
//!   [`traverse::steps`], that walk as resumable steps over an explicit state;
//!   [`traverse::packet`], 4- and 8-wide packets; [`traverse::wide`], the single-ray walk over
//!   the tree collapsed into eight-wide nodes with tight boxes; [`traverse::stream`], ray
//!   streams — many rays in one call, sorted into packets and single rays (over a large tree's
//!   wide nodes, several at a time in turns, but for WebAssembly), answers in input order.
//! - [`render`]: the render kernel, a path tracer writing into a caller's buffer.
//! - [`description`]: the render description (camera, settings, materials, lights) that a target
//!   reads next to the scene's words; [`words`]: bytes (`include_bytes!`, a fetch) viewed as
//!   words without `unsafe`; [`color`]: linear radiance to 8-bit sRGB, alike on every target.
//! - `instance` (with the `instances` feature, on by default): the top level of a scene of
//!   many meshes — instances of bottom-level scenes placed by affine transforms, its own word
//!   array, validation and two-level walk.
//! - [`spawn`]: origins of rays leaving a surface, offset by its floating-point error bounds.
//! - [`simd`]: 4- and 8-wide ray packets, the lane trait they are generic over, and the packet
//!   kernels, which match the scalar ones lane by lane.
//!
//! Equation and section numbers ("Rukin §4", "equation (16)") refer to Rukin, "Equations for Ray
//! Tracing Implementation", the document the scalar math was written from; where it errs (a lost
//! sign, an exponent), the docs say so in place.
#![no_std]
#![forbid(unsafe_code)]
// Hit tests are written as `!(x > y)` on purpose: NaN must fail them (see the crate doc).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod camera;
pub mod color;
pub mod description;
pub mod distance;
pub mod far;
pub mod format;
pub mod group;
#[cfg(feature = "instances")]
pub mod instance;
pub mod isa;
pub mod math;
pub mod node;
pub mod optics;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod simd;
pub mod spawn;
pub mod sphere;
pub mod traverse;
pub mod triangle;
pub mod watertight;
pub mod words;

pub use format::{FormatError, Scene};
pub use ray::{Hit, Ray};
pub use sphere::Sphere;
pub use triangle::Triangle;
