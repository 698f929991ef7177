//! Ray streams through a top level: many world rays in one call, answers in input order, as the
//! single-mesh stream ([`crate::traverse::stream`]) traces a scene, with its [`Config`], its
//! scratch ([`scratch_words`]) and its errors.
//!
//! 1. Each run of `W` consecutive input rays that is coherent
//!    ([`Coherence`](crate::traverse::stream::Coherence)) is traced as one packet
//!    ([`InstancedScene::intersect_packet_in`]).
//! 2. The other rays, when some bottom scene has no wide nodes, are sorted by octant, origin and
//!    direction (the single-mesh stream's keys over the top level's box), and the coherent runs
//!    of that order are traced as packets; when every bottom scene has wide nodes, the one-ray
//!    walk over them is the faster (as for one mesh: docs/BENCHMARKS.md, "The stream over wide
//!    nodes"), and the other rays go straight to step 3, unsorted.
//! 3. What is left is traced ray by ray ([`InstancedScene::intersect_in`]).
//!
//! Every answer is the single-ray walk's: the leftover rays run it, and the packet walk gives
//! each lane its `t` bits (where two primitives or instances tie at that `t`, either). With
//! [`Packets::Off`] the answers are the single-ray walk's bit for bit, ties included.
//!
//! [`intersect`] and [`occluded`] are `#[inline]`, so that they and every walk they call are
//! compiled in the caller's crate, not the core's: compiled in the core, they moved LLVM's
//! inlining of the single-mesh walks' watertight kernels (scripts/icount.sh: up to +9 % on the
//! single-mesh watertight rows).

use super::{InstanceHit, InstancedScene};
use crate::ray::Ray;
use crate::simd::{Lanes, RayPacket, f32x4, f32x8};
use crate::traverse::Mode;
use crate::traverse::stream::order::{key, origin_scale};
use crate::traverse::stream::{Config, IDLE, Packets, StreamError, run_length, scratch_words};

/// A query answered for a whole stream: its answer per ray, one ray's and one packet's.
trait Answer {
    type Out: Copy;
    const NONE: Self::Out;
    fn single(top: &InstancedScene, mode: Mode, ray: &Ray) -> Self::Out;
    /// Traces a packet whose lanes are all active; `out[lane]` receives each answer.
    fn packet<L: Lanes>(
        top: &InstancedScene,
        mode: Mode,
        rays: &RayPacket<L>,
        out: &mut [Self::Out],
    );
}

/// Closest hits.
struct ClosestHits;
/// Any hit.
struct AnyHits;

impl Answer for ClosestHits {
    type Out = InstanceHit;
    const NONE: InstanceHit = InstanceHit::MISS;
    #[inline(always)]
    fn single(top: &InstancedScene, mode: Mode, ray: &Ray) -> InstanceHit {
        top.intersect_in(mode, ray)
    }
    #[inline(always)]
    fn packet<L: Lanes>(
        top: &InstancedScene,
        mode: Mode,
        rays: &RayPacket<L>,
        out: &mut [InstanceHit],
    ) {
        top.intersect_packet_in(mode, rays).write_active(rays, out);
    }
}

impl Answer for AnyHits {
    type Out = bool;
    const NONE: bool = false;
    #[inline(always)]
    fn single(top: &InstancedScene, mode: Mode, ray: &Ray) -> bool {
        top.occluded_in(mode, ray)
    }
    #[inline(always)]
    fn packet<L: Lanes>(top: &InstancedScene, mode: Mode, rays: &RayPacket<L>, out: &mut [bool]) {
        let mask = top.occluded_packet_in(mode, rays).bitmask();
        for (lane, o) in out.iter_mut().enumerate() {
            *o = mask >> lane & 1 == 1;
        }
    }
}

/// Closest hits of the world rays `rays` into `hits` (same length, in the rays' order).
///
/// # Errors
/// [`StreamError::Length`] if `hits` is not as long as `rays`; [`StreamError::Scratch`] if
/// `scratch` is shorter than [`scratch_words`]`(rays.len())`.
#[inline]
pub fn intersect(
    top: &InstancedScene,
    config: &Config,
    rays: &[Ray],
    hits: &mut [InstanceHit],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    run::<ClosestHits>(top, config, rays, hits, scratch)
}

