//! The `bvh` crate (crates.io `bvh` 0.13, svenstaro/bvh) as a benchmark peer.
//!
//! The crate builds a binary SAH BVH with one shape per leaf and offers AABB traversals; it has no
//! closest-hit query of its own. A closest hit is therefore one of the crate's traversals plus a
//! triangle test per shape it yields:
//! - [`BvhPeer::trace`]: [`Bvh::traverse`] collects every shape whose box the ray crosses, and all
//!   are tested — the way the crate's README and benchmarks use it;
//! - [`BvhPeer::trace_nearest_first_into`]: [`Bvh::nearest_traverse_iterator`] yields shapes in
//!   order of the ray's entry into their boxes, and the loop stops once a box starts beyond the
//!   closest hit so far.
//!
//! Measured on the full dragon (primary and random rays, release build, a noisy shared machine)
//! the two were within noise of each other, so [`BvhPeer::trace`] uses the simpler. The crate's
//! allocation-free `traverse_iterator` was slower and is not used: its fixed 32-entry stack holds
//! the path from the root, and the full dragon's tree is already 30 levels deep.
//!
//! Differs from using the crate as-is in one place: the triangle test is kdray's
//! [`Triangle::intersect`] (two-sided Möller–Trumbore with a relative parallel threshold and the
//! `tmin < t < tmax` interval), not the crate's `Ray::intersects_triangle`, which culls back faces
//! and rejects `det < f32::EPSILON` absolutely, a threshold in squared scene units: on the full
//! dragon (in metres, edges ~1e-3) a quarter of the primary rays that hit the mesh find no hit
//! with it. The comparison is therefore between acceleration structures and their
//! traversal, with the same primitive test on both sides.
//!
//! Preconditions shared with the crate: `tmin >= 0` (the crate's slab test clamps boxes at
//! `t = 0`, so hits at negative `t` are not found); rays that are not finite are reported as
//! misses without being traced (the nearest-first heap would panic on a NaN distance).

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::Bvh;
use glam::Vec3;
use kdray_core::{Hit, Ray, Triangle};
use nalgebra::{Point3, Vector3};

/// One triangle as the crate sees it: its box, its index in input order and the node the crate
/// stores it in, plus the kernel layout for the intersection test.
#[derive(Clone, Debug)]
struct Shape {
    aabb: Aabb<f32, 3>,
    tri: Triangle,
    prim: u32,
    node: usize,
}

impl Bounded<f32, 3> for Shape {
    fn aabb(&self) -> Aabb<f32, 3> {
        self.aabb
    }
}

impl BHShape<f32, 3> for Shape {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node = index;
    }

    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// A `bvh`-crate BVH over a triangle soup.
#[derive(Clone, Debug)]
pub struct BvhPeer {
    bvh: Bvh<f32, 3>,
    shapes: Vec<Shape>,
}

fn point(v: Vec3) -> Point3<f32> {
    Point3::new(v.x, v.y, v.z)
}

impl BvhPeer {
    /// Builds the BVH single-threaded ([`Bvh::build`], not the crate's rayon `build_par`), as the
    /// benchmark protocol asks. Everything the build needs — the boxes and the kernel layout — is
    /// computed here, so timing this call times the whole build.
    ///
    /// # Panics
    /// If there are more than `u32::MAX` triangles.
    pub fn build(triangles: &[[Vec3; 3]]) -> Self {
        assert!(
            u32::try_from(triangles.len()).is_ok(),
            "the bvh peer indexes triangles with u32"
        );
        let mut shapes: Vec<Shape> = triangles
            .iter()
            .zip(0u32..)
            .map(|(&[v0, v1, v2], prim)| Shape {
                // The box of the input vertices, as a user of the crate would compute it.
                aabb: Aabb::with_bounds(point(v0.min(v1).min(v2)), point(v0.max(v1).max(v2))),
                tri: Triangle::from_vertices(v0, v1, v2),
                prim,
                node: 0,
            })
            .collect();
        let bvh = Bvh::build(&mut shapes);
        Self { bvh, shapes }
    }

    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// True when built over no triangles.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// The closest hit of each ray: every shape whose box the ray crosses is tested (see the
    /// module doc).
    pub fn trace(&self, rays: &[Ray]) -> Vec<Hit> {
        let mut hits = vec![Hit::MISS; rays.len()];
        self.trace_into(rays, &mut hits);
        hits
    }

    /// [`trace`](Self::trace) into a caller's buffer, so that a timed loop does not allocate the
    /// output (the crate's [`Bvh::traverse`] still allocates its candidate list per ray).
    ///
    /// # Panics
    /// If `hits.len() != rays.len()`.
    pub fn trace_into(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit record per ray");
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = Hit::MISS;
            let Some(bray) = crate_ray(ray) else { continue };
            let mut r = *ray;
            for shape in self.bvh.traverse(&bray, &self.shapes) {
                closer_hit(shape, &mut r, hit);
            }
        }
    }

    /// The closest hit of each ray by the crate's nearest-first traversal with early exit (see
    /// the module doc).
    ///
    /// # Panics
    /// If `hits.len() != rays.len()`.
    pub fn trace_nearest_first_into(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit record per ray");
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = self.closest_nearest_first(ray);
        }
    }

    fn closest_nearest_first(&self, ray: &Ray) -> Hit {
        let mut hit = Hit::MISS;
        let Some(bray) = crate_ray(ray) else {
            return hit;
        };
        let mut r = *ray;
        for shape in self.bvh.nearest_traverse_iterator(&bray, &self.shapes) {
            // Shapes arrive in order of where the ray enters their box (a child's box lies inside
            // its parent's, so the crate's best-first heap pops entries in nondecreasing order),
            // and a hit lies inside its triangle's box: once a box starts past the closest hit so
            // far (or past tmax), no later shape can be closer.
            match bray.intersection_slice_for_aabb(&shape.aabb) {
                Some((entry, _)) if entry > r.tmax => break,
                Some(_) => closer_hit(shape, &mut r, &mut hit),
                None => {}
            }
        }
        hit
    }
}

/// The crate's ray for `ray`, with `dir` kept as given (the crate's `Ray::new` would normalize it
/// and change the meaning of `t`), or `None` for a ray that is not finite.
fn crate_ray(ray: &Ray) -> Option<bvh::ray::Ray<f32, 3>> {
    if !ray.is_finite() {
        return None;
    }
    let d = Vector3::new(ray.dir.x, ray.dir.y, ray.dir.z);
    Some(bvh::ray::Ray {
        origin: point(ray.origin),
        direction: d,
        inv_direction: d.map(|x| 1.0 / x),
    })
}

/// Tests `shape` against `r` and, on a hit closer than `r.tmax`, records it and shrinks `r.tmax`
/// so that later tests only accept closer hits (ties keep the first found).
#[inline]
fn closer_hit(shape: &Shape, r: &mut Ray, hit: &mut Hit) {
    if let Some((t, u, v)) = shape.tri.intersect(r) {
        r.tmax = t;
        *hit = Hit {
            t,
            prim: shape.prim,
            u,
            v,
        };
    }
}
