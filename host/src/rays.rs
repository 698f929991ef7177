//! Ray and hit files (docs/FORMATS.md, "Binary files") and the benchmark protocol's ray sets.
//!
//! - rays: `n × 8 f32`: `ox oy oz dx dy dz tmin tmax`, little-endian, no header;
//! - hits: `n × (f32 t, u32 prim, f32 u, f32 v)`; a miss is `t = +inf`, `prim = 0xFFFF_FFFF`.

use crate::error::{Error, Result};
use glam::Vec3;
use kdray_core::camera::{Camera, Pinhole};
use kdray_core::sampling::{Onb, Pcg32, cosine_hemisphere};
use kdray_core::simd::{Lanes, RayPacket};
use kdray_core::traverse::Mode;
use kdray_core::{Hit, Ray, Scene};
use std::path::Path;

/// Bytes per ray record.
pub const RAY_BYTES: usize = 32;
/// Bytes per hit record.
pub const HIT_BYTES: usize = 16;

/// The most a finite ray's direction length may differ from 1 (docs/FORMATS.md: directions
/// are normalized). The kernels' parallel test compares `det²` with a threshold made for unit
/// directions, so a direction much shorter than 1 (about 2e-7) would miss a triangle straight
/// ahead; 1e-3 leaves room for any writer's rounding and moves that threshold by 0.2 % at most.
pub const DIR_LENGTH_TOLERANCE: f32 = 1e-3;

/// How many `record`-byte records of `what` (e.g. "rays") a file of `bytes` bytes holds.
///
/// # Errors
/// A length that is not a whole number of records.
pub fn record_count(path: &Path, bytes: u64, record: usize, what: &str) -> Result<u64> {
    let record = record as u64;
    if !bytes.is_multiple_of(record) {
        let msg =
            format!("{bytes} bytes is not a whole number of {record}-byte {what} (truncated?)");
        return Err(Error::new(path, msg));
    }
    Ok(bytes / record)
}

/// One ray record.
pub fn decode_ray(c: &[u8; RAY_BYTES]) -> Ray {
    let f = |i: usize| f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]]);
    Ray {
        origin: Vec3::new(f(0), f(1), f(2)),
        dir: Vec3::new(f(3), f(4), f(5)),
        tmin: f(6),
        tmax: f(7),
    }
}

/// Decodes a rays file.
///
/// # Errors
/// A length that is not a whole number of records. The values are not checked here: see
/// [`check_rays`].
pub fn decode_rays(path: &Path, bytes: &[u8]) -> Result<Vec<Ray>> {
    record_count(path, bytes.len() as u64, RAY_BYTES, "rays")?;
    Ok(bytes
        .as_chunks::<RAY_BYTES>()
        .0
        .iter()
        .map(decode_ray)
        .collect())
}

/// Reads a rays file (a regular file) record by record into one allocation (a rays file may be
/// as large as memory: no second copy), checking each ray ([`check_rays`]) as it comes.
///
/// # Errors
/// As [`record_count`] and [`check_rays`]; the rays do not fit in memory (reserved fallibly:
/// exit 1 naming the size, not an abort); reading fails.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    use std::io::Read as _;
    let file = crate::files::open(path)?;
    let bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let n = record_count(path, bytes, RAY_BYTES, "rays")?;
    let mut rays = Vec::new();
    let reserved = usize::try_from(n)
        .ok()
        .is_some_and(|n| rays.try_reserve_exact(n).is_ok());
    if !reserved {
        let msg = format!(
            "{n} rays take {} of memory, which cannot be allocated here (out of memory, or an \
             address-space limit)",
            crate::memory::mib(bytes)
        );
        return Err(Error::new(path, msg));
    }
    let mut records = std::io::BufReader::with_capacity(1 << 16, file);
    let mut record = [0u8; RAY_BYTES];
    for i in 0..n {
        records
            .read_exact(&mut record)
            .map_err(|e| Error::io(path, e))?;
        let ray = decode_ray(&record);
        if let Some(problem) = ray_problem(&ray) {
            return Err(Error::new(path, format!("ray {i}: {problem}")));
        }
        rays.push(ray);
    }
    Ok(rays)
}

