//! The `fast` builder ([`super::Quality::Fast`]): the same SAH, termination rules and reference
//! budget as the event builder, over a list of primitive references, each carrying its clipped
//! box, instead of three sorted event lists.
//!
//! Per node: a node of at least [`FastParams::bin_min`] references finds its plane by binning
//! ([`super::binned`], [`FastParams::bins`] bins per axis); a smaller one searches exactly: up
//! to `SMALL_MAX` (32) references by comparing every candidate plane with every box
//! (`small_split`), above that by sorting its boxes' events and sweeping them
//! ([`events::best_split_on_axis`]); both find the same plane. The partition compares each box with
//! the plane; a straddling primitive is clipped exactly to each child (perfect splits,
//! [`super::clip::clip_triangle`]) in nodes of at least [`FastParams::clip_min`] references, and
//! below that (by default everywhere) split by the plane alone ([`super::clip::split_triangle`]:
//! its part on each side, within its box), which is exact where the triangle crosses no other
//! wall of the cell and otherwise looser. A plane at the contents' extent (a cut-off of empty
//! space) moves no reference. Children are built in parallel like the event builder's, and the
//! tree depends on nothing but the input and the parameters.
//!
//! Memory: a subtree built on one thread keeps its references on one stack (a `Vec<Ref>`): a
//! node's references are the stack's top; partitioning puts the above child's references in their
//! place and the below child's on top of them, the below subtree is built (and pops its own), then
//! the above one. No allocation per node but the leaves' lists.
//!
//! What it saves: the event builder splits three event lists at every level, some 20–30 levels
//! for each triangle; here a node costs a pass over its boxes to bin them and one to partition
//! them, and the smallest nodes compare their boxes with their candidate planes (docs/BUILD.md,
//! "Quality" and "`fast`, third pass").

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
    /// Bins per axis of the binned split search (at least 2, at most
    /// [`binned::MAX_BINS`] = 256).
    pub bins: usize,
    /// Nodes of at least this many references are binned; smaller ones are swept exactly.
    pub bin_min: usize,
    /// Nodes of at least this many references clip straddlers exactly (perfect splits); smaller
    /// ones split them by the plane alone.
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
pub const BIN_MIN: usize = 32;
/// [`FastParams::clip_min`]'s default: no node clips exactly; every straddler is split by the
/// plane alone (docs/BUILD.md, "Quality").
pub const CLIP_MIN: usize = usize::MAX;

/// Below this many references children are built on the current thread.
const PARALLEL_MIN: usize = 2048;

/// Builds the tree over `refs` inside `bounds` (the root).
pub(super) fn build(ctx: &Ctx, mut refs: Vec<Ref>, bounds: Aabb, share: Share) -> BuildNode {
    build_node(ctx, &mut refs, 0, bounds, 0, 0, share, None)
}