/// Occlusion of the world rays `rays` into `occluded` (same length, input order).
///
/// # Errors
/// As [`intersect`].
#[inline]
pub fn occluded(
    top: &InstancedScene,
    config: &Config,
    rays: &[Ray],
    occluded: &mut [bool],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    run::<AnyHits>(top, config, rays, occluded, scratch)
}

fn run<A: Answer>(
    top: &InstancedScene,
    config: &Config,
    rays: &[Ray],
    out: &mut [A::Out],
    scratch: &mut [u64],
) -> Result<(), StreamError> {
    if rays.len() != out.len() {
        return Err(StreamError::Length {
            rays: rays.len(),
            answers: out.len(),
        });
    }
    let needed = scratch_words(rays.len());
    let Some(pairs) = scratch.get_mut(..needed) else {
        return Err(StreamError::Scratch {
            needed,
            given: scratch.len(),
        });
    };
    let pairs = pairs.as_chunks_mut::<2>().0;
    match config.packets {
        Packets::Off => stream::<A, f32x8, false>(top, config, rays, out, pairs),
        Packets::Four => stream::<A, f32x4, true>(top, config, rays, out, pairs),
        Packets::Eight => stream::<A, f32x8, true>(top, config, rays, out, pairs),
    }
    Ok(())
}

/// The whole stream (see the module doc); `scratch` holds a `[key, index]` pair per ray.
fn stream<A: Answer, L: Lanes, const PACKETS: bool>(
    top: &InstancedScene,
    config: &Config,
    rays: &[Ray],
    out: &mut [A::Out],
    scratch: &mut [[u64; 2]],
) {
    let (mode, rule) = (config.mode, &config.coherence);
    let [lo, hi] = top.bounds();
    // (An infinite fraction admits any origin, even in a box of zero size.)
    let max_origin = if rule.max_origin.is_finite() {
        rule.max_origin * (hi - lo).length()
    } else {
        rule.max_origin
    };
    let max_origin2 = max_origin * max_origin;
    let scale = origin_scale(lo, hi);
    const { assert!(L::WIDTH <= 16) };
    let width = L::WIDTH;
    let alone = top.bottoms().iter().all(|b| !b.wide_nodes().is_empty());
    let mut m = 0;
    for (c, chunk) in rays.chunks(width).enumerate() {
        let base = c * width;
        if PACKETS && run_length(chunk.iter(), rule, max_origin2) == width {
            trace_packet::<A, L>(top, mode, chunk, |lane| base + lane, out);
            continue;
        }
        for (k, ray) in chunk.iter().enumerate() {
            if alone {
                if let Some(o) = out.get_mut(base + k) {
                    *o = A::single(top, mode, ray);
                }
            } else if let Some(slot) = scratch.get_mut(m) {
                *slot = [key(ray, lo, scale), (base + k) as u64];
                m += 1;
            }
        }
    }
    let keys = &mut scratch[..m];
    keys.sort_unstable();
    let ray_of = |e: &[u64; 2]| rays.get(e[1] as usize);
    let mut i = 0;
    while i < m {
        if PACKETS {
            let run = &keys[i..m.min(i + width)];
            if run_length(run.iter().filter_map(ray_of), rule, max_origin2) == width {
                let mut batch = [IDLE; 16];
                for (b, e) in batch.iter_mut().zip(run) {
                    *b = ray_of(e).copied().unwrap_or(IDLE);
                }
                trace_packet::<A, L>(
                    top,
                    mode,
                    &batch[..width],
                    |lane| run[lane][1] as usize,
                    out,
                );
                i += width;
                continue;
            }
        }
        let index = keys[i][1] as usize;
        if let (Some(ray), Some(o)) = (rays.get(index), out.get_mut(index)) {
            *o = A::single(top, mode, ray);
        }
        i += 1;
    }
}

/// Traces `batch` (all finite) as one packet; lane `l`'s answer goes to `out[index(l)]`.
#[inline(always)]
fn trace_packet<A: Answer, L: Lanes>(
    top: &InstancedScene,
    mode: Mode,
    batch: &[Ray],
    index: impl Fn(usize) -> usize,
    out: &mut [A::Out],
) {
    let packet = RayPacket::<L>::from_rays(batch);
    let mut answers = [A::NONE; 16];
    A::packet::<L>(top, mode, &packet, &mut answers[..L::WIDTH]);
    for (lane, a) in answers.iter().take(batch.len()).enumerate() {
        if let Some(o) = out.get_mut(index(lane)) {
            *o = *a;
        }
    }
}