/// What is wrong with one ray of a rays file, if anything: the origin, the direction and `tmin`
/// must be finite, `tmax` finite or `+inf` and not below `tmin` (`tmin = tmax` is an empty
/// interval: a miss), the direction normalized within [`DIR_LENGTH_TOLERANCE`].
///
/// The core would not fail on the others, but would answer a question the file's writer did not
/// mean to ask: it reports a ray with a NaN or infinite origin or direction as a miss
/// ([`Ray::is_finite`]), traces `tmin = −inf` as the whole line behind the origin, and a
/// `tmin > tmax` as an empty interval; each is refused instead of being written out as a result.
pub fn ray_problem(r: &Ray) -> Option<String> {
    if !(r.origin.is_finite() && r.dir.is_finite()) {
        return Some(format!(
            "origin {} or direction {} is not finite",
            r.origin, r.dir
        ));
    }
    if !r.tmin.is_finite() || r.tmax.is_nan() || r.tmax == f32::NEG_INFINITY {
        return Some(format!(
            "interval ({}, {}): tmin must be finite, tmax finite or +inf",
            r.tmin, r.tmax
        ));
    }
    if r.tmin > r.tmax {
        return Some(format!(
            "interval ({}, {}): tmin is above tmax",
            r.tmin, r.tmax
        ));
    }
    let length = r.dir.as_dvec3().length();
    if (length - 1.0).abs() > f64::from(DIR_LENGTH_TOLERANCE) {
        return Some(format!(
            "direction {} has length {length:e}; directions must be normalized \
             (length 1 ± {DIR_LENGTH_TOLERANCE:e})",
            r.dir
        ));
    }
    None
}

/// Refuses the first ray of a rays file that [`ray_problem`] finds wrong.
///
/// # Errors
/// The ray's index and its problem, naming `path`.
pub fn check_rays(path: &Path, rays: &[Ray]) -> Result<()> {
    match rays
        .iter()
        .enumerate()
        .find_map(|(i, r)| Some((i, ray_problem(r)?)))
    {
        None => Ok(()),
        Some((i, problem)) => Err(Error::new(path, format!("ray {i}: {problem}"))),
    }
}

/// Encodes rays.
pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    for r in rays {
        for v in [
            r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Writes `rays` as [`encode_rays`] encodes them, without a copy in memory (a set of 2²⁶ rays
/// is 2 GiB).
///
/// # Errors
/// `out`'s.
pub fn write_rays(out: &mut impl std::io::Write, rays: &[Ray]) -> std::io::Result<()> {
    for r in rays {
        for v in [
            r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax,
        ] {
            out.write_all(&v.to_le_bytes())?;
        }
    }
    Ok(())
}

/// Encodes hits.
pub fn encode_hits(hits: &[Hit]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * HIT_BYTES);
    // Writing to a Vec cannot fail.
    let _ = write_hits(&mut out, hits);
    out
}

/// Writes `hits` as [`encode_hits`] encodes them, without a copy in memory.
///
/// # Errors
/// `out`'s.
pub fn write_hits(out: &mut impl std::io::Write, hits: &[Hit]) -> std::io::Result<()> {
    for h in hits {
        out.write_all(&h.t.to_le_bytes())?;
        out.write_all(&h.prim.to_le_bytes())?;
        out.write_all(&h.u.to_le_bytes())?;
        out.write_all(&h.v.to_le_bytes())?;
    }
    Ok(())
}

/// One hit record.
pub fn decode_hit(c: &[u8; HIT_BYTES]) -> Hit {
    let w = |i: usize| [c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]];
    Hit {
        t: f32::from_le_bytes(w(0)),
        prim: u32::from_le_bytes(w(1)),
        u: f32::from_le_bytes(w(2)),
        v: f32::from_le_bytes(w(3)),
    }
}

/// Decodes a hits file.
///
/// # Errors
/// A length that is not a whole number of records.
pub fn decode_hits(path: &Path, bytes: &[u8]) -> Result<Vec<Hit>> {
    record_count(path, bytes.len() as u64, HIT_BYTES, "hits")?;
    Ok(bytes
        .as_chunks::<HIT_BYTES>()
        .0
        .iter()
        .map(decode_hit)
        .collect())
}

/// The benchmark protocol's camera: a pinhole looking along −z at the centre of `bounds`, far
/// enough that the bounding sphere fills a 45° vertical field of view. `None` when that camera's
/// position overflows f32 (a scene with coordinates near 1e19 and beyond) or the core refuses it.
pub fn framing_camera(bounds: [Vec3; 2]) -> Option<Pinhole> {
    let (lo, hi) = (bounds[0].as_dvec3(), bounds[1].as_dvec3());
    let center = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let vfov = 45.0f32;
    let dist = radius / (0.5 * f64::from(vfov).to_radians()).sin();
    let eye = (center + glam::DVec3::new(0.0, 0.0, dist)).as_vec3();
    let center = center.as_vec3();
    if !(eye.is_finite() && center.is_finite()) {
        return None;
    }
    Pinhole::look_at(eye, center, Vec3::Y, vfov).ok()
}

/// Width and height of the protocol's pixel tiles: 8 consecutive rays are one 2×4 (W×H) tile.
pub const TILE: (u32, u32) = (2, 4);

/// Primary rays of a `width × height` image through `camera`, ordered tile by tile (tiles in
/// row-major order, pixels row-major inside a tile). Sizes need not be multiples of the tile:
/// tiles at the border are cut.
pub fn primary_rays(camera: &impl Camera, width: u32, height: u32) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(width as usize * height as usize);
    for ty in (0..height).step_by(TILE.1 as usize) {
        for tx in (0..width).step_by(TILE.0 as usize) {
            for y in ty..(ty + TILE.1).min(height) {
                for x in tx..(tx + TILE.0).min(width) {
                    rays.push(camera.pixel_ray(x, y, width, height));
                }
            }
        }
    }
    rays
}