/// Builds the subtree over `stack[start..]` inside `bounds`, and truncates `stack` to `start`;
/// `kept`: what of the parent's bins it may keep ([`binned::Kept`]).
#[allow(clippy::too_many_arguments)]
fn build_node(
    ctx: &Ctx,
    stack: &mut Vec<Ref>,
    start: usize,
    bounds: Aabb,
    depth: u32,
    bad_refines: u32,
    share: Share,
    kept: binned::Kept,
) -> BuildNode {
    let n = stack.len() - start;
    let leaf = |stack: &mut Vec<Ref>| {
        let ids = stack[start..].iter().map(|r| r.id).collect();
        stack.truncate(start);
        ctx.leaf(ids, share.weight)
    };
    if !ctx.may_split(depth, n, share.refs) {
        return leaf(stack);
    }
    let (parallel, fast) = (ctx.params.parallel, &ctx.params.fast);
    let refs = &stack[start..];
    let (best, contents, in_bins) = if n >= fast.bin_min {
        let bins = bins_for(n, fast.bins);
        match binned::best_split(refs, &bounds, bins, &ctx.costs, parallel, kept) {
            Some((s, c, in_bins)) => (Some(s), Some(c), in_bins),
            None => (None, None, false),
        }
    } else {
        let best = if n <= SMALL_MAX {
            small_split(refs, &bounds, &ctx.costs)
        } else {
            exact_split(refs, &bounds, &ctx.costs)
        };
        (best, None, false)
    };
    let Some((split, bad_refines)) = best.and_then(|s| ctx.accept(s, n, bad_refines)) else {
        return leaf(stack);
    };
    let (below_box, above_box) = bounds.split(split.axis, split.pos);
    // A plane at the contents' extent cuts off empty space: every reference stays, unchanged,
    // on the contents' side (`side` says so of each), and the partition is skipped.
    let cut_off = match contents {
        Some(c) if split.pos <= c.min[split.axis] && !split.planar_below => Some((0, n)),
        // Below goes on top: here the only child, already in place.
        Some(c) if split.pos >= c.max[split.axis] && split.planar_below => Some((n, 0)),
        _ => None,
    };
    if parallel && n >= PARALLEL_MIN {
        // Each child on a stack of its own, so that the two can be built at once. A node this
        // large has its stack to itself (no ancestor of a node smaller than PARALLEL_MIN is
        // parallel, and a child is never larger than its parent): the above child takes it
        // over, and the partition writes the below child's references straight into theirs.
        debug_assert_eq!(start, 0);
        let mut b = Vec::new();
        let na = match cut_off {
            Some((0, _)) => n,
            Some(_) => {
                core::mem::swap(&mut b, stack);
                0
            }
            None => partition_into(ctx, stack, start, &split, &below_box, &above_box, &mut b),
        };
        let (sb, sa) = share.split(b.len(), na);
        let mut a = core::mem::take(stack);
        let (below, above) = join(
            true,
            || build_node(ctx, &mut b, 0, below_box, depth + 1, bad_refines, sb, None),
            || build_node(ctx, &mut a, 0, above_box, depth + 1, bad_refines, sa, None),
        );
        return BuildNode::Interior {
            axis: split.axis as u8,
            split: split.pos,
            children: Box::new([below, above]),
        };
    }
    let (nb, na) =
        cut_off.unwrap_or_else(|| partition(ctx, stack, start, &split, &below_box, &above_box));
    let (sb, sa) = share.split(nb, na);
    // After a cut-off the child holding every reference keeps this node's counts but on the
    // split's axis: it is built right after its empty sibling (a leaf, which bins nothing).
    let kept = (cut_off.is_some() && in_bins).then_some(split.axis);
    let below = build_node(
        ctx,
        stack,
        start + na,
        below_box,
        depth + 1,
        bad_refines,
        sb,
        kept.filter(|_| nb > 0),
    );
    let above = build_node(
        ctx,
        stack,
        start,
        above_box,
        depth + 1,
        bad_refines,
        sa,
        kept.filter(|_| na > 0),
    );
    BuildNode::Interior {
        axis: split.axis as u8,
        split: split.pos,
        children: Box::new([below, above]),
    }
}

/// Bins for a node of `n` references: `bins`, or fewer for small nodes (at least 8), whose
/// pricing would otherwise cost more than their counting.
fn bins_for(n: usize, bins: usize) -> usize {
    bins.min((n / 2).max(8)).clamp(2, binned::MAX_BINS)
}

thread_local! {
    static EXACT: core::cell::RefCell<(Vec<u64>, Vec<Event>)> =
        const { core::cell::RefCell::new((Vec::new(), Vec::new())) };
    static BELOW: core::cell::RefCell<Vec<Ref>> = const { core::cell::RefCell::new(Vec::new()) };
}

/// The exact sweep of a small node: its boxes' events sorted on each axis. The sweep needs no
/// primitive ids, so the events are sorted as their bare keys (integers: a third of the time of
/// sorting events by a computed key).
fn exact_split(refs: &[Ref], bounds: &Aabb, costs: &events::Costs) -> Option<Split> {
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
            if let Some(s) = events::best_split_on_axis(list, refs.len(), bounds, axis, costs)
                && best.is_none_or(|b| s.cost < b.cost)
            {
                best = Some(s);
            }
        }
        best
    })
}

/// Nodes of at most this many references take the exact search by comparison
/// ([`small_split`]) instead of sorting their events.
const SMALL_MAX: usize = 32;

