//! What the render kernel needs from what it renders, so that one path vertex
//! (`render/path.rs`) serves a single-mesh [`Scene`] and, with the `instances` feature, an
//! [`InstancedScene`](crate::instance::InstancedScene) (`render/instanced.rs`): a hit's material,
//! its point with its error bound (for spawning rays, [`crate::spawn`]), its geometric and shading
//! normals, and points on lights for next-event estimation.
//!
//! The methods are the single-mesh kernel's own calls, one for one, so that for a [`Scene`] the
//! monomorphized vertex is the code it was before the trait.

use crate::format::Scene;
use crate::ray::{Hit, Ray};
use crate::spawn::SurfacePoint;
use crate::traverse::Contents;
use glam::Vec3;

/// A scene the path vertex can shade (see the module doc), and its single-ray walks (the packet
/// and stream walks, `render/pixel.rs` and `render/wavefront.rs`, are a [`Scene`]'s own).
pub(crate) trait World {
    /// What a walk returns for one ray.
    type Hit: Copy;
    /// One emitting primitive, as the caller lists them for next-event estimation.
    type Light: Copy;

    /// The closest hit of `ray`, with the kernels `K` names (its mode included).
    fn intersect_one<K: Contents>(&self, ray: &Ray) -> Self::Hit;

    /// Whether anything blocks `ray`, with the kernels `K` names.
    fn occluded_one<K: Contents>(&self, ray: &Ray) -> bool;

    /// Whether `hit` is a hit (not a miss).
    fn is_hit(hit: &Self::Hit) -> bool;

    /// The material id of the primitive hit (an index into the render's materials).
    fn material_id(&self, hit: &Self::Hit) -> u32;

    /// The hit point, in world space, with its error bound.
    fn surface_point(&self, hit: &Self::Hit, ray: &Ray) -> SurfacePoint;

    /// The unit geometric and shading normals at `hit` (world point `p`), or `None` where they
    /// vanish (a degenerate triangle). The geometric normal is a triangle's
    /// `(v1 − v0) × (v2 − v0)` as placed, a sphere's outward one.
    fn normals(&self, hit: &Self::Hit, ray: &Ray, p: Vec3) -> Option<(Vec3, Vec3)>;

    /// The material id of `light`.
    fn light_material_id(&self, light: Self::Light) -> u32;

    /// A point on `light` uniform by area from `(u1, u2)` in `[0, 1)²`: the point, the unit
    /// normal there and the light's area, in world space; `None` for a degenerate primitive.
    fn point_on(&self, light: Self::Light, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)>;
}

impl World for Scene<'_> {
    type Hit = Hit;
    type Light = u32;

    #[inline(always)]
    fn intersect_one<K: Contents>(&self, ray: &Ray) -> Hit {
        self.intersect_with::<K>(ray)
    }

    #[inline(always)]
    fn occluded_one<K: Contents>(&self, ray: &Ray) -> bool {
        self.occluded_with::<K>(ray)
    }

    #[inline(always)]
    fn is_hit(hit: &Hit) -> bool {
        hit.is_hit()
    }

    #[inline(always)]
    fn material_id(&self, hit: &Hit) -> u32 {
        self.material(hit.prim)
    }

    #[inline(always)]
    fn surface_point(&self, hit: &Hit, ray: &Ray) -> SurfacePoint {
        Scene::surface_point(self, hit, ray)
    }

    #[inline(always)]
    fn normals(&self, hit: &Hit, _ray: &Ray, p: Vec3) -> Option<(Vec3, Vec3)> {
        super::path::normals(self, hit, p)
    }

    #[inline(always)]
    fn light_material_id(&self, light: u32) -> u32 {
        self.material(light)
    }

    #[inline(always)]
    fn point_on(&self, light: u32, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
        super::path::point_on(self, light, u1, u2)
    }
}
