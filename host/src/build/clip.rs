//! Perfect splits: the bounds of a primitive's part inside a box (Havran 2000, §4.4; Wald &
//! Havran 2006, §4.3 "split clipping").
//!
//! Triangles are clipped in f64 by Sutherland–Hodgman against the box's six planes and the
//! polygon's bounds rounded outward to f32, so a triangle is never lost to rounding: the f32 box
//! always contains the exact clipped part. Spheres use their bounding box cut by the box
//! (conservative, not tight).

use glam::{DVec3, Vec3};

/// An axis-aligned box in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box around some points.
    pub fn around(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| Aabb {
            min: b.min.min(p),
            max: b.max.max(p),
        })
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Surface area, in f64 to keep the SAH's ratios exact enough on flat boxes.
    pub fn area(&self) -> f64 {
        let d = (self.max - self.min).as_dvec3().max(DVec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The box with `max[axis]` (below) or `min[axis]` (above) moved to `split`.
    pub fn split(&self, axis: usize, split: f32) -> (Aabb, Aabb) {
        let (mut below, mut above) = (*self, *self);
        below.max[axis] = split;
        above.min[axis] = split;
        (below, above)
    }
}

/// Largest f32 ≤ `x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// Smallest f32 ≥ `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// The f32 bounds of the part of triangle `tri` inside `bounds`, or `None` when the exact f64
/// clip leaves nothing.
pub fn clip_triangle(tri: &[Vec3; 3], bounds: &Aabb) -> Option<Aabb> {
    // Sutherland–Hodgman: a triangle clipped by 6 half-spaces has at most 9 vertices in exact
    // arithmetic. In f64 an intersection point can land a rounding off an earlier plane, and the
    // polygon is then not quite convex: with coordinates spanning some 70 orders of magnitude
    // (found by the `obj` fuzz target), a plane can cross it more than twice. Past the capacity
    // the clip gives up for the triangle's whole box cut by `bounds`: larger than the clipped
    // part, so still a correct (only less tight) bound.
    const CAP: usize = 16;
    let fallback = || {
        let b = Aabb::around(tri).intersection(bounds);
        (!b.is_empty()).then_some(b)
    };
    let mut poly = [DVec3::ZERO; CAP];
    let mut next = [DVec3::ZERO; CAP];
    for (dst, src) in poly.iter_mut().zip(tri) {
        *dst = src.as_dvec3();
    }
    let mut n = 3;
    // A plane the whole triangle is inside of leaves the polygon as it is: skip it (deep in the
    // tree a triangle crosses one or two of the cell's planes).
    let whole = Aabb::around(tri);
    for axis in 0..3 {
        for (limit, keep_below) in [
            (bounds.min[axis] as f64, false),
            (bounds.max[axis] as f64, true),
        ] {
            let crosses = if keep_below {
                whole.max[axis] as f64 > limit
            } else {
                (whole.min[axis] as f64) < limit
            };
            if !crosses {
                continue;
            }
            let inside = |p: &DVec3| {
                if keep_below {
                    p[axis] <= limit
                } else {
                    p[axis] >= limit
                }
            };
            let mut m = 0;
            for i in 0..n {
                if m + 2 > CAP {
                    return fallback();
                }
                let (a, b) = (poly[i], poly[(i + 1) % n]);
                let (ia, ib) = (inside(&a), inside(&b));
                if ia {
                    next[m] = a;
                    m += 1;
                }
                if ia != ib {
                    let s = (limit - a[axis]) / (b[axis] - a[axis]);
                    let mut p = a + (b - a) * s;
                    p[axis] = limit; // exactly on the plane, whatever the rounding of s
                    next[m] = p;
                    m += 1;
                }
            }
            n = m;
            if n == 0 {
                return None;
            }
            poly[..n].copy_from_slice(&next[..n]);
        }
    }
    let (lo, hi) = poly[..n]
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let out = Aabb {
        min: Vec3::new(round_down(lo.x), round_down(lo.y), round_down(lo.z)),
        max: Vec3::new(round_up(hi.x), round_up(hi.y), round_up(hi.z)),
    };
    Some(out.intersection(bounds))
}

/// The f32 bounds of the parts of triangle `tri` below and above the plane `axis = pos`, each
/// cut by `within` and by its side of the plane, or `None` for a side the triangle does not
/// reach. `within` must contain the part of the triangle that matters (its part inside the node,
/// whose box `within` already bounds): the result then bounds the part inside each child.
///
/// One plane instead of the cell's six (Embree's spatial splits split a reference's box this way,
/// Stich, Friedrich & Dietrich 2009, §4.1): the same box as [`clip_triangle`] when the triangle
/// crosses no other plane of the cell, a looser one when it also crosses the cell's walls. The
/// crossings are computed in f64 and rounded outward, as [`clip_triangle`] does.
pub fn split_triangle(
    tri: &[Vec3; 3],
    axis: usize,
    pos: f32,
    within: &Aabb,
) -> (Option<Aabb>, Option<Aabb>) {
    // One body per axis, so that no coordinate is picked at run time (in WebAssembly a jump
    // table at each of them).
    match axis {
        0 => split_on::<0>(tri, pos, within),
        1 => split_on::<1>(tri, pos, within),
        _ => split_on::<2>(tri, pos, within),
    }
}

/// [`split_triangle`] on axis `AXIS`.
#[inline]
fn split_on<const AXIS: usize>(
    tri: &[Vec3; 3],
    pos: f32,
    within: &Aabb,
) -> (Option<Aabb>, Option<Aabb>) {
    let axis = AXIS;
    let plane = pos as f64;
    let v = tri.map(|p| p.as_dvec3());
    let (mut lo_b, mut hi_b) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut lo_a, mut hi_a) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for i in 0..3 {
        let (a, b) = (v[i], v[(i + 1) % 3]);
        if a[axis] <= plane {
            (lo_b, hi_b) = (lo_b.min(a), hi_b.max(a));
        }
        if a[axis] >= plane {
            (lo_a, hi_a) = (lo_a.min(a), hi_a.max(a));
        }
        if (a[axis] < plane && b[axis] > plane) || (a[axis] > plane && b[axis] < plane) {
            let s = (plane - a[axis]) / (b[axis] - a[axis]);
            let mut p = a + (b - a) * s;
            p[axis] = plane; // exactly on the plane, whatever the rounding of s
            (lo_b, hi_b) = (lo_b.min(p), hi_b.max(p));
            (lo_a, hi_a) = (lo_a.min(p), hi_a.max(p));
        }
    }
    let side = |lo: DVec3, hi: DVec3, below: bool| {
        if lo.x > hi.x {
            return None;
        }
        let mut b = Aabb {
            min: Vec3::new(round_down(lo.x), round_down(lo.y), round_down(lo.z)),
            max: Vec3::new(round_up(hi.x), round_up(hi.y), round_up(hi.z)),
        }
        .intersection(within);
        if below {
            b.max[axis] = b.max[axis].min(pos);
        } else {
            b.min[axis] = b.min[axis].max(pos);
        }
        (!b.is_empty()).then_some(b)
    };
    (side(lo_b, hi_b, true), side(lo_a, hi_a, false))
}

