//! Batches of rays from numpy arrays, traced on rayon's pool by the core's walks.
//!
//! A batch is four arrays read in place: origins and directions (`k × 3` floats), `tmin` and
//! `tmax` (`k` floats), each with `k = n` rows or one row shared by every ray (numpy's
//! broadcasting of a single row, without a copy). A ray's direction need not be normalized: it
//! is traced normalized (the core's kernels expect unit directions: their parallel test is set
//! for them) over the interval scaled to match, and `t` is scaled back, so that every answer is
//! in units of the direction given: the hit point is `origin + t·direction`, as in Open3D and
//! Embree. A direction of unit length already (its squared length within 2⁻²⁰ of 1, as
//! normalized f32 vectors are) is traced as given, as `kdray trace` traces it: no square root,
//! no division, and the same answers as the native tracer's on the same rays.
//!
//! Closest hits take the walk `kdray trace` is fastest with for the rays at hand (`closest`); any
//! hits go through the core's ray stream (`kdray_core::traverse::stream`: coherent runs as
//! packets, the rest sorted and traced as single rays), one stream per piece of the batch; every
//! hit along a ray through the host's exact crossings (`crate::crossings`).

use crate::mesh::{number, row};
use crate::run::{Cancel, cancelled};
use crate::stop::{self, Stop};
use glam::Vec3;
use kdray_core::simd::{Lanes, RayPacket, Vec3x, f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Ray, Scene};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Rays per piece of work at least: enough to amortize a stream's sort and scheduling. A batch
/// of at most this many rays is traced on the calling thread: handing a few rays to the pool
/// costs more than tracing them.
pub const CHUNK: usize = 4096;

/// The first item that is `bad`: on the pool for a long slice, here for a short one.
fn first<T: Sync>(items: &[T], bad: impl Fn(&T) -> bool + Sync + Send) -> Option<usize> {
    if items.len() <= CHUNK {
        items.iter().position(bad)
    } else {
        // Pieces checked by plain loops: rayon's item-by-item `position_first` cost more than
        // the trace itself.
        items
            .par_chunks(CHUNK)
            .enumerate()
            .find_map_first(|(k, c)| c.iter().position(&bad).map(|j| k * CHUNK + j))
    }
}

/// A placeholder in a buffer, overwritten before it is traced.
pub const IDLE: Ray = Ray {
    origin: Vec3::ZERO,
    dir: Vec3::X,
    tmin: 0.0,
    tmax: 0.0,
};

/// Rays a stream traces at most: long enough for the sort to find coherent runs, short enough
/// that a thread's buffers ([`Buffers`]) stay a few MB and are reused (fresh pages cost this VM
/// about as much as tracing into them).
pub const MAX_PIECE: usize = 1 << 17;

/// A thread's buffers for one stream: the rays, the sort's scratch. Kept between pieces and
/// calls.
#[derive(Default)]
struct Buffers {
    rays: Vec<Ray>,
    scratch: Vec<u64>,
}

thread_local! {
    static BUFFERS: core::cell::RefCell<Buffers> = core::cell::RefCell::default();
}

/// Runs `f` with this thread's [`Buffers`], the rays `range` of `batch` in them (as traced).
fn with_rays<R>(
    batch: &Batch,
    range: core::ops::Range<usize>,
    f: impl FnOnce(&mut Buffers) -> R,
) -> R {
    BUFFERS.with_borrow_mut(|b| {
        b.rays.clear();
        b.rays.extend(range.map(|i| batch.ray(i).0));
        b.scratch.resize(stream::scratch_words(b.rays.len()), 0);
        f(b)
    })
}

/// Runs `work` on each chunk of `out` of `c` items (and its index), on the pool when there is
/// more than one.
pub fn for_chunks<T: Send>(out: &mut [T], c: usize, work: impl Fn(usize, &mut [T]) + Sync) {
    if out.len() <= c {
        work(0, out);
    } else {
        out.par_chunks_mut(c)
            .enumerate()
            .for_each(|(k, chunk)| work(k, chunk));
    }
}