/// The protocol's secondary rays: one cosine-weighted bounce from each primary hit, around the
/// geometric normal turned towards the incoming ray, starting at the hit point with `tmin` scaled
/// to the scene so the surface itself is not hit again. Misses produce no ray.
pub fn diffuse_rays(scene: &Scene, primary: &[Ray], hits: &[Hit], seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 0x6b64_7261);
    let [lo, hi] = scene.bounds();
    let eps = 1e-4 * (hi - lo).abs().max_element().max(1e-6);
    let mut out = Vec::with_capacity(hits.len());
    for (ray, hit) in primary.iter().zip(hits) {
        if !hit.is_hit() {
            continue;
        }
        let p = ray.at(hit.t);
        let Some(n) = scene.geometric_normal(hit.prim, p).try_normalize() else {
            continue;
        };
        let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
        let local = cosine_hemisphere(rng.next_f32(), rng.next_f32());
        let dir = Onb::from_normal(n).to_world(local).normalize();
        out.push(Ray::new(p, dir).with_range(eps, f32::INFINITY));
    }
    out
}

/// Rewrites each hit's primitive from storage order to input order ([`Scene::input_id`]), the
/// ids the hits file reports. The tracing functions here report storage order, the ids the
/// scene's own accessors take (e.g. [`diffuse_rays`]).
pub fn to_input_ids(scene: &Scene, hits: &mut [Hit]) {
    if scene.reorders_triangles() {
        for h in hits {
            h.prim = scene.input_id(h.prim);
        }
    }
}

/// Closest hits of `rays` into `hits` (same length) by the scalar traversal; primitives in
/// storage order (see [`to_input_ids`]).
pub fn trace_scalar(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    trace_scalar_in(scene, Mode::Fast, rays, hits);
}

/// [`trace_scalar`] in `mode` (fast or watertight). Never inlined, so that scripts/icount.sh
/// can count the instructions inside it by name.
#[inline(never)]
pub fn trace_scalar_in(scene: &Scene, mode: Mode, rays: &[Ray], hits: &mut [Hit]) {
    for (ray, hit) in rays.iter().zip(hits) {
        *hit = scene.intersect_in(mode, ray);
    }
}

/// Closest hits of `rays` into `hits` (same length, pre-filled: rays that are not finite are
/// inactive lanes and leave their slot as it was) by packet traversal, `L::WIDTH` consecutive
/// rays a packet.
pub fn trace_packets<L: Lanes>(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    trace_packets_in::<L>(scene, Mode::Fast, rays, hits);
}

/// [`trace_packets`] in `mode` (fast or watertight). Never inlined, as [`trace_scalar_in`].
#[inline(never)]
pub fn trace_packets_in<L: Lanes>(scene: &Scene, mode: Mode, rays: &[Ray], hits: &mut [Hit]) {
    for (r, h) in rays.chunks(L::WIDTH).zip(hits.chunks_mut(L::WIDTH)) {
        let packet = RayPacket::<L>::from_rays(r);
        scene
            .intersect_packet_in(mode, &packet)
            .write_active(&packet, h);
    }
}
