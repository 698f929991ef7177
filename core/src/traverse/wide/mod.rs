//! The single-ray walk over the wide section ([`walk`]). The wide nodes' encoding, their cut and
//! its validation are the format's ([`crate::format::wide`]); they are re-exported here, where
//! the walk and its users have always found them.

pub use crate::format::wide::*;

#[cfg(not(target_arch = "wasm32"))]
pub mod turns;
pub mod walk;
