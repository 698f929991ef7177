//! Ray streams: many rays traced in one call, answers in input order.
//!
//! The caller hands over a slice of rays, the answers' slice and scratch memory it owns
//! ([`scratch_words`] `u64`s for `n` rays); nothing is allocated. Inside, the stream
//! 1. traces each run of consecutive input rays that is coherent (one direction octant,
//!    directions within a cone, origins close: [`Coherence`]) as one packet — a camera's tiles
//!    stay packets without paying for a sort;
//! 2. sorts the other rays by octant, origin and direction ([`order`]), and traces the coherent
//!    runs of that order as packets — unless the scene has wide nodes (and the core its `wide`
//!    feature): then the one-ray walk over them is faster than packets of sorted rays over the
//!    binary nodes, and the other rays go straight to step 3, unsorted;
//! 3. traces what is left as single rays, one after another, by the one-ray walk (over the wide
//!    nodes when the scene has them).
//!
//! Every answer equals the single-ray walk's ([`Scene::intersect_in`], [`Scene::occluded_in`]):
//! the leftover rays run that very walk, and the packet walks match it lane by lane (the same
//! `t` bits; where two primitives tie at exactly that `t`, the packet may report either, as the
//! packet walks do everywhere). With [`Packets::Off`] the answers are the single-ray walk's
//! bit for bit, ties included.
//!
//! (Until format 12 the leftover rays could walk the binary nodes 4 to 16 at a time, interleaved
//! with prefetches to overlap their loads; the wide walk is faster one ray at a time, so that
//! walk was retired: docs/BENCHMARKS.md, "Retired: blocks and interleaved walks".)
//!
//! Errors (slices of the wrong length, too little scratch) are returned, never a panic.

pub mod order;
mod trace;

pub use order::Coherence;

use crate::format::Scene;
use crate::ray::{Hit, Ray};
use crate::simd::{f32x4, f32x8};
use crate::traverse::{Contents, Mode, by_contents};
use trace::{Answer, AnyHits, ClosestHits};
/// For the stream over a top level (`crate::instance::stream`).
#[cfg(feature = "instances")]
pub(crate) use trace::{IDLE, run_length};

/// `u64` words of scratch a stream of `rays` rays needs: a sort key and an index per ray.
pub const fn scratch_words(rays: usize) -> usize {
    2 * rays
}

/// Why a stream call refused its arguments (nothing was traced).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamError {
    /// The answers' slice is not as long as the rays'.
    Length { rays: usize, answers: usize },
    /// The scratch holds fewer words than [`scratch_words`] asks for.
    Scratch { needed: usize, given: usize },
}

impl core::fmt::Display for StreamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Length { rays, answers } => {
                write!(f, "{rays} rays but room for {answers} answers")
            }
            Self::Scratch { needed, given } => {
                write!(f, "scratch of {given} words, {needed} needed")
            }
        }
    }
}

/// The packets a stream forms from coherent runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Packets {
    /// None: every ray is a single ray (sorted).
    Off,
    Four,
    Eight,
}

impl Default for Packets {
    /// As wide as this build's SIMD registers ([`crate::isa::lanes`]): eight lanes with AVX, four
    /// otherwise, where `wide` makes an 8-wide packet of two 4-wide halves. On the portable x86-64
    /// build (SSE2) the renderer's wavefronts ran 1.07× (default scene) and 1.11× (dragon scene)
    /// faster with 4-wide packets than with 8-wide (docs/BENCHMARKS.md, "The renderer's rays as
    /// streams").
    fn default() -> Self {
        if crate::isa::lanes() >= 8 {
            Self::Eight
        } else {
            Self::Four
        }
    }
}

/// Whether the stream's single rays over wide nodes walk in turns, four at a time
/// (`traverse::wide::turns`: the same answers). Never in a WebAssembly build, whatever this says
/// (the module `turns` is not compiled there): their copies of the walk added 13 % to the npm
/// package's modules (1.38 → 1.56 MB scalar), and under V8 the npm package's `raycastMany` of the
/// torus knot took 0.87–1.29× its time without them over four runs, no gain this machine could
/// tell from its noise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Turns {
    /// When what a walk reads is at least [`TURNS_FROM_BYTES`] ([`Scene::walked_bytes`]): a tree
    /// larger than a core's L2 cache, whose walks wait on memory. A smaller tree's walks stay in
    /// the cache, where the turns only add instructions (up to 40 % more on the bunny's diffuse
    /// rays, for the same time).
    #[default]
    Auto,
    /// Always (with wide nodes).
    Always,
    /// Never: one ray after another.
    Never,
}

