//! Batches of rays from numpy arrays, traced on rayon's pool by the core's walks.
//!
//! A batch is four arrays read in place: origins and directions (`k × 3` floats), `tmin` and
//! `tmax` (`k` floats), each with `k = n` rows or one row shared by every ray (numpy's
//! broadcasting of a single row, without a copy). A ray's direction need not be normalized: it
//! is traced normalized (the core's kernels expect unit directions: their parallel test is set
//! for them) over the interval scaled to match, and `t` is scaled back, so that every answer is
//! in units of the direction given: the hit point is `origin + t·direction`, as in Open3D and
//! Embree.
//!
//! Closest and any hits go through the core's ray stream (`kdray_core::traverse::stream`: coherent
//! runs as packets, the rest sorted and traced as single rays), one stream per piece
//! of the batch; every hit along a ray through the host's exact crossings (`kdray::crossings`).

use crate::mesh::{number, row};
use glam::Vec3;
use kdray::crossings::{AllHit, all_hits};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};
use rayon::prelude::*;

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

/// Rays a stream traces at most: long enough for the sort to find coherent runs, short enough
/// that a thread's buffers ([`Buffers`]) stay a few MB and are reused (fresh pages cost this VM
/// about as much as tracing into them).
const MAX_PIECE: usize = 1 << 17;

/// A thread's buffers for one stream: the rays, their answers, the sort's scratch. Kept between
/// pieces and calls.
#[derive(Default)]
struct Buffers {
    rays: Vec<Ray>,
    hits: Vec<Hit>,
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
fn for_chunks<T: Send>(out: &mut [T], c: usize, work: impl Fn(usize, &mut [T]) + Sync) {
    if out.len() <= c {
        work(0, out);
    } else {
        out.par_chunks_mut(c)
            .enumerate()
            .for_each(|(k, chunk)| work(k, chunk));
    }
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
        let i = (0..rows.div_ceil(CHUNK))
            .into_par_iter()
            .find_map_first(|k| {
                (k * CHUNK..rows.min((k + 1) * CHUNK))
                    .position(|i| above(&i))
                    .map(|j| k * CHUNK + j)
            });
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
        let d = Self::row3(self.directions, i).as_dvec3();
        let len = d.length();
        let ray = Ray {
            origin: o,
            dir: (d / len).as_vec3(),
            tmin: (f64::from(Self::row(self.tmin, i)) * len) as f32,
            tmax: (f64::from(Self::row(self.tmax, i)) * len) as f32,
        };
        (ray, len)
    }

    /// The point at `t` along ray `i` as given: `origin + t·direction`.
    fn point(&self, i: usize, t: f32) -> [f32; 3] {
        let o = Self::row3(self.origins, i).as_dvec3();
        let d = Self::row3(self.directions, i).as_dvec3();
        (o + f64::from(t) * d).as_vec3().to_array()
    }

    fn pieces(&self) -> usize {
        self.n
            .div_ceil(4 * rayon::current_num_threads().max(1))
            .clamp(CHUNK, MAX_PIECE)
    }

    /// The length of ray `i`'s direction, by which `t` is scaled back.
    fn length(&self, i: usize) -> f64 {
        Self::row3(self.directions, i).as_dvec3().length()
    }
}

fn stream_config(mode: Mode) -> Config {
    Config {
        mode,
        ..Config::default()
    }
}

/// Closest hits: `t` (+inf for a miss), the triangle in input order (−1 for a miss), the
/// barycentrics `u`, `v` of `v1` and `v2` (0 for a miss), and on request the hit points and the
/// triangles' unit geometric normals (`(v1 − v0) × (v2 − v0)` normalized; NaN for a miss).
#[derive(Debug, Default)]
pub struct Closest {
    pub t: Vec<f32>,
    pub prim: Vec<i64>,
    pub u: Vec<f32>,
    pub v: Vec<f32>,
    pub points: Option<Vec<f32>>,
    pub normals: Option<Vec<f32>>,
}

