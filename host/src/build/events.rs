//! Split events and the SAH sweep of Wald & Havran 2006, "On building fast kd-Trees for Ray
//! Tracing, and on doing that in O(N log N)", §4.2–4.3.
//!
//! Each primitive's (clipped) box gives, on each axis, a START and an END event, or one PLANAR
//! event when the box is flat on that axis. Lists are sorted once by `(position, kind)` with
//! END < PLANAR < START, and kept sorted by the split step, so one linear sweep per axis finds the
//! best plane.

use super::clip::Aabb;
use wide::f64x4;

pub const END: u8 = 0;
pub const PLANAR: u8 = 1;
pub const START: u8 = 2;

/// One event: position on its axis, the primitive's index local to the node, and its kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    pub pos: f32,
    pub prim: u32,
    pub kind: u8,
}

impl Event {
    /// A u64 whose order is the `(position, kind)` order (positions are finite).
    #[inline]
    pub fn key(&self) -> u64 {
        let bits = self.pos.to_bits();
        let ordered = if bits & 0x8000_0000 != 0 {
            !bits
        } else {
            bits | 0x8000_0000
        };
        ((ordered as u64) << 2) | self.kind as u64
    }
}

impl Event {
    /// The event of primitive `prim` whose [`Event::key`] is `key`.
    #[inline]
    pub fn from_key(key: u64, prim: u32) -> Event {
        let ordered = (key >> 2) as u32;
        let bits = if ordered & 0x8000_0000 != 0 {
            ordered & 0x7fff_ffff
        } else {
            !ordered
        };
        Event {
            pos: f32::from_bits(bits),
            prim,
            kind: (key & 3) as u8,
        }
    }
}

/// Appends the events of `prim`'s box on `axis`.
#[inline]
pub fn push_events(out: &mut Vec<Event>, b: &Aabb, axis: usize, prim: u32) {
    let (lo, hi) = (b.min[axis], b.max[axis]);
    if lo == hi {
        out.push(Event {
            pos: lo,
            prim,
            kind: PLANAR,
        });
    } else {
        out.push(Event {
            pos: lo,
            prim,
            kind: START,
        });
        out.push(Event {
            pos: hi,
            prim,
            kind: END,
        });
    }
}

pub fn sort_events(events: &mut [Event]) {
    events.sort_unstable_by_key(Event::key);
}

/// SAH cost constants (pbrt-v3's `KdTreeAccel` parameters), and how many primitives one test
/// takes: 1, or 4 for leaves stored in groups of four (`kdray_core::group`), priced in groups
/// as Embree's `leafSAH` with block size 4 does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Costs {
    pub traversal: f64,
    pub intersect: f64,
    pub empty_bonus: f64,
    pub group: usize,
}

impl Costs {
    /// The tests a leaf of `n` primitives costs: `⌈n / group⌉`.
    #[inline]
    pub fn tests(&self, n: usize) -> f64 {
        // The sweep calls this four times a plane: no division where it is not needed.
        if self.group == 1 {
            n as f64
        } else {
            n.div_ceil(self.group) as f64
        }
    }
}

/// The best plane found: axis, position, cost, and whether planar primitives go below.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub axis: usize,
    pub pos: f32,
    pub cost: f64,
    pub planar_below: bool,
}

/// The SAH cost of planes on one axis of a node's box:
/// `Kt + Ki·(1 − bonus)·(P_b·⌈n_b/g⌉ + P_a·⌈n_a/g⌉)` (g = 1: pbrt's), the bonus applying when a
/// side is empty (pbrt-v3 §4.4.2, after MacDonald & Booth 1990). With `a`, `b` the box's other two
/// extents, a child's area is `2(ab + (a + b)·length)`. Both split searches (the event sweep and
/// the binned one, [`super::binned`]) price planes here, so another node or leaf cost (wide
/// nodes, groups) changes both.
pub struct AxisSah {
    cap: f64,
    side: f64,
    pub lo: f32,
    pub hi: f32,
    costs: Costs,
}

impl AxisSah {
    /// `None` when the box has no area (no plane can be priced).
    pub fn new(bounds: &Aabb, axis: usize, costs: &Costs) -> Option<Self> {
        let inv_area = 1.0 / bounds.area();
        if !inv_area.is_finite() {
            return None;
        }
        let d = (bounds.max - bounds.min).as_dvec3();
        let (a, b) = (d[(axis + 1) % 3], d[(axis + 2) % 3]);
        Some(Self {
            cap: 2.0 * a * b * inv_area,
            side: 2.0 * (a + b) * inv_area,
            lo: bounds.min[axis],
            hi: bounds.max[axis],
            costs: *costs,
        })
    }

    /// Whether `pos` is strictly inside the box on this axis (a plane that splits something).
    #[inline]
    pub fn inside(&self, pos: f32) -> bool {
        pos > self.lo && pos < self.hi
    }

    /// The cost of the plane at `pos` with `nb` primitives below and `na` above.
    #[inline]
    pub fn cost(&self, pos: f32, nb: usize, na: usize) -> f64 {
        let pos = pos as f64;
        let pb = self.cap + self.side * (pos - self.lo as f64);
        let pa = self.cap + self.side * (self.hi as f64 - pos);
        let c = &self.costs;
        let bonus = if nb == 0 || na == 0 {
            c.empty_bonus
        } else {
            0.0
        };
        c.traversal + c.intersect * (1.0 - bonus) * (pb * c.tests(nb) + pa * c.tests(na))
    }