/// Runs `trace` on every piece of a batch, on the current pool (on this thread when there is
/// one piece: a batch of at most [`CHUNK`] rays, where nothing may ask rayon, `Batch::pieces`);
/// the pieces not yet begun are skipped once a `trace` returns false (a ray that
/// [`Batch::check_values`] refuses) or `cancel` is set. False if a `trace` did.
pub fn trace_pieces<P: Send>(
    pieces: Vec<P>,
    cancel: &Cancel,
    trace: impl Fn(P) -> bool + Sync,
) -> bool {
    let bad = AtomicBool::new(false);
    let work = |p: P| {
        if !bad.load(Ordering::Relaxed) && !cancelled(cancel) && !trace(p) {
            bad.store(true, Ordering::Relaxed);
        }
    };
    if pieces.len() == 1 {
        pieces.into_iter().for_each(work);
    } else {
        pieces.into_par_iter().for_each(work);
    }
    !bad.into_inner()
}

/// Rays as numpy hands them over (module doc).
#[derive(Clone, Copy, Debug)]
pub struct Batch<'a> {
    pub origins: &'a [f32],
    pub directions: &'a [f32],
    pub tmin: &'a [f32],
    pub tmax: &'a [f32],
    pub n: usize,
}

impl Batch<'_> {
    fn row3(a: &[f32], i: usize) -> Vec3 {
        let i = if a.len() == 3 { 0 } else { i };
        Vec3::from_slice(&a[3 * i..3 * i + 3])
    }

    fn row(a: &[f32], i: usize) -> f32 {
        if a.len() == 1 { a[0] } else { a[i] }
    }

    /// Whether every array has `n` rows or one.
    ///
    /// # Errors
    /// The first array of another length.
    pub fn check_lengths(&self) -> Result<(), String> {
        for (name, len, width) in [
            ("origins", self.origins.len(), 3),
            ("directions", self.directions.len(), 3),
            ("tmin", self.tmin.len(), 1),
            ("tmax", self.tmax.len(), 1),
        ] {
            if len != width && len != width * self.n {
                return Err(format!(
                    "{name} has {} rows, neither 1 nor the batch's {}",
                    len / width,
                    self.n
                ));
            }
        }
        Ok(())
    }

    /// The first ray's problem, if any: a non-finite origin or direction, a zero direction,
    /// `tmin` not finite, `tmax` NaN or −∞, `tmin > tmax`.
    ///
    /// # Errors
    /// The array, the row and the problem.
    pub fn check_values(&self) -> Result<(), String> {
        let bad3 = |a: &[f32], name: &str| -> Result<(), String> {
            let (rows, _) = a.as_chunks::<3>();
            match first(rows, |v| !v.iter().all(|x| x.is_finite())) {
                Some(i) => Err(format!(
                    "{name}[{i}] is {}: every coordinate must be finite",
                    row(&rows[i])
                )),
                None => Ok(()),
            }
        };
        bad3(self.origins, "origins")?;
        bad3(self.directions, "directions")?;
        if let Some(i) = first(self.directions.as_chunks::<3>().0, |v| *v == [0.0; 3]) {
            return Err(format!("directions[{i}] is zero"));
        }
        if let Some(i) = first(self.tmin, |t| !t.is_finite()) {
            return Err(format!(
                "tmin[{i}] is {}: it must be finite",
                number(self.tmin[i])
            ));
        }
        if let Some(i) = first(self.tmax, |t| t.is_nan() || *t == f32::NEG_INFINITY) {
            return Err(format!(
                "tmax[{i}] is {}: it must be finite or +inf",
                number(self.tmax[i])
            ));
        }
        let above = |i: &usize| Self::row(self.tmin, *i) > Self::row(self.tmax, *i);
        let rows = if self.tmin.len() == 1 && self.tmax.len() == 1 {
            self.n.min(1)
        } else {
            self.n
        };
        // Not through rayon for a few rays: they are checked on the calling thread, outside the
        // package's pools (`pool`), where a parallel call would start rayon's global pool.
        let i = if rows <= CHUNK {
            (0..rows).position(|i| above(&i))
        } else {
            (0..rows.div_ceil(CHUNK))
                .into_par_iter()
                .find_map_first(|k| {
                    (k * CHUNK..rows.min((k + 1) * CHUNK))
                        .position(|i| above(&i))
                        .map(|j| k * CHUNK + j)
                })
        };
        if let Some(i) = i {
            return Err(format!(
                "ray {i}: tmin {} is above tmax {}",
                number(Self::row(self.tmin, i)),
                number(Self::row(self.tmax, i))
            ));
        }
        Ok(())
    }

    /// Ray `i` as traced (unit direction, interval in distance) and the direction's length.
    pub fn ray(&self, i: usize) -> (Ray, f64) {
        let o = Self::row3(self.origins, i);
        let d = Self::row3(self.directions, i);
        traced(o, d, Self::row(self.tmin, i), Self::row(self.tmax, i))
    }

    /// Appends rays `range` as traced ([`Batch::ray`]) to `rays` and the lengths by which
    /// their answers' `t` are divided to `lengths`, checking each on the way; false if one of
    /// them is a ray that [`Batch::check_values`] refuses (nothing is appended then).
    pub fn convert(
        &self,
        range: core::ops::Range<usize>,
        rays: &mut Vec<Ray>,
        lengths: &mut Vec<f64>,
    ) -> bool {
        let from = rays.len();
        rays.resize(from + range.len(), IDLE);
        lengths.resize(from + range.len(), 1.0);
        let (out, lens) = (&mut rays[from..], &mut lengths[from..]);
        let ok = if [self.origins.len(), self.directions.len()] == [3 * self.n; 2]
            && [self.tmin.len(), self.tmax.len()] == [self.n; 2]
        {
            self.convert_rows(range, out, lens)
        } else {
            self.convert_broadcast(range, out, lens)
        };
        if !ok {
            rays.truncate(from);
            lengths.truncate(from);
        }
        ok
    }

    /// [`Batch::convert`] when every array has a row per ray: the checks as loops over each
    /// array's rows that the compiler vectorizes, then the rays as copies, but for directions
    /// not of unit length.
    fn convert_rows(
        &self,
        range: core::ops::Range<usize>,
        out: &mut [Ray],
        lens: &mut [f64],
    ) -> bool {
        let (o, _) = self.origins[3 * range.start..3 * range.end].as_chunks::<3>();
        let (d, _) = self.directions[3 * range.start..3 * range.end].as_chunks::<3>();
        let (lo, hi) = (&self.tmin[range.clone()], &self.tmax[range]);
        let finite = |a: &[f32]| a.iter().fold(true, |ok, x| ok & x.is_finite());
        let intervals = lo.iter().zip(hi).fold(true, |ok, (lo, hi)| {
            ok & lo.is_finite() & (*hi != f32::NEG_INFINITY) & (lo <= hi)
        });
        if !(finite(o.as_flattened()) & finite(d.as_flattened()) & intervals) {
            return false;
        }
        let rows = o.iter().zip(d).zip(lo.iter().zip(hi));
        for ((ray, len), ((o, d), (lo, hi))) in out.iter_mut().zip(lens).zip(rows) {
            let d = Vec3::from_array(*d);
            if d == Vec3::ZERO {
                return false;
            }
            (*ray, *len) = traced(Vec3::from_array(*o), d, *lo, *hi);
        }
        true
    }

    /// [`Batch::convert`] when some array has one row for every ray.
    fn convert_broadcast(
        &self,
        range: core::ops::Range<usize>,
        out: &mut [Ray],
        lens: &mut [f64],
    ) -> bool {
        for ((ray, len), i) in out.iter_mut().zip(lens).zip(range) {
            let o = Self::row3(self.origins, i);
            let d = Self::row3(self.directions, i);
            let (tmin, tmax) = (Self::row(self.tmin, i), Self::row(self.tmax, i));
            let valid = o.is_finite()
                && d.is_finite()
                && d != Vec3::ZERO
                && tmin.is_finite()
                && !tmax.is_nan()
                && tmax != f32::NEG_INFINITY
                && tmin <= tmax;
            if !valid {
                return false;
            }
            (*ray, *len) = traced(o, d, tmin, tmax);
        }
        true
    }

    /// The point at `t` along ray `i` as given: `origin + t·direction`.
    pub fn point(&self, i: usize, t: f32) -> [f32; 3] {
        let o = Self::row3(self.origins, i).as_dvec3();
        let d = Self::row3(self.directions, i).as_dvec3();
        (o + f64::from(t) * d).as_vec3().to_array()
    }

    /// The batch's rows, read with a stride per array (0 for an array of one row).
    pub fn rows(&self) -> Rows<'_> {
        let stride = |a: &[f32], width: usize| if a.len() == width { 0 } else { width };
        Rows {
            origins: self.origins,
            directions: self.directions,
            tmin: self.tmin,
            tmax: self.tmax,
            strides: [
                stride(self.origins, 3),
                stride(self.directions, 3),
                stride(self.tmin, 1),
                stride(self.tmax, 1),
            ],
        }
    }

    pub fn pieces(&self) -> usize {
        if self.n <= CHUNK {
            // On the calling thread: no question to rayon, whose global pool it would start.
            return CHUNK;
        }
        self.n
            .div_ceil(4 * rayon::current_num_threads().max(1))
            .clamp(CHUNK, MAX_PIECE)
    }
}

