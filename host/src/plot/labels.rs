//! Where the labels of a scatter plot go: beside their own point, clear of every point and of
//! every label already placed, so that a label can neither hide a point nor sit next to a point
//! it does not belong to. A greedy search over candidate positions at growing distances (the
//! simple end of the point-feature label placement problem; Christensen, Marks & Shieber, "An
//! empirical study of algorithms for point-feature label placement", ACM TOG 14(3), 1995): near
//! the point first, farther out (with a leader line back to it) only where the near ones are taken.

/// An axis-aligned box in pixels: left, top, right, bottom (right and bottom exclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub left: i32,
    pub top: i32,
    pub right: i32,
    pub bottom: i32,
}

impl Rect {
    /// The box of `(w, h)` pixels whose top-left corner is `(x, y)`.
    pub fn at(x: i32, y: i32, (w, h): (u32, u32)) -> Self {
        Self {
            left: x,
            top: y,
            right: x + w as i32,
            bottom: y + h as i32,
        }
    }

    /// The box around a point marker of `radius` pixels at `(x, y)`.
    pub fn around((x, y): (i32, i32), radius: i32) -> Self {
        Self {
            left: x - radius,
            top: y - radius,
            right: x + radius + 1,
            bottom: y + radius + 1,
        }
    }

    pub fn overlaps(&self, o: &Rect) -> bool {
        self.left < o.right && o.left < self.right && self.top < o.bottom && o.top < self.bottom
    }

    fn inside(&self, o: &Rect) -> bool {
        self.left >= o.left && self.right <= o.right && self.top >= o.top && self.bottom <= o.bottom
    }

    /// The box grown by `dx` pixels left and right and `dy` up and down.
    fn grown(&self, dx: i32, dy: i32) -> Self {
        Self {
            left: self.left - dx,
            top: self.top - dy,
            right: self.right + dx,
            bottom: self.bottom + dy,
        }
    }

    /// The squared distance from `(x, y)` to the nearest point of the box.
    pub fn distance2(&self, (x, y): (i32, i32)) -> i64 {
        let dx = i64::from((self.left - x).max(x - self.right).max(0));
        let dy = i64::from((self.top - y).max(y - self.bottom).max(0));
        dx * dx + dy * dy
    }
}

/// A label's place: the top-left corner of its text, and whether it is far enough from its point
/// to need a leader line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placed {
    pub x: i32,
    pub y: i32,
    pub leader: bool,
}

/// The point markers' radius in pixels, with a margin that keeps text off them.
pub const MARKER: i32 = 7;

/// The least space between two labels, in pixels (horizontal, vertical): two labels that touch
/// read as one ("x4, 9.76% lostscalar, 9.76% lost", seen before this gap).
const GAP: (i32, i32) = (8, 2);

/// Gaps, in pixels, between a point and its label's nearest edge that are tried in turn: the
/// first is "beside the point", the others need a leader line.
const DISTANCES: [i32; 6] = [2, 14, 28, 44, 64, 90];

