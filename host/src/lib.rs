//! # kdray (host)
//!
//! The `std` side of kdray: loads meshes and scenes, builds the SAH kd-tree, serializes it into the
//! flat word array that `kdray-core` traverses, and drives the `kdray` command line.

pub mod error;
pub mod files;
pub mod geometry;
pub mod input;
pub mod load;
pub mod memory;
pub mod scene;

pub use error::{Error, Result};
pub use geometry::Geometry;
#[cfg(feature = "cli")]
pub mod accuracy;
pub mod blocks;
pub mod build;
pub mod closed;
#[cfg(feature = "cli")]
pub mod converge;
pub mod description;
pub mod f64ref;
pub mod flat;
#[cfg(feature = "cli")]
pub mod image;
#[cfg(feature = "cli")]
pub mod plot;
#[cfg(feature = "cli")]
pub mod progressive;
pub mod rays;
