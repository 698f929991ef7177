//! Many single-ray walks in flight at once, stepped round-robin, to hide memory latency.
//!
//! A diffuse ray's kd-tree walk is a chain of dependent loads (docs/BENCHMARKS.md: ~72 interior
//! steps and ~12 leaves a ray, in a tree far larger than the cache), each deciding one plane with
//! little arithmetic, so a lone walk spends most of its time waiting. Here `N` rays walk at once:
//! each step of a ray ([`Stepper::step`] with `HIDE`) ends by asking the cache for the node (or
//! leaf data) that ray reads next, and the next step goes to the next ray, so up to `N` loads are
//! outstanding while the core works on the others. A ray whose walk ends hands its answer back
//! and its slot takes the next ray of the input. This is software pipelining across rays, as in
//! Pharr & Mark's and Aila & Laine's discussions of latency hiding (Aila & Laine 2009,
//! "Understanding the Efficiency of Ray Traversal on GPUs", §4), done on one CPU core with
//! prefetch hints in place of hardware threads.
//!
//! Every ray runs exactly the steps of the one-ray walk (the same [`Stepper::step`]), so the
//! answers are the one-ray walk's, bit for bit.

use crate::ray::Ray;
use crate::traverse::Contents;
use crate::traverse::steps::{Progress, Query, Stepper};
use glam::Vec3;

/// A slot's ray before it holds a real one (never traced: a slot is used only after `refill`).
const IDLE_RAY: Ray = Ray {
    origin: Vec3::ZERO,
    dir: Vec3::Z,
    tmin: 0.0,
    tmax: 0.0,
};

/// One ray in flight: where its answer goes, its walk and its query.
struct Slot<S, Q> {
    index: usize,
    state: S,
    query: Q,
}

/// Answers the queries of the rays `order` names (indices into `rays`; an index past the end is
/// skipped), `N` walks in flight. `new` makes a ray's query, `finish(index, query)` receives it
/// when its walk has ended (at once for a ray with nothing to walk).
#[inline(always)]
pub(crate) fn run<W, C, Q, const N: usize>(
    layout: &W,
    rays: &[Ray],
    mut order: impl Iterator<Item = usize>,
    new: impl Fn(&Ray) -> Q,
    mut finish: impl FnMut(usize, &Q),
) where
    W: Stepper,
    C: Contents,
    Q: Query,
{
    let mut slots: [Slot<W::State, Q>; N] = core::array::from_fn(|_| Slot {
        index: 0,
        state: W::empty_state(),
        query: new(&IDLE_RAY),
    });
    let mut live = 0;
    while live < N
        && refill::<W, C, Q>(
            layout,
            rays,
            &mut order,
            &new,
            &mut finish,
            &mut slots[live],
        )
    {
        live += 1;
    }
    while live > 0 {
        let mut k = 0;
        while k < live {
            let slot = &mut slots[k];
            // Steps whose next node is probably cached are taken at once; a step that had to
            // ask for far data hands over to the next ray.
            // (One in flight has nothing to overlap: it runs the plain walk, no prefetch.)
            let progress = loop {
                let p = if N == 1 {
                    layout.step::<C, Q, false>(&mut slot.state, &mut slot.query)
                } else {
                    layout.step::<C, Q, true>(&mut slot.state, &mut slot.query)
                };
                if p != Progress::Near {
                    break p;
                }
            };
            if progress == Progress::Far {
                k += 1;
                continue;
            }
            finish(slot.index, &slot.query);
            if refill::<W, C, Q>(layout, rays, &mut order, &new, &mut finish, slot) {
                k += 1;
            } else {
                // The input is used up: the last live slot moves here and is stepped next.
                live -= 1;
                slots.swap(k, live);
            }
        }
    }
}

/// Loads the next ray of `order` that has a walk into `slot` (answering the others at once);
/// false when the input is used up.
#[inline(always)]
fn refill<W, C, Q>(
    layout: &W,
    rays: &[Ray],
    order: &mut impl Iterator<Item = usize>,
    new: &impl Fn(&Ray) -> Q,
    finish: &mut impl FnMut(usize, &Q),
    slot: &mut Slot<W::State, Q>,
) -> bool
where
    W: Stepper,
    C: Contents,
    Q: Query,
{
    for i in order.by_ref() {
        let Some(ray) = rays.get(i) else { continue };
        slot.query = new(ray);
        if layout.begin::<C>(ray, &mut slot.state) {
            slot.index = i;
            return true;
        }
        finish(i, &slot.query);
    }
    false
}