/// A [`Batch`]'s arrays with the step from one ray's row to the next in each (0: one row shared by
/// every ray), for reading rays as given, unchecked, in a loop.
#[derive(Clone, Copy, Debug)]
pub struct Rows<'a> {
    origins: &'a [f32],
    directions: &'a [f32],
    tmin: &'a [f32],
    tmax: &'a [f32],
    strides: [usize; 4],
}

impl Rows<'_> {
    /// Ray `i` as given: not checked, not normalized (what `kdray trace` reads from its file).
    #[inline(always)]
    pub fn given(&self, i: usize) -> Ray {
        let [so, _, slo, shi] = self.strides;
        Ray {
            origin: Vec3::from_slice(&self.origins[i * so..i * so + 3]),
            dir: self.direction(i),
            tmin: self.tmin[i * slo],
            tmax: self.tmax[i * shi],
        }
    }

    /// Rays `i..i + L::WIDTH` as given, as a packet: what `RayPacket::from_rays` makes of the
    /// same rays (its lanes, active mask and `inv_dir`, computed the same way), read from the
    /// arrays straight into lanes instead of through a buffer of rays.
    ///
    /// # Panics
    /// If the rays are not all in the batch.
    #[inline(always)]
    pub fn packet<L: Columns>(&self, i: usize) -> RayPacket<L> {
        let w = L::WIDTH;
        let [so, sd, slo, shi] = self.strides;
        // The columns of 3-vectors: a row per ray (`stride` 3) or one for all (0).
        let columns = |a: &[f32], stride: usize| {
            let [x, y, z] = if stride == 0 {
                [0, 1, 2].map(|c| L::splat(a[c]))
            } else {
                L::columns3(&a[3 * i..3 * (i + w)])
            };
            Vec3x { x, y, z }
        };
        let scalar = |a: &[f32], stride: usize| {
            if stride == 0 {
                L::splat(a[0])
            } else {
                let rows = &a[i..i + w];
                L::from_fn(|j| rows[j])
            }
        };
        let origin = columns(self.origins, so);
        let dir = columns(self.directions, sd);
        let (tmin, tmax) = (scalar(self.tmin, slo), scalar(self.tmax, shi));
        let inf = L::splat(f32::INFINITY);
        let finite = |x: L| x.abs().lt(inf);
        let active = finite(origin.x)
            & finite(origin.y)
            & finite(origin.z)
            & finite(dir.x)
            & finite(dir.y)
            & finite(dir.z)
            & !tmin.is_nan()
            & !tmax.is_nan();
        RayPacket {
            origin,
            dir,
            inv_dir: dir.recip(),
            tmin,
            tmax,
            active,
        }
    }

    /// The directions of rays `range`, 3 floats each, when each ray has its own (`None`: one
    /// for all).
    pub fn direction_rows(&self, range: core::ops::Range<usize>) -> Option<&[f32]> {
        (self.strides[1] != 0).then(|| &self.directions[3 * range.start..3 * range.end])
    }

    /// Ray `i`'s direction as given.
    #[inline(always)]
    pub fn direction(&self, i: usize) -> Vec3 {
        let sd = self.strides[1];
        Vec3::from_slice(&self.directions[i * sd..i * sd + 3])
    }
}

