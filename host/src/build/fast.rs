//! The `fast` builder ([`super::Quality::Fast`]): the same SAH, termination rules and reference
//! budget as the event builder, over a list of primitive references, each carrying its clipped
//! box, instead of three sorted event lists.
//!
//! Per node: a node of at least [`BIN_MIN`] references finds its plane by binning
//! ([`super::binned`], [`BINS`] bins per axis); a smaller one sorts its boxes' events and sweeps
//! them exactly ([`events::best_split_on_axis`]). The partition compares each box with the plane;
//! a straddling primitive is clipped exactly to each child ([`Ctx::clip`]: perfect splits) in
//! nodes of at least [`CLIP_MIN`] references, and below that keeps its box cut by the plane, which
//! costs nothing but is looser. Children are built in parallel like the event builder's, and the
//! tree depends on nothing but the input and the parameters.
//!
//! Where the time goes instead: the event builder clips every straddler in f64 and splits three
//! event lists at every level, some 20–30 levels for each triangle; here a deep node costs a pass
//! over its boxes (docs/BUILD.md, "Quality").

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
pub const CLIP_MIN: usize = 4096;

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
    static EVENTS: core::cell::RefCell<Vec<Event>> = const { core::cell::RefCell::new(Vec::new()) };
}

/// The exact sweep of a small node: its boxes' events sorted on each axis.
fn exact_split(refs: &[Ref], bounds: &Aabb, ctx: &Ctx) -> Option<Split> {
    EVENTS.with_borrow_mut(|list| {
        let mut best: Option<Split> = None;
        for axis in 0..3 {
            list.clear();
            for (i, r) in refs.iter().enumerate() {
                events::push_events(list, &r.bounds, axis, i as u32);
            }
            events::sort_events(list);
            if let Some(s) = events::best_split_on_axis(list, refs.len(), bounds, axis, &ctx.costs)
                && best.is_none_or(|b| s.cost < b.cost)
            {
                best = Some(s);
            }
        }
        best
    })
}

/// Sends each reference below, above or both ways, as the event builder classifies its events
/// (a box ending on the plane is below only, one starting on it above only, a flat one on it
/// where `split.planar_below` says); straddlers are clipped to each child.
fn partition(
    ctx: &Ctx,
    refs: &[Ref],
    split: &Split,
    below_box: &Aabb,
    above_box: &Aabb,
) -> (Vec<Ref>, Vec<Ref>) {
    let (axis, pos) = (split.axis, split.pos);
    let exact = refs.len() >= ctx.params.fast.clip_min;
    let (mut below, mut above) = (Vec::new(), Vec::new());
    for r in refs {
        let (lo, hi) = (r.bounds.min[axis], r.bounds.max[axis]);
        if lo == hi {
            if lo < pos || (lo == pos && split.planar_below) {
                below.push(*r);
            } else {
                above.push(*r);
            }
        } else if hi <= pos {
            below.push(*r);
        } else if lo >= pos {
            above.push(*r);
        } else if exact {
            let b = ctx.clip(r.id, below_box);
            let a = ctx.clip(r.id, above_box);
            // Rounding can in principle empty both: keep the primitive, conservatively, below.
            let b = if b.is_none() && a.is_none() {
                Some(r.bounds.intersection(below_box))
            } else {
                b
            };
            below.extend(b.map(|bounds| Ref { id: r.id, bounds }));
            above.extend(a.map(|bounds| Ref { id: r.id, bounds }));
        } else {
            let (mut b, mut a) = (*r, *r);
            b.bounds.max[axis] = pos;
            a.bounds.min[axis] = pos;
            below.push(b);
            above.push(a);
        }
    }
    (below, above)
}