/// Places one label of `size` pixels for each point of `points` (pixel positions), inside
/// `bounds` and off the boxes in `blocked` (a legend), in order: each at the first candidate
/// position — right, left, above, below, then the diagonals, at growing distances — whose box
/// touches no point marker and no label placed before it. A label with no free candidate goes right of its point over whatever is there
/// (never seen in the reports' figures; the tests check that their layouts need none).
pub fn place(
    points: &[(i32, i32)],
    sizes: &[(u32, u32)],
    bounds: Rect,
    blocked: &[Rect],
) -> Vec<Placed> {
    let markers: Vec<Rect> = points.iter().map(|&p| Rect::around(p, MARKER)).collect();
    let mut taken: Vec<Rect> = blocked.to_vec();
    let mut out = Vec::with_capacity(points.len());
    for (&(px, py), &(w, h)) in points.iter().zip(sizes) {
        let (wi, hi) = (w as i32, h as i32);
        let candidates = DISTANCES.iter().flat_map(|&d| {
            let r = MARKER + d;
            [
                (px + r, py - hi / 2),      // right
                (px - r - wi, py - hi / 2), // left
                (px - wi / 2, py - r - hi), // above
                (px - wi / 2, py + r),      // below
                (px + r, py - r - hi),      // above right
                (px + r, py + r),           // below right
                (px - r - wi, py - r - hi), // above left
                (px - r - wi, py + r),      // below left
            ]
            .map(move |(x, y)| (x, y, d))
        });
        let free = candidates
            .map(|(x, y, d)| (Rect::at(x, y, (w, h)), d))
            .find(|&(r, d)| {
                // Beside its point (no leader line), a label must be nearer to it than to any
                // other point, or it reads as another point's.
                let own = r.distance2((px, py));
                let unambiguous = d > DISTANCES[0]
                    || points
                        .iter()
                        .all(|&p| p == (px, py) || r.distance2(p) > own);
                r.inside(&bounds)
                    && unambiguous
                    && !markers.iter().any(|m| m.overlaps(&r))
                    && !taken.iter().any(|t| t.grown(GAP.0, GAP.1).overlaps(&r))
            });
        let (rect, d) = free.unwrap_or((Rect::at(px + MARKER + 2, py - hi / 2, (w, h)), 0));
        taken.push(rect);
        out.push(Placed {
            x: rect.left,
            y: rect.top,
            leader: d > DISTANCES[0],
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(points: &[(i32, i32)], sizes: &[(u32, u32)], bounds: Rect) {
        let placed = place(points, sizes, bounds, &[]);
        let rects: Vec<Rect> = placed
            .iter()
            .zip(sizes)
            .map(|(p, &s)| Rect::at(p.x, p.y, s))
            .collect();
        for (i, r) in rects.iter().enumerate() {
            assert!(r.inside(&bounds), "label {i} leaves the plot: {r:?}");
            for (j, p) in points.iter().enumerate() {
                assert!(
                    !r.overlaps(&Rect::around(*p, MARKER)),
                    "label {i} covers point {j}"
                );
            }
            for (j, o) in rects.iter().enumerate().take(i) {
                assert!(
                    !r.overlaps(&o.grown(GAP.0, GAP.1)),
                    "labels {i} and {j} collide or touch"
                );
            }
            // Its own point is the nearest to the label's box of all points, unless it needed a
            // leader line (which then shows where it belongs).
            if !placed[i].leader {
                let own = r.distance2(points[i]);
                for (j, p) in points.iter().enumerate() {
                    assert!(
                        j == i || r.distance2(*p) > own,
                        "label {i} is as near point {j}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_lone_point_gets_its_label_at_its_right() {
        let bounds = Rect::at(0, 0, (400, 300));
        let placed = place(&[(100, 100)], &[(60, 14)], bounds, &[]);
        assert_eq!(
            placed,
            [Placed {
                x: 100 + MARKER + 2,
                y: 93,
                leader: false
            }]
        );
    }

    #[test]
    fn crowded_points_get_labels_that_cover_nothing() {
        // The `seams` panel's cluster: Möller–Trumbore and sphere points a few pixels apart, with
        // the long "x4, 9.76% lost" labels that once landed beside the sphere's points.
        let points = [
            (180, 200),
            (150, 200),
            (140, 200),
            (250, 60),
            (170, 300),
            (182, 230),
            (152, 232),
            (141, 231),
            (240, 300),
            (188, 205),
        ];
        let sizes = [
            (110, 14),
            (95, 14),
            (95, 14),
            (40, 14),
            (80, 14),
            (45, 14),
            (30, 14),
            (30, 14),
            (80, 14),
            (45, 14),
        ];
        check(&points, &sizes, Rect::at(60, 20, (560, 420)));
    }

    #[test]
    fn a_label_near_the_edge_stays_inside() {
        let bounds = Rect::at(0, 0, (300, 200));
        check(&[(295, 5), (5, 195)], &[(80, 14), (80, 14)], bounds);
    }
}
