//! Rendering a scene of instances ([`InstancedScene`]): the same path vertex as a single-mesh
//! scene (`render/path.rs`), every ray through the two-level single-ray walk
//! ([`InstancedScene::intersect_in`], [`InstancedScene::occluded_in`]); the packet and stream
//! ways of [`Bounces`](super::Bounces) trace single rays here, and give the same image as they do
//! (each path makes the same choices from the same random numbers).
//!
//! What the vertex needs is carried out of the instance it hit:
//! - the material is the bottom scene's, by the primitive's id (a mesh placed many times keeps
//!   its material in every copy);
//! - normals go through the inverse transpose of the instance's linear part; under a mirroring
//!   transform a triangle's geometric normal is also negated, so that it stays
//!   `(v1 − v0) × (v2 − v0)` of the triangle as placed (the side a one-sided light emits from
//!   mirrors with the mesh), while a sphere's stays the outward one;
//! - the hit point, with its error bound, is the bottom scene's ([`crate::spawn`]) carried to
//!   world space, see [`to_world`];
//! - a light is an [`InstanceLight`] (instance and primitive): a triangle is sampled as placed
//!   (its world vertices, so its area is exact); a sphere's area is scaled by `|det|^(2/3)`,
//!   exact for rotations, uniform scales and mirrors, approximate under other scales.

use super::path::{Context, Path, add_path, camera_path, vertex_in};
use super::world::World;
use super::{Material, PixelSamples, RenderError, SampleSums, Settings};
use crate::camera::Camera;
use crate::instance::{Affine, InstanceHit, InstancedScene};
use crate::math::{self, gamma};
use crate::ray::{Hit, Ray};
use crate::spawn::SurfacePoint;
use crate::traverse::Mode;
use core::ops::Range;
use glam::Vec3;

/// One emitting primitive of an instanced scene: primitive `prim` (storage order) of the bottom
/// scene of instance record `instance`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InstanceLight {
    pub instance: u32,
    pub prim: u32,
}

/// The emitting primitives of every instance of `scene`, instance by instance, written to `out`;
/// returns how many there are (those past `out.len()` are counted, not written).
#[inline]
pub fn instanced_emitters(
    scene: &InstancedScene,
    materials: &[Material],
    out: &mut [InstanceLight],
) -> usize {
    let mut n = 0;
    for instance in 0..scene.instance_count() {
        let bottom = scene.bottom_of(instance);
        for prim in 0..bottom.prim_count() {
            let m = materials.get(bottom.material(prim) as usize);
            if m.copied()
                .unwrap_or(Material::FALLBACK)
                .emission
                .max_element()
                > 0.0
            {
                if let Some(slot) = out.get_mut(n) {
                    *slot = InstanceLight { instance, prim };
                }
                n += 1;
            }
        }
    }
    n
}

/// The closest hit of `ray` ([`InstancedScene::intersect_in`]).
///
/// This module's functions are `#[inline]` or generic, so that the core compiles none of them
/// unless a program renders instances. Compiled in the core, they moved LLVM's choices for the
/// single-mesh kernels compiled there: `scripts/icount.sh`'s watertight rows rose by up to 9 %
/// (one ray at a time on index lists) in a binary that never called them; as they are, the
/// watertight packet rows still rise by 3–5 % (not understood yet).
#[inline]
fn closest(scene: &InstancedScene, mode: Mode, ray: &Ray) -> InstanceHit {
    scene.intersect_in(mode, ray)
}

/// Whether anything blocks `ray` ([`InstancedScene::occluded_in`]).
#[inline]
fn any(scene: &InstancedScene, mode: Mode, ray: &Ray) -> bool {
    scene.occluded_in(mode, ray)
}

/// `(A⁻¹)ᵀ·n` for the stored inverse `inv`: a normal carried to world space (not normalized).
#[inline]
fn normal_to_world(inv: &Affine, n: Vec3) -> Vec3 {
    let m = &inv.0;
    let col = |j: usize| m[j] * n.x + m[4 + j] * n.y + m[8 + j] * n.z;
    Vec3::new(col(0), col(1), col(2))
}

/// `|A|·v` (entrywise absolute values of the linear part) and `|b|`.
#[inline]
fn abs_linear(a: &Affine, v: Vec3) -> Vec3 {
    let m = &a.0;
    let row = |r: usize| m[4 * r].abs() * v.x + m[4 * r + 1].abs() * v.y + m[4 * r + 2].abs() * v.z;
    Vec3::new(row(0), row(1), row(2))
}

#[inline]
fn abs_translation(a: &Affine) -> Vec3 {
    let m = &a.0;
    Vec3::new(m[3].abs(), m[7].abs(), m[11].abs())
}

