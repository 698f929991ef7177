//! The single-ray walk over the binary nodes as resumable steps over an explicit state: the
//! one-ray walk ([`super::single`]: [`Scene::intersect`], [`Scene::occluded`], when the scene has
//! no wide nodes) runs them to the end, and code that drives a walk itself — counting its steps
//! (`kdray trace --counts`), a custom query at the leaves (the host's crossing counts) — runs the
//! same steps, so it visits the same leaves in the same order and finds the same hits, ties
//! between primitives included.
//!
//! A step is one node: an interior node's plane decision, or a leaf's tests, then the next node
//! (a child or a pending node from the stack).
//!
//! (Until format 12 a step could also end by prefetching the node or leaf data its ray read
//! next, for a walk that kept 4 to 16 rays in flight; the wide walk made it pointless:
//! docs/BENCHMARKS.md, "Retired: blocks and interleaved walks".)

use super::{Contents, entry_interval, entry_with_slack, widen};
use crate::format::{LeafPrims, MAX_DEPTH, Scene};
use crate::group::WIDTH;
use crate::ray::{Hit, Ray};
use crate::simd::group::{GroupLanes, Pair, closest_in_group, intersect_group_watertight};
use crate::simd::kernels::PrimHits;
use crate::watertight::{self, Shear};
use glam::Vec3;

/// One pending far child: node index and its `(tmin, tmax)`.
type StackItem = (u32, f32, f32);

/// What a walk does at a leaf: the query it answers for one ray.
pub trait Query {
    /// Tests a leaf's primitives; returns the closest candidate's `t` so far (the walk skips a
    /// pending node entered beyond it) and whether to stop at once.
    fn leaf<C: Contents>(&mut self, scene: &Scene, prims: LeafPrims) -> (f32, bool);
}

/// The closest-hit query: the hit so far, and the ray with `tmax` shrunk to it.
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    query: Ray,
    best: Hit,
    shear: Shear,
}

impl Closest {
    /// A query along `ray` with no hit yet, for contents `C` (the shear only if watertight).
    #[inline(always)]
    pub fn new<C: Contents>(ray: &Ray) -> Self {
        Self {
            query: *ray,
            best: Hit::MISS,
            shear: shear_for::<C>(ray),
        }
    }

    /// The closest hit found ([`Hit::MISS`] if none).
    #[inline(always)]
    pub fn hit(&self) -> Hit {
        self.best
    }
}

impl Query for Closest {
    #[inline(always)]
    fn leaf<C: Contents>(&mut self, scene: &Scene, prims: LeafPrims) -> (f32, bool) {
        if C::GROUPS {
            if let LeafPrims::Groups(groups) = prims {
                // Two groups at a time in the eight lanes, the last one alone.
                let mut pairs = groups.chunks_exact(2);
                for p in &mut pairs {
                    self.group::<C, _>(Pair(&p[0], &p[1]));
                }
                if let [g] = pairs.remainder() {
                    self.group::<C, _>(g);
                }
                return (self.query.tmax, false);
            }
            if let LeafPrims::Many(ids) = prims {
                // A listed leaf's triangles gathered from the triangles section, eight at a
                // time in two groups, the last four or fewer in one.
                for ids in ids.chunks(2 * WIDTH) {
                    if ids.len() > WIDTH {
                        self.group::<C, _>(scene.gather8(ids));
                    } else {
                        self.group::<C, _>(scene.gather4(ids));
                    }
                }
                return (self.query.tmax, false);
            }
        }
        self.one_by_one::<C>(scene, prims)
    }
}

impl Closest {
    /// The triangles of `g`: a group, or a pair of groups.
    #[inline(always)]
    fn group<C: Contents, G: GroupLanes>(&mut self, g: G) {
        let found = intersect_group::<C, _>(g, &self.query, &self.shear);
        if let Some((t, u, v, prim)) = closest_in_group(g, &found) {
            self.query.tmax = t;
            self.best = Hit { t, prim, u, v };
        }
    }

    /// A leaf's primitives one at a time.
    #[inline(always)]
    fn one_by_one<C: Contents>(&mut self, scene: &Scene, prims: LeafPrims) -> (f32, bool) {
        for &prim in prims.listed() {
            if let Some((t, u, v)) =
                scene.intersect_prim_sheared::<C>(prim, &self.query, &self.shear)
            {
                self.query.tmax = t;
                self.best = Hit { t, prim, u, v };
            }
        }
        (self.query.tmax, false)
    }
}

/// The any-hit query (shadow rays): stops at the first primitive hit in the ray's interval.
#[derive(Clone, Copy, Debug)]
pub struct Occlusion {
    ray: Ray,
    shear: Shear,
    found: bool,
}

