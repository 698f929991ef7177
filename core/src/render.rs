//! The render kernel: a unidirectional path tracer that writes linear RGB radiance into a
//! caller's buffer, row by row, with no allocation.
//!
//! Each pixel's samples are jittered inside the pixel and traced eight at a time, side by side:
//! with [`Bounces::Packets`] (the default) each round of their camera, bounce and shadow rays is one
//! 8-wide packet, the lanes of finished paths masked: even diffuse bounces, which are incoherent,
//! trace faster that way than one by one (docs/BENCHMARKS.md, "Which path is used when");
//! [`Bounces::SingleRays`] sends every ray through the scalar walk ([`Scene::intersect`]) and gives
//! the same image.
//!
//! Light transport, per path vertex (at most [`Settings::max_depth`] of them):
//! - `Diffuse` and `Emissive` surfaces scatter Lambertian-wise, by cosine-weighted sampling, so
//!   the throughput is multiplied by `albedo` alone (the cosine and π cancel against the pdf), and
//!   take direct light by next-event estimation: one point picked uniformly by area on one light
//!   picked uniformly from the caller's list, with a shadow ray;
//! - `Mirror` reflects about the shading normal, times `albedo`;
//! - `Glass` reflects with the exact Fresnel probability ([`optics::fresnel_dielectric`]) and
//!   otherwise refracts ([`optics::refract`]), times `albedo` either way;
//! - emission is added where a camera ray or a specular bounce lands on it; after a diffuse
//!   bounce it is not, since next-event estimation counted it. A light emits from the side its
//!   geometric normal faces (a triangle's `(v1 − v0) × (v2 − v0)`, a sphere's outside) unless its
//!   material is [`Material::two_sided`]; emission and next-event estimation agree on this, so
//!   the two estimators of direct light have the same mean;
//! - a ray that leaves the scene adds `background`.
//!
//! Bounce, refraction and shadow rays start from the hit point moved off its surface by a bound
//! derived from that point's floating-point error ([`crate::spawn`]), so they never hit the
//! surface they leave, at any scale.
//!
//! A sample's camera ray comes from [`Camera::sample`], whose weight scales everything the path
//! gathers; a sample the camera drops (a lens's rim) adds zero but still counts in the mean.
//!
//! Each sample depends only on the pixel, the sample index and [`Settings::seed`], so an image
//! does not depend on how rows are split between threads.

use crate::camera::Camera;
use crate::format::{Scene, contents};
use crate::math;
use crate::optics;
use crate::ray::{Hit, Ray};
use crate::sampling::{Onb, Pcg32, cosine_hemisphere};
use crate::simd::lanes::set_lanes;
use crate::simd::{Lanes, RayPacket, f32x8};
use crate::traverse::{Contents, Mixed, Mode, Spheres, Triangles, Watertight};
use crate::triangle::shading_normal;
use core::f32::consts::PI;
use core::ops::Range;
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
    /// Whether the surface emits from both sides; otherwise only from the side its geometric
    /// normal faces.
    pub two_sided: bool,
}

