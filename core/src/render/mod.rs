//! The render kernel: a unidirectional path tracer that writes linear RGB radiance into a
//! caller's buffer, row by row, with no allocation.
//!
//! Each pixel's samples are jittered inside the pixel. How their paths are traced is
//! [`Bounces`]' choice, and every choice gives the same image:
//! - [`Bounces::Packets`] (the default): a pixel's samples eight at a time, side by side
//!   (`render/pixel.rs`), each round of their camera, bounce and shadow rays one 8-wide packet, the lanes
//!   of finished paths masked;
//! - [`Bounces::Stream`]: many pixels' paths as one wavefront ([`Wavefront`],
//!   `render/wavefront.rs`), each round of all their rays one ray stream
//!   ([`crate::traverse::stream`]), which sorts the incoherent bounce and shadow rays into
//!   one-octant packets — the fastest where the caller can hold a wavefront (`kdray render`'s
//!   default);
//! - [`Bounces::SingleRays`]: every ray through the scalar walk ([`Scene::intersect`]).
//!
//! One path vertex function (`render/path.rs`) serves all three.
//!
//! Light transport, per path vertex (at most [`Settings::max_depth`] of them):
//! - `Diffuse` and `Emissive` surfaces scatter Lambertian-wise, by cosine-weighted sampling, so
//!   the throughput is multiplied by `albedo` alone (the cosine and π cancel against the pdf), and
//!   take direct light by next-event estimation: one point picked uniformly by area on one light
//!   picked uniformly from the caller's list, with a shadow ray;
//! - `Mirror` reflects about the shading normal, times `albedo`;
//! - `Glass` reflects with the exact Fresnel probability ([`crate::optics::fresnel_dielectric`]) and
//!   otherwise refracts ([`crate::optics::refract`]), times `albedo` either way;
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

#[cfg(feature = "instances")]
mod instanced;
mod path;
mod pixel;
mod wavefront;
mod world;

#[cfg(feature = "instances")]
pub use instanced::{InstanceLight, InstancedFrame, instanced_emitters};
pub use path::emitters;
pub use wavefront::{PixelSamples, Wavefront};

use crate::camera::Camera;
use crate::format::Scene;
use crate::traverse::{Contents, Mode, by_contents};
use core::ops::Range;
use glam::Vec3;
use path::Context;

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

/// How [`render_rows`] traces the bounce and shadow rays of a pixel's paths. All give the same
/// image, bit for bit (each path makes the same choices from the same random numbers, and packet
/// and stream traversal find what the scalar walk finds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Bounces {
    /// A pixel's (up to) eight samples advance together: each round of bounce rays, and of shadow
    /// rays, is one 8-wide packet with the finished paths' lanes inactive. The default here, as it
    /// needs no memory beyond one pixel's paths; where many pixels are rendered at once,
    /// [`Bounces::Stream`] is faster (`kdray render`'s default; docs/BENCHMARKS.md, "The
    /// renderer's rays as streams").
    #[default]
    Packets,
    /// Each path on its own, every ray (the camera's too) through the scalar walk: the reference,
    /// and meant for targets where `wide` emulates its lanes in scalar code (e.g. Cortex-M4F), where
    /// a packet costs eight rays' work however few of its lanes are live.
    SingleRays,
    /// Many pixels' paths advance as one wavefront ([`Wavefront`]): each round of all their
    /// bounce rays, and of all their shadow rays, is one ray stream ([`crate::traverse::stream`]:
    /// coherent runs as packets, the rest sorted by octant and origin into one-octant packets, what
    /// is left as interleaved single rays). Measured 1.1× (dragon scene) to 1.4× (default scene)
    /// the speed of [`Bounces::Packets`] on one thread with 2048-path wavefronts. Needs many pixels
    /// at once: [`render_rows`] (a wavefront of [`ROWS_WAVEFRONT`] paths on the stack) and
    /// [`Frame::add_pixels`] (the caller's wavefront); [`Frame::add_samples`], one pixel, traces as
    /// [`Bounces::Packets`].
    Stream,
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
    by_contents!(scene, settings.mode, |K| match settings.bounces {
        Bounces::Packets => {
            render_rows_with::<K, C, true>(
                scene, camera, materials, lights, settings, first_row, out,
            )
        }
        Bounces::SingleRays => {
            render_rows_with::<K, C, false>(
                scene, camera, materials, lights, settings, first_row, out,
            )
        }
        Bounces::Stream => {
            let frame = Frame {
                scene,
                camera,
                materials,
                lights,
                settings,
            };
            check_rows(settings, first_row, out)?;
            let mut wave = Wavefront::<ROWS_WAVEFRONT>::new();
            wavefront::render_rows::<K, C, ROWS_WAVEFRONT>(&frame, first_row, out, &mut wave);
            Ok(())
        }
    })
}

