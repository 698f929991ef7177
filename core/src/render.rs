//! The render kernel: a unidirectional path tracer that writes linear RGB radiance into a
//! caller's buffer, row by row, with no allocation.
//!
//! Each pixel's samples are jittered inside the pixel and traced eight at a time as one 8-wide
//! packet (the samples of one pixel are as coherent as rays get); every bounce after the first
//! hit is a single ray through the scalar walk ([`Scene::intersect`]), since diffuse bounces are
//! incoherent (docs/BENCHMARKS.md, "Which path is used when").
//!
//! Light transport, per path vertex (at most [`Settings::max_depth`] of them):
//! - `Diffuse` and `Emissive` surfaces scatter Lambertian-wise, by cosine-weighted sampling, so
//!   the throughput is multiplied by `albedo` alone (the cosine and π cancel against the pdf), and
//!   take direct light by next-event estimation: one point picked uniformly by area on one light
//!   picked uniformly from the caller's list, with a shadow ray;
//! - `Mirror` reflects about the shading normal, times `albedo`;
//! - `Glass` reflects with the exact Fresnel probability ([`optics::fresnel_dielectric`]) and
//!   otherwise refracts ([`optics::refract`]), times `albedo` either way;
//! - emission (from either side of a surface) is added where a camera ray or a specular bounce
//!   lands on it; after a diffuse bounce it is not, since next-event estimation counted it;
//! - a ray that leaves the scene adds `background`.
//!
//! Each sample depends only on the pixel, the sample index and [`Settings::seed`], so an image
//! does not depend on how rows are split between threads.

use crate::camera::Camera;
use crate::format::Scene;
use crate::math;
use crate::optics;
use crate::ray::{Hit, Ray};
use crate::sampling::{Onb, Pcg32, cosine_hemisphere};
use crate::simd::{RayPacket, f32x8};
use crate::triangle::shading_normal;
use core::f32::consts::PI;
use glam::Vec3;

/// How a surface scatters light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialKind {
    /// Lambertian reflection of `albedo`.
    Diffuse,
    /// Perfect specular reflection tinted by `albedo`.
    Mirror,
    /// A smooth dielectric of index `ior`, tinted by `albedo`.
    Glass,
    /// Emits `emission` and reflects like [`MaterialKind::Diffuse`].
    Emissive,
}

/// A material; primitive `p` uses `materials[scene.material(p)]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub kind: MaterialKind,
    /// Reflectance (or tint), each channel in `[0, 1]`.
    pub albedo: Vec3,
    /// Emitted radiance (linear RGB), added at every path vertex on this surface.
    pub emission: Vec3,
    /// Index of refraction (glass).
    pub ior: f32,
}

impl Material {
    /// What a primitive whose material id has no entry gets: diffuse, albedo 0.8.
    pub const FALLBACK: Material = Material {
        kind: MaterialKind::Diffuse,
        albedo: Vec3::splat(0.8),
        emission: Vec3::ZERO,
        ior: 1.5,
    };
}

/// Image size, sampling and path settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel, ≥ 1.
    pub spp: u32,
    /// The most surface hits a path may have; a path cut off there adds nothing more (0 gives a
    /// black image).
    pub max_depth: u32,
    /// Radiance of rays that leave the scene.
    pub background: Vec3,
    /// Seeds every sample's random numbers.
    pub seed: u64,
}

/// Why [`render_rows`] refused its arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderError {
    /// Width, height or spp is 0.
    EmptyImage,
    /// The buffer is not a whole number of rows, or runs past the image's last row.
    BufferSize,
}

impl core::fmt::Display for RenderError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::EmptyImage => "width, height and spp must be at least 1",
            Self::BufferSize => "the buffer must hold whole rows that lie inside the image",
        })
    }
}