impl Material {
    /// What a primitive whose material id has no entry gets: diffuse, albedo 0.8.
    pub const FALLBACK: Material = Material {
        kind: MaterialKind::Diffuse,
        albedo: Vec3::splat(0.8),
        emission: Vec3::ZERO,
        ior: 1.5,
        two_sided: false,
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
    /// How the rays after the camera's are traced; the image is the same either way.
    pub bounces: Bounces,
    /// The triangle test and walk every ray uses: [`Mode::Fast`], or [`Mode::Watertight`] so
    /// that no ray slips through a seam of a closed mesh (`[render] watertight = true`). Read by
    /// [`render_rows`] and [`Frame`], which pick the kernels; [`render_rows_with`]'s type decides.
    pub mode: Mode,
}

/// How [`render_rows`] traces the bounce and shadow rays of a pixel's paths. Both give the same
/// image, bit for bit (each path makes the same choices from the same random numbers, and packet
/// traversal finds what the scalar walk finds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Bounces {
    /// A pixel's (up to) eight samples advance together: each round of bounce rays, and of shadow
    /// rays, is one 8-wide packet with the finished paths' lanes inactive. The faster choice where
    /// `wide` has SIMD registers (docs/BENCHMARKS.md, "Which path is used when").
    #[default]
    Packets,
    /// Each path on its own, every ray (the camera's too) through the scalar walk: the reference,
    /// and meant for targets where `wide` emulates its lanes in scalar code (e.g. Cortex-M4F), where
    /// a packet costs eight rays' work however few of its lanes are live.
    SingleRays,
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

/// `$body` with `$k` the [`Contents`] type of `$settings.mode` (wrapped in [`Watertight`] for
/// [`Mode::Watertight`]) and of `$scene`'s primitive kinds, and `$p` whether `$settings.bounces`
/// asks for packets: the run-time choice of a kernel monomorphized at compile time.
macro_rules! by_kernel {
    ($scene:expr, $settings:expr, |$k:ident, $p:ident| $body:expr) => {{
        let packets = $settings.bounces == Bounces::Packets;
        match ($settings.mode, packets) {
            (Mode::Fast, true) => by_kernel!(@kinds $scene, Plain, true, $k, $p, $body),
            (Mode::Fast, false) => by_kernel!(@kinds $scene, Plain, false, $k, $p, $body),
            (Mode::Watertight, true) => by_kernel!(@kinds $scene, Watertight, true, $k, $p, $body),
            (Mode::Watertight, false) => {
                by_kernel!(@kinds $scene, Watertight, false, $k, $p, $body)
            }
        }
    }};
    (@kinds $scene:expr, $w:ident, $v:expr, $k:ident, $p:ident, $body:expr) => {{
        match $scene.contents() & (contents::TRIANGLES | contents::SPHERES) {
            contents::TRIANGLES => by_kernel!(@arm $k = $w<Triangles>, $p = $v, $body),
            contents::SPHERES => by_kernel!(@arm $k = $w<Spheres>, $p = $v, $body),
            _ => by_kernel!(@arm $k = $w<Mixed>, $p = $v, $body),
        }
    }};
    (@arm $k:ident = $t:ty, $p:ident = $v:expr, $body:expr) => {{
        type $k = $t;
        const $p: bool = $v;
        $body
    }};
}

/// The contents `C` in fast mode: [`by_kernel`]'s counterpart of [`Watertight`].
type Plain<C> = C;

/// Renders the rows `first_row..` that `out` holds (row-major, `settings.width` pixels a row):
/// each pixel gets the mean radiance of its `spp` samples, linear RGB.
///
/// `lights` lists the primitives whose material emits (every one of them: emission that a
/// diffuse bounce lands on is counted only through this list); [`emitters`] finds them.
///
/// Traces with the kernels monomorphized for the scene's contents ([`render_rows_with`]).
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
    by_kernel!(scene, settings, |K, P| {
        render_rows_with::<K, C, P>(scene, camera, materials, lights, settings, first_row, out)
    })
}

/// Whether `scene` holds only primitive kinds that `K` handles: the precondition of
/// [`render_rows_with`] for a target that names its contents.
pub fn kernel_fits<K: Contents>(scene: &Scene) -> bool {
    (K::TRIANGLES || scene.tri_count() == 0) && (K::SPHERES || scene.sphere_count() == 0)
}

/// [`render_rows`] with the traversal kernels for a fixed [`Contents`] and a fixed way of tracing
/// bounces, whatever `settings.bounces` says: `PACKETS` as [`Bounces::Packets`], otherwise as
/// [`Bounces::SingleRays`] (the image is the same), and in the mode `K` names (`Watertight<_>` for
/// watertight mode), whatever `settings.mode` says. Firmware that names its contents links only
/// that kernel, and with `PACKETS = false` no packet code at all, for targets where `wide`
/// emulates its lanes in scalar code (Cortex-M4F; the bytes table in `targets/cortex-m4f/README.md`).
/// The scene must hold no other kind of primitive than `K` ([`kernel_fits`]; one would be tested
/// as the wrong kind, never out of bounds).
///
/// # Errors
/// As [`render_rows`].
pub fn render_rows_with<K: Contents, C: Camera, const PACKETS: bool>(
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
        let mut sums = SampleSums::default();
        render_pixel::<K, C, PACKETS>(&ctx, camera, x, y, 0..settings.spp, &mut sums);
        *pixel = (sums.sum / settings.spp as f32).to_array();
    }
    Ok(())
}

/// Everything a render reads, for callers that choose each pixel's samples themselves
/// (progressive passes, adaptive sampling): [`Frame::add_samples`] renders any range of a
/// pixel's samples. `settings.spp` is not read.
#[derive(Clone, Copy)]
pub struct Frame<'a, 's, C> {
    pub scene: &'a Scene<'s>,
    pub camera: &'a C,
    pub materials: &'a [Material],
    /// As for [`render_rows`]: every emitting primitive, see [`emitters`].
    pub lights: &'a [u32],
    pub settings: &'a Settings,
}

