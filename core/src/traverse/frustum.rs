//! The frustum walk: a tile of coherent packets (a camera's neighbouring rays, one direction
//! octant) starts the packet walk ([`super::packet`]) at an entry node found once for the whole
//! tile, instead of at the root — the entry-point search of multi-level ray tracing (Reshetov,
//! Soupikov & Hurley 2005, "Multi-Level Ray Tracing Algorithm", SIGGRAPH: its entry-point search).
//!
//! # The entry-point search
//! The tile is bounded by interval arithmetic instead of the paper's four corner rays, so that any
//! tile of one octant qualifies (a pinhole's, a thin lens's, parallel rays): per axis the range of
//! the active lanes' origins and of their reciprocal directions, and the range of their intervals'
//! ends in the scene box (lanes that miss the box included: wider bounds, still bounds on the
//! lanes that matter). Down from the root, a split plane's distance `(split − o) · (1/d)` is
//! bounded over the tile by the corners of those ranges (the product is bilinear, so its extremes
//! lie at the corners, and f32 rounding is monotone, so each lane's rounded distance lies between
//! the rounded corners); the bounds are [`widen`]ed as the walk widens each lane's distance
//! (`widen` is monotone). If no lane can need one child, the search descends into the other
//! alone, clipping the tile's bounds as the lanes' intervals are clipped; it stops at the first
//! node where some lane may need both children (a leaf, or a corner distance that is NaN: an
//! origin on the plane of a direction parallel to it).
//!
//! # Why starting there is exact
//! Along the path, every lane of every packet needs at most the path's child, so the packet walk
//! from the root would go down the same path with nothing pending (or stop early, all lanes
//! dead), and a lane's interval at the entry node is its box interval clipped at each node of the
//! path. Each packet replays those clips with the same operations as the walk (a subtraction, a
//! product, [`widen`], a `min` or `max`) before walking on from the entry node, so every lane
//! reaches the entry node with the bits the walk from the root gives it, and from there the walks
//! are the same: the same leaves in the same order, the same hits (differs from the paper, whose
//! packets start with the frustum's interval, not their own). When no lane needs either child
//! somewhere on the path, every ray of the tile misses.
//!
//! # What it costs
//! The tile's bounds (a pass over its lanes), the search, and each packet's replay of the path,
//! against the node steps the packets skip. On a camera's primary rays that does not pay: the
//! search stops at the first plane the tile crosses, the root's in half of the tiles of a camera
//! centred on the scene, and the packet walk's steps near the root are cheap (docs/BENCHMARKS.md,
//! "The frustum walk: measured, not wired", has the figures). So the stream does not use it.
//!
//! A tile falls back to its packets' own walks ([`Scene::intersect_packet_with`]) when its active
//! lanes span more than one octant, or, in fast mode, when a packet's tests could overflow
//! ([`crate::simd::range`]); non-finite rays are inactive lanes, as in the packet walk.

use super::packet::{clip_packet_to_box, copy_packet, live_lanes, widen_lanes};
use super::{Contents, Mode, by_contents, widen};
use crate::format::{MAX_DEPTH, Scene};
use crate::simd::lanes::Lanes;
use crate::simd::packet::{HitPacket, RayPacket};
use crate::simd::watertight::ShearX;

/// The most packets one entry-point search serves: longer tiles are split into tiles of this many.
pub const MAX_PACKETS: usize = 8;

/// Bounds on a tile's active lanes, and so on its live ones: per axis the range of their origins
/// and reciprocal directions, and the smallest start and largest end of their intervals.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    origin: [[f32; 2]; 3],
    inv_dir: [[f32; 2]; 3],
    tmin: f32,
    tmax: f32,
}

/// One node of the path to the entry node: its split plane (value and axis), and whether the
/// path goes to its near child (else to its far one).
#[derive(Clone, Copy, Debug)]
struct Step {
    split: f32,
    axis: u8,
    near: bool,
}

/// Where a tile's walk starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// At this node, `depth` levels below the root.
    Node { index: u32, depth: usize },
    /// Nowhere: no lane needs any node, every ray misses.
    Miss,
}