/// The exact search of a node of at most [`SMALL_MAX`] references, without sorting: every bound
/// of a box is a candidate plane, and its counts come from comparing it with every box, eight
/// candidates at a time. At a candidate `p` the event sweep ([`events::best_split_on_axis`])
/// has below it the boxes with `min < p`, above those with `max > p`, and the boxes flat at `p`
/// go to the cheaper side; so here. The sweep keeps the first of equal costs (axes in order,
/// positions ascending, −0 before +0); so does this search, and it finds the same plane.
fn small_split(refs: &[Ref], bounds: &Aabb, costs: &events::Costs) -> Option<Split> {
    use wide::{f32x8, f64x4};
    const CHUNKS: usize = 2 * SMALL_MAX / 8;
    let n = refs.len();
    debug_assert!(n <= SMALL_MAX);
    let chunks = (2 * n).div_ceil(8);
    // The candidates on each axis: every box's minimum, then its maximum; NaN pads (never
    // inside the node).
    let mut cand = [[f32::NAN; 2 * SMALL_MAX]; 3];
    {
        let [x, y, z] = &mut cand;
        let pairs = x.chunks_exact_mut(2).zip(y.chunks_exact_mut(2));
        for ((r, (x, y)), z) in refs.iter().zip(pairs).zip(z.chunks_exact_mut(2)) {
            let (lo, hi) = (r.bounds.min, r.bounds.max);
            (x[0], x[1], y[0], y[1], z[0], z[1]) = (lo.x, hi.x, lo.y, hi.y, lo.z, hi.z);
        }
    }
    let mut best: Option<Split> = None;
    for (axis, cand) in cand.iter().enumerate() {
        let Some(sah) = events::AxisSah::new(bounds, axis, costs) else {
            continue;
        };
        let c: [f32x8; CHUNKS] = core::array::from_fn(|k| {
            f32x8::from(<[f32; 8]>::try_from(&cand[8 * k..8 * k + 8]).unwrap())
        });
        let (mut below, mut above) = ([f32x8::ZERO; CHUNKS], [f32x8::ZERO; CHUNKS]);
        let mut flat = [f32x8::ZERO; CHUNKS];
        let boxes = &cand[..2 * n];
        // A loop of a known length per count of candidates, unrolled.
        let any_flat = match chunks {
            1 => count::<1>(boxes, &c, &mut below, &mut above, &mut flat),
            2 => count::<2>(boxes, &c, &mut below, &mut above, &mut flat),
            3 => count::<3>(boxes, &c, &mut below, &mut above, &mut flat),
            4 => count::<4>(boxes, &c, &mut below, &mut above, &mut flat),
            5 => count::<5>(boxes, &c, &mut below, &mut above, &mut flat),
            6 => count::<6>(boxes, &c, &mut below, &mut above, &mut flat),
            7 => count::<7>(boxes, &c, &mut below, &mut above, &mut flat),
            _ => count::<8>(boxes, &c, &mut below, &mut above, &mut flat),
        };
        let (lo, hi) = (f32x8::splat(sah.lo), f32x8::splat(sah.hi));
        for k in 0..chunks {
            // The planes strictly inside the node (NaN pads are not).
            let mut inside = (c[k].simd_gt(lo) & c[k].simd_lt(hi)).to_bitmask();
            if inside == 0 {
                continue;
            }
            let pos = c[k].to_array();
            let (nb, na, np) = (below[k].to_array(), above[k].to_array(), flat[k].to_array());
            // Without flat boxes (the usual case) each plane has one price, four at a time.
            let prices = (!any_flat).then(|| {
                let q = |h: usize| {
                    let f =
                        |v: &[f32; 8]| f64x4::from(core::array::from_fn(|j| v[4 * h + j] as f64));
                    sah.cost4(f(&pos), f(&nb), f(&na)).to_array()
                };
                let (l, h) = (q(0), q(1));
                [l[0], l[1], l[2], l[3], h[0], h[1], h[2], h[3]]
            });
            while inside != 0 {
                let j = inside.trailing_zeros() as usize;
                inside &= inside - 1;
                let pos = pos[j];
                let (cost, planar_below) = match prices {
                    Some(p) => (p[j], true),
                    None => {
                        // Whole numbers below 2²⁴: exact as u32.
                        let (nb, na) = (nb[j] as u32 as usize, na[j] as u32 as usize);
                        sah.cost_with_planars(pos, nb, na, np[j] as u32 as usize)
                    }
                };
                let first = |b: &Split| {
                    cost < b.cost || (cost == b.cost && axis == b.axis && order(pos) < order(b.pos))
                };
                if best.as_ref().is_none_or(first) {
                    best = Some(Split {
                        axis,
                        pos,
                        cost,
                        planar_below,
                    });
                }
            }
        }
    }
    best
}

