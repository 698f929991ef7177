//! Split events and the SAH sweep of Wald & Havran 2006, "On building fast kd-Trees for Ray
//! Tracing, and on doing that in O(N log N)", §4.2–4.3.
//!
//! Each primitive's (clipped) box gives, on each axis, a START and an END event, or one PLANAR
//! event when the box is flat on that axis. Lists are sorted once by `(position, kind)` with
//! END < PLANAR < START, and kept sorted by the split step, so one linear sweep per axis finds the
//! best plane.

use super::clip::Aabb;

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

/// Merges two sorted lists.
pub fn merge(a: Vec<Event>, b: Vec<Event>) -> Vec<Event> {
    if b.is_empty() {
        return a;
    }
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if b[j].key() < a[i].key() {
            out.push(b[j]);
            j += 1;
        } else {
            out.push(a[i]);
            i += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// SAH cost constants (pbrt-v3's `KdTreeAccel` parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Costs {
    pub traversal: f64,
    pub intersect: f64,
    pub empty_bonus: f64,
}

/// The best plane found: axis, position, cost, and whether planar primitives go below.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    pub axis: usize,
    pub pos: f32,
    pub cost: f64,
    pub planar_below: bool,
}

/// The SAH cost of splitting `bounds` on `axis` at `pos` with `nb` primitives below and `na`
/// above: `Kt + Ki·(1 − bonus)·(P_b·n_b + P_a·n_a)`, the bonus applying when a side is empty
/// (pbrt-v3 §4.4.2, after MacDonald & Booth 1990).
fn sah(
    costs: &Costs,
    bounds: &Aabb,
    inv_area: f64,
    axis: usize,
    pos: f32,
    nb: usize,
    na: usize,
) -> f64 {
    let (below, above) = bounds.split(axis, pos);
    let (pb, pa) = (below.area() * inv_area, above.area() * inv_area);
    let bonus = if nb == 0 || na == 0 {
        costs.empty_bonus
    } else {
        0.0
    };
    costs.traversal + costs.intersect * (1.0 - bonus) * (pb * nb as f64 + pa * na as f64)
}

/// One sweep over a sorted event list of `axis`: the best split strictly inside `bounds`.
pub fn best_split_on_axis(
    events: &[Event],
    n: usize,
    bounds: &Aabb,
    axis: usize,
    costs: &Costs,
) -> Option<Split> {
    let inv_area = 1.0 / bounds.area();
    if !inv_area.is_finite() {
        return None;
    }
    let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
    let mut best: Option<Split> = None;
    let (mut nb, mut na) = (0usize, n);
    let mut i = 0;
    while i < events.len() {
        let pos = events[i].pos;
        let mut counts = [0usize; 3];
        for kind in [END, PLANAR, START] {
            while i < events.len() && events[i].pos == pos && events[i].kind == kind {
                counts[kind as usize] += 1;
                i += 1;
            }
        }
        let [ends, planars, starts] = counts;
        na -= ends + planars;
        if pos > lo && pos < hi {
            let below = sah(costs, bounds, inv_area, axis, pos, nb + planars, na);
            let above = sah(costs, bounds, inv_area, axis, pos, nb, na + planars);
            let (cost, planar_below) = if below <= above {
                (below, true)
            } else {
                (above, false)
            };
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