/// Lanes that read `WIDTH` 3-vectors, stored as rows (`x y z` each, as numpy's `(n, 3)` arrays
/// lie), into three columns of lanes: `x`, `y` and `z`.
pub trait Columns: Lanes {
    /// The columns of `rows`, `3 × WIDTH` floats: lane by lane, unless the lanes have a faster
    /// way.
    #[inline(always)]
    fn columns3(rows: &[f32]) -> [Self; 3] {
        [0, 1, 2].map(|c| Self::from_fn(|j| rows[3 * j + c]))
    }
}

impl Columns for f32x4 {}

impl Columns for f32x8 {
    /// With AVX: six 4-float loads and five shuffles (the 3-vector transpose of Intel's
    /// "3D Vector Normalization Using 256-Bit Intel AVX"), where lane by lane took 13
    /// instructions a column, and the reading of packets a quarter of the package's own time on
    /// the bunny's primary rays.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    #[inline(always)]
    fn columns3(rows: &[f32]) -> [Self; 3] {
        use core::arch::x86_64::{__m128, _mm_loadu_ps, _mm256_set_m128, _mm256_shuffle_ps};
        let rows: &[f32; 24] = rows.try_into().expect("8 rows of 3 floats");
        // Floats 4k..4k+4 of the 24: m0 = x0 y0 z0 x1, m1 = y1 z1 x2 y2, m2 = z2 x3 y3 z3, and
        // m3..m5 the same for vectors 4 to 7.
        // SAFETY: the build enables AVX (the `cfg` above), so the CPU has it; each load reads
        // floats 4k..4k + 4, k < 6, inside the 24, unaligned.
        let columns = unsafe {
            let m = |k: usize| -> __m128 { _mm_loadu_ps(rows.as_ptr().add(4 * k)) };
            let (m03, m14, m25) = (
                _mm256_set_m128(m(3), m(0)),
                _mm256_set_m128(m(4), m(1)),
                _mm256_set_m128(m(5), m(2)),
            );
            // In each 128-bit half (vectors 0-3 below, 4-7 above):
            let xy = _mm256_shuffle_ps::<0b10_01_11_10>(m14, m25); // x2 y2 x3 y3
            let yz = _mm256_shuffle_ps::<0b01_00_10_01>(m03, m14); // y0 z0 y1 z1
            [
                _mm256_shuffle_ps::<0b10_00_11_00>(m03, xy), // x0 x1 x2 x3
                _mm256_shuffle_ps::<0b11_01_10_00>(yz, xy),  // y0 y1 y2 y3
                _mm256_shuffle_ps::<0b11_00_11_01>(yz, m25), // z0 z1 z2 z3
            ]
        };
        columns.map(bytemuck::cast)
    }
}

