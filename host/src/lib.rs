//! # kdray (host)
//!
//! The `std` side of kdray: loads meshes and scenes, builds the SAH kd-tree, serializes it into the
//! flat word array that `kdray-core` traverses, and drives the `kdray` command line.
//!
//! ## Getting started
//! Triangles (and spheres) in a [`Geometry`] → [`build::build`] → [`flat::serialize`] gives the
//! words of a tree, the same words `kdray build` writes into a `.kdt` ([`flat::write_kdt`]);
//! [`kdray_core::Scene::from_words`] checks them and traces rays through them, on the host as on
//! a microcontroller or in WebAssembly:
//!
//! ```
//! use kdray::Geometry;
//! use kdray::glam::Vec3;
//! use kdray::build::{BuildParams, build};
//! use kdray_core::{Ray, Scene};
//!
//! // One triangle in the z = 0 plane and a sphere of radius 0.5 around (0, 0, -3).
//! let geom = Geometry {
//!     triangles: vec![[Vec3::ZERO, Vec3::X, Vec3::Y]],
//!     spheres: vec![(Vec3::new(0.0, 0.0, -3.0), 0.5)],
//!     ..Geometry::default()
//! };
//! let tree = build(&geom, &BuildParams::default(), None).unwrap();
//! let words: Vec<u32> = kdray::flat::serialize(&tree, &geom, 0.0).unwrap();
//!
//! let scene = Scene::from_words(&words).unwrap();
//! let hit = scene.intersect(&Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z));
//! // `hit.prim` is the id in the scene's storage order (the leaves' order, which every accessor
//! // takes); `input_id` maps it to the index in `geom` (here both are 0, the only triangle).
//! assert_eq!(scene.input_id(hit.prim), 0); // the triangle
//! assert!((hit.t - 1.0).abs() < 1e-6);
//! let hit = scene.intersect(&Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::NEG_Z));
//! // The sphere: triangles are numbered first, then spheres.
//! assert_eq!(scene.input_id(hit.prim), 1);
//! assert!((hit.t - 1.5).abs() < 1e-6);
//! ```
//!
//! With many triangles the two orders differ: the serializer stores triangles in the order the
//! leaves reach them, so that neighbours share cache lines. `scene.triangle(hit.prim)` is the hit
//! triangle; `scene.input_id(hit.prim)` its index in `geom.triangles`, what `kdray trace`'s hits
//! file, `kdray::rays::to_input_ids`, the Python package's `prim` and the npm package's
//! `faceIndex` report.
//!
//! Scene files (`docs/SCENE.md`) load with [`scene::load_scene`] (camera, materials, geometry);
//! meshes with [`input::load_input`] (PLY, OBJ, `.tri`); [`progressive`] renders on all cores.
//! Runnable programs: `cargo run --release -p kdray --example triangles` (this example with more
//! rays), `--example render_buffer` (a scene rendered into a buffer) and `--example instances`
//! (10,000 instances of one mesh under a top level, [`instances`]) in this crate,
//! `-p kdray-core --example trace_kdt` (a `.kdt` compiled in, traced `no_std`-style) in
//! `kdray-core`. (`-p` keeps the crates' features those of `cargo run --release -p kdray`, so
//! nothing is compiled again; without it cargo unifies the whole workspace's features, the
//! benches' included, and rebuilds the dependency tree.) The
//! command line: `kdray --help`.
//!
//! ## As a library: features
//! The default feature, `cli`, brings the command line and what only it uses: clap, indicatif,
//! png, exr, plotters and rayon, and the modules [`accuracy`], [`converge`], [`cpu`],
//! [`image`], [`plot`] and [`progressive`]. A program that loads, builds and traces needs none
//! of it:
//! ```toml
//! [dependencies]
//! kdray = { version = "0.1", default-features = false, features = ["parallel"] }
//! kdray-core = "0.1"
//! ```
//! `parallel` keeps the multithreaded build (rayon; [`build::BuildParams::parallel`]); leave it
//! out too for a single-threaded build or for `wasm32-unknown-unknown` (the npm package's
//! module). Without `cli` the crate compiles about half as long and pulls in none of the command
//! line's dependencies.
//!
//! ## glam
//! Vectors in this API ([`Geometry`]'s triangles, cameras, rays) are [`glam`]'s (0.34); the
//! crate re-exports it as `kdray::glam`, so a program need not name a matching version itself:
//! `use kdray::glam::Vec3;`.

pub use glam;

pub mod error;
pub mod files;
pub mod geometry;
pub mod input;
pub mod instances;
pub mod load;
pub mod memory;
pub mod scene;

pub use error::{Error, Result};
pub use geometry::Geometry;
#[cfg(feature = "cli")]
pub mod accuracy;
pub mod build;
pub mod closed;
#[cfg(feature = "cli")]
pub mod converge;
pub mod counts;
#[cfg(feature = "cli")]
pub mod cpu;
pub mod crossings;
pub mod description;
pub mod f64ref;
pub mod flat;
#[cfg(feature = "cli")]
pub mod image;
pub mod par;
#[cfg(feature = "cli")]
pub mod plot;
#[cfg(feature = "cli")]
pub mod progressive;
pub mod rays;
pub mod reach;
pub mod wide;
