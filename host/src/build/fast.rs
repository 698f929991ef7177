//! The `fast` builder ([`super::Quality::Fast`]): the same SAH, termination rules and reference
//! budget as the event builder, over a list of primitive references, each carrying its clipped
//! box, instead of three sorted event lists.
//!
//! Per node: a node of at least [`BIN_MIN`] references finds its plane by binning
//! ([`super::binned`], [`BINS`] bins per axis); a smaller one sorts its boxes' events and sweeps
//! them exactly ([`events::best_split_on_axis`]). The partition compares each box with the plane;
//! a straddling primitive is clipped exactly to each child (perfect splits, [`super::clip`]) in
//! nodes of at least [`FastParams::clip_min`] references, and below that keeps its box cut by the
//! plane, which costs nothing but is looser (measured: it does not pay, so the default clips
//! everywhere). Children are built in parallel like the event builder's, and the tree depends on
//! nothing but the input and the parameters.
//!
//! What it saves: the event builder splits three event lists at every level, some 20–30 levels
//! for each triangle; here a large node costs a pass over its boxes, a small one three sorts of
//! its events' keys (docs/BUILD.md, "Quality").

use super::clip::Aabb;
use super::events::{self, Event, Split};
use super::{BuildNode, Ctx, Share, binned, join};

/// A primitive in a node: its global id and the bounds of its part inside the node's box.
#[derive(Clone, Copy, Debug)]
pub struct Ref {
    pub id: u32,
    pub bounds: Aabb,
}

/// The `fast` builder's settings; the defaults were measured (docs/BUILD.md, "Quality").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastParams {
    /// Bins per axis of the binned split search (at least 2).
    pub bins: usize,
    /// Nodes of at least this many references are binned; smaller ones are swept exactly.
    pub bin_min: usize,
    /// Nodes of at least this many references clip straddlers exactly (perfect splits).
    pub clip_min: usize,
}

impl Default for FastParams {
    fn default() -> Self {
        Self {
            bins: BINS,
            bin_min: BIN_MIN,
            clip_min: CLIP_MIN,
        }
    }
}

/// [`FastParams::bins`]'s default.
pub const BINS: usize = 32;
/// [`FastParams::bin_min`]'s default.
pub const BIN_MIN: usize = 256;
/// [`FastParams::clip_min`]'s default.
pub const CLIP_MIN: usize = 0;

/// Below this many references children are built on the current thread.
const PARALLEL_MIN: usize = 2048;

/// Builds the subtree over `refs` inside `bounds`.
pub(super) fn build_node(
    ctx: &Ctx,
    refs: Vec<Ref>,
    bounds: Aabb,
    depth: u32,
    bad_refines: u32,
    share: Share,
) -> BuildNode {
    let n = refs.len();
    let leaf =
        |ctx: &Ctx, refs: Vec<Ref>| ctx.leaf(refs.iter().map(|r| r.id).collect(), share.weight);
    if !ctx.may_split(depth, n, share.refs) {
        return leaf(ctx, refs);
    }
    let (parallel, fast) = (ctx.params.parallel, &ctx.params.fast);
    let best = if n >= fast.bin_min {
        binned::best_split(&refs, &bounds, fast.bins.max(2), &ctx.costs, parallel)
    } else {
        exact_split(&refs, &bounds, ctx)
    };
    let Some((split, bad_refines)) = best.and_then(|s| ctx.accept(s, n, bad_refines)) else {
        return leaf(ctx, refs);
    };
    let (below_box, above_box) = bounds.split(split.axis, split.pos);
    let (below, above) = partition(ctx, &refs, &split, &below_box, &above_box);
    drop(refs);
    let (sb, sa) = share.split(below.len(), above.len());
    let build_below = || build_node(ctx, below, below_box, depth + 1, bad_refines, sb);
    let build_above = || build_node(ctx, above, above_box, depth + 1, bad_refines, sa);
    let children = join(parallel && n >= PARALLEL_MIN, build_below, build_above);
    BuildNode::Interior {
        axis: split.axis as u8,
        split: split.pos,
        children: Box::new([children.0, children.1]),
    }
}

thread_local! {
    static EXACT: core::cell::RefCell<(Vec<u64>, Vec<Event>)> =
        const { core::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// The exact sweep of a small node: its boxes' events sorted on each axis. The sweep needs no
/// primitive ids, so the events are sorted as their bare keys (integers: a third of the time of
/// sorting events by a computed key).
fn exact_split(refs: &[Ref], bounds: &Aabb, ctx: &Ctx) -> Option<Split> {
    EXACT.with_borrow_mut(|(keys, list)| {
        let mut best: Option<Split> = None;
        for axis in 0..3 {
            list.clear();
            for r in refs {
                events::push_events(list, &r.bounds, axis, 0);
            }
            keys.clear();
            keys.extend(list.iter().map(Event::key));
            keys.sort_unstable();
            list.clear();
            list.extend(keys.iter().map(|&k| Event::from_key(k, 0)));
            if let Some(s) = events::best_split_on_axis(list, refs.len(), bounds, axis, &ctx.costs)
                && best.is_none_or(|b| s.cost < b.cost)
            {
                best = Some(s);
            }
        }
        best
    })
}

/// Which way a reference goes: below, above or both (it straddles the plane).
#[derive(Clone, Copy, PartialEq)]
enum Side {
    Below,
    Above,
    Both,
}

/// The side of `r` as the event builder classifies its events: a box ending on the plane is
/// below only, one starting on it above only, a flat one on it where `split.planar_below` says.
#[inline]
fn side(r: &Ref, split: &Split) -> Side {
    let (lo, hi) = (r.bounds.min[split.axis], r.bounds.max[split.axis]);
    let pos = split.pos;
    if lo == hi {
        if lo < pos || (lo == pos && split.planar_below) {
            Side::Below
        } else {
            Side::Above
        }
    } else if hi <= pos {
        Side::Below
    } else if lo >= pos {
        Side::Above
    } else {
        Side::Both
    }
}

/// Sends each reference below, above or both ways ([`side`]); straddlers are clipped to each
/// child. The children's lists are counted first and allocated once.
fn partition(
    ctx: &Ctx,
    refs: &[Ref],
    split: &Split,
    below_box: &Aabb,
    above_box: &Aabb,
) -> (Vec<Ref>, Vec<Ref>) {
    let (axis, pos) = (split.axis, split.pos);
    let exact = refs.len() >= ctx.params.fast.clip_min;
    let (mut nb, mut na) = (0, 0);
    for r in refs {
        match side(r, split) {
            Side::Below => nb += 1,
            Side::Above => na += 1,
            Side::Both => (nb, na) = (nb + 1, na + 1),
        }
    }
    let (mut below, mut above) = (Vec::with_capacity(nb), Vec::with_capacity(na));
    for r in refs {
        match side(r, split) {
            Side::Below => below.push(*r),
            Side::Above => above.push(*r),
            Side::Both if exact => {
                let b = ctx.clip(r.id, below_box);
                let a = ctx.clip(r.id, above_box);
                // Rounding can in principle empty both: keep the primitive, conservatively,
                // below.
                let b = if b.is_none() && a.is_none() {
                    Some(r.bounds.intersection(below_box))
                } else {
                    b
                };
                below.extend(b.map(|bounds| Ref { id: r.id, bounds }));
                above.extend(a.map(|bounds| Ref { id: r.id, bounds }));
            }
            Side::Both => {
                let (mut b, mut a) = (*r, *r);
                b.bounds.max[axis] = pos;
                a.bounds.min[axis] = pos;
                below.push(b);
                above.push(a);
            }
        }
    }
    (below, above)
}
