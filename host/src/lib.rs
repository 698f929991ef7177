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
pub mod accuracy;
pub mod blocks;
pub mod build;
pub mod closed;
pub mod converge;
pub mod description;
pub mod f64ref;
pub mod flat;
pub mod image;
pub mod plot;
pub mod progressive;
pub mod rays;