/// The box of a sphere, cut by `bounds`, or `None` when they do not meet.
pub fn clip_sphere(center: Vec3, radius: f32, bounds: &Aabb) -> Option<Aabb> {
    let c = center.as_dvec3();
    let r = radius as f64;
    let lo = c - DVec3::splat(r);
    let hi = c + DVec3::splat(r);
    let b = Aabb {
        min: Vec3::new(round_down(lo.x), round_down(lo.y), round_down(lo.z)),
        max: Vec3::new(round_up(hi.x), round_up(hi.y), round_up(hi.z)),
    }
    .intersection(bounds);
    if b.is_empty() { None } else { Some(b) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipped_triangle_stays_inside_box_and_covers_the_part() {
        let tri = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(3.0, -1.0, 0.0),
            Vec3::new(-1.0, 3.0, 0.0),
        ];
        let b = Aabb {
            min: Vec3::new(0.0, 0.0, -1.0),
            max: Vec3::new(1.0, 1.0, 1.0),
        };
        let c = clip_triangle(&tri, &b).unwrap();
        assert_eq!(c.min, Vec3::new(0.0, 0.0, 0.0));
        assert_eq!(c.max, Vec3::new(1.0, 1.0, 0.0));
        // A corner of the box cut off by the hypotenuse x + y = 2.
        let b2 = Aabb {
            min: Vec3::new(0.5, 0.5, -1.0),
            max: Vec3::new(2.0, 2.0, 1.0),
        };
        let c2 = clip_triangle(&tri, &b2).unwrap();
        assert_eq!(c2.max.x, 1.5);
        assert_eq!(c2.max.y, 1.5);
        let far = Aabb {
            min: Vec3::new(5.0, 5.0, -1.0),
            max: Vec3::new(6.0, 6.0, 1.0),
        };
        assert!(clip_triangle(&tri, &far).is_none());
    }

    #[test]
    fn a_split_by_one_plane_bounds_each_side_and_is_the_clip_where_no_other_wall_is_crossed() {
        let tri = [
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(0.9, 0.3, 0.5),
            Vec3::new(0.4, 0.8, 0.7),
        ];
        let cell = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        // Inside the cell but for the plane: the same boxes as the exact clip.
        for (axis, pos) in [(0, 0.5), (1, 0.25), (2, 0.6)] {
            let within = clip_triangle(&tri, &cell).unwrap();
            let (b, a) = split_triangle(&tri, axis, pos, &within);
            let (below, above) = cell.split(axis, pos);
            assert_eq!(b, clip_triangle(&tri, &below), "axis {axis}");
            assert_eq!(a, clip_triangle(&tri, &above), "axis {axis}");
        }
        // Crossing another wall too: each side still contains the exact clip of its child cell.
        let small = Aabb {
            min: Vec3::new(0.3, 0.0, 0.0),
            max: Vec3::new(0.7, 0.5, 1.0),
        };
        let within = clip_triangle(&tri, &small).unwrap();
        let (b, a) = split_triangle(&tri, 1, 0.35, &within);
        let (below, above) = small.split(1, 0.35);
        for (got, cell) in [(b.unwrap(), below), (a.unwrap(), above)] {
            let exact = clip_triangle(&tri, &cell).unwrap();
            assert_eq!(got.union(&exact), got, "{got:?} contains {exact:?}");
            assert_eq!(got.intersection(&cell), got, "{got:?} inside {cell:?}");
        }
        // A plane the triangle does not reach leaves one side empty.
        let (b, a) = split_triangle(&tri, 0, 0.05, &within);
        assert!(b.is_none() && a.is_some());
    }

    #[test]
    fn outward_rounding_never_shrinks() {
        let x = 0.1f64;
        assert!((round_down(x) as f64) <= x && (round_up(x) as f64) >= x);
        assert_eq!(round_down(1.0), 1.0);
        assert_eq!(round_up(1.0), 1.0);
    }
}
