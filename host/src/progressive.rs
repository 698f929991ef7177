//! Progressive rendering: the image is rendered in passes of a few samples per pixel, kept as
//! per-pixel running sums (a [`Film`]), until a stopping rule ([`Stop`]) is met: a sample count, a
//! time budget, or an estimated noise level. Adaptive sampling ([`Plan::adaptive`]) spends every
//! other pass's samples where the per-pixel variance says they lower the image's error most.
//!
//! Noise estimate: each pixel keeps the sum and the sum of squares of its sample radiances, so
//! its sample variance `s²` is known and the variance of its mean is `s²/n` (the squared standard
//! error of a mean). The image's estimated RMSE is `sqrt(mean over pixels and channels of s²/n)`
//! and its relative RMSE divides that by the image's mean value. Both are estimates of the error
//! against the converged image: a rare bright path (a caustic firefly) that no sample has found
//! yet is not in them.
//!
//! A pixel's sample `i` is the same whatever pass renders it ([`Frame::add_samples`]), and every
//! pixel's passes depend only on the plan, so a band of rows rendered alone has the same pixels,
//! bit for bit, as the same rows of the whole image with the same `--spp` (a time or noise stop
//! depends on how fast the band went, so it can end at other counts).

use core::cell::RefCell;
use core::ops::Range;
use core::sync::atomic::{AtomicU64, Ordering};
use kdray_core::camera::Camera;
use kdray_core::render::{
    Frame, InstancedFrame, PixelSamples, RenderError, SampleSums, Settings, Wavefront,
};
use rayon::prelude::*;
use std::time::Instant;

/// What passes render: a single-mesh scene's [`Frame`] or an instanced scene's
/// [`InstancedFrame`] (every ray a single ray through the two-level walk).
pub trait Pixels: Sync {
    /// The image's settings.
    fn settings(&self) -> &Settings;

    /// Adds samples `jobs[k].samples` of pixel `(jobs[k].x, jobs[k].y)` to `sums[k]`, each
    /// pixel's in sample order ([`Frame::add_pixels`]), on the calling worker's wavefront.
    ///
    /// # Errors
    /// As [`Frame::add_pixels`].
    fn add_pixels(&self, jobs: &[PixelSamples], sums: &mut [SampleSums])
    -> Result<(), RenderError>;
}

impl<C: Camera + Sync> Pixels for Frame<'_, '_, C> {
    fn settings(&self) -> &Settings {
        self.settings
    }

    fn add_pixels(
        &self,
        jobs: &[PixelSamples],
        sums: &mut [SampleSums],
    ) -> Result<(), RenderError> {
        WAVE.with_borrow_mut(|wave| {
            let wave = wave.get_or_insert_with(|| Box::new(Wavefront::new()));
            Frame::add_pixels(self, jobs, sums, wave)
        })
    }
}

impl<C: Camera + Sync> Pixels for InstancedFrame<'_, '_, '_, C> {
    fn settings(&self) -> &Settings {
        self.settings
    }

    fn add_pixels(
        &self,
        jobs: &[PixelSamples],
        sums: &mut [SampleSums],
    ) -> Result<(), RenderError> {
        InstancedFrame::add_pixels(self, jobs, sums)
    }
}

/// Samples per pixel in one pass: one 8-wide packet per pixel.
pub const PASS: u32 = 8;

/// When a progressive render stops: at the first rule met (the sample cap always applies).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Samples per pixel (the mean, with adaptive sampling): at most this many.
    pub spp: u32,
    /// Wall seconds: no pass is started that would end past them (by the last pass's time).
    pub seconds: Option<f64>,
    /// Estimated relative RMSE: stop once it is below this.
    pub noise: Option<f64>,
}

/// What to render: the rows (a band, or the whole image) and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub rows: Range<u32>,
    pub stop: Stop,
    /// Spend every other pass's samples where the variance is (see [`adaptive_counts`]).
    pub adaptive: bool,
}

/// Per-pixel running sums of the rows a render covers. The sums are the core's f32 sums, added
/// to in sample order, so a pixel's mean is bit for bit what [`kdray_core::render::render_rows`]
/// gives for the same samples (and what firmware rendering the same scene checksums).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub rows: Range<u32>,
    pub sums: Vec<SampleSums>,
    pub count: Vec<u32>,
}

impl Film {
    pub fn new(width: u32, rows: Range<u32>) -> Self {
        let n = width as usize * rows.len();
        Self {
            width,
            rows,
            sums: vec![SampleSums::default(); n],
            count: vec![0; n],
        }
    }

