//! Scalar kd-tree traversal, closest hit and any hit, with a fixed stack: pbrt-v3's
//! `KdTreeAccel::Intersect` (PBR 3rd ed., §4.4.3), with the cases it leaves to chance made exact.
//!
//! Deviations from pbrt-v3, each for a case it gets wrong or leaves undefined:
//! - near and far children follow the sign of the direction, not the side of the origin, and the
//!   split interval is clipped on both ends, so rays with `tmin < 0` are traced correctly (pbrt-v3
//!   assumes `tmin = 0` in its `tPlane <= 0` test); this is also exactly the rule of the packet
//!   traversal, so the two visit the same leaves;
//! - a direction component of `±0` gives `t_plane = ±∞`, so a ray parallel to a split plane
//!   visits only the side holding its origin, or, when the origin lies on the plane (`0 · ∞ =
//!   NaN`), both sides;
//! - the root box is entered with an explicit per-axis test for zero components and a far distance
//!   widened by `2γ₃` of its magnitude (pbrt-v3's robust `Bounds3::IntersectP`), so a ray grazing the box is
//!   not lost to rounding;
//! - non-finite rays are a miss before any arithmetic, so nothing can loop on NaN.
//!
//! Straddling primitives: a primitive in several leaves may be hit in an earlier leaf at a `t`
//! beyond that leaf's range. The hit is kept as a candidate, and a pending node is skipped only
//! when the closest candidate lies before its entry; so the reported hit is always the closest
//! (the argument of pbrt-v3's `ray.tMax < tMin` test, which stops the whole walk instead).

use crate::format::{MAX_DEPTH, Scene, contents};
use crate::ray::{Hit, Ray};
use glam::Vec3;

/// `γ₃ = 3ε / (1 − 3ε)`, with ε half an f32 ULP (PBR 3rd ed., §3.9.1).
pub(crate) const GAMMA3: f32 = 3.0 * (f32::EPSILON * 0.5) / (1.0 - 3.0 * (f32::EPSILON * 0.5));

/// A compile-time choice of which primitive kinds a kernel handles, so that a triangles-only
/// scene runs no sphere code (and firmware naming one variant links only it).
pub trait Contents {
    const TRIANGLES: bool;
    const SPHERES: bool;
}

/// Triangles only.
pub struct Triangles;
/// Spheres only.
pub struct Spheres;
/// Triangles and spheres.
pub struct Mixed;

impl Contents for Triangles {
    const TRIANGLES: bool = true;
    const SPHERES: bool = false;
}
impl Contents for Spheres {
    const TRIANGLES: bool = false;
    const SPHERES: bool = true;
}
impl Contents for Mixed {
    const TRIANGLES: bool = true;
    const SPHERES: bool = true;
}

