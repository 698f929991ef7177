//! Every crossing along a batch's rays (`count_intersections`, `intersect_all`, `contains`):
//! the host's exact crossings (`kdray::crossings`, watertight), which count a ray through an
//! edge or a vertex that triangles share once, ray by ray on the package's pool.
//!
//! The number of crossings has no cap (a ray may cross every triangle), so `intersect_all` keeps
//! them in memory reserved fallibly, and stops every thread at the first refusal.

use crate::rays::{Batch, for_chunks};
use crate::run::{Cancel, cancelled};
use crate::stop::{self, Stop};
use core::sync::atomic::Ordering;
use kdray::crossings::{AllHit, all_hits};
use kdray_core::Scene;

/// Calls `each(i, hits)` with every hit of ray `i` of `batch` (checked), exact on shared edges
/// and vertices (`kdray::crossings`, watertight), for the rays of one piece at a time; stops
/// early once `cancel` is set.
fn every_hit<T: Send>(
    scene: &Scene,
    batch: &Batch,
    out: &mut [T],
    cancel: &Cancel,
    each: impl Fn(usize, f64, &[AllHit]) -> T + Sync,
) {
    let c = batch.pieces();
    for_chunks(out, c, |k, out| {
        let mut hits = Vec::new();
        for (j, o) in out.iter_mut().enumerate() {
            if cancelled(cancel) {
                return;
            }
            let i = k * c + j;
            let (ray, len) = batch.ray(i);
            all_hits(scene, &ray, true, &mut hits);
            *o = each(i, len, &hits);
        }
    });
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
    });
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
    });
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

/// The direction `contains` casts its rays in.
pub const CONTAINS_DIRECTION: [f32; 3] = [1.0, 0.0, 0.0];

/// Whether each point (finite, checked) lies inside the closed surface: an odd number of exact
/// crossings along `+x` ([`CONTAINS_DIRECTION`]). A point on the surface may be either.
///
/// # Errors
/// The answers' memory cannot be allocated.
pub fn contains(scene: &Scene, points: &[f32], cancel: &Cancel) -> Result<Vec<bool>, Stop> {
    let batch = Batch {
        origins: points,
        directions: &CONTAINS_DIRECTION,
        tmin: &[0.0],
        tmax: &[f32::INFINITY],
        n: points.len() / 3,
    };
    let mut out = stop::filled(batch.n, false, "contains' answers")?;
    every_hit(scene, &batch, &mut out, cancel, |_, _, hits| {
        hits.len() % 2 == 1
    });
    Ok(out)
}
