//! Single rays walked in turns: [`TURNS`] rays' walks over the wide nodes advance one wide node
//! or one leaf at a time, each in turn, a finished ray's place taken by the next ray.
//!
//! A walk over a large mesh waits on memory: each wide node and each leaf's triangles are read
//! once their reference is known, so one ray's cache misses come one after another, and the
//! processor, which runs a few hundred instructions ahead, finds little else to do meanwhile.
//! Rays in turns give it other, independent chains of loads to work on while one waits: four
//! took 0.79–0.82× the time of one by one on the dragon's random rays and 0.85–0.92× on its
//! diffuse ones (docs/BENCHMARKS.md, "Single rays in turns"), for some 40 % more instructions,
//! which is why the stream takes turns only on large trees ([`crate::traverse::stream::Turns`]).
//! Each ray's walk is the same sequence of steps as [`super::walk::walk_counted`]'s, so the
//! answers are the same bit for bit; only the order in which the work is done changes.

use super::WideNode;
use super::walk::Walk;
use crate::format::Scene;
use crate::ray::Ray;
use crate::traverse::Contents;
use crate::traverse::steps::Query;

/// How many rays walk in turns.
pub const TURNS: usize = 4;

/// Walks the rays `order` names over `wide` (not empty), [`TURNS`] at a time in turns, each with
/// the query `start` makes for it; `finish(i, query)` receives ray `i`'s query once its walk is
/// over. A ray that is not finite is finished at once, untraced (as the one-ray walk leaves it).
///
/// Not inlined: inlined into the stream beside the one-by-one walk, it changed how that walk
/// compiled (3 % more instructions a ray on the bunny, where the turns are not taken).
#[inline(never)]
pub(crate) fn walk_in_turns<C: Contents, Q: Query>(
    scene: &Scene,
    wide: &[WideNode],
    rays: &[Ray],
    order: impl Iterator<Item = usize>,
    start: impl Fn(&Ray) -> Q,
    mut finish: impl FnMut(usize, &Q),
) {
    let mut order = order.filter_map(|i| rays.get(i).map(|r| (i, r)));
    // The next finite ray's index and query, the others finished on the way.
    let mut next = |walk: &mut Walk, finish: &mut dyn FnMut(usize, &Q)| -> Option<(usize, Q)> {
        for (i, ray) in order.by_ref() {
            let q = start(ray);
            if ray.is_finite() {
                walk.restart(ray);
                return Some((i, q));
            }
            finish(i, &q);
        }
        None
    };
    // Each walk is restarted for its first ray before it steps: any finite ray sets it up.
    let idle = Ray::new(glam::Vec3::ZERO, glam::Vec3::Z);
    let mut walks: [Walk; TURNS] = core::array::from_fn(|_| Walk::new(&idle));
    let mut live: [Option<(usize, Q)>; TURNS] = core::array::from_fn(|_| None);
    for (walk, slot) in walks.iter_mut().zip(&mut live) {
        *slot = next(walk, &mut finish);
    }
    loop {
        let mut any = false;
        for (walk, slot) in walks.iter_mut().zip(&mut live) {
            if let Some((i, q)) = slot {
                any = true;
                if !walk.step::<C, Q>(scene, wide, q) {
                    finish(*i, q);
                    *slot = next(walk, &mut finish);
                }
            }
        }
        if !any {
            return;
        }
    }
}
