//! The binned SAH split search (Shevtsov, Soupikov & Kapustin 2007, "Highly Parallel Fast
//! KD-tree Construction for Interactive Ray Tracing of Dynamic Scenes", §3.1: min-max binning).
//!
//! Each primitive's (clipped) box drops its minimum into a "start" bin and its maximum into an
//! "end" bin on each axis, bins of equal width over the node's box; a plane at the border of bins
//! `b − 1` and `b` then has below it the primitives starting in bins `< b` and above it those
//! ending in bins `≥ b`. Besides the bin borders, the two planes at the extent of the node's
//! contents are priced: they cut off empty space exactly, which the kd-tree's empty bonus rewards
//! and which no bin border need hit.
//!
//! The counts are estimates where a box's bound lies on or a rounding away from a border; the
//! partition compares boxes with the chosen plane itself, so the tree is correct whatever the
//! estimate, and deterministic: the bins are integer counts, added in any order.

use super::clip::Aabb;
use super::events::{AxisSah, Costs, Split};
use super::fast::Ref;
use glam::Vec3;
use wide::{f32x8, f64x4, i32x8};

/// Bins per axis at most ([`Bins`]' stride).
pub const MAX_BINS: usize = 256;

/// Per-axis start and end counts over `bins` bins, and the contents' extent.
///
/// The counts are one array of eight rows of [`MAX_BINS`]: rows 0–2 the starts on x, y, z,
/// rows 3–5 the ends, 6–7 unused. A box's six bins are then one 8-lane computation
/// (`Grid::index`) and six increments, each index below the array's length by construction.
#[derive(Clone)]
pub struct Bins {
    bins: usize,
    counts: Box<[u32; 8 * MAX_BINS]>,
    /// `b / bins` for each border `b`: where the borders lie in the box, the same on every axis
    /// and for every node of as many bins (one division a border when the count changes, not
    /// three a node).
    fractions: Box<[f32; MAX_BINS]>,
    /// The union of the binned boxes.
    contents: Aabb,
}

/// Where a node's box puts its bins, for the six bounds of a box at once: per lane (min x, y, z,
/// max x, y, z, two unused), the low bound, bins per unit length, and the lane's row in
/// [`Bins`]' counts.
#[derive(Clone, Copy)]
pub struct Grid {
    lo: f32x8,
    scale: f32x8,
    last: f32x8,
    row: i32x8,
    bins: usize,
}

/// A box as eight lanes: its minimum, its maximum, and two zeros.
#[inline]
fn lanes(b: &Aabb) -> f32x8 {
    f32x8::from([
        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z, 0.0, 0.0,
    ])
}

impl Grid {
    pub fn new(bounds: &Aabb, bins: usize) -> Self {
        debug_assert!((2..=MAX_BINS).contains(&bins));
        let scale: [f32; 3] = core::array::from_fn(|a| {
            let extent = bounds.max[a] - bounds.min[a];
            let s = bins as f32 / extent;
            if s.is_finite() { s } else { 0.0 }
        });
        let lo = bounds.min;
        let row = |r: i32| r * MAX_BINS as i32;
        Self {
            lo: f32x8::from([lo.x, lo.y, lo.z, lo.x, lo.y, lo.z, 0.0, 0.0]),
            scale: f32x8::from([
                scale[0], scale[1], scale[2], scale[0], scale[1], scale[2], 0.0, 0.0,
            ]),
            last: f32x8::splat((bins - 1) as f32),
            row: i32x8::from([
                row(0),
                row(1),
                row(2),
                row(3),
                row(4),
                row(5),
                row(6),
                row(7),
            ]),
            bins,
        }
    }

    /// The count indices of a box's six bounds (lanes 0–5; 6 and 7 point at unused rows). A
    /// bound below the box (rounding) goes to bin 0, one past it to the last: the position is
    /// clamped as a float (infinities included) and again as an integer, so that no input, NaN
    /// included, gives an index outside its row.
    #[inline]
    fn index(&self, b: f32x8) -> [i32; 8] {
        let t = ((b - self.lo) * self.scale)
            .fast_max(f32x8::ZERO)
            .fast_min(self.last);
        let bin = t
            .fast_trunc_int()
            .max(i32x8::ZERO)
            .min(i32x8::splat(self.bins as i32 - 1));
        (bin + self.row).to_array()
    }

    fn scale(&self, axis: usize) -> f32 {
        self.scale.to_array()[axis]
    }

