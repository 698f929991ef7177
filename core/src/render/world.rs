//! What the render kernel needs from what it renders, so that one path vertex
//! (`render/path.rs`) serves a single-mesh [`Scene`] and, with the `instances` feature, an
//! [`InstancedScene`](crate::instance::InstancedScene) (`render/instanced.rs`): a hit's material,
//! its point with its error bound (for spawning rays, [`crate::spawn`]), its geometric and shading
//! normals, and points on lights for next-event estimation.
//!
//! The methods are the single-mesh kernel's own calls, one for one, so that for a [`Scene`] the
//! monomorphized vertex is the code it was before the trait.

use crate::format::Scene;
use crate::math;
use crate::ray::{Hit, Ray};
use crate::spawn::SurfacePoint;
use crate::triangle::shading_normal;
use core::f32::consts::PI;
use glam::Vec3;

/// A scene the path vertex can shade (see the module doc). Tracing is not part of it: the ways
/// of tracing (`render/pixel.rs`, `render/wavefront.rs`, `render/instanced.rs`) call their
/// scene's own walks.
pub(crate) trait World {
    /// What a walk returns for one ray.
    type Hit: Copy;
    /// One emitting primitive, as the caller lists them for next-event estimation.
    type Light: Copy;

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
        normals(self, hit, p)
    }

    #[inline(always)]
    fn light_material_id(&self, light: u32) -> u32 {
        self.material(light)
    }

    #[inline(always)]
    fn point_on(&self, light: u32, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
        point_on(self, light, u1, u2)
    }
}

/// A point on primitive `prim` uniform by area from `(u1, u2)` in `[0, 1)²`: the point, the unit
/// normal there and the primitive's area; `None` for a degenerate primitive.
pub(super) fn point_on(scene: &Scene, prim: u32, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
    let n_tris = scene.tri_count();
    if prim >= n_tris {
        let s = scene.sphere(prim - n_tris);
        let z = 1.0 - 2.0 * u1;
        let r = math::sqrt((1.0 - z * z).max(0.0));
        let phi = 2.0 * PI * u2;
        let n = Vec3::new(r * math::cos(phi), r * math::sin(phi), z);
        return Some((s.center + s.radius * n, n, 4.0 * PI * s.radius * s.radius));
    }
    let tri = scene.triangle(prim);
    let cross = tri.geometric_normal();
    let area = 0.5 * cross.length();
    let n = cross.try_normalize()?;
    // Uniform on a triangle (Osada et al. 2002): √u1 picks the distance from v0.
    let s = math::sqrt(u1);
    Some((
        tri.v0 + tri.e1 * (s * (1.0 - u2)) + tri.e2 * (s * u2),
        n,
        area,
    ))
}

/// The unit geometric and shading normals at hit `hit` (point `p`), or `None` where they
/// vanish (a degenerate triangle).
pub(super) fn normals(scene: &Scene, hit: &Hit, p: Vec3) -> Option<(Vec3, Vec3)> {
    let geometric = scene.geometric_normal(hit.prim, p).try_normalize()?;
    let shading = match scene.vertex_normals(hit.prim) {
        Some(vn) => shading_normal(vn, hit.u, hit.v, geometric),
        None => geometric,
    };
    Some((geometric, shading))
}