impl Occlusion {
    /// A query along `ray`, nothing found yet, for contents `C`.
    #[inline(always)]
    pub fn new<C: Contents>(ray: &Ray) -> Self {
        Self {
            ray: *ray,
            shear: shear_for::<C>(ray),
            found: false,
        }
    }

    /// Whether anything was found.
    #[inline(always)]
    pub fn found(&self) -> bool {
        self.found
    }
}

impl Query for Occlusion {
    #[inline(always)]
    fn leaf<C: Contents>(&mut self, scene: &Scene, prims: LeafPrims) -> (f32, bool) {
        let (ray, shear) = (&self.ray, &self.shear);
        if C::GROUPS {
            if let LeafPrims::Groups(groups) = prims {
                let mut pairs = groups.chunks_exact(2);
                self.found = pairs.any(|p| {
                    intersect_group::<C, _>(Pair(&p[0], &p[1]), ray, shear)
                        .mask
                        .any()
                }) || pairs
                    .remainder()
                    .iter()
                    .any(|g| intersect_group::<C, _>(g, ray, shear).mask.any());
                return (self.ray.tmax, self.found);
            }
            if let LeafPrims::Many(ids) = prims {
                self.found = ids.chunks(2 * WIDTH).any(|ids| {
                    if ids.len() > WIDTH {
                        intersect_group::<C, _>(scene.gather8(ids), ray, shear)
                            .mask
                            .any()
                    } else {
                        intersect_group::<C, _>(scene.gather4(ids), ray, shear)
                            .mask
                            .any()
                    }
                });
                return (self.ray.tmax, self.found);
            }
        }
        self.found = prims.listed().iter().any(|&prim| {
            scene
                .intersect_prim_sheared::<C>(prim, ray, shear)
                .is_some()
        });
        (self.ray.tmax, self.found)
    }
}

/// What a step left to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The walk has ended.
    Done,
    /// The walk goes on at the next step.
    More,
}

/// A node layout's single-ray walk, as resumable steps.
pub trait Stepper {
    /// One ray's walk in progress.
    type State;
    /// A state to start from (its contents are overwritten by [`Stepper::begin`]).
    fn empty_state() -> Self::State;
    /// Starts the walk of `ray` in `state`; false when there is nothing to walk (a non-finite ray,
    /// or one missing the scene's box), and the query's answer is its initial one.
    fn begin<C: Contents>(&self, ray: &Ray, state: &mut Self::State) -> bool;
    /// Runs one step.
    fn step<C: Contents, Q: Query>(&self, state: &mut Self::State, query: &mut Q) -> Progress;
}

/// The kd-tree walk's state for one ray: the ray's origin and reciprocal direction, the node and
/// interval it is at, the closest candidate so far, and its pending far children.
#[derive(Clone, Debug)]
pub struct WalkState {
    origin: Vec3,
    inv_dir: Vec3,
    index: u32,
    tmin: f32,
    tmax: f32,
    best_t: f32,
    stack: heapless::Vec<StackItem, MAX_DEPTH>,
}

impl WalkState {
    /// A state holding no walk.
    pub const EMPTY: Self = Self {
        origin: Vec3::ZERO,
        inv_dir: Vec3::ZERO,
        index: 0,
        tmin: 0.0,
        tmax: 0.0,
        best_t: 0.0,
        stack: heapless::Vec::new(),
    };

    /// Continues with the next pending node, or ends (false).
    #[inline(always)]
    fn pop(&mut self) -> bool {
        match self.stack.pop() {
            Some((next, a, b)) => {
                (self.index, self.tmin, self.tmax) = (next, a, b);
                true
            }
            None => false,
        }
    }
}