    /// This grid on `axis` alone, for four boxes' (minimum, maximum) pairs at once: each lane
    /// computes what the lane of `axis` or `3 + axis` computes in [`Grid::index`], so the same
    /// bin.
    fn on_axis(&self, axis: usize) -> Self {
        let (lo, scale) = (self.lo.to_array()[axis], self.scale(axis));
        let rows = [axis, 3 + axis].map(|r| (r * MAX_BINS) as i32);
        Self {
            lo: f32x8::splat(lo),
            scale: f32x8::splat(scale),
            last: self.last,
            row: i32x8::from(core::array::from_fn(|j| rows[j % 2])),
            bins: self.bins,
        }
    }
}

impl Bins {
    pub fn new(bins: usize) -> Self {
        Self {
            bins,
            counts: Box::new([0; 8 * MAX_BINS]),
            fractions: Box::new(fractions(bins)),
            contents: Aabb::EMPTY,
        }
    }

    /// Empties the bins and makes them `bins` a axis.
    fn reset(&mut self, bins: usize) {
        for row in 0..6 {
            self.counts[row * MAX_BINS..row * MAX_BINS + self.bins.max(bins)].fill(0);
        }
        if bins != self.bins {
            *self.fractions = fractions(bins);
        }
        self.bins = bins;
        self.contents = Aabb::EMPTY;
    }

    /// The border below bin `b` on `axis`.
    #[inline]
    fn border(&self, b: usize, axis: usize, bounds: &Aabb) -> f32 {
        bounds.min[axis] + (bounds.max[axis] - bounds.min[axis]) * self.fractions[b]
    }

    /// The counts of row `row` (0–2 starts, 3–5 ends).
    fn row(&self, row: usize) -> &[u32] {
        &self.counts[row * MAX_BINS..row * MAX_BINS + self.bins]
    }

    /// Counts `refs` into the bins of `grid`.
    pub fn add(&mut self, refs: &[Ref], grid: &Grid) {
        let c = &mut *self.counts;
        // The contents: the minimum of lanes 0–2 and the maximum of lanes 3–5.
        let (mut lo, mut hi) = (f32x8::splat(f32::INFINITY), f32x8::splat(f32::NEG_INFINITY));
        for r in refs {
            let b = lanes(&r.bounds);
            lo = lo.fast_min(b);
            hi = hi.fast_max(b);
            let i = grid.index(b);
            // Masked to the array's length (a no-op: the indices are in range) so that the
            // increments need no bounds checks.
            for &i in &i[..6] {
                c[i as usize & (8 * MAX_BINS - 1)] += 1;
            }
        }
        let (lo, hi) = (lo.to_array(), hi.to_array());
        let contents = Aabb {
            min: Vec3::new(lo[0], lo[1], lo[2]),
            max: Vec3::new(hi[3], hi[4], hi[5]),
        };
        self.contents = self.contents.union(&contents);
    }

    /// Counts `refs` again on `axis` alone, the other axes' counts and the contents kept: for a
    /// node whose parent cut off empty space on `axis` with these bins, which hold the same
    /// references over the same box on the other two axes, so their counts there. Four
    /// references a computation, two increments each (binning all three axes takes one and six).
    pub fn recount(&mut self, refs: &[Ref], grid: &Grid, axis: usize) {
        for row in [axis, 3 + axis] {
            self.counts[row * MAX_BINS..row * MAX_BINS + self.bins].fill(0);
        }
        let g = grid.on_axis(axis);
        match axis {
            0 => recount_on(&mut self.counts, refs, &g, |v| v.x),
            1 => recount_on(&mut self.counts, refs, &g, |v| v.y),
            _ => recount_on(&mut self.counts, refs, &g, |v| v.z),
        }
    }

    /// The sum of two partial binnings of one node.
    pub fn merge(mut self, other: &Bins) -> Bins {
        for row in 0..6 {
            let r = row * MAX_BINS..row * MAX_BINS + self.bins;
            for (a, b) in self.counts[r.clone()].iter_mut().zip(&other.counts[r]) {
                *a += b;
            }
        }
        self.contents = self.contents.union(&other.contents);
        self
    }

