//! The subcommands behind `main`.

mod build;
mod render;
mod trace;

pub use build::{BuildArgs, build, info};
pub use render::{RenderArgs, render};
pub use trace::{RayKind, TraceArgs, parse_size, rays, trace};