/// The parametric interval `(t0, t1)` in which `ray` is inside the box, clipped to the ray's own
/// range, or `None`.
#[inline]
#[allow(clippy::needless_range_loop)]
pub fn clip_to_box(ray: &Ray, bounds: [Vec3; 2]) -> Option<(f32, f32)> {
    let mut t0 = ray.tmin;
    let mut t1 = ray.tmax;
    for axis in 0..3 {
        let (o, d) = (ray.origin[axis], ray.dir[axis]);
        let (lo, hi) = (bounds[0][axis], bounds[1][axis]);
        // (indexing three Vec3s by axis reads better than zipping their arrays)
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d;
        let (mut near, mut far) = ((lo - o) * inv, (hi - o) * inv);
        if near > far {
            core::mem::swap(&mut near, &mut far);
        }
        // Away from the origin's side whatever the sign (pbrt-v3 multiplies, which narrows the
        // slab when `far < 0`, possible with `tmin < 0`).
        far += far.abs() * (2.0 * GAMMA3);
        t0 = t0.max(near);
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

/// Relative slack on a node's entry distance before the closest hit may rule the node out.
///
/// A split plane's `t` and Möller–Trumbore's `t` of a triangle lying on (or touching) that plane
/// are both correctly computed to a few ULPs, but not to the same bits: the triangle's hit can come
/// out below the plane's `t`. Without slack, a closer hit on a triangle in the plane of the far
/// child is skipped in favour of a farther one found in the near child (found by the
/// brute-force property test). 2⁻¹⁸ is 32 ULPs, far more than either rounding error; it only
/// makes traversal visit a node it could have skipped when two hits lie that close.
pub const ENTRY_SLACK: f32 = 1.0 / (1 << 18) as f32;

/// `tmin` moved towards −∞ by [`ENTRY_SLACK`] of its magnitude.
#[inline(always)]
pub fn entry_with_slack(tmin: f32) -> f32 {
    tmin - tmin.abs() * ENTRY_SLACK
}

/// One pending far child: node index and its `(tmin, tmax)`.
type StackItem = (u32, f32, f32);

impl Scene<'_> {
    /// The closest hit along `ray` in `(ray.tmin, ray.tmax)`, or [`Hit::MISS`]. Picks the kernel
    /// monomorphized for the scene's contents.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Hit {
        match self.contents() & (contents::TRIANGLES | contents::SPHERES) {
            contents::TRIANGLES => self.intersect_with::<Triangles>(ray),
            contents::SPHERES => self.intersect_with::<Spheres>(ray),
            _ => self.intersect_with::<Mixed>(ray),
        }
    }

    /// Whether anything lies along `ray` in `(ray.tmin, ray.tmax)` (shadow rays).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match self.contents() & (contents::TRIANGLES | contents::SPHERES) {
            contents::TRIANGLES => self.occluded_with::<Triangles>(ray),
            contents::SPHERES => self.occluded_with::<Spheres>(ray),
            _ => self.occluded_with::<Mixed>(ray),
        }
    }

    /// Tests one primitive against `ray`, returning `(t, u, v)`.
    #[inline(always)]
    pub fn intersect_prim<C: Contents>(&self, prim: u32, ray: &Ray) -> Option<(f32, f32, f32)> {
        let n_tris = self.tri_count();
        if C::SPHERES && (!C::TRIANGLES || prim >= n_tris) {
            return self
                .sphere(prim - n_tris)
                .intersect(ray)
                .map(|t| (t, 0.0, 0.0));
        }
        let (tri, min_det2) = self.prepared_triangle(prim);
        tri.intersect_prepared(ray, min_det2)
    }

    /// [`Scene::intersect`] for a fixed [`Contents`]; the caller promises the scene holds no other
    /// kind of primitive (it would be tested as the wrong kind, never out of bounds).
    pub fn intersect_with<C: Contents>(&self, ray: &Ray) -> Hit {
        let mut best = Hit::MISS;
        let mut query = *ray;
        self.walk(ray, |scene, prims, _| {
            for &prim in prims {
                if let Some((t, u, v)) = scene.intersect_prim::<C>(prim, &query) {
                    query.tmax = t;
                    best = Hit { t, prim, u, v };
                }
            }
            (query.tmax, false)
        });
        best
    }

    /// [`Scene::occluded`] for a fixed [`Contents`].
    pub fn occluded_with<C: Contents>(&self, ray: &Ray) -> bool {
        let mut found = false;
        self.walk(ray, |scene, prims, _| {
            found = prims
                .iter()
                .any(|&prim| scene.intersect_prim::<C>(prim, ray).is_some());
            (ray.tmax, found)
        });
        found
    }

    /// The front-to-back walk shared by both queries. `visit(scene, leaf_prims, (tmin, tmax))`
    /// returns the closest candidate's `t` so far and whether to stop at once.
    #[inline(always)]
    fn walk<F>(&self, ray: &Ray, mut visit: F)
    where
        F: FnMut(&Self, &[u32], (f32, f32)) -> (f32, bool),
    {
        if !ray.is_finite() {
            return;
        }
        let Some((mut tmin, mut tmax)) = clip_to_box(ray, self.bounds()) else {
            return;
        };
        let inv_dir = ray.dir.recip();
        let mut best_t = ray.tmax;
        let mut stack: heapless::Vec<StackItem, MAX_DEPTH> = heapless::Vec::new();
        let mut index = 0u32;
        loop {
            let node = self.node(index);
            // A node entered beyond the closest hit so far is skipped, not a reason to stop: a
            // ray lying in a split plane pushes both children with the same interval, so the
            // stack is not always ordered by entry distance. The entry is lowered by
            // `ENTRY_SLACK` first, see there.
            let beyond = best_t < entry_with_slack(tmin);
            if beyond || node.is_leaf() {
                if !beyond {
                    let prims = self.leaf_prims(&node);
                    let (t, stop) = visit(self, prims.as_slice(), (tmin, tmax));
                    best_t = t;
                    if stop {
                        return;
                    }
                }
                match stack.pop() {
                    Some((next, a, b)) => (index, tmin, tmax) = (next, a, b),
                    None => return,
                }
                continue;
            }
            let axis = node.axis();
            let t_plane = (node.split() - ray.origin[axis]) * inv_dir[axis];
            // Near and far by the direction's sign (the sign of 1/d, so −0 counts as negative):
            // for d > 0 the below child holds the ray for t < t_plane. A NaN t_plane (origin on
            // the plane, direction parallel to it) visits both children with the same interval.
            let [below_empty, above_empty] = node.empty_children();
            let ((near, near_empty), (far, far_empty)) = if inv_dir[axis] < 0.0 {
                ((node.above_child(), above_empty), (index + 1, below_empty))
            } else {
                ((index + 1, below_empty), (node.above_child(), above_empty))
            };
            // An empty child is never entered: the split only clips the interval.
            let visit_near = !(t_plane < tmin) && !near_empty;
            let visit_far = !(t_plane > tmax) && !far_empty;
            // Validation bounds the tree's depth by MAX_DEPTH, and at most one item per level is
            // pending, so the push cannot fail.
            match (visit_near, visit_far) {
                (true, true) => {
                    let _ = stack.push((far, tmin.max(t_plane), tmax));
                    tmax = tmax.min(t_plane);
                    index = near;
                }
                (true, false) => {
                    tmax = tmax.min(t_plane);
                    index = near;
                }
                (false, true) => {
                    tmin = tmin.max(t_plane);
                    index = far;
                }
                (false, false) => match stack.pop() {
                    Some((next, a, b)) => (index, tmin, tmax) = (next, a, b),
                    None => return,
                },
            }
        }
    }
}