    /// The cheapest plane strictly inside `bounds` among the bin borders and the contents'
    /// extent on every axis, for a node of `n` primitives.
    pub fn best_split(&self, n: usize, bounds: &Aabb, grid: &Grid, costs: &Costs) -> Option<Split> {
        let k = self.bins;
        let mut best: Option<Split> = None;
        let mut consider = |s: Split| {
            if best.is_none_or(|b| s.cost < b.cost) {
                best = Some(s);
            }
        };
        for axis in 0..3 {
            let Some(sah) = AxisSah::new(bounds, axis, costs) else {
                continue;
            };
            if grid.scale(axis) == 0.0 {
                continue;
            }
            // Cut-offs of the empty space around the contents: every primitive on one side
            // (a primitive flat on the plane goes to the contents' side).
            let (cmin, cmax) = (self.contents.min[axis], self.contents.max[axis]);
            for (pos, nb, na, planar_below) in [(cmin, 0, n, false), (cmax, n, 0, true)] {
                if sah.inside(pos) {
                    let cost = sah.cost(pos, nb, na);
                    consider(Split {
                        axis,
                        pos,
                        cost,
                        planar_below,
                    });
                }
            }
            let (starts, ends) = (self.row(axis), self.row(3 + axis));
            // The borders' counts, then their prices four at a time (priced in order, so the
            // first of equal costs wins, as before).
            let (mut below, mut above) = (0usize, n);
            for q in (1..k).step_by(4) {
                let (mut p4, mut b4, mut a4) = ([f32::NAN; 4], [0usize; 4], [0usize; 4]);
                for j in 0..4 {
                    let b = q + j;
                    if b < k {
                        below += starts[b - 1] as usize;
                        above -= ends[b - 1] as usize;
                        (p4[j], b4[j], a4[j]) = (self.border(b, axis, bounds), below, above);
                    }
                }
                let f = |v: [usize; 4]| f64x4::from(v.map(|n| n as f64));
                let c4 = sah
                    .cost4(f64x4::from(p4.map(f64::from)), f(b4), f(a4))
                    .to_array();
                for j in 0..4 {
                    let pos = p4[j];
                    // Borders outside the contents are priced by the cut-offs above; a
                    // primitive flat on a border counts in the bin above it.
                    if sah.inside(pos) && pos > cmin && pos < cmax {
                        consider(Split {
                            axis,
                            pos,
                            cost: c4[j],
                            planar_below: false,
                        });
                    }
                }
            }
        }
        best
    }
}

/// [`Bins::recount`] on the axis that `pick` reads, with `grid` from [`Grid::on_axis`].
#[inline(always)]
fn recount_on(c: &mut [u32; 8 * MAX_BINS], refs: &[Ref], grid: &Grid, pick: impl Fn(Vec3) -> f32) {
    let pair = |r: &Ref| [pick(r.bounds.min), pick(r.bounds.max)];
    let mut quads = refs.chunks_exact(4);
    for q in &mut quads {
        let [a, b, c2, d] = [&q[0], &q[1], &q[2], &q[3]].map(pair);
        let i = grid.index(f32x8::from([
            a[0], a[1], b[0], b[1], c2[0], c2[1], d[0], d[1],
        ]));
        for &i in &i {
            c[i as usize & (8 * MAX_BINS - 1)] += 1;
        }
    }
    let rest = quads.remainder();
    if !rest.is_empty() {
        let mut lanes = [0.0; 8];
        for (k, r) in rest.iter().enumerate() {
            lanes[2 * k..2 * k + 2].copy_from_slice(&pair(r));
        }
        let i = grid.index(f32x8::from(lanes));
        for &i in &i[..2 * rest.len()] {
            c[i as usize & (8 * MAX_BINS - 1)] += 1;
        }
    }
}

/// `b / bins` for the borders `b` of `bins` bins (0 past them).
fn fractions(bins: usize) -> [f32; MAX_BINS] {
    core::array::from_fn(|b| {
        if b < bins {
            b as f32 / bins as f32
        } else {
            0.0
        }
    })
}

/// Bins `refs` over `bounds` and returns the best plane, the union of the boxes (the contents)
/// and whether the counts stay in this thread's bins (for [`Kept`]); the bins of a large node
/// are counted in fixed chunks on the rayon pool (with the `cli` feature and `parallel`), and the
/// counts are the same whatever the thread count.
///
/// `kept`: `Some(axis)` when this thread's bins hold, from the node's parent, these references'
/// counts over this box on every axis but `axis` (see [`Kept`]); only `axis` is counted again.
pub fn best_split(
    refs: &[Ref],
    bounds: &Aabb,
    bins: usize,
    costs: &Costs,
    parallel: bool,
    kept: Kept,
) -> Option<(Split, Aabb, bool)> {
    let grid = Grid::new(bounds, bins);
    let best = |b: &Bins, in_bins: bool| {
        let split = b.best_split(refs.len(), bounds, &grid, costs)?;
        Some((split, b.contents, in_bins))
    };
    #[cfg(feature = "parallel")]
    if parallel && refs.len() >= 4 * CHUNK {
        return best(&count_parallel(refs, &grid), false);
    }
    let _ = parallel;
    // One set of bins a thread, reused: most binned nodes are small.
    SERIAL.with_borrow_mut(|b| {
        match kept {
            Some(axis) if b.bins == bins => b.recount(refs, &grid, axis),
            _ => {
                b.reset(bins);
                b.add(refs, &grid);
            }
        }
        best(b, true)
    })
}