impl Stepper for Scene<'_> {
    type State = WalkState;

    #[inline(always)]
    fn empty_state() -> WalkState {
        WalkState::EMPTY
    }

    /// Clips the ray to the scene's box (both slab distances widened outward with
    /// [`Contents::CONSERVATIVE`]) and starts at the root.
    #[inline(always)]
    fn begin<C: Contents>(&self, ray: &Ray, s: &mut WalkState) -> bool {
        let Some((tmin, tmax)) = entry_interval::<C>(ray, self.bounds()) else {
            return false;
        };
        s.origin = ray.origin;
        s.inv_dir = ray.dir.recip();
        (s.index, s.tmin, s.tmax, s.best_t) = (0, tmin, tmax, ray.tmax);
        s.stack.clear();
        true
    }

    /// One node of the front-to-back walk (the argument is in [`crate::traverse`]'s module doc).
    ///
    /// With [`Contents::CONSERVATIVE`] (both modes since issue 39) every split-plane distance is
    /// [`widen`]ed: the near child's interval ends at the upper bound of the exact distance, the
    /// far child's starts at the lower bound, and each child is entered if the bracket reaches its
    /// side. Every interval then contains the exact one (by induction from the root box, clipped
    /// the same way), so a cell the ray really passes through, if only at one point (a vertex on
    /// two split planes), is never skipped. Without it, the two rounded distances of planes that
    /// the ray crosses at one point can cross over, and the cell between them is dropped
    /// (docs/ROBUSTNESS.md counts the rays this loses).
    #[inline(always)]
    fn step<C: Contents, Q: Query>(&self, s: &mut WalkState, q: &mut Q) -> Progress {
        let node = self.node(s.index);
        // A node entered beyond the closest hit so far is skipped, not a reason to stop: a ray
        // lying in a split plane pushes both children with the same interval, so the stack is not
        // always ordered by entry distance. The entry is lowered by `ENTRY_SLACK` first, see there.
        let beyond = s.best_t < entry_with_slack(s.tmin);
        if beyond || node.is_leaf() {
            if !beyond {
                let (t, stop) = q.leaf::<C>(self, self.leaf_prims(&node));
                s.best_t = t;
                if stop {
                    return Progress::Done;
                }
            }
            return next_pending(s);
        }
        let axis = node.axis();
        let t_plane = (node.split() - s.origin[axis]) * s.inv_dir[axis];
        // The near child ends, the far child starts, at the plane (its bracket, if conservative).
        let (far_start, near_end) = if C::CONSERVATIVE {
            widen(t_plane)
        } else {
            (t_plane, t_plane)
        };
        // Near and far by the direction's sign (the sign of 1/d, so −0 counts as negative): for
        // d > 0 the below child holds the ray for t < t_plane. A NaN t_plane (origin on the plane,
        // direction parallel to it) visits both children with the same interval.
        let [below_empty, above_empty] = node.empty_children();
        let ((near, near_empty), (far, far_empty)) = if s.inv_dir[axis] < 0.0 {
            (
                (node.above_child(), above_empty),
                (s.index + 1, below_empty),
            )
        } else {
            (
                (s.index + 1, below_empty),
                (node.above_child(), above_empty),
            )
        };
        // An empty child is never entered: the split only clips the interval.
        let visit_near = !(near_end < s.tmin) && !near_empty;
        let visit_far = !(far_start > s.tmax) && !far_empty;
        // Validation bounds the tree's depth by MAX_DEPTH, and at most one item per level is
        // pending, so the push cannot fail.
        match (visit_near, visit_far) {
            (true, true) => {
                let _ = s.stack.push((far, s.tmin.max(far_start), s.tmax));
                s.tmax = s.tmax.min(near_end);
                s.index = near;
            }
            (true, false) => {
                s.tmax = s.tmax.min(near_end);
                s.index = near;
            }
            (false, true) => {
                s.tmin = s.tmin.max(far_start);
                s.index = far;
            }
            (false, false) => return next_pending(s),
        }
        Progress::More
    }
}

/// Pops the next pending node, or ends the walk.
#[inline(always)]
fn next_pending(s: &mut WalkState) -> Progress {
    if s.pop() {
        Progress::More
    } else {
        Progress::Done
    }
}

impl Scene<'_> {
    /// Tests one primitive against `ray` given the ray's [`Shear`] (unused unless watertight).
    #[inline(always)]
    pub(crate) fn intersect_prim_sheared<C: Contents>(
        &self,
        prim: u32,
        ray: &Ray,
        shear: &Shear,
    ) -> Option<(f32, f32, f32)> {
        let n_tris = self.tri_count();
        if C::SPHERES && (!C::TRIANGLES || prim >= n_tris) {
            return self
                .sphere(prim - n_tris)
                .intersect(ray)
                .map(|t| (t, 0.0, 0.0));
        }
        let (tri, min_det2) = self.prepared_triangle(prim);
        if C::WATERTIGHT {
            return watertight::intersect_sheared(&self.vertices(prim), min_det2, ray, shear);
        }
        tri.intersect_prepared(ray, min_det2)
    }
}

/// One ray against a group of four triangles, or a [`Pair`] of groups, in `C`'s mode
/// ([`crate::simd::group`]).
#[inline(always)]
fn intersect_group<C: Contents, G: GroupLanes>(g: G, ray: &Ray, shear: &Shear) -> PrimHits<G::L> {
    if C::WATERTIGHT {
        intersect_group_watertight(g, ray, shear)
    } else {
        crate::simd::group::intersect_group(g, ray)
    }
}

/// The ray's [`Shear`] when `C` is watertight; otherwise a constant that nothing reads.
#[inline(always)]
pub(crate) fn shear_for<C: Contents>(ray: &Ray) -> Shear {
    if C::WATERTIGHT {
        Shear::new(ray.dir)
    } else {
        Shear {
            k: [0, 1, 2],
            s: [0.0; 3],
        }
    }
}
