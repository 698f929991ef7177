//! The stream's work, for either query: coherent runs of the input as packets, then the rest
//! sorted ([`super::order`]), the sorted coherent runs as packets, and what remains as single
//! rays, one after another (over the wide nodes when the scene has them).

use super::order::{Coherence, key, origin_scale};
use crate::format::Scene;
use crate::ray::{Hit, Ray};
use crate::simd::{Lanes, RayPacket};
use crate::traverse::Contents;
use crate::traverse::steps::{Closest, Occlusion, Query};
#[cfg(all(feature = "wide", not(target_arch = "wasm32")))]
use crate::traverse::wide::turns::walk_in_turns;

/// A query answered for a whole stream: its per-ray answer, its single-ray query and its packet
/// call.
pub(crate) trait Answer {
    type Out: Copy;
    type Q: Query;
    /// The answer for a ray that hits nothing.
    const NONE: Self::Out;
    fn query<C: Contents>(ray: &Ray) -> Self::Q;
    fn answer(query: &Self::Q) -> Self::Out;
    /// Traces a packet whose lanes are all active; `out[lane]` receives each answer.
    fn packet<C: Contents, L: Lanes>(scene: &Scene, rays: &RayPacket<L>, out: &mut [Self::Out]);
}

/// Closest hits.
pub(crate) struct ClosestHits;
/// Occlusion.
pub(crate) struct AnyHits;

impl Answer for ClosestHits {
    type Out = Hit;
    type Q = Closest;
    const NONE: Hit = Hit::MISS;
    #[inline(always)]
    fn query<C: Contents>(ray: &Ray) -> Closest {
        Closest::new::<C>(ray)
    }
    #[inline(always)]
    fn answer(query: &Closest) -> Hit {
        query.hit()
    }
    #[inline(always)]
    fn packet<C: Contents, L: Lanes>(scene: &Scene, rays: &RayPacket<L>, out: &mut [Hit]) {
        scene
            .intersect_packet_with::<C, L>(rays)
            .write_active(rays, out);
    }
}

impl Answer for AnyHits {
    type Out = bool;
    type Q = Occlusion;
    const NONE: bool = false;
    #[inline(always)]
    fn query<C: Contents>(ray: &Ray) -> Occlusion {
        Occlusion::new::<C>(ray)
    }
    #[inline(always)]
    fn answer(query: &Occlusion) -> bool {
        query.found()
    }
    #[inline(always)]
    fn packet<C: Contents, L: Lanes>(scene: &Scene, rays: &RayPacket<L>, out: &mut [bool]) {
        let mask = scene.occluded_packet_with::<C, L>(rays).bitmask();
        for (lane, o) in out.iter_mut().enumerate() {
            *o = mask >> lane & 1 == 1;
        }
    }
}

/// Traces the rays `order` names as single rays, one after another, answers into `out`: the
/// one-ray walk ([`Scene::walk`]: over the wide nodes when the scene has them and the core is
/// built with the `wide` feature, else over the nodes).
#[inline(always)]
fn singles<A: Answer, C: Contents>(
    scene: &Scene,
    rays: &[Ray],
    order: impl Iterator<Item = usize>,
    out: &mut [A::Out],
) {
    for i in order {
        if let (Some(ray), Some(o)) = (rays.get(i), out.get_mut(i)) {
            let mut q = A::query::<C>(ray);
            scene.walk::<C, _>(ray, &mut q);
            *o = A::answer(&q);
        }
    }
}

/// Whether this build can walk single rays in turns: with wide nodes, and not for WebAssembly
/// ([`super::Turns`] says why).
const TURNS_BUILT: bool = cfg!(all(feature = "wide", not(target_arch = "wasm32")));