    /// The cost of the plane at `pos` with `nb` primitives below, `na` above and `planars` flat
    /// on it, which go to the cheaper side (below on a tie): the cost and whether they go below.
    #[inline]
    pub fn cost_with_planars(&self, pos: f32, nb: usize, na: usize, planars: usize) -> (f64, bool) {
        let below = self.cost(pos, nb + planars, na);
        if planars == 0 {
            return (below, true);
        }
        let above = self.cost(pos, nb, na + planars);
        if below <= above {
            (below, true)
        } else {
            (above, false)
        }
    }
}

impl AxisSah {
    /// [`AxisSah::cost`] of four planes at once, with `nb` and `na` primitives below and above
    /// (whole numbers as f64); each cost is bit for bit the scalar one (the same f64 operations,
    /// unfused; `⌈n/g⌉` as `(n/g).ceil()`, exact for whole numbers below 2⁵²).
    #[inline]
    pub fn cost4(&self, pos: f64x4, nb: f64x4, na: f64x4) -> f64x4 {
        let c = &self.costs;
        let pb =
            f64x4::splat(self.cap) + f64x4::splat(self.side) * (pos - f64x4::splat(self.lo as f64));
        let pa =
            f64x4::splat(self.cap) + f64x4::splat(self.side) * (f64x4::splat(self.hi as f64) - pos);
        let (tb, ta) = if c.group == 1 {
            (nb, na)
        } else if c.group.is_power_of_two() {
            // `n / g` is exactly `n · (1/g)` for a power of two (whole `n` below 2⁵²): the same
            // bits without a division (two a plane, the pricing's slowest step in WebAssembly).
            let r = f64x4::splat(1.0 / c.group as f64);
            ((nb * r).ceil(), (na * r).ceil())
        } else {
            let g = f64x4::splat(c.group as f64);
            ((nb / g).ceil(), (na / g).ceil())
        };
        let empty = nb.simd_eq(f64x4::ZERO) | na.simd_eq(f64x4::ZERO);
        #[allow(clippy::identity_op)]
        let factor = empty.select(f64x4::splat(1.0 - c.empty_bonus), f64x4::splat(1.0 - 0.0));
        f64x4::splat(c.traversal) + f64x4::splat(c.intersect) * factor * (pb * tb + pa * ta)
    }
}

/// One sweep over a sorted event list of `axis`: the best split strictly inside `bounds`.
pub fn best_split_on_axis(
    events: &[Event],
    n: usize,
    bounds: &Aabb,
    axis: usize,
    costs: &Costs,
) -> Option<Split> {
    let sah = AxisSah::new(bounds, axis, costs)?;
    let mut best: Option<Split> = None;
    let (mut nb, mut na) = (0usize, n);
    let mut i = 0;
    while i < events.len() {
        // The events at `pos`: the list is sorted by (position, kind), so these are its ENDs,
        // then PLANARs, then STARTs.
        let pos = events[i].pos;
        let mut counts = [0usize; 3];
        while let Some(e) = events.get(i).filter(|e| e.pos == pos) {
            counts[e.kind as usize] += 1;
            i += 1;
        }
        let [ends, planars, starts] = counts;
        na -= ends + planars;
        if sah.inside(pos) {
            let (cost, planar_below) = sah.cost_with_planars(pos, nb, na, planars);
            if best.is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    axis,
                    pos,
                    cost,
                    planar_below,
                });
            }
        }
        nb += starts + planars;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::BuildParams;

    #[test]
    fn four_costs_are_the_scalar_costs() {
        let bounds = Aabb {
            min: glam::Vec3::new(-1.5, 0.25, 3.0),
            max: glam::Vec3::new(7.0, 0.5, 1e6),
        };
        for group in [1, 3, 4, 8] {
            let costs = BuildParams {
                group,
                ..BuildParams::default()
            }
            .costs();
            for axis in 0..3 {
                let sah = AxisSah::new(&bounds, axis, &costs).unwrap();
                let (lo, hi) = (sah.lo, sah.hi);
                let pos = [lo, hi, (lo + hi) * 0.5, lo + (hi - lo) * 0.1];
                for (nb, na) in [
                    ([0, 1, 5, 9], [9, 0, 3, 1]),
                    ([2, 7, 0, 13], [0, 0, 4, 8]),
                    ([1 << 40, 4095, 4097, (1 << 52) - 1], [3, 1 << 33, 12, 1]),
                ] {
                    let f = |v: [usize; 4]| f64x4::from(v.map(|n| n as f64));
                    let p4 = f64x4::from(pos.map(f64::from));
                    let four = sah.cost4(p4, f(nb), f(na)).to_array();
                    for i in 0..4 {
                        assert_eq!(four[i].to_bits(), sah.cost(pos[i], nb[i], na[i]).to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn a_key_gives_back_its_event() {
        for pos in [0.0, -0.0, 1.5, -1.5, f32::MIN_POSITIVE, -3e38, 3e38, 1e-42] {
            for kind in [END, PLANAR, START] {
                let e = Event { pos, prim: 7, kind };
                let back = Event::from_key(e.key(), 7);
                assert_eq!(back.pos.to_bits(), pos.to_bits());
                assert_eq!(back.kind, kind);
            }
        }
    }
}
