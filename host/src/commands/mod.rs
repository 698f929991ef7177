//! The subcommands behind `main`.

mod build;
mod trace;

pub use build::{BuildArgs, build, info};
pub use trace::{RayKind, TraceArgs, parse_size, rays, trace};