    /// Each pixel's mean radiance, `sum / n` in f32 as the core computes it (black where it has
    /// no samples).
    pub fn mean(&self) -> Vec<[f32; 3]> {
        self.sums
            .iter()
            .zip(&self.count)
            .map(|(s, &n)| (s.sum / n.max(1) as f32).to_array())
            .collect()
    }

    /// The unbiased sample variance of pixel `k`'s samples, per channel (0 below two samples).
    pub fn variance(&self, k: usize) -> [f64; 3] {
        let n = f64::from(self.count[k]);
        if n < 2.0 {
            return [0.0; 3];
        }
        let s = &self.sums[k];
        core::array::from_fn(|c| {
            let mean = f64::from(s.sum[c]) / n;
            ((f64::from(s.sum_sq[c]) - n * mean * mean) / (n - 1.0)).max(0.0)
        })
    }

    /// The estimated RMSE of the image against the converged one, and that divided by the
    /// image's mean value (module doc).
    pub fn estimated_error(&self) -> (f64, f64) {
        let pixels = self.count.len().max(1) as f64;
        let (mut mse, mut total) = (0.0, 0.0);
        for k in 0..self.count.len() {
            let n = f64::from(self.count[k].max(1));
            mse += self.variance(k).iter().sum::<f64>() / n;
            total += self.sums[k]
                .sum
                .to_array()
                .iter()
                .map(|&v| f64::from(v))
                .sum::<f64>()
                / n;
        }
        let rmse = (mse / (3.0 * pixels)).sqrt();
        let mean = total / (3.0 * pixels);
        (rmse, if mean > 0.0 { rmse / mean } else { 0.0 })
    }

    /// How many pixels' sums (or sums of squares) are not finite: radiance past f32's range,
    /// which no figure or image should be made from.
    pub fn overflowed(&self) -> usize {
        self.sums
            .iter()
            .filter(|s| !(s.sum.is_finite() && s.sum_sq.is_finite()))
            .count()
    }

    /// Samples per pixel, averaged over the film.
    pub fn mean_spp(&self) -> f64 {
        let total: u64 = self.count.iter().map(|&n| u64::from(n)).sum();
        total as f64 / self.count.len().max(1) as f64
    }
}

/// What a progressive render did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub seconds: f64,
    pub passes: u32,
    /// Camera samples traced (paths started).
    pub samples: u64,
    /// Rays traced: camera, bounce and shadow rays alike.
    pub rays: u64,
    /// Samples per pixel, the mean over the rows rendered.
    pub mean_spp: f64,
    pub rmse: f64,
    pub rel_rmse: f64,
}

/// Renders `plan.rows` of `frame`'s image pass by pass until `plan.stop` (on the caller's rayon
/// pool), adding the samples done to `progress` as it goes.
///
/// # Errors
/// What [`Frame::add_samples`] refuses (an empty image, rows outside it).
pub fn render<F: Pixels>(
    frame: &F,
    plan: &Plan,
    progress: &AtomicU64,
) -> Result<(Film, Stats), RenderError> {
    let s = frame.settings();
    if plan.rows.is_empty() || plan.rows.end > s.height {
        return Err(RenderError::BufferSize);
    }
    let mut film = Film::new(s.width, plan.rows.clone());
    let pixels = film.count.len();
    let start = Instant::now();
    let mut passes = 0;
    let mut last_pass = 0.0f64;
    let budget = plan.stop.spp as f64 * pixels as f64;
    let (mut samples, mut rays) = (0u64, 0u64);
    loop {
        let spent = samples as f64;
        if spent >= budget {
            break;
        }
        let elapsed = start.elapsed().as_secs_f64();
        if passes > 0 {
            if plan.stop.seconds.is_some_and(|t| elapsed + last_pass > t) {
                break;
            }
            let (_, rel) = film.estimated_error();
            // A radiance past f32's range makes the estimate infinite or NaN, never below the
            // target: stop (the caller refuses such a film, [`Film::overflowed`]).
            if plan.stop.noise.is_some_and(|e| rel < e) || !rel.is_finite() {
                break;
            }
        }
        // Uniform passes give every pixel PASS samples (fewer in a last, partial pass); with
        // adaptive sampling, after two uniform passes every other pass hands out the same total
        // where the variance is. The uniform passes in between keep every pixel at half the
        // samples at least, so that a pixel whose first samples happened to agree is not starved
        // (the first version, all passes adaptive, was measured worse: README).
        let uniform = (plan.stop.spp - (samples / pixels as u64) as u32).min(PASS);
        let mut counts = Vec::new();
        if plan.adaptive && passes >= 2 && passes % 2 == 1 {
            let left = (budget - spent) as u64;
            counts = adaptive_counts(&film, left.min(u64::from(PASS) * pixels as u64));
        }
        if counts.iter().all(|&n| n == 0) {
            counts = vec![uniform; pixels];
        }
        let t0 = Instant::now();
        rays += pass(frame, &mut film, &counts, progress)?;
        last_pass = t0.elapsed().as_secs_f64();
        samples += counts.iter().map(|&n| u64::from(n)).sum::<u64>();
        passes += 1;
    }
    let (rmse, rel_rmse) = film.estimated_error();
    let stats = Stats {
        seconds: start.elapsed().as_secs_f64(),
        passes,
        samples,
        rays,
        mean_spp: film.mean_spp(),
        rmse,
        rel_rmse,
    };
    Ok((film, stats))
}