impl Scene<'_> {
    /// The closest hit of each active lane of each packet of `tile` into `hits` (one per packet,
    /// as [`Scene::intersect_packet`]'s), in fast mode; packets past `hits`' length are not traced.
    /// The answers are the packet walk's, bit for bit (see the module doc).
    #[inline]
    pub fn intersect_tile<L: Lanes>(&self, tile: &[RayPacket<L>], hits: &mut [HitPacket<L>]) {
        self.intersect_tile_in(Mode::Fast, tile, hits);
    }

    /// [`Scene::intersect_tile`] in `mode`.
    #[inline]
    pub fn intersect_tile_in<L: Lanes>(
        &self,
        mode: Mode,
        tile: &[RayPacket<L>],
        hits: &mut [HitPacket<L>],
    ) {
        by_contents!(self, mode, |C| self.intersect_tile_with::<C, L>(tile, hits))
    }

    /// [`Scene::intersect_tile`] for a fixed [`Contents`].
    pub fn intersect_tile_with<C: Contents, L: Lanes>(
        &self,
        tile: &[RayPacket<L>],
        hits: &mut [HitPacket<L>],
    ) {
        for (tile, hits) in tile.chunks(MAX_PACKETS).zip(hits.chunks_mut(MAX_PACKETS)) {
            self.tile_walk::<C, L, false>(tile, |p, found, _| {
                if let Some(h) = hits.get_mut(p) {
                    *h = found;
                }
            });
        }
    }

    /// The mask of the active lanes that hit anything, for each packet of `tile` into `occluded`,
    /// as [`Scene::occluded_packet_with`]'s.
    pub fn occluded_tile_with<C: Contents, L: Lanes>(
        &self,
        tile: &[RayPacket<L>],
        occluded: &mut [L],
    ) {
        for (tile, occluded) in tile
            .chunks(MAX_PACKETS)
            .zip(occluded.chunks_mut(MAX_PACKETS))
        {
            self.tile_walk::<C, L, true>(tile, |p, _, done| {
                if let Some(o) = occluded.get_mut(p) {
                    *o = L::mask_from_bits(done);
                }
            });
        }
    }

    /// Where the walk of `tile` (at most [`MAX_PACKETS`] packets, one octant) starts in `C`'s
    /// walk; `None` when the tile falls back to its packets' own walks.
    pub fn tile_entry<C: Contents, L: Lanes>(&self, tile: &[RayPacket<L>]) -> Option<Entry> {
        let mut path = heapless::Vec::new();
        let (bounds, negative) = self.tile_bounds::<C, L>(tile)?.0;
        Some(self.entry::<C>(&bounds, negative, &mut path))
    }

    /// Walks the packets of `tile` (at most [`MAX_PACKETS`]) from their common entry node;
    /// `answer(p, hits, done)` receives packet `p`'s closest hits or (with `ANY`) the lanes that
    /// hit something.
    #[inline(always)]
    fn tile_walk<C: Contents, L: Lanes, const ANY: bool>(
        &self,
        tile: &[RayPacket<L>],
        mut answer: impl FnMut(usize, HitPacket<L>, u32),
    ) {
        let Some(((bounds, negative), intervals)) = self.tile_bounds::<C, L>(tile) else {
            // Several octants, or a packet out of the fast tests' range: each packet alone.
            for (p, rays) in tile.iter().enumerate() {
                if ANY {
                    let done = self.occluded_packet_with::<C, L>(rays).bitmask();
                    answer(p, HitPacket::miss(), done);
                } else {
                    answer(p, self.intersect_packet_with::<C, L>(rays), 0);
                }
            }
            return;
        };
        let mut path = heapless::Vec::new();
        let start = match self.entry::<C>(&bounds, negative, &mut path) {
            Entry::Node { index, .. } => index,
            Entry::Miss => {
                for p in 0..tile.len() {
                    answer(p, HitPacket::miss(), 0);
                }
                return;
            }
        };
        for (p, (rays, &(tmin, tmax))) in tile.iter().zip(&intervals).enumerate() {
            let mut hits = HitPacket::miss();
            let group = rays.active.bitmask();
            let live = live_lanes(tmin, tmax) & group;
            let mut done = 0;
            if live != 0 {
                let (tmin, tmax) = replay::<C, L>(rays, &path, tmin, tmax);
                let mut query = copy_packet(rays);
                let shear = C::WATERTIGHT.then(|| ShearX::new(rays));
                let start = (start, tmin, tmax);
                done =
                    self.walk_from::<C, L, ANY>(&mut query, group, live, &mut hits, &shear, start);
            }
            answer(p, hits, done);
        }
    }

    /// The bounds of the live lanes of `tile` and its octant (whether each axis's directions are
    /// negative), and each packet's lanes' intervals in the scene box; `None` when the active lanes
    /// span several octants or, in fast mode, a packet could overflow the packet kernels.
    #[allow(clippy::type_complexity)]
    #[inline(always)]
    fn tile_bounds<C: Contents, L: Lanes>(
        &self,
        tile: &[RayPacket<L>],
    ) -> Option<((Bounds, [bool; 3]), [(L, L); MAX_PACKETS])> {
        let (inf, zero) = (L::splat(f32::INFINITY), L::splat(0.0));
        let mut intervals = [(inf, -inf); MAX_PACKETS];
        let mut lo = [inf; 8];
        let mut hi = [-inf; 8];
        // The octant's bits per axis: which lanes are negative, and which positive.
        let (mut negative, mut positive) = ([0u32; 3], [0u32; 3]);
        for (rays, interval) in tile.iter().zip(&mut intervals) {
            if !C::WATERTIGHT && !self.packet_in_range(rays) {
                return None;
            }
            let active = rays.active.bitmask();
            let inv = [rays.inv_dir.x, rays.inv_dir.y, rays.inv_dir.z];
            for (axis, inv) in inv.into_iter().enumerate() {
                let n = inv.lt(zero).bitmask() & active;
                negative[axis] |= n;
                positive[axis] |= active & !n;
            }
            let (tmin, tmax) = clip_packet_to_box::<C, L>(rays, self.bounds());
            *interval = (tmin, tmax);
            // Bounds over the active lanes, dead ones included (wider bounds, still bounds on the
            // live lanes), so that a packet of active lanes masks nothing.
            let full = active == (1 << L::WIDTH) - 1;
            let keep = rays.active;
            let values = [
                rays.origin.x,
                rays.origin.y,
                rays.origin.z,
                rays.inv_dir.x,
                rays.inv_dir.y,
                rays.inv_dir.z,
                tmin,
                tmax,
            ];
            for ((lo, hi), v) in lo.iter_mut().zip(&mut hi).zip(values) {
                if full {
                    (*lo, *hi) = (lo.min(v), hi.max(v));
                } else {
                    *lo = lo.min(keep.select(v, inf));
                    *hi = hi.max(keep.select(v, -inf));
                }
            }
        }
        if (0..3).any(|k| negative[k] != 0 && positive[k] != 0) {
            return None;
        }
        // (No lane is NaN here: plain comparisons, where `f32::min` would also handle NaN.)
        let low = |v: L| {
            v.to_array()
                .as_ref()
                .iter()
                .fold(f32::INFINITY, |a, &b| if b < a { b } else { a })
        };
        let high = |v: L| {
            v.to_array()
                .as_ref()
                .iter()
                .fold(f32::NEG_INFINITY, |a, &b| if b > a { b } else { a })
        };
        let range = |k: usize| [low(lo[k]), high(hi[k])];
        let bounds = Bounds {
            origin: [range(0), range(1), range(2)],
            inv_dir: [range(3), range(4), range(5)],
            tmin: low(lo[6]),
            tmax: high(hi[7]),
        };
        Some(((bounds, negative.map(|n| n != 0)), intervals))
    }

    /// The entry-point search (the module doc): the node the tile's walk starts at, and in `path`
    /// the nodes above it with the child taken at each.
    #[inline(always)]
    fn entry<C: Contents>(
        &self,
        bounds: &Bounds,
        negative: [bool; 3],
        path: &mut heapless::Vec<Step, MAX_DEPTH>,
    ) -> Entry {
        // No live lane (the tile misses the scene's box): `tmin` stays +∞ and no child is needed.
        let (mut tmin, mut tmax) = (bounds.tmin, bounds.tmax);
        let mut index = 0u32;
        loop {
            let node = self.node(index);
            let here = Entry::Node {
                index,
                depth: path.len(),
            };
            if node.is_leaf() {
                return here;
            }
            let axis = node.axis();
            let Some((t_lo, t_hi)) = split_range(node.split(), bounds, axis) else {
                return here;
            };
            // The lowest far start and the highest near end of any lane.
            let (far_start, near_end) = if C::CONSERVATIVE {
                (widen(t_lo).0, widen(t_hi).1)
            } else {
                (t_lo, t_hi)
            };
            let [below_empty, above_empty] = node.empty_children();
            let ((near, near_empty), (far, far_empty)) = if negative[axis] {
                ((node.above_child(), above_empty), (index + 1, below_empty))
            } else {
                ((index + 1, below_empty), (node.above_child(), above_empty))
            };
            // A lane needs the near child unless its near end lies before its interval, the far
            // child unless its far start lies beyond it; no lane does if the bounds say so.
            let need_near = !near_empty && !(near_end < tmin);
            let need_far = !far_empty && !(far_start > tmax);
            let step = |near| Step {
                split: node.split(),
                axis: axis as u8,
                near,
            };
            match (need_near, need_far) {
                (true, true) => return here,
                (false, false) => return Entry::Miss,
                (true, false) => {
                    if path.push(step(true)).is_err() {
                        return here;
                    }
                    tmax = tmax.min(near_end);
                    index = near;
                }
                (false, true) => {
                    if path.push(step(false)).is_err() {
                        return here;
                    }
                    tmin = tmin.max(far_start);
                    index = far;
                }
            }
        }
    }
}