/// The size of tree from which [`Turns::Auto`] walks single rays in turns: 2 MiB, a server
/// core's L2 cache (docs/BENCHMARKS.md, "Single rays in turns").
pub const TURNS_FROM_BYTES: usize = 2 << 20;

/// How a stream traces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub mode: Mode,
    pub packets: Packets,
    pub coherence: Coherence,
    pub turns: Turns,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            mode: Mode::Fast,
            packets: Packets::default(),
            // Same octant, whatever the directions and origins within it: on the dragon's
            // diffuse rays every looser rule ran faster (docs/BENCHMARKS.md, "Ray streams"),
            // since a ray left out of a packet takes the slower single-ray path.
            coherence: Coherence {
                min_cos: -1.0,
                max_origin: f32::INFINITY,
            },
            turns: Turns::Auto,
        }
    }
}

/// Closest hits of the stream `rays` into `hits` (same length, in the rays' order; each `prim`
/// in storage order, as [`Scene::intersect`]'s).
///
/// # Errors
/// [`StreamError::Length`] if `hits` is not as long as `rays`; [`StreamError::Scratch`] if
/// `scratch` is shorter than [`scratch_words`]`(rays.len())`.
pub fn intersect(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    hits: &mut [Hit],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    run::<ClosestHits>(scene, config, rays, hits, scratch)
}

/// Occlusion of the stream `rays` into `occluded` (same length, input order).
///
/// # Errors
/// As [`intersect`].
pub fn occluded(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    occluded: &mut [bool],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    run::<AnyHits>(scene, config, rays, occluded, scratch)
}

fn check_length<T>(rays: &[Ray], answers: &[T]) -> Result<(), StreamError> {
    if rays.len() == answers.len() {
        Ok(())
    } else {
        Err(StreamError::Length {
            rays: rays.len(),
            answers: answers.len(),
        })
    }
}

fn run<A: Answer>(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    out: &mut [A::Out],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    check_length(rays, out)?;
    let needed = scratch_words(rays.len());
    let pairs = match scratch.get_mut(..needed) {
        Some(s) => s.as_chunks_mut::<2>().0,
        None => {
            return Err(StreamError::Scratch {
                needed,
                given: scratch.len(),
            });
        }
    };
    by_contents!(scene, config.mode, |C| run_with::<A, C>(
        scene, config, rays, out, pairs
    ));
    Ok(())
}

/// [`intersect`] for contents `C` fixed at compile time (`config.mode` is not read): for the
/// renderer's wavefront, whose kernel is chosen once a frame. `hits` is as long as `rays` and
/// `pairs` holds a pair of words for each ray (a shorter `pairs` leaves the rays past it
/// untraced: the callers size it, it is not input).
pub(crate) fn intersect_with<C: Contents>(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    hits: &mut [Hit],
    pairs: &mut [[u64; 2]],
) {
    run_with::<ClosestHits, C>(scene, config, rays, hits, pairs);
}

/// [`occluded`] for contents `C` fixed at compile time, as [`intersect_with`].
pub(crate) fn occluded_with<C: Contents>(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    occluded: &mut [bool],
    pairs: &mut [[u64; 2]],
) {
    run_with::<AnyHits, C>(scene, config, rays, occluded, pairs);
}

fn run_with<A: Answer, C: Contents>(
    scene: &Scene,
    config: &Config,
    rays: &[Ray],
    out: &mut [A::Out],
    pairs: &mut [[u64; 2]],
) {
    let rule = &config.coherence;
    let turns = match config.turns {
        Turns::Auto => scene.walked_bytes() >= TURNS_FROM_BYTES,
        Turns::Always => true,
        Turns::Never => false,
    };
    let s = (rule, turns);
    match config.packets {
        Packets::Off => trace::stream::<A, C, f32x8, false>(scene, rays, out, pairs, s),
        Packets::Four => trace::stream::<A, C, f32x4, true>(scene, rays, out, pairs, s),
        Packets::Eight => trace::stream::<A, C, f32x8, true>(scene, rays, out, pairs, s),
    }
}