/// One pass: pixel `k` of the film gets its next `counts[k]` samples; returns the rays traced.
fn pass<F: Pixels>(
    frame: &F,
    film: &mut Film,
    counts: &[u32],
    progress: &AtomicU64,
) -> Result<u64, RenderError> {
    let w = film.width as usize;
    let first_row = film.rows.start;
    let rays_before: u64 = film.sums.iter().map(|s| s.rays).sum();
    film.sums
        .par_chunks_mut(w)
        .zip(film.count.par_chunks_mut(w))
        .zip(counts.par_chunks(w))
        .enumerate()
        .try_for_each(|(r, ((sums, done), n))| {
            let y = first_row + r as u32;
            let jobs: Vec<PixelSamples> = (0..w)
                .map(|x| PixelSamples {
                    x: x as u32,
                    y,
                    samples: done[x]..done[x] + n[x],
                })
                .collect();
            frame.add_pixels(&jobs, sums)?;
            for (done, n) in done.iter_mut().zip(n) {
                *done += n;
            }
            progress.fetch_add(n.iter().map(|&n| u64::from(n)).sum(), Ordering::Relaxed);
            Ok(())
        })?;
    Ok(film.sums.iter().map(|s| s.rays).sum::<u64>() - rays_before)
}

/// The paths of a worker's wavefront with `--bounces stream`: a row of a 256-pixel-wide image's
/// pass of 8 samples. The stream sorts what it is given, so longer is more coherent; on the
/// dragon's diffuse rays streams of 2048 to 8192 rays ran fastest, 512 clearly slower
/// (docs/BENCHMARKS.md, "The renderer's rays as streams").
pub const WAVEFRONT: usize = 2048;

thread_local! {
    /// Each worker thread's wavefront (~450 KB, on the heap), made on its first stream pass and
    /// reused for every row after, so that workers do not allocate and fault in fresh pages per
    /// piece of work (which would also cost the two-thread render its scaling).
    static WAVE: RefCell<Option<Box<Wavefront<WAVEFRONT>>>> = const { RefCell::new(None) };
}

/// How many samples each pixel gets in an adaptive pass of about `budget` samples.
///
/// A pixel's mean has variance `σ²/n`; for a fixed total of samples, the sum of those over the
/// image is smallest with `n ∝ σ` (minimize `Σ σ²/nᵢ` subject to `Σ nᵢ = N`, Lagrange: `σ²/nᵢ²`
/// equal for all pixels). Each pixel's target is its share of the samples taken so far plus this
/// pass's, by its `σ` (the channels' mean standard deviation, floored at a tenth of the image's
/// mean so that a pixel whose first samples happened to agree is not starved); it gets what it
/// is short of its target, in whole packets of [`PASS`] samples, at most four packets a pass.
pub fn adaptive_counts(film: &Film, budget: u64) -> Vec<u32> {
    let sigma: Vec<f64> = (0..film.count.len())
        .map(|k| film.variance(k).iter().map(|v| v.sqrt()).sum::<f64>() / 3.0)
        .collect();
    let mean_sigma = sigma.iter().sum::<f64>() / sigma.len().max(1) as f64;
    if mean_sigma <= 0.0 {
        let per_pixel = (budget / film.count.len().max(1) as u64) as u32;
        return vec![per_pixel; film.count.len()];
    }
    let floor = 0.1 * mean_sigma;
    let weights: Vec<f64> = sigma.iter().map(|&s| s.max(floor)).collect();
    let total_weight: f64 = weights.iter().sum();
    let done: u64 = film.count.iter().map(|&n| u64::from(n)).sum();
    let target_total = (done + budget) as f64;
    weights
        .iter()
        .zip(&film.count)
        .map(|(&w, &n)| {
            let short = target_total * w / total_weight - f64::from(n);
            let packets = (short / f64::from(PASS)).round().clamp(0.0, 4.0);
            packets as u32 * PASS
        })
        .collect()
}