/// One piece of a batch's answers: rays `start..start + t.len()`.
struct Piece<'a> {
    start: usize,
    t: &'a mut [f32],
    prim: &'a mut [i64],
    u: &'a mut [f32],
    v: &'a mut [f32],
    points: Option<&'a mut [f32]>,
    normals: Option<&'a mut [f32]>,
}

/// `len` pieces of `v`'s chunks of `c` (`None` each when `v` is).
fn chunks_or_none<T>(v: Option<&mut [T]>, c: usize, len: usize) -> Vec<Option<&mut [T]>> {
    match v {
        Some(v) => v.chunks_mut(c).map(Some).collect(),
        None => (0..len).map(|_| None).collect(),
    }
}

/// The closest hits of `batch` (checked) on `scene`, in `mode`, on the current rayon pool.
pub fn intersect(scene: &Scene, batch: &Batch, mode: Mode, points: bool, normals: bool) -> Closest {
    let n = batch.n;
    let mut out = Closest {
        t: vec![0.0; n],
        prim: vec![0; n],
        u: vec![0.0; n],
        v: vec![0.0; n],
        points: points.then(|| vec![0.0; 3 * n]),
        normals: normals.then(|| vec![0.0; 3 * n]),
    };
    let c = batch.pieces();
    let count = n.div_ceil(c);
    let pieces: Vec<Piece> = out
        .t
        .chunks_mut(c)
        .zip(out.prim.chunks_mut(c))
        .zip(out.u.chunks_mut(c))
        .zip(out.v.chunks_mut(c))
        .zip(chunks_or_none(out.points.as_deref_mut(), 3 * c, count))
        .zip(chunks_or_none(out.normals.as_deref_mut(), 3 * c, count))
        .enumerate()
        .map(|(k, (((((t, prim), u), v), points), normals))| Piece {
            start: k * c,
            t,
            prim,
            u,
            v,
            points,
            normals,
        })
        .collect();
    let config = stream_config(mode);
    let work = |p: Piece| {
        let range = p.start..p.start + p.t.len();
        let hits = with_rays(batch, range, |b| {
            b.hits.clear();
            b.hits.resize(b.rays.len(), Hit::MISS);
            // The lengths match by construction, so this cannot fail.
            let _ = stream::intersect(scene, &config, &b.rays, &mut b.hits, &mut b.scratch);
            core::mem::take(&mut b.hits)
        });
        for (j, h) in hits.iter().enumerate() {
            let hit = h.is_hit();
            p.t[j] = if hit {
                (f64::from(h.t) / batch.length(p.start + j)) as f32
            } else {
                f32::INFINITY
            };
            p.prim[j] = if hit {
                i64::from(scene.input_id(h.prim))
            } else {
                -1
            };
            p.u[j] = h.u;
            p.v[j] = h.v;
        }
        if let Some(points) = p.points {
            for (j, (h, out)) in hits.iter().zip(points.chunks_exact_mut(3)).enumerate() {
                let at = if h.is_hit() {
                    batch.point(p.start + j, p.t[j])
                } else {
                    [f32::NAN; 3]
                };
                out.copy_from_slice(&at);
            }
        }
        if let Some(normals) = p.normals {
            for (h, out) in hits.iter().zip(normals.chunks_exact_mut(3)) {
                let normal = if h.is_hit() {
                    scene
                        .geometric_normal(h.prim, Vec3::ZERO)
                        .normalize()
                        .to_array()
                } else {
                    [f32::NAN; 3]
                };
                out.copy_from_slice(&normal);
            }
        }
        BUFFERS.with_borrow_mut(|b| b.hits = hits);
    };
    if pieces.len() == 1 {
        pieces.into_iter().for_each(work);
    } else {
        pieces.into_par_iter().for_each(work);
    }
    out
}

