//! Every crossing along a batch's rays (`count_intersections`, `intersect_all`, `contains`):
//! the host's exact crossings (`kdray::crossings`, watertight), which count a ray through an
//! edge or a vertex that triangles share once, ray by ray on the package's pool, in pieces of a
//! few rays ([`FEW`]) walked in an order that keeps neighbouring rays together.
//!
//! The number of crossings has no cap (a ray may cross every triangle), so `intersect_all` keeps
//! them in memory reserved fallibly, and stops every thread at the first refusal.

use crate::rays::{Batch, MAX_PIECE, for_chunks};
use crate::run::{Cancel, cancelled};
use crate::stop::{self, Stop};
use core::sync::atomic::Ordering;
use glam::Vec3;
use kdray::crossings::{AllHit, CoherentKey, all_hits};
use kdray_core::Scene;
use rayon::slice::ParallelSliceMut;

/// Rays per piece of work at least, and the most that a call walks on the calling thread: one
/// ray's every crossing can cost as much as thousands of closest hits (a ray through 2,000
/// stacked quads, about 100 µs), so pieces far shorter than the closest hits' (`rays::CHUNK`)
/// keep every thread busy (a batch of 1,000 such rays, under `rays::CHUNK`, ran on one thread).
pub const FEW: usize = 16;

/// Rays per piece for a batch of `n`: about four pieces a thread.
fn piece(n: usize) -> usize {
    if n <= FEW {
        // On the calling thread: no question to rayon, whose global pool it would start.
        return FEW;
    }
    n.div_ceil(4 * rayon::current_num_threads().max(1))
        .clamp(FEW, MAX_PIECE)
}

/// Fills `out` on the pool: `answer(i, x, hits)` for item `i`, `x` what `item(i)` gave with its
/// key, `hits` a buffer it may use. The items are walked in the order of their [`CoherentKey`],
/// sorted once for the whole batch with `x` carried along (read in input order, not gathered
/// in walk order), in pieces of consecutive keys (each piece of random points sorted alone, by
/// a 3-D Morton code, took 1.3–1.4× the time of points given in this order); stops early once
/// `cancel` is set.
///
/// # Errors
/// The memory of the order or of the answers in it cannot be allocated.
fn in_pieces<T: Default + Send, X: Copy + Send + Sync>(
    out: &mut [T],
    cancel: &Cancel,
    item: impl Fn(usize) -> (u32, X) + Sync,
    answer: impl Fn(usize, X, &mut Vec<AllHit>) -> T + Sync,
) -> Result<(), Stop> {
    let n = out.len();
    let mut order: Vec<(u32, u32, X)> = Vec::new();
    stop::reserve(&mut order, n, "the order of the rays")?;
    order.extend((0..n).map(|i| {
        let (key, x) = item(i);
        (key, i as u32, x)
    }));
    let by_key = |&(key, i, _): &(u32, u32, X)| (key, i);
    if n > FEW {
        order.par_sort_unstable_by_key(by_key);
    } else {
        order.sort_unstable_by_key(by_key);
    }
    let mut sorted: Vec<T> = Vec::new();
    stop::reserve(&mut sorted, n, "the answers in walk order")?;
    sorted.resize_with(n, T::default);
    let c = piece(n);
    for_chunks(&mut sorted, c, |k, piece| {
        let mut hits = Vec::new();
        for (o, &(_, i, x)) in piece.iter_mut().zip(&order[k * c..]) {
            if cancelled(cancel) {
                return;
            }
            *o = answer(i as usize, x, &mut hits);
        }
    });
    for (a, &(_, i, _)) in sorted.iter_mut().zip(&order) {
        out[i as usize] = core::mem::take(a);
    }
    Ok(())
}

/// Calls `each(i, len, hits)` with every hit of ray `i` of `batch` (checked), exact on shared
/// edges and vertices (`kdray::crossings`, watertight), `len` the length of its direction.
///
/// # Errors
/// As [`in_pieces`].
fn every_hit<T: Default + Send>(
    scene: &Scene,
    batch: &Batch,
    out: &mut [T],
    cancel: &Cancel,
    each: impl Fn(usize, f64, &[AllHit]) -> T + Sync,
) -> Result<(), Stop> {
    let key = CoherentKey::new(scene.bounds(), None, batch.n);
    in_pieces(
        out,
        cancel,
        |i| {
            let (ray, len) = batch.ray(i);
            (key.key(ray.origin), (ray, len))
        },
        |i, (ray, len), hits| {
            all_hits(scene, &ray, true, hits);
            each(i, len, hits)
        },
    )
}