/// Renders the rows `first_row..` that `out` holds (row-major, `settings.width` pixels a row):
/// each pixel gets the mean radiance of its `spp` samples, linear RGB.
///
/// `lights` lists the primitives whose material emits (every one of them: emission that a
/// diffuse bounce lands on is counted only through this list); [`emitters`] finds them.
///
/// # Errors
/// [`RenderError`] for an empty image or a buffer that does not fit the image.
pub fn render_rows<C: Camera>(
    scene: &Scene,
    camera: &C,
    materials: &[Material],
    lights: &[u32],
    settings: &Settings,
    first_row: u32,
    out: &mut [[f32; 3]],
) -> Result<(), RenderError> {
    let (w, h) = (settings.width, settings.height);
    if w == 0 || h == 0 || settings.spp == 0 {
        return Err(RenderError::EmptyImage);
    }
    let rows = out.len() / w as usize;
    if !out.len().is_multiple_of(w as usize) || first_row as usize + rows > h as usize {
        return Err(RenderError::BufferSize);
    }
    let ctx = Context {
        scene,
        materials,
        lights,
        settings,
    };
    for (k, pixel) in out.iter_mut().enumerate() {
        let (x, y) = ((k % w as usize) as u32, first_row + (k / w as usize) as u32);
        let sum = render_pixel(&ctx, camera, x, y);
        *pixel = (sum / settings.spp as f32).to_array();
    }
    Ok(())
}

/// What every path of a render reads.
struct Context<'a, 's> {
    scene: &'a Scene<'s>,
    materials: &'a [Material],
    lights: &'a [u32],
    settings: &'a Settings,
}

impl Context<'_, '_> {
    fn material(&self, prim: u32) -> Material {
        material_of(self.scene, self.materials, prim)
    }
}

/// Primitive `prim`'s material: `materials[scene.material(prim)]`, or [`Material::FALLBACK`].
fn material_of(scene: &Scene, materials: &[Material], prim: u32) -> Material {
    materials
        .get(scene.material(prim) as usize)
        .copied()
        .unwrap_or(Material::FALLBACK)
}

/// The primitives of `scene` whose material emits, in storage order, written to `out`; returns
/// how many there are (those past `out.len()` are counted, not written).
pub fn emitters(scene: &Scene, materials: &[Material], out: &mut [u32]) -> usize {
    let mut n = 0;
    for prim in 0..scene.prim_count() {
        if material_of(scene, materials, prim).emission.max_element() > 0.0 {
            if let Some(slot) = out.get_mut(n) {
                *slot = prim;
            }
            n += 1;
        }
    }
    n
}

/// The sum of pixel `(x, y)`'s sample radiances.
fn render_pixel<C: Camera>(ctx: &Context, camera: &C, x: u32, y: u32) -> Vec3 {
    let settings = ctx.settings;
    let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
    let mut sum = Vec3::ZERO;
    let mut first = 0;
    while first < settings.spp {
        let n = (settings.spp - first).min(8) as usize;
        let mut rngs = [Pcg32::new(0, 0); 8];
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
        for i in 0..n {
            let mut rng = Pcg32::new(settings.seed, pixel << 32 | u64::from(first + i as u32));
            let (jx, jy) = (rng.next_f32(), rng.next_f32());
            rays[i] = camera.ray(
                x as f32 + jx,
                y as f32 + jy,
                settings.width,
                settings.height,
            );
            rngs[i] = rng;
        }
        let hits = ctx
            .scene
            .intersect_packet(&RayPacket::<f32x8>::from_rays(&rays[..n]));
        for i in 0..n {
            let l = trace_path(ctx, rays[i], hits.hit(i), &mut rngs[i]);
            // A non-finite sample (a NaN from a degenerate normal, say) is dropped, not spread.
            if l.is_finite() {
                sum += l;
            }
        }
        first += n as u32;
    }
    sum
}