/// The running sum and sum of squares (per channel) of a pixel's sample radiances, and the rays
/// traced for them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleSums {
    pub sum: Vec3,
    pub sum_sq: Vec3,
    /// Rays traced for these samples: camera, bounce and shadow rays.
    pub rays: u64,
}

impl<C: Camera> Frame<'_, '_, C> {
    /// Adds samples `samples` of pixel `(x, y)` to `sums`, one after the other in sample order.
    /// Sample `i` of a pixel is the same whichever call renders it, and the sums are added to
    /// in the same order, so `0..a` then `a..b` give exactly, bit for bit, the sums of `0..b`;
    /// [`render_rows`] writes `sum / spp` of `0..spp`. Ranges that start at a multiple of 8 fill
    /// the 8-wide packets best.
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
        by_kernel!(self.scene, self.settings, |K, P| {
            self.add_samples_with::<K, P>(x, y, samples, sums)
        })
    }

    /// [`Frame::add_samples`] with the kernel chosen at compile time, as [`render_rows_with`]:
    /// contents `K` (the scene must fit it, [`kernel_fits`]) and packets or not, whatever
    /// `settings.bounces` says.
    ///
    /// # Errors
    /// As [`Frame::add_samples`].
    pub fn add_samples_with<K: Contents, const PACKETS: bool>(
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
        let ctx = Context {
            scene: self.scene,
            materials: self.materials,
            lights: self.lights,
            settings: s,
        };
        render_pixel::<K, C, PACKETS>(&ctx, self.camera, x, y, samples, sums);
        Ok(())
    }
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

/// Adds pixel `(x, y)`'s sample radiances over `samples` to `sums`, in sample order; bounce
/// rays as 8-wide packets when `PACKETS`.
fn render_pixel<K: Contents, C: Camera, const PACKETS: bool>(
    ctx: &Context,
    camera: &C,
    x: u32,
    y: u32,
    samples: Range<u32>,
    sums: &mut SampleSums,
) {
    let settings = ctx.settings;
    let pixel = u64::from(y) * u64::from(settings.width) + u64::from(x);
    let mut first = samples.start;
    while first < samples.end {
        let n = (samples.end - first).min(8) as usize;
        let mut paths = [Path::new(Ray::new(Vec3::ZERO, Vec3::Z), Pcg32::new(0, 0), 0.0); 8];
        // The samples the camera keeps, packed to the front.
        let mut kept = 0;
        for i in 0..n {
            let mut rng = Pcg32::new(settings.seed, pixel << 32 | u64::from(first + i as u32));
            let (jx, jy) = (rng.next_f32(), rng.next_f32());
            let (px, py) = (x as f32 + jx, y as f32 + jy);
            if let Some((ray, weight)) =
                camera.sample(px, py, settings.width, settings.height, &mut rng)
            {
                paths[kept] = Path::new(ray, rng, weight);
                kept += 1;
            }
        }
        let paths = &mut paths[..kept];
        if paths.is_empty() {
            // The camera dropped every sample of this round: nothing to trace.
        } else if PACKETS {
            trace_paths_packed::<K>(ctx, paths);
        } else {
            paths.iter_mut().for_each(|p| trace_path::<K>(ctx, p));
        }
        for path in paths.iter() {
            // A non-finite sample (a NaN from a degenerate normal, say) is dropped, not spread.
            if path.radiance.is_finite() {
                sums.sum += path.radiance;
                sums.sum_sq += path.radiance * path.radiance;
            }
            sums.rays += u64::from(path.rays);
        }
        first += n as u32;
    }
}

/// One sample's path: the ray it follows next, its random numbers and what it has gathered.
#[derive(Clone, Copy)]
struct Path {
    ray: Ray,
    rng: Pcg32,
    radiance: Vec3,
    throughput: Vec3,
    /// Whether emission where `ray` lands counts (camera rays, specular bounces, no lights).
    count_emission: bool,
    /// Rays traced so far, shadow rays included.
    rays: u32,
}

/// A shadow ray that a path vertex waits on: if nothing blocks `ray`, the path gains
/// `factor * light`, otherwise `factor * 0`.
#[derive(Clone, Copy)]
struct Shadow {
    ray: Ray,
    factor: Vec3,
    light: Vec3,
}

