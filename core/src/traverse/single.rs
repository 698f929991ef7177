//! The one-ray walk: closest hit ([`Scene::intersect`]) and any hit ([`Scene::occluded`]) for one
//! ray, in fast or watertight mode, chosen at run time (`_in`) or at compile time (`_with`). It
//! walks the wide nodes when the scene has them and the core is built with the `wide` feature
//! ([`super::wide::walk`]: the same closest hits), else runs the resumable steps of
//! [`super::steps`] over the binary nodes to the end. The rules the walks follow are in
//! [`super`]'s module doc.

use super::steps::{Closest, Occlusion, Progress, Query, Stepper, shear_for};
use super::{Contents, Mode, by_contents};
use crate::format::Scene;
use crate::ray::{Hit, Ray};

impl Scene<'_> {
    /// The closest hit along `ray` in `(ray.tmin, ray.tmax)`, or [`Hit::MISS`], in fast mode.
    /// Picks the kernel monomorphized for the scene's contents. `prim` is in storage order:
    /// [`Scene::input_id`] gives the mesh's triangle index ([`Hit`]).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Hit {
        self.intersect_in(Mode::Fast, ray)
    }

    /// Whether anything lies along `ray` in `(ray.tmin, ray.tmax)` (shadow rays), in fast mode.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_in(Mode::Fast, ray)
    }

    /// [`Scene::intersect`] in `mode`.
    #[inline]
    pub fn intersect_in(&self, mode: Mode, ray: &Ray) -> Hit {
        by_contents!(self, mode, |C| self.intersect_with::<C>(ray))
    }

    /// [`Scene::occluded`] in `mode`.
    #[inline]
    pub fn occluded_in(&self, mode: Mode, ray: &Ray) -> bool {
        by_contents!(self, mode, |C| self.occluded_with::<C>(ray))
    }

    /// Tests one primitive against `ray`, returning `(t, u, v)`.
    #[inline(always)]
    pub fn intersect_prim<C: Contents>(&self, prim: u32, ray: &Ray) -> Option<(f32, f32, f32)> {
        self.intersect_prim_sheared::<C>(prim, ray, &shear_for::<C>(ray))
    }

    /// [`Scene::intersect`] for a fixed [`Contents`]; the caller promises the scene holds no other
    /// kind of primitive (it would be tested as the wrong kind, never out of bounds).
    ///
    /// Never inlined: a walk is large, a call per ray costs nothing beside it, and inlined into
    /// [`Scene::intersect_in`] with its other modes' walks LLVM kept the listed leaves' gathered
    /// groups in memory — up to 15 % more instructions a ray (scripts/icount.sh), which came and
    /// went with unrelated changes to the calling crate.
    #[inline(never)]
    pub fn intersect_with<C: Contents>(&self, ray: &Ray) -> Hit {
        let mut query = Closest::new::<C>(ray);
        self.walk::<C, _>(ray, &mut query);
        query.hit()
    }

    /// [`Scene::occluded`] for a fixed [`Contents`]; never inlined, as [`Scene::intersect_with`].
    #[inline(never)]
    pub fn occluded_with<C: Contents>(&self, ray: &Ray) -> bool {
        let mut query = Occlusion::new::<C>(ray);
        self.walk::<C, _>(ray, &mut query);
        query.found()
    }

    /// Walks `ray` to the end for `query` (the one-ray walk): over the wide nodes when the scene
    /// has them and the core is built with the `wide` feature, else over the binary nodes, one
    /// step after another.
    #[inline(always)]
    pub(crate) fn walk<C: Contents, Q: Query>(&self, ray: &Ray, query: &mut Q) {
        #[cfg(feature = "wide")]
        if !self.wide_nodes().is_empty() {
            return super::wide::walk::walk::<C, Q>(self, self.wide_nodes(), ray, query);
        }
        walk_to_end::<_, C, Q>(self, ray, query)
    }
}

/// Walks `ray` over `layout` to the end for `query`, one plain step after another.
#[inline(always)]
fn walk_to_end<W: Stepper, C: Contents, Q: Query>(layout: &W, ray: &Ray, query: &mut Q) {
    let mut state = W::empty_state();
    if layout.begin::<C>(ray, &mut state) {
        while layout.step::<C, Q>(&mut state, query) != Progress::Done {}
    }
}