/// For the first `C` chunks of candidates `c`, adds up the boxes (`boxes`: min, max pairs on
/// one axis) below each candidate (`min < p`), above it (`max > p`) and flat on it; returns
/// whether any box is flat.
#[inline(always)]
fn count<const C: usize>(
    boxes: &[f32],
    c: &[wide::f32x8; 2 * SMALL_MAX / 8],
    below: &mut [wide::f32x8; 2 * SMALL_MAX / 8],
    above: &mut [wide::f32x8; 2 * SMALL_MAX / 8],
    flat: &mut [wide::f32x8; 2 * SMALL_MAX / 8],
) -> bool {
    use wide::{bytemuck::cast, f32x8, i32x8};
    // Counted as integers: a true comparison is −1 in every bit, so subtracting the mask adds
    // one (a third fewer operations than masking 1.0 and adding floats; the same whole numbers).
    let mask = |m: f32x8| cast::<f32x8, i32x8>(m);
    let c: [f32x8; C] = core::array::from_fn(|k| c[k]);
    let (mut b, mut a) = ([i32x8::ZERO; C], [i32x8::ZERO; C]);
    let mut f = [i32x8::ZERO; C];
    let mut any_flat = false;
    for pair in boxes.chunks_exact(2) {
        let (lo, hi) = (pair[0], pair[1]);
        let (l, h) = (f32x8::splat(lo), f32x8::splat(hi));
        for k in 0..C {
            b[k] -= mask(l.simd_lt(c[k]));
            a[k] -= mask(h.simd_gt(c[k]));
        }
        if lo == hi {
            any_flat = true;
            for k in 0..C {
                f[k] -= mask(l.simd_eq(c[k]));
            }
        }
    }
    for k in 0..C {
        below[k] = f32x8::from_i32x8(b[k]);
        above[k] = f32x8::from_i32x8(a[k]);
        flat[k] = f32x8::from_i32x8(f[k]);
    }
    any_flat
}