impl Path {
    /// A path starting with camera ray `ray` of weight `weight`.
    fn new(ray: Ray, rng: Pcg32, weight: f32) -> Self {
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
    fn resolve(&mut self, shadow: &Shadow, occluded: bool) {
        let light = if occluded { Vec3::ZERO } else { shadow.light };
        self.radiance += shadow.factor * light;
        self.rays += 1;
    }
}

/// One path all by itself: every ray through the scalar walk.
fn trace_path<K: Contents>(ctx: &Context, path: &mut Path) {
    let mut hit = ctx.scene.intersect_with::<K>(&path.ray);
    for depth in 1..=ctx.settings.max_depth {
        let (goes_on, shadow) = vertex(ctx, path, &hit);
        if let Some(shadow) = shadow {
            path.resolve(&shadow, ctx.scene.occluded_with::<K>(&shadow.ray));
        }
        if !goes_on || depth == ctx.settings.max_depth {
            return;
        }
        hit = ctx.scene.intersect_with::<K>(&path.ray);
    }
}

/// Up to eight paths side by side: each round's camera or bounce rays are one 8-wide packet, and
/// so are its shadow rays, with the lanes of finished paths (or of paths without a shadow ray)
/// inactive. Every lane does exactly what [`trace_path`] does for it, in the same order, and the
/// packet traversal finds what the scalar walk finds, so the image is the same.
fn trace_paths_packed<K: Contents>(ctx: &Context, paths: &mut [Path]) {
    let scene = ctx.scene;
    let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
    let mut live = 0u32;
    for (i, path) in paths.iter().enumerate() {
        rays[i] = path.ray;
        live |= 1 << i;
    }
    let mut hits = scene.intersect_packet_with::<K, f32x8>(&packet(&rays, live));
    for depth in 1..=ctx.settings.max_depth {
        let mut shadows = [None; 8];
        let (mut next, mut waiting) = (0u32, 0u32);
        for i in set_lanes(live) {
            let (goes_on, shadow) = vertex(ctx, &mut paths[i], &hits.hit(i));
            if let Some(shadow) = shadow {
                rays[i] = shadow.ray;
                waiting |= 1 << i;
            }
            shadows[i] = shadow;
            next |= u32::from(goes_on) << i;
        }
        if waiting != 0 {
            let occluded = scene
                .occluded_packet_with::<K, f32x8>(&packet(&rays, waiting))
                .bitmask();
            for i in set_lanes(waiting) {
                if let Some(shadow) = &shadows[i] {
                    paths[i].resolve(shadow, occluded >> i & 1 == 1);
                }
            }
        }
        live = next;
        if live == 0 || depth == ctx.settings.max_depth {
            return;
        }
        for i in set_lanes(live) {
            rays[i] = paths[i].ray;
        }
        hits = scene.intersect_packet_with::<K, f32x8>(&packet(&rays, live));
    }
}

/// The packet of `rays` with only the lanes in `mask` active.
fn packet(rays: &[Ray; 8], mask: u32) -> RayPacket<f32x8> {
    let mut packet = RayPacket::from_rays(rays);
    packet.active &= f32x8::mask_from_bits(mask);
    packet
}

/// The path vertex where `path.ray` lands (`hit`): adds what it emits and, after a diffuse
/// bounce, returns the shadow ray of its direct light; then either turns `path.ray` into the next
/// bounce and returns `true`, or ends the path (`false`).
fn vertex(ctx: &Context, path: &mut Path, hit: &Hit) -> (bool, Option<Shadow>) {
    let scene = ctx.scene;
    let ray = path.ray;
    path.rays += 1;
    if !hit.is_hit() {
        path.radiance += path.throughput * ctx.settings.background;
        return (false, None);
    }
    let m = ctx.material(hit.prim);
    // The hit point rebuilt from the primitive, with its error bound (crate::spawn).
    let point = scene.surface_point(hit, &ray);
    let normals = normals(scene, hit, point.p);
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
fn direct_light(ctx: &Context, origin: Vec3, n: Vec3, rng: &mut Pcg32) -> Option<(Ray, Vec3)> {
    let count = ctx.lights.len();
    if count == 0 {
        return None;
    }
    let pick = ((rng.next_f32() * count as f32) as usize).min(count - 1);
    let prim = ctx.lights[pick];
    let (u1, u2) = (rng.next_f32(), rng.next_f32());
    let (q, nl, area) = point_on(ctx.scene, prim, u1, u2)?;
    let to_light = q - origin;
    let dist2 = to_light.length_squared();
    let dist = math::sqrt(dist2);
    let wi = to_light / dist;
    let light = ctx.material(prim);
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

/// Fraction of a shadow ray's length left out at the light's end, so that the light's own surface
/// (whose sampled point has rounding error) does not count as a blocker: pbrt-v4's
/// `ShadowEpsilon` in `SpawnRayTo`, here 2⁻¹². The origin end needs no such slack (crate::spawn).
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
