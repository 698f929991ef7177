//! Closest hits of a batch (`Tree.intersect`): the path of `kdray trace` that is fastest for
//! the rays at hand, with the batch's checks, conversion and answers in the same pass.
//!
//! Which walk: rays that come in coherent packets as they are given — a camera's tiles: eight
//! consecutive rays of one direction octant — are traced as packets of consecutive rays
//! (`kdray::rays::trace_packets_in`, what `kdray trace --packet 8` does); other rays through the
//! core's ray stream, which sorts them into coherent runs and traces the rest as single rays
//! (over the wide nodes, the default layout: `kdray_core::traverse::stream`, what `kdray trace
//! --stream --packet 8` does). The
//! stream traces a camera's tiles as the same packets, but it tests each run's coherence first
//! (a quarter of its time in a profile of the bunny's primary rays): on those rays it ran 0.63×
//! as fast as packets of consecutive rays on the bunny, 0.85× on the dragon; on diffuse bounces,
//! packets of consecutive rays ran 0.72–0.84× the stream (README, "Python").
//!
//! How: each thread converts a run of rays into its own buffer (the rays as traced: unit
//! directions, intervals scaled, the module doc of `rays`), checking them on the way, traces them
//! and writes their answers, before the next run; a packet run's rays stay in the core's cache
//! between the three steps. A batch with a ray `check_values` refuses traces nothing more once a
//! thread finds it, and the caller reports the error as `check_values` words it.

use crate::rays::{Batch, CHUNK, MAX_PIECE};
use glam::Vec3;
use kdray_core::simd::{f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::order::octant;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicBool, Ordering};

/// Rays converted, traced and answered at a time on the packet path: few enough that a run's
/// rays and hits stay in the L1 cache from their conversion to their answers (8 KiB of rays).
const RUN: usize = 256;

/// Where closest hits go (the package's arrays, `n` items each, `3n` for points and normals):
/// `t` (+inf for a miss), the triangle in input order (−1 for a miss), the barycentrics `u`, `v`
/// of `v1` and `v2` (0 for a miss), and on request the hit points and the triangles' unit
/// geometric normals (`(v1 − v0) × (v2 − v0)` normalized; NaN for a miss).
/// They may start uninitialized (new numpy arrays): [`intersect`] writes every element, unless
/// it refuses the batch.
pub struct Answers<'a> {
    pub t: &'a mut [MaybeUninit<f32>],
    pub prim: &'a mut [MaybeUninit<i64>],
    pub u: &'a mut [MaybeUninit<f32>],
    pub v: &'a mut [MaybeUninit<f32>],
    pub points: Option<&'a mut [MaybeUninit<f32>]>,
    pub normals: Option<&'a mut [MaybeUninit<f32>]>,
}

/// One piece of a batch's answers: rays `start..start + t.len()`.
struct Piece<'a> {
    start: usize,
    t: &'a mut [MaybeUninit<f32>],
    prim: &'a mut [MaybeUninit<i64>],
    u: &'a mut [MaybeUninit<f32>],
    v: &'a mut [MaybeUninit<f32>],
    points: Option<&'a mut [MaybeUninit<f32>]>,
    normals: Option<&'a mut [MaybeUninit<f32>]>,
}

/// A thread's buffers: a run's rays as traced, their directions' lengths, their hits, the
/// stream's scratch. Kept between runs and calls (fresh pages cost this VM about as much as
/// tracing into them).
#[derive(Default)]
struct Buffers {
    rays: Vec<Ray>,
    lengths: Vec<f64>,
    hits: Vec<Hit>,
    scratch: Vec<u64>,
}

thread_local! {
    static BUFFERS: core::cell::RefCell<Buffers> = core::cell::RefCell::default();
}

/// `len` pieces of `v`'s chunks of `c` (`None` each when `v` is).
fn chunks_or_none<T>(v: Option<&mut [T]>, c: usize, len: usize) -> Vec<Option<&mut [T]>> {
    match v {
        Some(v) => v.chunks_mut(c).map(Some).collect(),
        None => (0..len).map(|_| None).collect(),
    }
}