/// The sort order of positions in the event lists ([`Event::key`]): −0 before +0.
#[inline]
fn order(pos: f32) -> u64 {
    Event {
        pos,
        prim: 0,
        kind: 0,
    }
    .key()
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
/// `AXIS` is `split.axis`.
#[inline]
fn side<const AXIS: usize>(r: &Ref, split: &Split) -> Side {
    let (lo, hi) = (r.bounds.min[AXIS], r.bounds.max[AXIS]);
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

/// Sends each reference of `stack[start..]` below, above or both ways ([`side`]), straddlers
/// clipped to each child, each child's references in their parent's order. Leaves the above
/// child's `na` references at `stack[start..start + na]` and the below child's `nb` on top of
/// them, and returns `(nb, na)`.
fn partition(
    ctx: &Ctx,
    stack: &mut Vec<Ref>,
    start: usize,
    split: &Split,
    below_box: &Aabb,
    above_box: &Aabb,
) -> (usize, usize) {
    BELOW.with_borrow_mut(|below| {
        below.clear();
        let na = partition_into(ctx, stack, start, split, below_box, above_box, below);
        stack.extend_from_slice(below);
        (below.len(), na)
    })
}

/// [`partition`] with the below child's references pushed onto `below` instead: the above
/// child's are left at `stack[start..]`; returns their number.
fn partition_into(
    ctx: &Ctx,
    stack: &mut Vec<Ref>,
    start: usize,
    split: &Split,
    below_box: &Aabb,
    above_box: &Aabb,
    below: &mut Vec<Ref>,
) -> usize {
    // One loop per axis, so that no coordinate of the loop is picked at run time.
    let on = match split.axis {
        0 => partition_on::<0>,
        1 => partition_on::<1>,
        _ => partition_on::<2>,
    };
    on(ctx, stack, start, split, below_box, above_box, below)
}

/// [`partition_into`] with `AXIS` the split's axis.
fn partition_on<const AXIS: usize>(
    ctx: &Ctx,
    stack: &mut Vec<Ref>,
    start: usize,
    split: &Split,
    below_box: &Aabb,
    above_box: &Aabb,
    below: &mut Vec<Ref>,
) -> usize {
    let end = stack.len();
    let exact = end - start >= ctx.params.fast.clip_min;
    // The above child's references go on top of the stack, the below child's aside.
    for i in start..end {
        let r = stack[i];
        match side::<AXIS>(&r, split) {
            Side::Below => below.push(r),
            Side::Above => stack.push(r),
            Side::Both => {
                let (b, a) = if exact {
                    (ctx.clip(r.id, below_box), ctx.clip(r.id, above_box))
                } else {
                    ctx.prims.split(r.id, AXIS, split.pos, &r.bounds)
                };
                // Rounding can in principle empty both: keep the primitive,
                // conservatively, below.
                let b = match (b, a) {
                    (None, None) => Some(r.bounds.intersection(below_box)),
                    _ => b,
                };
                below.extend(b.map(|bounds| Ref { id: r.id, bounds }));
                stack.extend(a.map(|bounds| Ref { id: r.id, bounds }));
            }
        }
    }
    let na = stack.len() - end;
    stack.copy_within(end.., start);
    stack.truncate(start + na);
    na
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::BuildParams;
    use glam::Vec3;

    /// A deterministic generator (SplitMix64).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    /// Random boxes in `bounds`, their bounds drawn from a few values (so that boxes share
    /// bounds, lie flat, touch the node's walls, and sit on ±0), at scale `s`.
    fn boxes(rng: &mut Rng, n: usize, s: f32) -> Vec<Ref> {
        let values = [-4.0, -1.5, -0.0, 0.0, 0.25, 1.0, 2.5, 3.0, 4.0].map(|v: f32| v * s);
        (0..n)
            .map(|i| {
                let mut pick = || {
                    let (a, b) = (values[rng.below(9)], values[rng.below(9)]);
                    // One box in five flat on the axis.
                    if rng.below(5) == 0 {
                        (a, a)
                    } else {
                        (a.min(b), a.max(b))
                    }
                };
                let (x, y, z) = (pick(), pick(), pick());
                Ref {
                    id: i as u32,
                    bounds: Aabb {
                        min: Vec3::new(x.0, y.0, z.0),
                        max: Vec3::new(x.1, y.1, z.1),
                    },
                }
            })
            .collect()
    }

    #[test]
    fn the_small_search_finds_the_sweeps_plane() {
        let mut rng = Rng(7);
        for group in [1, 4] {
            let costs = BuildParams {
                group,
                ..BuildParams::default()
            }
            .costs();
            for s in [1.0, 1e-30, 1e30, 3e-39] {
                let bounds = Aabb {
                    min: Vec3::splat(-4.0 * s),
                    max: Vec3::splat(4.0 * s),
                };
                for n in (1..=SMALL_MAX).chain([SMALL_MAX; 40]) {
                    let refs = boxes(&mut rng, n, s);
                    let (small, sweep) = (
                        small_split(&refs, &bounds, &costs),
                        exact_split(&refs, &bounds, &costs),
                    );
                    let bits = |s: Option<Split>| {
                        s.map(|s| (s.axis, s.pos.to_bits(), s.cost.to_bits(), s.planar_below))
                    };
                    assert_eq!(bits(small), bits(sweep), "n {n}, scale {s}, group {group}");
                }
            }
            // All boxes the same, and a flat node (no depth on z).
            let same = vec![boxes(&mut Rng(1), 1, 1.0)[0]; SMALL_MAX];
            let flat = Aabb {
                min: Vec3::new(-4.0, -4.0, 0.0),
                max: Vec3::new(4.0, 4.0, 0.0),
            };
            let bounds = Aabb {
                min: Vec3::splat(-4.0),
                max: Vec3::splat(4.0),
            };
            for (refs, bounds) in [(same, bounds), (boxes(&mut rng, 20, 1.0), flat)] {
                assert_eq!(
                    small_split(&refs, &bounds, &costs),
                    exact_split(&refs, &bounds, &costs)
                );
            }
        }
    }
}