/// What a node's binning may keep of its parent's: `Some(axis)` when the parent was binned in
/// this thread's bins and its plane cut off empty space on `axis` (a cut-off moves no
/// reference): the child then holds the same references, so the same number of bins, over a
/// box changed on `axis` alone, and its counts on the other two axes are its parent's. On the
/// knot of the npm benchmark half the binned references are in such nodes.
pub type Kept = Option<usize>;

thread_local! {
    static SERIAL: core::cell::RefCell<Bins> = core::cell::RefCell::new(Bins::new(0));
}

/// Refs per parallel binning task.
#[cfg(feature = "parallel")]
const CHUNK: usize = 16 * 1024;

#[cfg(feature = "parallel")]
fn count_parallel(refs: &[Ref], grid: &Grid) -> Bins {
    use rayon::prelude::*;
    refs.par_chunks(CHUNK)
        .map(|c| {
            let mut b = Bins::new(grid.bins);
            b.add(c, grid);
            b
        })
        .reduce_with(|a, b| a.merge(&b))
        .unwrap_or_else(|| Bins::new(grid.bins))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bound_lands_in_a_bin_of_its_row() {
        let bounds = Aabb {
            min: Vec3::new(-1.0, 0.0, 1e-30),
            max: Vec3::new(1.0, 0.0, 3e38),
        };
        let b = |lo: f32, hi: f32| Ref {
            id: 0,
            bounds: Aabb {
                min: Vec3::splat(lo),
                max: Vec3::splat(hi),
            },
        };
        // Outside the box (rounding), on its walls, at the extremes of f32 and denormal.
        let refs = [
            b(-3e38, 3e38),
            b(-1.0, 1.0),
            b(-1.5, -1.2),
            b(1.2, 1.5),
            b(0.0, 0.0),
            b(-0.0, 1e-45),
            b(f32::MIN, f32::MAX),
            b(f32::NEG_INFINITY, f32::INFINITY),
        ];
        for bins in [2, 3, 32, MAX_BINS] {
            let grid = Grid::new(&bounds, bins);
            let mut counts = Bins::new(bins);
            counts.add(&refs, &grid);
            for row in 0..6 {
                let total: u32 = counts.row(row).iter().sum();
                assert_eq!(total as usize, refs.len(), "bins {bins}, row {row}");
            }
            // Below the box: the first bin; past it: the last.
            let mut one = Bins::new(bins);
            one.add(&refs[2..4], &grid);
            assert_eq!((one.row(0)[0], one.row(3)[bins - 1]), (1, 1));
        }
    }

    #[test]
    fn a_recount_on_one_axis_gives_a_fresh_counts() {
        // Boxes inside [-1, 1]³ (some flat, some on the walls, one past them by rounding);
        // the node's box then cut on each axis as a cut-off would, and a few odd counts of
        // references (the recount takes them four at a time).
        let mut seed = 12345u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed % 2001) as f32 / 1000.0 - 1.0
        };
        let refs: Vec<Ref> = (0..103)
            .map(|i| {
                let (a, b) = (
                    Vec3::new(next(), next(), next()),
                    Vec3::new(next(), next(), next()),
                );
                let mut r = Ref {
                    id: i,
                    bounds: Aabb {
                        min: a.min(b),
                        max: a.max(b),
                    },
                };
                if i % 7 == 0 {
                    r.bounds.max.y = r.bounds.min.y;
                }
                if i == 5 {
                    r.bounds.min.x = -1.0000001;
                }
                r
            })
            .collect();
        let bounds = Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        };
        for n in [103, 100, 33, 6] {
            let refs = &refs[..n];
            for bins in [8, 17, 32] {
                for axis in 0..3 {
                    for cut in [(-0.4, 1.0), (-1.0, 0.3)] {
                        let mut cell = bounds;
                        (cell.min[axis], cell.max[axis]) = cut;
                        let mut kept = Bins::new(bins);
                        kept.add(refs, &Grid::new(&bounds, bins));
                        kept.recount(refs, &Grid::new(&cell, bins), axis);
                        let mut fresh = Bins::new(bins);
                        fresh.add(refs, &Grid::new(&cell, bins));
                        for row in 0..6 {
                            assert_eq!(
                                kept.row(row),
                                fresh.row(row),
                                "n {n} bins {bins} axis {axis}"
                            );
                        }
                        assert_eq!(kept.contents, fresh.contents);
                    }
                }
            }
        }
    }
}