/// The whole stream: `scratch` holds at least one `[key, index]` pair per ray. With
/// `PACKETS`, coherent runs of `L::WIDTH` rays (by `rule`) are traced as packets; with `turns`
/// the single rays over wide nodes walk in turns.
pub(crate) fn stream<A: Answer, C: Contents, L: Lanes, const PACKETS: bool>(
    scene: &Scene,
    rays: &[Ray],
    out: &mut [A::Out],
    scratch: &mut [[u64; 2]],
    (rule, turns): (&Coherence, bool),
) {
    let [lo, hi] = scene.bounds();
    // (An infinite fraction admits any origin, even in a scene box of zero size.)
    let max_origin = if rule.max_origin.is_finite() {
        rule.max_origin * (hi - lo).length()
    } else {
        rule.max_origin
    };
    let max_origin2 = max_origin * max_origin;
    let scale = origin_scale(lo, hi);
    const { assert!(L::WIDTH <= 16) };
    let width = L::WIDTH;
    // Coherent runs of the input as it comes (a camera's tiles), the rest keyed for sorting, or,
    // over wide nodes, traced as single rays: one by one at once, or listed in input order to be
    // walked in turns.
    let alone = walks_wide(scene);
    let turns = TURNS_BUILT && alone && turns;
    let mut m = 0;
    for (c, chunk) in rays.chunks(width).enumerate() {
        if PACKETS && run_length(chunk.iter(), rule, max_origin2) == width {
            trace_packet::<A, C, L>(scene, chunk, c * width, |i| i, out);
            continue;
        }
        if alone && !turns {
            singles::<A, C>(scene, rays, c * width..c * width + chunk.len(), out);
            continue;
        }
        for (k, ray) in chunk.iter().enumerate() {
            if let Some(slot) = scratch.get_mut(m) {
                let sort_key = if turns { 0 } else { key(ray, lo, scale) };
                *slot = [sort_key, (c * width + k) as u64];
                m += 1;
            }
        }
    }
    #[cfg(all(feature = "wide", not(target_arch = "wasm32")))]
    if turns {
        let finish = |i: usize, q: &A::Q| {
            if let Some(o) = out.get_mut(i) {
                *o = A::answer(q);
            }
        };
        let order = scratch[..m].iter().map(|e| e[1] as usize);
        let wide = scene.wide_nodes();
        return walk_in_turns::<C, A::Q>(scene, wide, rays, order, A::query::<C>, finish);
    }
    let keys = &mut scratch[..m];
    keys.sort_unstable();
    // Coherent runs of the sorted rays as packets; the others compacted to the front of `keys`.
    let ray_of = |e: &[u64; 2]| rays.get(e[1] as usize);
    let mut n_singles = 0;
    let mut i = 0;
    while i < m {
        if PACKETS {
            let run = &keys[i..m.min(i + width)];
            let n = run_length(run.iter().filter_map(ray_of), rule, max_origin2);
            if n == width {
                let mut batch = [IDLE; 16];
                for (b, e) in batch.iter_mut().zip(run) {
                    *b = ray_of(e).copied().unwrap_or(IDLE);
                }
                trace_packet::<A, C, L>(
                    scene,
                    &batch[..width],
                    0,
                    |lane| run[lane][1] as usize,
                    out,
                );
                i += width;
                continue;
            }
        }
        keys[n_singles] = keys[i];
        n_singles += 1;
        i += 1;
    }
    let order = keys[..n_singles].iter().map(|e| e[1] as usize);
    singles::<A, C>(scene, rays, order, out);
}

/// Whether the scene's single rays walk wide nodes. Then a ray outside a coherent run of the input
/// is traced alone, unsorted: on the dragon's diffuse rays the sort and the packets of sorted rays
/// over the binary nodes ran at 0.64× the wide walk's speed (docs/BENCHMARKS.md, "The stream over
/// wide nodes"). (Without the `wide` feature a scene's wide section is set aside on load, so
/// this is false there.)
#[inline(always)]
fn walks_wide(scene: &Scene) -> bool {
    !scene.wide_nodes().is_empty()
}

/// A ray no kernel hits, filling unused entries of a gathered batch.
pub(crate) const IDLE: Ray = Ray {
    origin: glam::Vec3::ZERO,
    dir: glam::Vec3::ZERO,
    tmin: f32::INFINITY,
    tmax: f32::NEG_INFINITY,
};

/// How many rays from the start of `rays` may share a packet with the first (0 if it is not
/// finite).
#[inline(always)]
pub(crate) fn run_length<'r>(
    mut rays: impl Iterator<Item = &'r Ray>,
    rule: &Coherence,
    max_origin2: f32,
) -> usize {
    let Some(first) = rays.next().filter(|r| r.is_finite()) else {
        return 0;
    };
    1 + rays
        .take_while(|r| rule.admits(first, r, max_origin2))
        .count()
}

/// Traces `batch` (all finite) as one packet; lane `l`'s answer goes to `out[base + index(l)]`.
#[inline(always)]
fn trace_packet<A: Answer, C: Contents, L: Lanes>(
    scene: &Scene,
    batch: &[Ray],
    base: usize,
    index: impl Fn(usize) -> usize,
    out: &mut [A::Out],
) {
    const { assert!(L::WIDTH <= 16) };
    let packet = RayPacket::<L>::from_rays(batch);
    let mut answers = [A::NONE; 16];
    A::packet::<C, L>(scene, &packet, &mut answers[..L::WIDTH]);
    for (lane, a) in answers.iter().take(batch.len()).enumerate() {
        if let Some(o) = out.get_mut(base + index(lane)) {
            *o = *a;
        }
    }
}
