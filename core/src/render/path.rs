//! One path of the render kernel: its state, what happens where it lands (a path vertex:
//! emission, next-event estimation, the next direction) and the shadow rays it waits on. The ways
//! of tracing paths ([`super::pixel`]: one by one or eight side by side; [`super::wavefront`]: many
//! pixels' paths as one ray stream) all advance paths through [`vertex`], so a path makes the same
//! choices from the same random numbers whichever traces it.

use super::world::World;
use super::{Material, MaterialKind, SampleSums, Settings};
use crate::camera::Camera;
use crate::format::Scene;
use crate::math;
use crate::optics;
use crate::ray::{Hit, Ray};
use crate::sampling::{Onb, Pcg32, cosine_hemisphere};
use core::f32::consts::PI;
use glam::Vec3;

/// What every path of a render reads: a single-mesh [`Scene`] or, with the `instances`
/// feature, an [`InstancedScene`](crate::instance::InstancedScene) ([`World`]).
pub(super) struct Context<'a, W: World> {
    pub scene: &'a W,
    pub materials: &'a [Material],
    pub lights: &'a [W::Light],
    pub settings: &'a Settings,
}

impl<W: World> Context<'_, W> {
    fn material(&self, id: u32) -> Material {
        self.materials
            .get(id as usize)
            .copied()
            .unwrap_or(Material::FALLBACK)
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

/// Adds pixel `(x, y)`'s sample radiances over `samples` to `sums`, in sample order; bounce
/// One sample's path: the ray it follows next, its random numbers and what it has gathered.
#[derive(Clone, Copy)]
pub(super) struct Path {
    pub ray: Ray,
    rng: Pcg32,
    pub radiance: Vec3,
    throughput: Vec3,
    /// Whether emission where `ray` lands counts (camera rays, specular bounces, no lights).
    count_emission: bool,
    /// Rays traced so far, shadow rays included.
    pub rays: u32,
}

/// A shadow ray that a path vertex waits on: if nothing blocks `ray`, the path gains
/// `factor * light`, otherwise `factor * 0`.
#[derive(Clone, Copy)]
pub(super) struct Shadow {
    pub ray: Ray,
    pub factor: Vec3,
    pub light: Vec3,
}

impl Path {
    /// A placeholder in a path array before a sample fills it (never traced).
    pub const IDLE: Path = Path {
        ray: Ray {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
            tmin: 0.0,
            tmax: 0.0,
        },
        rng: Pcg32::IDLE,
        radiance: Vec3::ZERO,
        throughput: Vec3::ZERO,
        count_emission: false,
        rays: 0,
    };

    /// A path starting with camera ray `ray` of weight `weight`.
    pub fn new(ray: Ray, rng: Pcg32, weight: f32) -> Self {
        Self {
            ray,
            rng,
            radiance: Vec3::ZERO,
            throughput: Vec3::splat(weight),
            count_emission: true,
            rays: 0,
        }
    }

    /// Adds the direct light of `shadow` once its ray's fate is known.
    pub fn resolve(&mut self, shadow: &Shadow, occluded: bool) {
        let light = if occluded { Vec3::ZERO } else { shadow.light };
        self.radiance += shadow.factor * light;
        self.rays += 1;
    }
}

/// One path all by itself: every ray through the scalar walk.
/// The starting point of sample `sample` of pixel `pixel`'s random numbers: the three hashed
/// into one well-mixed 64-bit key (SplitMix64's finalizer, Steele, Lea & Flood, "Fast splittable
/// pseudorandom number generators", OOPSLA 2014), which seeds one PCG32 sequence.
///
/// Why not one PCG stream per sample (`Pcg32::new(seed, pixel << 32 | sample)`, as before): the
/// streams of one LCG are affine images of each other (a state of stream `c` is `c·X + seed·Y`
/// for fixed sequences `X`, `Y`), so the samples of a pixel were slightly correlated. On the
/// white furnace (32×32) the pixels' error at 16,384 spp was 0.0040 where their sample variance
/// predicted 0.0032, and the error fell only 1.77× from 4,096 to 16,384 spp instead of 2×; with
/// hashed keys it matches the prediction (README, "Error against run time").
fn sample_key(seed: u64, pixel: u64, sample: u32) -> u64 {
    fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    // `pixel << 32 | sample` is unique per sample (an image has at most 2²⁶ pixels); `mix` is a
    // bijection, and the seed enters through a second round so that seeds s and s + 1 share no
    // structure either.
    mix(mix(pixel << 32 | u64::from(sample)) ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// Sample `sample` of pixel `(x, y)`: its random numbers (one stream a sample, so a sample does
/// not depend on which call or thread renders it), its jitter inside the pixel and the camera's
/// ray; `None` where the camera drops the sample (a lens's rim).
pub(super) fn camera_path<C: Camera>(
    settings: &Settings,
    camera: &C,
    x: u32,
    y: u32,
    sample: u32,
) -> Option<Path> {
    let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
    let mut rng = Pcg32::new(sample_key(settings.seed, pixel, sample), 0);
    let (jx, jy) = (rng.next_f32(), rng.next_f32());
    let (px, py) = (x as f32 + jx, y as f32 + jy);
    let (ray, weight) = camera.sample(px, py, settings.width, settings.height, &mut rng)?;
    Some(Path::new(ray, rng, weight))
}

/// Adds a finished path's radiance and rays to its pixel's sums.
pub(super) fn add_path(sums: &mut SampleSums, path: &Path) {
    // A non-finite sample (a NaN from a degenerate normal, say) is dropped, not spread.
    if path.radiance.is_finite() {
        sums.sum += path.radiance;
        sums.sum_sq += path.radiance * path.radiance;
    }
    sums.rays += u64::from(path.rays);
}

/// bounce and returns `true`, or ends the path (`false`).
/// The path vertex where `path.ray` lands (`hit`): adds what it emits and, after a diffuse
/// bounce, returns the shadow ray of its direct light; then either turns `path.ray` into the next
/// bounce and returns `true`, or ends the path (`false`).
///
/// Never inlined, so that it stays compiled in the core as it was before [`World`]: the render
/// loops, generic over the camera and compiled in the caller's crate, call it rather than carry a
/// copy of [`vertex_in`] beside the packet kernels compiled there (whose instruction counts
/// `scripts/icount.sh` holds to within 3 %).
#[inline(never)]
pub(super) fn vertex(ctx: &Context<Scene>, path: &mut Path, hit: &Hit) -> (bool, Option<Shadow>) {
    vertex_in(ctx, path, hit)
}

/// [`vertex`] for any [`World`]: a single-mesh scene's or an instanced scene's.
pub(super) fn vertex_in<W: World>(
    ctx: &Context<W>,
    path: &mut Path,
    hit: &W::Hit,
) -> (bool, Option<Shadow>) {
    let scene = ctx.scene;
    let ray = path.ray;
    path.rays += 1;
    if !W::is_hit(hit) {
        path.radiance += path.throughput * ctx.settings.background;
        return (false, None);
    }
    let m = ctx.material(scene.material_id(hit));
    // The hit point rebuilt from the primitive, with its error bound (crate::spawn).
    let point = scene.surface_point(hit, &ray);
    let normals = scene.normals(hit, &ray, point.p);
    // Whether the ray meets the side the geometric normal faces.
    let front = normals.is_some_and(|(geometric, _)| geometric.dot(ray.dir) < 0.0);
    if path.count_emission && (front || m.two_sided) {
        path.radiance += path.throughput * m.emission;
    }
    let Some((geometric, shading)) = normals else {
        return (false, None);
    };
    // Both normals turned to the side the ray comes from.
    let ng = if front { geometric } else { -geometric };
    let ns = if shading.dot(ng) > 0.0 { shading } else { ng };
    let diffuse = matches!(m.kind, MaterialKind::Diffuse | MaterialKind::Emissive);
    let mut shadow = None;
    let rng = &mut path.rng;
    let dir = match m.kind {
        MaterialKind::Diffuse | MaterialKind::Emissive => {
            let origin = point.spawn_origin(ng);
            let factor = path.throughput * m.albedo;
            match direct_light(ctx, origin, ns, rng) {
                Some((ray, light)) => shadow = Some(Shadow { ray, factor, light }),
                None => path.radiance += factor * Vec3::ZERO,
            }
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
        return (false, shadow);
    };
    path.throughput *= m.albedo;
    path.count_emission = !diffuse || ctx.lights.is_empty();
    // Leave the surface on the side the new direction goes to, by the distance its rounding error
    // calls for (pbrt-v4's `OffsetRayOrigin`, after Wächter & Binder, Ray Tracing Gems ch. 6; see
    // crate::spawn), so the ray cannot hit the surface it leaves.
    let side = if dir.dot(ng) >= 0.0 { ng } else { -ng };
    path.ray = Ray::new(point.spawn_origin(side), dir);
    (true, shadow)
}

/// Next-event estimation at a Lambertian point (`origin`, already off the surface, with unit
/// normal `n`): one point on one light, as a shadow ray towards it and the light it brings if
/// nothing blocks it — the incident radiance times `cosθ / π`, which multiplied by the albedo is
/// the reflected direct light. `None` where that light is zero whatever the shadow ray finds.
fn direct_light<W: World>(
    ctx: &Context<W>,
    origin: Vec3,
    n: Vec3,
    rng: &mut Pcg32,
) -> Option<(Ray, Vec3)> {
    let count = ctx.lights.len();
    if count == 0 {
        return None;
    }
    let pick = ((rng.next_f32() * count as f32) as usize).min(count - 1);
    let prim = ctx.lights[pick];
    let (u1, u2) = (rng.next_f32(), rng.next_f32());
    let (q, nl, area) = ctx.scene.point_on(prim, u1, u2)?;
    let to_light = q - origin;
    let dist2 = to_light.length_squared();
    let dist = math::sqrt(dist2);
    let wi = to_light / dist;
    let light = ctx.material(ctx.scene.light_material_id(prim));
    // A one-sided light sends nothing to points behind it (as emission where a ray lands on it).
    let cos_there = if light.two_sided {
        wi.dot(nl).abs()
    } else {
        -wi.dot(nl)
    };
    let cos_here = wi.dot(n);
    if !(cos_here > 0.0 && cos_there > 0.0 && dist2 > 0.0) {
        return None;
    }
    // Stop short of the light's surface so that it does not shadow itself.
    let shadow = Ray::new(origin, wi).with_range(0.0, dist * (1.0 - SHADOW_SLACK));
    // pdf of the point, per unit area: 1 / (count · area); converted to solid angle by
    // dist² / cos_there.
    let light = light.emission * (cos_here * cos_there / dist2 * area * count as f32 / PI);
    Some((shadow, light))
}

/// Fraction of a shadow ray's length left out at the light's end, so that the light's own surface
/// (whose sampled point has rounding error) does not count as a blocker: pbrt-v4's
/// `ShadowEpsilon` in `SpawnRayTo`, here 2⁻¹². The origin end needs no such slack (crate::spawn).
const SHADOW_SLACK: f32 = 1.0 / (1 << 12) as f32;