/// Writes the closest hits of `batch` (lengths checked) on `scene`, in `mode`, into `out`, on
/// the current rayon pool; false if a ray is one that [`Batch::check_values`] refuses (which
/// then says why; `out` is then partly written).
pub fn intersect(scene: &Scene, batch: &Batch, mode: Mode, out: Answers) -> bool {
    let n = batch.n;
    // A piece per quarter of a thread's share (for balance), whole runs (so whole packets).
    let c = n
        .div_ceil(4 * rayon::current_num_threads().max(1))
        .clamp(CHUNK, MAX_PIECE)
        .next_multiple_of(RUN);
    let count = n.div_ceil(c);
    let pieces: Vec<Piece> = out
        .t
        .chunks_mut(c)
        .zip(out.prim.chunks_mut(c))
        .zip(out.u.chunks_mut(c))
        .zip(out.v.chunks_mut(c))
        .zip(chunks_or_none(out.points, 3 * c, count))
        .zip(chunks_or_none(out.normals, 3 * c, count))
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
    let bad = AtomicBool::new(false);
    let work = |p: Piece| {
        if !bad.load(Ordering::Relaxed) && !trace_piece(scene, batch, mode, p) {
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

/// Whether `rays` come in packets of `width` as they are: at least 3 runs in 4 of `width`
/// consecutive rays share one direction octant (a camera's tiles all do; diffuse bounces in
/// pixel order almost never: 0.05 % of runs on the dragon).
fn in_packets(rays: &[Ray], width: usize) -> bool {
    let runs = rays.chunks(width);
    let total = runs.len();
    let coherent = runs
        .filter(|r| {
            let first = octant(r[0].dir);
            r.iter().all(|ray| octant(ray.dir) == first)
        })
        .count();
    4 * coherent >= 3 * total
}

/// Traces piece `p` of `batch` into its answers, a run at a time; false (and the rest of the
/// piece untraced) at a ray that [`Batch::check_values`] refuses.
fn trace_piece(scene: &Scene, batch: &Batch, mode: Mode, mut p: Piece) -> bool {
    let end = p.start + p.t.len();
    let lanes = kdray_core::isa::lanes();
    BUFFERS.with_borrow_mut(|b| {
        let mut start = p.start;
        while start < end {
            let run = start..end.min(start + RUN);
            b.rays.clear();
            b.lengths.clear();
            if !batch.convert(run.clone(), &mut b.rays, &mut b.lengths) {
                return false;
            }
            b.hits.clear();
            if in_packets(&b.rays, lanes) {
                b.hits.resize(b.rays.len(), Hit::MISS);
                if lanes >= 8 {
                    kdray::rays::trace_packets_in::<f32x8>(scene, mode, &b.rays, &mut b.hits);
                } else {
                    kdray::rays::trace_packets_in::<f32x4>(scene, mode, &b.rays, &mut b.hits);
                }
                start = run.end;
            } else {
                // The rest of the piece as one stream: the longer, the more coherent runs its
                // sort finds.
                if !batch.convert(run.end..end, &mut b.rays, &mut b.lengths) {
                    return false;
                }
                b.hits.resize(b.rays.len(), Hit::MISS);
                b.scratch.resize(stream::scratch_words(b.rays.len()), 0);
                let config = Config {
                    mode,
                    ..Config::default()
                };
                // The lengths match by construction, so this cannot fail.
                let _ = stream::intersect(scene, &config, &b.rays, &mut b.hits, &mut b.scratch);
                start = end;
            }
            answer(scene, batch, &mut p, run.start, &b.hits, &b.lengths);
        }
        true
    })
}

/// Writes `hits` (of rays `from..`, whose directions have `lengths`) into `p`'s answers.
fn answer(scene: &Scene, batch: &Batch, p: &mut Piece, from: usize, hits: &[Hit], lengths: &[f64]) {
    let at = from - p.start;
    let len = hits.len();
    let rows = p.t[at..at + len]
        .iter_mut()
        .zip(&mut p.prim[at..at + len])
        .zip(&mut p.u[at..at + len])
        .zip(&mut p.v[at..at + len]);
    // `t` in units of the direction given.
    let t_of = |h: &Hit, l: f64| {
        if !h.is_hit() {
            f32::INFINITY
        } else if l == 1.0 {
            h.t
        } else {
            (f64::from(h.t) / l) as f32
        }
    };
    for ((((t, prim), u), v), (h, l)) in rows.zip(hits.iter().zip(lengths)) {
        t.write(t_of(h, *l));
        prim.write(if h.is_hit() {
            i64::from(scene.input_id(h.prim))
        } else {
            -1
        });
        u.write(h.u);
        v.write(h.v);
    }
    let write3 = |out: &mut [MaybeUninit<f32>], xyz: [f32; 3]| {
        for (o, x) in out.iter_mut().zip(xyz) {
            o.write(x);
        }
    };
    if let Some(points) = p.points.as_deref_mut() {
        let rows = points[3 * at..3 * (at + len)].chunks_exact_mut(3);
        for (j, ((h, l), out)) in hits.iter().zip(lengths).zip(rows).enumerate() {
            let point = if h.is_hit() {
                batch.point(from + j, t_of(h, *l))
            } else {
                [f32::NAN; 3]
            };
            write3(out, point);
        }
    }
    if let Some(normals) = p.normals.as_deref_mut() {
        let rows = normals[3 * at..3 * (at + len)].chunks_exact_mut(3);
        for (h, out) in hits.iter().zip(rows) {
            let normal = if h.is_hit() {
                scene
                    .geometric_normal(h.prim, Vec3::ZERO)
                    .normalize()
                    .to_array()
            } else {
                [f32::NAN; 3]
            };
            write3(out, normal);
        }
    }
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