/// How far from 1 a direction's squared length (in f32) may be for the direction to be traced as
/// given: 2⁻²⁰, a few of f32's units in the last place of 1, as a normalized f32 vector has.
pub const UNIT: f32 = 1.0 / (1u32 << 20) as f32;

/// The ray `origin + t·dir`, `tmin < t < tmax`, as traced, and the length of `dir` by which its
/// `t` is divided: a direction of unit length (to within [`UNIT`]) as given, with length 1 (the
/// ray `kdray trace` traces); any other normalized (in f64, rounded once) and its interval scaled
/// to match.
#[inline(always)]
fn traced(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> (Ray, f64) {
    if (dir.length_squared() - 1.0).abs() <= UNIT {
        return (
            Ray {
                origin,
                dir,
                tmin,
                tmax,
            },
            1.0,
        );
    }
    let d = dir.as_dvec3();
    let len = d.length();
    let ray = Ray {
        origin,
        dir: (d / len).as_vec3(),
        tmin: (f64::from(tmin) * len) as f32,
        tmax: (f64::from(tmax).min(LARGEST_T) * len) as f32,
    };
    (ray, len)
}

/// The largest `t` a hit of a ray not of unit length may have, in lengths of its direction: f32's
/// largest value less 2⁻²⁰ of it, so that the traced `tmax` (this times the length, rounded to
/// f32: up by at most 2⁻²⁴) divided back by the length still rounds to a finite f32. Issue 39: a
/// direction of length 10⁻³⁸ reported a triangle at `t = inf`.
const LARGEST_T: f64 = f32::MAX as f64 * (1.0 - 1.0 / (1u64 << 20) as f64);

fn stream_config(mode: Mode) -> Config {
    Config {
        mode,
        ..Config::default()
    }
}

/// Whether anything lies along each ray of `batch` (checked) in its interval; stops early (its
/// answer then meaningless) once `cancel` is set.
///
/// # Errors
/// The answers' memory cannot be allocated.
pub fn occluded(
    scene: &Scene,
    batch: &Batch,
    mode: Mode,
    cancel: &Cancel,
) -> Result<Vec<bool>, Stop> {
    let mut out = stop::filled(batch.n, false, "occluded's answers")?;
    let c = batch.pieces();
    let config = stream_config(mode);
    for_chunks(&mut out, c, |k, out| {
        if cancelled(cancel) {
            return;
        }
        with_rays(batch, k * c..k * c + out.len(), |b| {
            let _ = stream::occluded(scene, &config, &b.rays, out, &mut b.scratch);
        });
    });
    Ok(out)
}