/// The range of every live lane's rounded distance `(split − o) · (1/d)` along `axis`, from the
/// corners of the tile's ranges of `o` and `1/d`; `None` when a corner is NaN (`0 · ∞`: a lane
/// may lie in the plane, parallel to it, and need both children).
#[inline(always)]
fn split_range(split: f32, bounds: &Bounds, axis: usize) -> Option<(f32, f32)> {
    let [o_lo, o_hi] = bounds.origin[axis];
    let [i_lo, i_hi] = bounds.inv_dir[axis];
    // `split − o` is monotone in `o`, and rounding keeps the order.
    let (x_lo, x_hi) = (split - o_hi, split - o_lo);
    let corners = [x_lo * i_lo, x_lo * i_hi, x_hi * i_lo, x_hi * i_hi];
    if corners.iter().any(|c| c.is_nan()) {
        return None;
    }
    let lo = corners.iter().fold(f32::INFINITY, |a, &c| a.min(c));
    let hi = corners.iter().fold(f32::NEG_INFINITY, |a, &c| a.max(c));
    Some((lo, hi))
}

/// The lanes' intervals `(tmin, tmax)` in the box clipped along `path` as the packet walk clips
/// them on its way down (the same operations, in the same order).
#[inline(always)]
fn replay<C: Contents, L: Lanes>(rays: &RayPacket<L>, path: &[Step], tmin: L, tmax: L) -> (L, L) {
    let origin = [rays.origin.x, rays.origin.y, rays.origin.z];
    let inv_dir = [rays.inv_dir.x, rays.inv_dir.y, rays.inv_dir.z];
    let (mut tmin, mut tmax) = (tmin, tmax);
    for step in path {
        let axis = usize::from(step.axis);
        let t_split = (L::splat(step.split) - origin[axis]) * inv_dir[axis];
        let (far_start, near_end) = if C::CONSERVATIVE {
            widen_lanes(t_split)
        } else {
            (t_split, t_split)
        };
        if step.near {
            tmax = tmax.min(near_end);
        } else {
            tmin = tmin.max(far_start);
        }
    }
    (tmin, tmax)
}