/// A bottom scene's surface point carried to world space by `transform`, so that an origin
/// spawned from it in world space lies, once the walk has moved it back by the stored `inverse`,
/// on the same side of the bottom primitive and as far off it as the bottom point's own spawn
/// would (pbrt-v4 §6.8.6 carries points and their error through transforms the same way; the
/// round trip is the difference, since the walk moves rays by the stored inverse).
///
/// - `p`: `A·p_l + b` in f32.
/// - The local error grows by the round trip world → local: the f32 evaluation of `inverse` at
///   `p` (`γ(3)·(|A⁻¹|·|p| + |b⁻¹|)`) plus how far the stored inverse takes `p` from `p_l`
///   (measured). With the local margin this is a distance `d_l = margin_l + ‖error_l‖` the origin
///   must keep from the local surface along its normal.
/// - A world offset `d` along the world normal is a local distance of at least `d / σ_max(A)`
///   (the local plane's distance is `|A⁻ᵀ n_l|·d ≥ d / σ_max`); `σ_max ≤ ‖A‖_F`, so the world
///   margin is `‖A‖_F·d_l`, rounded up by `γ(4)`.
/// - `error`: the forward transform's own rounding, `γ(3)·(|A|·|p_l| + |b|)` (pbrt-v4's bound).
#[inline]
fn to_world(transform: &Affine, inverse: &Affine, local: SurfacePoint) -> SurfacePoint {
    let p = transform.point(local.p);
    let error = gamma(3) * (abs_linear(transform, local.p.abs()) + abs_translation(transform));
    let back = inverse.point(p);
    let trip = (back - local.p).abs()
        + gamma(3) * (abs_linear(inverse, p.abs()) + abs_translation(inverse))
        + local.error;
    let frobenius = math::sqrt(
        transform.0.iter().enumerate().fold(
            0.0,
            |s, (i, x)| {
                if i % 4 == 3 { s } else { s + x * x }
            },
        ),
    );
    let margin = (1.0 + gamma(4)) * frobenius * (local.margin + trip.length() + error.length());
    SurfacePoint { p, error, margin }
}

impl World for InstancedScene<'_, '_> {
    type Hit = InstanceHit;
    type Light = InstanceLight;

    #[inline]
    fn is_hit(hit: &InstanceHit) -> bool {
        hit.is_hit()
    }

    #[inline]
    fn material_id(&self, hit: &InstanceHit) -> u32 {
        self.bottom_of(hit.instance).material(hit.prim)
    }

    #[inline]
    fn surface_point(&self, hit: &InstanceHit, ray: &Ray) -> SurfacePoint {
        let inst = self.instance(hit.instance);
        let (local_hit, local_ray) = local(&inst.inverse, hit, ray);
        let local_point = self
            .bottom_of(hit.instance)
            .surface_point(&local_hit, &local_ray);
        to_world(&inst.transform, &inst.inverse, local_point)
    }

    #[inline]
    fn normals(&self, hit: &InstanceHit, ray: &Ray, _p: Vec3) -> Option<(Vec3, Vec3)> {
        let inst = self.instance(hit.instance);
        let bottom = self.bottom_of(hit.instance);
        let (local_hit, local_ray) = local(&inst.inverse, hit, ray);
        let (g, s) = super::world::normals(bottom, &local_hit, local_ray.origin)?;
        let (mut g, mut s) = (
            normal_to_world(&inst.inverse, g),
            normal_to_world(&inst.inverse, s),
        );
        if hit.prim < bottom.tri_count() && inst.transform.determinant() < 0.0 {
            (g, s) = (-g, -s);
        }
        let g = g.try_normalize()?;
        Some((g, s.try_normalize().unwrap_or(g)))
    }

    #[inline]
    fn light_material_id(&self, light: InstanceLight) -> u32 {
        self.bottom_of(light.instance).material(light.prim)
    }

    #[inline]
    fn point_on(&self, light: InstanceLight, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
        let inst = self.instance(light.instance);
        let bottom = self.bottom_of(light.instance);
        let a = &inst.transform;
        if light.prim < bottom.tri_count() {
            let tri = bottom.triangle(light.prim);
            let v0 = a.point(tri.v0);
            let (e1, e2) = (a.point(tri.v0 + tri.e1) - v0, a.point(tri.v0 + tri.e2) - v0);
            let cross = e1.cross(e2);
            let n = cross.try_normalize()?;
            // Uniform on a triangle (Osada et al. 2002), as for a single-mesh scene's lights.
            let s = math::sqrt(u1);
            return Some((
                v0 + e1 * (s * (1.0 - u2)) + e2 * (s * u2),
                n,
                0.5 * cross.length(),
            ));
        }
        let (q, n, area) = super::world::point_on(bottom, light.prim, u1, u2)?;
        let area_scale = math::powf((a.determinant() as f32).abs(), 2.0 / 3.0);
        let n = normal_to_world(&inst.inverse, n).try_normalize()?;
        Some((a.point(q), n, area * area_scale))
    }
}