/// The closest hit of the one ray of `batch` (checked) by the single-ray walk: `(t, prim, u, v)`
/// as [`intersect`] gives them.
pub fn closest_one(scene: &Scene, batch: &Batch, mode: Mode) -> (f32, i64, f32, f32) {
    let (ray, len) = batch.ray(0);
    let h = scene.intersect_in(mode, &ray);
    if h.is_hit() {
        (
            (f64::from(h.t) / len) as f32,
            i64::from(scene.input_id(h.prim)),
            h.u,
            h.v,
        )
    } else {
        (f32::INFINITY, -1, 0.0, 0.0)
    }
}

/// Whether anything lies along each ray of `batch` (checked) in its interval.
pub fn occluded(scene: &Scene, batch: &Batch, mode: Mode) -> Vec<bool> {
    let mut out = vec![false; batch.n];
    let c = batch.pieces();
    let config = stream_config(mode);
    for_chunks(&mut out, c, |k, out| {
        with_rays(batch, k * c..k * c + out.len(), |b| {
            let _ = stream::occluded(scene, &config, &b.rays, out, &mut b.scratch);
        });
    });
    out
}

/// Calls `each(i, hits)` with every hit of ray `i` of `batch` (checked), exact on shared edges
/// and vertices (`kdray::crossings`, watertight), for the rays of one piece at a time.
fn every_hit<T: Send>(
    scene: &Scene,
    batch: &Batch,
    out: &mut [T],
    each: impl Fn(usize, f64, &[AllHit]) -> T + Sync,
) {
    let c = batch.pieces();
    for_chunks(out, c, |k, out| {
        let mut hits = Vec::new();
        for (j, o) in out.iter_mut().enumerate() {
            let i = k * c + j;
            let (ray, len) = batch.ray(i);
            all_hits(scene, &ray, true, &mut hits);
            *o = each(i, len, &hits);
        }
    });
}

/// The number of times each ray crosses the surface in its interval, exact on shared edges and
/// vertices.
pub fn count(scene: &Scene, batch: &Batch) -> Vec<i64> {
    let mut out = vec![0i64; batch.n];
    every_hit(scene, batch, &mut out, |_, _, hits| hits.len() as i64);
    out
}

/// Every crossing of every ray, flattened in ray order and along each ray by `t`: the ray's
/// index, `t` (in units of its direction) and the triangle (input order).
pub fn all(scene: &Scene, batch: &Batch) -> (Vec<i64>, Vec<f32>, Vec<i64>) {
    let mut per_ray: Vec<Vec<(f32, i64)>> = vec![Vec::new(); batch.n];
    every_hit(scene, batch, &mut per_ray, |_, len, hits| {
        hits.iter()
            .map(|h| {
                (
                    (f64::from(h.t) / len) as f32,
                    i64::from(scene.input_id(h.prim)),
                )
            })
            .collect()
    });
    let total = per_ray.iter().map(Vec::len).sum();
    let (mut ray, mut t, mut prim) = (
        Vec::with_capacity(total),
        Vec::with_capacity(total),
        Vec::with_capacity(total),
    );
    for (i, hits) in per_ray.iter().enumerate() {
        for &(ti, p) in hits {
            ray.push(i as i64);
            t.push(ti);
            prim.push(p);
        }
    }
    (ray, t, prim)
}

/// The direction `contains` casts its rays in.
pub const CONTAINS_DIRECTION: [f32; 3] = [1.0, 0.0, 0.0];

/// Whether each point (finite, checked) lies inside the closed surface: an odd number of exact
/// crossings along `+x` ([`CONTAINS_DIRECTION`]). A point on the surface may be either.
pub fn contains(scene: &Scene, points: &[f32]) -> Vec<bool> {
    let batch = Batch {
        origins: points,
        directions: &CONTAINS_DIRECTION,
        tmin: &[0.0],
        tmax: &[f32::INFINITY],
        n: points.len() / 3,
    };
    let mut out = vec![false; batch.n];
    every_hit(scene, &batch, &mut out, |_, _, hits| hits.len() % 2 == 1);
    out
}
