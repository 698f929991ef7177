//! Many pixels' paths advancing as one wavefront ([`Bounces::Stream`](super::Bounces::Stream)):
//! each round, all live paths' rays are one ray stream ([`crate::traverse::stream`]), and so are
//! all the shadow rays the round's vertices ask for.
//!
//! A pixel's eight side-by-side samples ([`super::pixel`]) make an 8-wide packet whose bounce
//! rays start near one point but scatter over the hemisphere, so the packet's lanes soon part
//! ways and each walk pays for eight. A wavefront hands the stream hundreds of such rays at once;
//! the stream sorts them by direction octant and origin, traces the runs that agree as packets
//! and the rest as interleaved single-ray walks whose memory loads overlap (Laine, Karras & Aila
//! 2013, "Megakernels Considered Harmful: Wavefront Path Tracing on GPUs", §4, regroups a GPU
//! path tracer's rays the same way; here without queues per material, since one [`vertex`]
//! function serves every material).
//!
//! No path depends on another: each runs [`vertex`] on its own hits in the same order as the
//! one-path trace (vertex, then its shadow ray's answer, then the next bounce), and the stream's
//! answers are the scalar walk's, so every path gathers the same radiance, bit for bit, and the
//! paths are summed into their pixels in input order.

use super::path::{Context, Path, Shadow, add_path, camera_path, vertex};
use super::{Frame, SampleSums};
use crate::camera::Camera;
use crate::format::Scene;
use crate::ray::{Hit, Ray};
use crate::traverse::Contents;
use crate::traverse::stream::{self, Config};
use core::ops::Range;
use glam::Vec3;

/// Some samples of one pixel: the unit of work [`Frame::add_pixels`] takes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PixelSamples {
    pub x: u32,
    pub y: u32,
    /// The pixel's sample indices to render, in order.
    pub samples: Range<u32>,
}

/// Room for a wavefront of up to `N` paths, the state of each and the rays of one round; owned by
/// the caller (no allocation in the core) and reused from call to call. About 220 bytes a path.
pub struct Wavefront<const N: usize> {
    paths: [Path; N],
    /// The job (index into [`Frame::add_pixels`]'s `jobs`) each path belongs to.
    owner: [usize; N],
    /// The paths still going, in path order.
    live: [u32; N],
    /// One round's rays (bounce rays, then shadow rays) and their answers.
    rays: [Ray; N],
    hits: [Hit; N],
    occluded: [bool; N],
    /// The shadow rays' paths and what each brings.
    shadow_of: [u32; N],
    shadows: [Shadow; N],
    /// The stream's scratch: [`stream::scratch_words`] of `N` rays.
    pairs: [[u64; 2]; N],
}

impl<const N: usize> Wavefront<N> {
    /// An empty wavefront.
    pub fn new() -> Self {
        const { assert!(N > 0 && N <= u32::MAX as usize) };
        let idle_ray = Path::IDLE.ray;
        Self {
            paths: [Path::IDLE; N],
            owner: [0; N],
            live: [0; N],
            rays: [idle_ray; N],
            hits: [Hit::MISS; N],
            occluded: [false; N],
            shadow_of: [0; N],
            shadows: [Shadow {
                ray: idle_ray,
                factor: Vec3::ZERO,
                light: Vec3::ZERO,
            }; N],
            pairs: [[0; 2]; N],
        }
    }
}

impl<const N: usize> Default for Wavefront<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// [`Frame::add_pixels`] for [`Bounces::Stream`](super::Bounces::Stream), contents `K`. The
/// caller has checked the jobs.
pub(super) fn add_pixels<K: Contents, C: Camera, const N: usize>(
    frame: &Frame<C>,
    jobs: &[PixelSamples],
    sums: &mut [SampleSums],
    wave: &mut Wavefront<N>,
) {
    trace_jobs::<K, C, N>(frame, wave, jobs.iter().cloned(), |j, path| {
        if let Some(s) = sums.get_mut(j) {
            add_path(s, path);
        }
    });
}

