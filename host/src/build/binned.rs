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

/// Per-axis start and end counts over `bins` bins, and the contents' extent.
#[derive(Clone)]
pub struct Bins {
    bins: usize,
    /// `starts[axis * bins + i]`, likewise `ends`.
    starts: Vec<u32>,
    ends: Vec<u32>,
    /// The union of the binned boxes.
    contents: Aabb,
}

/// Where a node's box puts its bins: per axis, the low bound and bins per unit length.
#[derive(Clone, Copy)]
pub struct Grid {
    lo: [f32; 3],
    scale: [f32; 3],
    bins: usize,
}

impl Grid {
    pub fn new(bounds: &Aabb, bins: usize) -> Self {
        let scale = core::array::from_fn(|a| {
            let extent = bounds.max[a] - bounds.min[a];
            let s = bins as f32 / extent;
            if s.is_finite() { s } else { 0.0 }
        });
        Self {
            lo: bounds.min.to_array(),
            scale,
            bins,
        }
    }

    #[inline]
    fn bin(&self, x: f32, axis: usize) -> usize {
        // Clamped as an i32, which costs a third of a saturating cast to usize: a bound below
        // the box (rounding) goes to bin 0, one past it to the last; NaN cannot occur (finite
        // input).
        let b = ((x - self.lo[axis]) * self.scale[axis]) as i32;
        b.clamp(0, self.bins as i32 - 1) as usize
    }

    /// The border below bin `b`.
    #[inline]
    fn border(&self, b: usize, axis: usize, bounds: &Aabb) -> f32 {
        let t = b as f32 / self.bins as f32;
        bounds.min[axis] + (bounds.max[axis] - bounds.min[axis]) * t
    }
}

impl Bins {
    pub fn new(bins: usize) -> Self {
        Self {
            bins,
            starts: vec![0; 3 * bins],
            ends: vec![0; 3 * bins],
            contents: Aabb::EMPTY,
        }
    }

    /// Empties the bins and makes them `bins` a axis.
    fn reset(&mut self, bins: usize) {
        self.bins = bins;
        for v in [&mut self.starts, &mut self.ends] {
            v.clear();
            v.resize(3 * bins, 0);
        }
        self.contents = Aabb::EMPTY;
    }

    /// Counts `refs` into the bins of `grid`.
    pub fn add(&mut self, refs: &[Ref], grid: &Grid) {
        let k = self.bins;
        let (mut lo, mut hi) = (self.contents.min.to_array(), self.contents.max.to_array());
        // One slice per axis and kind, each `k` long, so that a bin index clamped to `k - 1`
        // needs no bounds check.
        let (s0, rest) = self.starts.split_at_mut(k);
        let (s1, s2) = rest.split_at_mut(k);
        let (e0, rest) = self.ends.split_at_mut(k);
        let (e1, e2) = rest.split_at_mut(k);
        let starts = [s0, s1, &mut s2[..k]];
        let ends = [e0, e1, &mut e2[..k]];
        let last = k - 1;
        for r in refs {
            let (bmin, bmax) = (r.bounds.min.to_array(), r.bounds.max.to_array());
            for axis in 0..3 {
                starts[axis][grid.bin(bmin[axis], axis).min(last)] += 1;
                ends[axis][grid.bin(bmax[axis], axis).min(last)] += 1;
                lo[axis] = lo[axis].min(bmin[axis]);
                hi[axis] = hi[axis].max(bmax[axis]);
            }
        }
        self.contents = Aabb {
            min: lo.into(),
            max: hi.into(),
        };
    }

    /// The sum of two partial binnings of one node.
    pub fn merge(mut self, other: &Bins) -> Bins {
        for (a, b) in self.starts.iter_mut().zip(&other.starts) {
            *a += b;
        }
        for (a, b) in self.ends.iter_mut().zip(&other.ends) {
            *a += b;
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
            if grid.scale[axis] == 0.0 {
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
            let starts = &self.starts[axis * k..(axis + 1) * k];
            let ends = &self.ends[axis * k..(axis + 1) * k];
            let (mut nb, mut na) = (0usize, n);
            for b in 1..k {
                nb += starts[b - 1] as usize;
                na -= ends[b - 1] as usize;
                let pos = grid.border(b, axis, bounds);
                // Borders outside the contents are priced by the cut-offs above.
                if sah.inside(pos) && pos > cmin && pos < cmax {
                    // A primitive flat on a border counts in the bin above it.
                    let cost = sah.cost(pos, nb, na);
                    consider(Split {
                        axis,
                        pos,
                        cost,
                        planar_below: false,
                    });
                }
            }
        }
        best
    }
}

/// Bins `refs` over `bounds` and returns the best plane and the union of the boxes (the
/// contents); the bins of a large node are counted in fixed chunks on the rayon pool (with the
/// `cli` feature and `parallel`), and the counts are the same whatever the thread count.
pub fn best_split(
    refs: &[Ref],
    bounds: &Aabb,
    bins: usize,
    costs: &Costs,
    parallel: bool,
) -> Option<(Split, Aabb)> {
    let grid = Grid::new(bounds, bins);
    let best = |b: &Bins| Some((b.best_split(refs.len(), bounds, &grid, costs)?, b.contents));
    #[cfg(feature = "parallel")]
    if parallel && refs.len() >= 4 * CHUNK {
        return best(&count_parallel(refs, &grid));
    }
    let _ = parallel;
    // One set of bins a thread, reused: most binned nodes are small.
    SERIAL.with_borrow_mut(|b| {
        b.reset(bins);
        b.add(refs, &grid);
        best(b)
    })
}

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