/// The bottom scene's view of `hit`: its hit record with the world point moved into the instance
/// as the origin of a ray at `t = 0` (what [`crate::format::Scene::surface_point`] reads for a
/// sphere; a triangle's point comes from the barycentrics alone).
#[inline]
fn local(inverse: &Affine, hit: &InstanceHit, ray: &Ray) -> (Hit, Ray) {
    let origin = inverse.point(ray.at(hit.t));
    let local_hit = Hit {
        t: 0.0,
        prim: hit.prim,
        u: hit.u,
        v: hit.v,
    };
    (local_hit, Ray { origin, ..*ray })
}

/// Everything a render of an instanced scene reads, as [`super::Frame`] for a single-mesh one:
/// [`InstancedFrame::add_samples`] renders any range of a pixel's samples, the same bit for bit
/// whichever call renders them. `settings.spp` is not read; `settings.bounces` is not either
/// (every ray is a single ray here).
#[derive(Clone, Copy)]
pub struct InstancedFrame<'a, 'w, 'b, C> {
    pub scene: &'a InstancedScene<'w, 'b>,
    pub camera: &'a C,
    pub materials: &'a [Material],
    /// Every emitting primitive, see [`instanced_emitters`].
    pub lights: &'a [InstanceLight],
    pub settings: &'a Settings,
}

impl<C: Camera> InstancedFrame<'_, '_, '_, C> {
    /// Adds samples `samples` of pixel `(x, y)` to `sums`, in sample order (as
    /// [`super::Frame::add_samples`]).
    ///
    /// # Errors
    /// [`RenderError::EmptyImage`] for a zero width or height, [`RenderError::BufferSize`] for a
    /// pixel outside the image.
    pub fn add_samples(
        &self,
        x: u32,
        y: u32,
        samples: Range<u32>,
        sums: &mut SampleSums,
    ) -> Result<(), RenderError> {
        let s = self.settings;
        if s.width == 0 || s.height == 0 {
            return Err(RenderError::EmptyImage);
        }
        if x >= s.width || y >= s.height {
            return Err(RenderError::BufferSize);
        }
        self.trace(x, y, samples, sums);
        Ok(())
    }

    /// [`Self::add_samples`] for every job in turn (the single-mesh [`super::Frame::add_pixels`]
    /// without its wavefront).
    ///
    /// # Errors
    /// As [`Self::add_samples`]; [`RenderError::BufferSize`] too when `sums` is not as long as
    /// `jobs` (nothing is rendered then).
    pub fn add_pixels(
        &self,
        jobs: &[PixelSamples],
        sums: &mut [SampleSums],
    ) -> Result<(), RenderError> {
        let s = self.settings;
        if s.width == 0 || s.height == 0 {
            return Err(RenderError::EmptyImage);
        }
        if sums.len() != jobs.len() || jobs.iter().any(|j| j.x >= s.width || j.y >= s.height) {
            return Err(RenderError::BufferSize);
        }
        for (job, sums) in jobs.iter().zip(sums) {
            self.add_samples(job.x, job.y, job.samples.clone(), sums)?;
        }
        Ok(())
    }

    fn trace(&self, x: u32, y: u32, samples: Range<u32>, sums: &mut SampleSums) {
        let ctx = Context {
            scene: self.scene,
            materials: self.materials,
            lights: self.lights,
            settings: self.settings,
        };
        for sample in samples {
            if let Some(mut path) = camera_path(self.settings, self.camera, x, y, sample) {
                trace_one(&ctx, &mut path);
                add_path(sums, &path);
            }
        }
    }
}

/// One path through the two-level walk in the settings' mode, every ray a single ray (as
/// `render/pixel.rs` traces a single-mesh path with `Bounces::SingleRays`).
#[inline]
fn trace_one(ctx: &Context<InstancedScene>, path: &mut Path) {
    let mode = ctx.settings.mode;
    let mut hit = closest(ctx.scene, mode, &path.ray);
    for depth in 1..=ctx.settings.max_depth {
        let (goes_on, shadow) = vertex_in(ctx, path, &hit);
        if let Some(shadow) = shadow {
            path.resolve(&shadow, any(ctx.scene, mode, &shadow.ray));
        }
        if !goes_on || depth == ctx.settings.max_depth {
            return;
        }
        hit = closest(ctx.scene, mode, &path.ray);
    }
}