/// [`super::render_rows`] for [`Bounces::Stream`](super::Bounces::Stream): each pixel of `out`
/// gets the mean of its `spp` samples, summed in sample order in the pixel itself and then
/// divided, as [`super::render_rows_with`] does. The caller has checked `out`.
pub(super) fn render_rows<K: Contents, C: Camera, const N: usize>(
    frame: &Frame<C>,
    first_row: u32,
    out: &mut [[f32; 3]],
    wave: &mut Wavefront<N>,
) {
    let (w, spp) = (frame.settings.width as usize, frame.settings.spp);
    out.fill([0.0; 3]);
    let jobs = (0..out.len()).map(|k| PixelSamples {
        x: (k % w) as u32,
        y: first_row + (k / w) as u32,
        samples: 0..spp,
    });
    trace_jobs::<K, C, N>(frame, wave, jobs, |k, path| {
        if let Some(pixel) = out.get_mut(k) {
            let mut s = SampleSums {
                sum: Vec3::from(*pixel),
                ..SampleSums::default()
            };
            add_path(&mut s, path);
            *pixel = s.sum.to_array();
        }
    });
    for pixel in out.iter_mut() {
        *pixel = (Vec3::from(*pixel) / spp as f32).to_array();
    }
}

/// Fills the wavefront with the camera paths of `jobs` (job by job, each job's samples in
/// order), traces it whenever it is full and at the end, and hands each finished path to
/// `add` with its job's index, in that same order.
fn trace_jobs<K: Contents, C: Camera, const N: usize>(
    frame: &Frame<C>,
    wave: &mut Wavefront<N>,
    jobs: impl Iterator<Item = PixelSamples>,
    mut add: impl FnMut(usize, &Path),
) {
    let ctx = frame.context();
    let mut n = 0;
    for (j, job) in jobs.enumerate() {
        for sample in job.samples {
            if let Some(path) = camera_path(frame.settings, frame.camera, job.x, job.y, sample) {
                wave.paths[n] = path;
                wave.owner[n] = j;
                n += 1;
                if n == N {
                    wave.run::<K>(&ctx, n);
                    wave.finish(n, &mut add);
                    n = 0;
                }
            }
        }
    }
    if n > 0 {
        wave.run::<K>(&ctx, n);
        wave.finish(n, &mut add);
    }
}

impl<const N: usize> Wavefront<N> {
    /// Traces paths `0..n` to their ends, round by round.
    fn run<K: Contents>(&mut self, ctx: &Context<Scene>, n: usize) {
        let max_depth = ctx.settings.max_depth;
        let config = Config::default();
        let scene = ctx.scene;
        for (i, path) in self.paths[..n].iter().enumerate() {
            self.live[i] = i as u32;
            self.rays[i] = path.ray;
        }
        let mut live = if max_depth == 0 { 0 } else { n };
        let mut depth = 0;
        while live > 0 {
            depth += 1;
            let (rays, hits) = (&self.rays[..live], &mut self.hits[..live]);
            stream::intersect_with::<K>(scene, &config, rays, hits, &mut self.pairs);
            // Each live path's vertex; the paths that go on stay in `live` (in order), the shadow
            // rays take the front of `rays` (ray `j` was read for hit `j` already).
            let (mut next, mut shadows) = (0, 0);
            for j in 0..live {
                let p = self.live[j];
                let (goes_on, shadow) = vertex(ctx, &mut self.paths[p as usize], &self.hits[j]);
                if let Some(shadow) = shadow {
                    self.rays[shadows] = shadow.ray;
                    self.shadows[shadows] = shadow;
                    self.shadow_of[shadows] = p;
                    shadows += 1;
                }
                if goes_on {
                    self.live[next] = p;
                    next += 1;
                }
            }
            if shadows > 0 {
                let (rays, occluded) = (&self.rays[..shadows], &mut self.occluded[..shadows]);
                stream::occluded_with::<K>(scene, &config, rays, occluded, &mut self.pairs);
                for k in 0..shadows {
                    let path = &mut self.paths[self.shadow_of[k] as usize];
                    path.resolve(&self.shadows[k], self.occluded[k]);
                }
            }
            live = if depth == max_depth { 0 } else { next };
            for j in 0..live {
                self.rays[j] = self.paths[self.live[j] as usize].ray;
            }
        }
    }

    /// Hands paths `0..n` to `add` in order, with their jobs.
    fn finish(&self, n: usize, add: &mut impl FnMut(usize, &Path)) {
        for (path, &owner) in self.paths[..n].iter().zip(&self.owner[..n]) {
            add(owner, path);
        }
    }
}