/// The number of times each ray crosses the surface in its interval, exact on shared edges and
/// vertices.
///
/// # Errors
/// The answers' memory cannot be allocated.
pub fn count(scene: &Scene, batch: &Batch, cancel: &Cancel) -> Result<Vec<i64>, Stop> {
    let mut out = stop::filled(batch.n, 0i64, "count_intersections' answers")?;
    every_hit(scene, batch, &mut out, cancel, |_, _, hits| {
        hits.len() as i64
    })?;
    Ok(out)
}

/// Every crossing of every ray, flattened in ray order and along each ray by `t`: the ray's
/// index, `t` (in units of its direction) and the triangle (input order).
///
/// # Errors
/// The crossings' memory cannot be allocated (there is no cap on their number: a ray may cross
/// every triangle).
#[allow(clippy::type_complexity)]
pub fn all(
    scene: &Scene,
    batch: &Batch,
    cancel: &Cancel,
) -> Result<(Vec<i64>, Vec<f32>, Vec<i64>), Stop> {
    let what = "intersect_all's crossings";
    let mut per_ray: Vec<Vec<(f32, i64)>> = stop::filled(batch.n, Vec::new(), what)?;
    // Set when a ray's crossings cannot be kept: the other threads then stop too.
    let full = Cancel::new(false);
    let stopping = Cancel::new(false);
    every_hit(scene, batch, &mut per_ray, &stopping, |_, len, hits| {
        let mut mine = Vec::new();
        if cancelled(cancel) {
            stopping.store(true, Ordering::Relaxed);
            return mine;
        }
        if mine.try_reserve_exact(hits.len()).is_err() {
            full.store(true, Ordering::Relaxed);
            stopping.store(true, Ordering::Relaxed);
            return mine;
        }
        mine.extend(hits.iter().map(|h| {
            (
                (f64::from(h.t) / len) as f32,
                i64::from(scene.input_id(h.prim)),
            )
        }));
        mine
    })?;
    if cancelled(&full) {
        let so_far: u64 = per_ray.iter().map(|h| h.len() as u64).sum();
        return Err(Stop::Memory {
            what: format!("{what} (more than {so_far} of them)"),
            bytes: so_far.saturating_mul(16),
        });
    }
    let total = per_ray.iter().map(Vec::len).sum();
    let (mut ray, mut t, mut prim) = (Vec::new(), Vec::new(), Vec::new());
    stop::reserve(&mut ray, total, what)?;
    stop::reserve(&mut t, total, what)?;
    stop::reserve(&mut prim, total, what)?;
    for (i, hits) in per_ray.iter().enumerate() {
        for &(ti, p) in hits {
            ray.push(i as i64);
            t.push(ti);
            prim.push(p);
        }
    }
    Ok((ray, t, prim))
}

/// The axis along which `contains` casts its rays: `+x`, or `−x` from a point nearer the low
/// x face of the scene's box (`kdray::crossings::contains`).
pub const CONTAINS_DIRECTION: [f32; 3] = [1.0, 0.0, 0.0];

/// Whether each point (finite, checked) lies inside the closed surface: an odd number of exact
/// crossings along the x axis towards the nearer x face of the scene's box
/// (`kdray::crossings::contains`). A point on the surface may be either.
///
/// # Errors
/// The answers' memory cannot be allocated.
pub fn contains(scene: &Scene, points: &[f32], cancel: &Cancel) -> Result<Vec<bool>, Stop> {
    let mut out = stop::filled(points.len() / 3, false, "contains' answers")?;
    let point = |i: usize| Vec3::from_slice(&points[3 * i..3 * i + 3]);
    let key = CoherentKey::new(scene.bounds(), Some(0), points.len() / 3);
    in_pieces(
        &mut out,
        cancel,
        |i| (key.key(point(i)), point(i)),
        |_, p, hits| kdray::crossings::contains(scene, p, hits),
    )?;
    Ok(out)
}