/// The paths of the wavefront [`render_rows`] keeps on the stack for [`Bounces::Stream`]
/// (about 55 KB).
pub const ROWS_WAVEFRONT: usize = 256;

/// Checks that `out` is whole rows from `first_row` inside the image.
fn check_rows(settings: &Settings, first_row: u32, out: &[[f32; 3]]) -> Result<(), RenderError> {
    let (w, h) = (settings.width, settings.height);
    if w == 0 || h == 0 || settings.spp == 0 {
        return Err(RenderError::EmptyImage);
    }
    let rows = out.len() / w as usize;
    if !out.len().is_multiple_of(w as usize) || first_row as usize + rows > h as usize {
        return Err(RenderError::BufferSize);
    }
    Ok(())
}

/// Whether `scene` holds only primitive kinds that `K` handles: the precondition of
/// [`render_rows_with`] for a target that names its contents.
pub fn kernel_fits<K: Contents>(scene: &Scene) -> bool {
    (K::TRIANGLES || scene.tri_count() == 0)
        && (K::SPHERES || scene.sphere_count() == 0)
        && (K::GROUPS || !scene.has_groups())
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
    check_rows(settings, first_row, out)?;
    let w = settings.width;
    let ctx = Context {
        scene,
        materials,
        lights,
        settings,
    };
    for (k, pixel) in out.iter_mut().enumerate() {
        let (x, y) = ((k % w as usize) as u32, first_row + (k / w as usize) as u32);
        let mut sums = SampleSums::default();
        pixel::render_pixel::<K, C, PACKETS>(&ctx, camera, x, y, 0..settings.spp, &mut sums);
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

impl<'a, 's, C: Camera> Frame<'a, 's, C> {
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
        by_contents!(
            self.scene,
            self.settings.mode,
            |K| match self.settings.bounces {
                Bounces::Packets | Bounces::Stream =>
                    self.add_samples_with::<K, true>(x, y, samples, sums),
                Bounces::SingleRays => self.add_samples_with::<K, false>(x, y, samples, sums),
            }
        )
    }

    /// Adds samples `jobs[k].samples` of pixel `(jobs[k].x, jobs[k].y)` to `sums[k]`, for every
    /// `k`: the same sums, bit for bit, as [`Frame::add_samples`] for each job in turn. With
    /// [`Bounces::Stream`] the jobs' paths go through `wave` as wavefronts of up to `N` paths (a
    /// pixel's samples in order, so each pixel's sums are added to in sample order); otherwise
    /// `wave` is not used.
    ///
    /// # Errors
    /// [`RenderError::EmptyImage`] for a zero width or height; [`RenderError::BufferSize`] for a
    /// pixel outside the image or `sums` not as long as `jobs` (nothing is rendered then).
    pub fn add_pixels<const N: usize>(
        &self,
        jobs: &[PixelSamples],
        sums: &mut [SampleSums],
        wave: &mut Wavefront<N>,
    ) -> Result<(), RenderError> {
        let s = self.settings;
        if s.width == 0 || s.height == 0 {
            return Err(RenderError::EmptyImage);
        }
        if sums.len() != jobs.len() || jobs.iter().any(|j| j.x >= s.width || j.y >= s.height) {
            return Err(RenderError::BufferSize);
        }
        if s.bounces != Bounces::Stream {
            for (job, sums) in jobs.iter().zip(sums) {
                self.add_samples(job.x, job.y, job.samples.clone(), sums)?;
            }
            return Ok(());
        }
        by_contents!(self.scene, s.mode, |K| {
            wavefront::add_pixels::<K, C, N>(self, jobs, sums, wave)
        });
        Ok(())
    }

    /// The context every path of this frame reads.
    fn context(&self) -> Context<'a, Scene<'s>> {
        Context {
            scene: self.scene,
            materials: self.materials,
            lights: self.lights,
            settings: self.settings,
        }
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
        pixel::render_pixel::<K, C, PACKETS>(&self.context(), self.camera, x, y, samples, sums);
        Ok(())
    }
}