/// The radiance a path starting with `ray` (whose closest hit is `hit`) brings back.
fn trace_path(ctx: &Context, mut ray: Ray, mut hit: Hit, rng: &mut Pcg32) -> Vec3 {
    let scene = ctx.scene;
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    let mut count_emission = true;
    for _ in 0..ctx.settings.max_depth {
        if !hit.is_hit() {
            return radiance + throughput * ctx.settings.background;
        }
        let m = ctx.material(hit.prim);
        if count_emission {
            radiance += throughput * m.emission;
        }
        let p = ray.at(hit.t);
        let Some((geometric, shading)) = normals(scene, &hit, p) else {
            return radiance;
        };
        // Both normals turned to the side the ray comes from.
        let front = geometric.dot(ray.dir) < 0.0;
        let ng = if front { geometric } else { -geometric };
        let ns = if shading.dot(ng) > 0.0 { shading } else { ng };
        let diffuse = matches!(m.kind, MaterialKind::Diffuse | MaterialKind::Emissive);
        let dir = match m.kind {
            MaterialKind::Diffuse | MaterialKind::Emissive => {
                let origin = offset(p, ng);
                radiance += throughput * m.albedo * direct_light(ctx, origin, ns, rng);
                Onb::from_normal(ns).to_world(cosine_hemisphere(rng.next_f32(), rng.next_f32()))
            }
            MaterialKind::Mirror => optics::reflect(ray.dir, ns),
            MaterialKind::Glass => {
                let (eta1, eta2) = if front { (1.0, m.ior) } else { (m.ior, 1.0) };
                let cos_i = -ray.dir.dot(ns);
                let reflected = optics::reflect(ray.dir, ns);
                if rng.next_f32() < optics::fresnel_dielectric(cos_i, eta1, eta2) {
                    reflected
                } else {
                    optics::refract(ray.dir, ns, eta1, eta2).unwrap_or(reflected)
                }
            }
        };
        let Some(dir) = dir.try_normalize() else {
            return radiance;
        };
        throughput *= m.albedo;
        count_emission = !diffuse || ctx.lights.is_empty();
        // Leave the surface on the side the new direction goes to.
        let side = if dir.dot(ng) >= 0.0 { ng } else { -ng };
        ray = Ray::new(offset(p, side), dir);
        hit = scene.intersect(&ray);
    }
    radiance
}

/// `p` moved off its surface along the unit normal `n`, by [`SURFACE_OFFSET`] times
/// `1 + |p|∞` (relative to `p`'s magnitude, absolute near the origin).
fn offset(p: Vec3, n: Vec3) -> Vec3 {
    p + n * (SURFACE_OFFSET * (1.0 + p.abs().max_element()))
}

/// Next-event estimation at a Lambertian point (`origin`, already off the surface, with unit
/// normal `n`): the incident radiance times `cosθ / π`, estimated from one point on one light;
/// multiplied by the albedo it is the reflected direct light.
fn direct_light(ctx: &Context, origin: Vec3, n: Vec3, rng: &mut Pcg32) -> Vec3 {
    let count = ctx.lights.len();
    if count == 0 {
        return Vec3::ZERO;
    }
    let pick = ((rng.next_f32() * count as f32) as usize).min(count - 1);
    let prim = ctx.lights[pick];
    let (u1, u2) = (rng.next_f32(), rng.next_f32());
    let Some((q, nl, area)) = point_on(ctx.scene, prim, u1, u2) else {
        return Vec3::ZERO;
    };
    let to_light = q - origin;
    let dist2 = to_light.length_squared();
    let dist = math::sqrt(dist2);
    let wi = to_light / dist;
    let (cos_here, cos_there) = (wi.dot(n), wi.dot(nl).abs());
    if !(cos_here > 0.0 && cos_there > 0.0 && dist2 > 0.0) {
        return Vec3::ZERO;
    }
    // Stop short of the light's surface so that it does not shadow itself.
    let shadow = Ray::new(origin, wi).with_range(0.0, dist * (1.0 - SHADOW_SLACK));
    if ctx.scene.occluded(&shadow) {
        return Vec3::ZERO;
    }
    // pdf of the point, per unit area: 1 / (count · area); converted to solid angle by
    // dist² / cos_there.
    ctx.material(prim).emission * (cos_here * cos_there / dist2 * area * count as f32 / PI)
}

/// A point on primitive `prim` uniform by area from `(u1, u2)` in `[0, 1)²`: the point, the unit
/// normal there and the primitive's area; `None` for a degenerate primitive.
fn point_on(scene: &Scene, prim: u32, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
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

/// Relative distance a bounce starts from its surface, against self-intersection.
const SURFACE_OFFSET: f32 = 1.0 / (1 << 16) as f32;
/// Fraction of a shadow ray's length left out at the light's end.
const SHADOW_SLACK: f32 = 1.0 / (1 << 12) as f32;

/// The unit geometric and shading normals at hit `hit` (point `p`), or `None` where they
/// vanish (a degenerate triangle).
fn normals(scene: &Scene, hit: &Hit, p: Vec3) -> Option<(Vec3, Vec3)> {
    let geometric = scene.geometric_normal(hit.prim, p).try_normalize()?;
    let shading = match scene.vertex_normals(hit.prim) {
        Some(vn) => shading_normal(vn, hit.u, hit.v, geometric),
        None => geometric,
    };
    Some((geometric, shading))
}
