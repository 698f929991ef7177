//! Closest hits of a batch (`Tree.intersect`): the path of `kdray trace` that is fastest for
//! the rays at hand, with the batch's checks, conversion and answers in the same pass.
//!
//! Which walk: rays that come in coherent packets as they are given — a camera's tiles: eight
//! consecutive rays of one direction octant — are traced as packets of consecutive rays (the
//! packets and the walk of `kdray::rays::trace_packets_in`, what `kdray trace --packet 8` does,
//! made from the arrays here: `trace_packets`); other rays through the
//! core's ray stream, which sorts them into coherent runs and traces the rest as single rays
//! (over the wide nodes, the default layout: `kdray_core::traverse::stream`, what `kdray trace
//! --stream --packet 8` does). The
//! stream traces a camera's tiles as the same packets, but it tests each run's coherence first
//! (a quarter of its time in a profile of the bunny's primary rays): on those rays it ran 0.63×
//! as fast as packets of consecutive rays on the bunny, 0.85× on the dragon; on diffuse bounces,
//! packets of consecutive rays ran 0.72–0.84× the stream (README, "Python").
//!
//! How: each thread takes a run of rays at a time. On the packet path it reads each packet from
//! the arrays straight into lanes (`Rows::packet`), checks it lane by lane, traces it and writes
//! its answers from the lanes: no buffer of rays or hits in between (`trace_packets`; software
//! prefetching of the next run's rows and answers cost 4 % more CPU time on the bunny's primary
//! rays, 2 % on the dragon's, and was taken out). On the stream path it converts the rest of
//! its piece into its own buffer (the rays as traced: unit directions, intervals scaled, the
//! module doc of `rays`), checking them on the way, traces them and writes their answers. A batch
//! with a ray `check_values` refuses traces nothing more once a thread finds it, and the caller
//! reports the error as `check_values` words it.

use crate::rays::{Batch, CHUNK, Columns, IDLE, MAX_PIECE, Rows, UNIT, trace_pieces};
use crate::run::Cancel;
use core::ops::Range;
use glam::Vec3;
use kdray_core::simd::{RayPacket, f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};
use std::mem::MaybeUninit;

/// Rays decided on (packets or stream) at a time: few enough that a run's rows stay in the caches
/// from the decision to the packets (8 KiB).
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
pub(crate) fn chunks_or_none<T>(
    v: Option<&mut [T]>,
    c: usize,
    len: usize,
) -> Vec<Option<&mut [T]>> {
    match v {
        Some(v) => v.chunks_mut(c).map(Some).collect(),
        None => (0..len).map(|_| None).collect(),
    }
}

/// Writes the closest hits of `batch` (lengths checked) on `scene`, in `mode`, into `out`, on
/// the current rayon pool; false if a ray is one that [`Batch::check_values`] refuses (which
/// then says why; `out` is then partly written). Stops early, `out` partly written, once
/// `cancel` is set.
pub fn intersect(scene: &Scene, batch: &Batch, mode: Mode, out: Answers, cancel: &Cancel) -> bool {
    let n = batch.n;
    // Pieces of whole runs (so whole packets). A batch that starts in packets (a camera's) in
    // pieces of `CHUNK` rays, as `kdray trace --packet` splits its rays: many small pieces
    // balance the threads best, and packets gain nothing from longer ones. Other batches in a
    // piece per quarter of a thread's share: the stream's sort finds more coherent runs in a
    // longer piece. The answers are the same either way: only the split changes.
    // A batch of at most `CHUNK` rays is traced on the calling thread, outside the package's
    // pools: nothing may ask rayon there (it would start its global pool, which a fork breaks).
    let c = if n <= CHUNK || in_packets(&batch.rows(), 0..n.min(RUN), kdray_core::isa::lanes()) {
        CHUNK
    } else {
        n.div_ceil(4 * rayon::current_num_threads().max(1))
            .clamp(CHUNK, MAX_PIECE)
    }
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
    trace_pieces(pieces, cancel, |p| trace_piece(scene, batch, mode, p))
}

/// Whether rays `run` of `rows` come in packets of `width` as they are: at least 3 runs in 4 of
/// `width` consecutive rays share one direction octant (a camera's tiles all do; diffuse bounces
/// in pixel order almost never: 0.05 % of runs on the dragon). Read from the directions as given:
/// a direction's octant is its components' signs, which normalizing keeps.
fn in_packets(rows: &Rows, run: Range<usize>, width: usize) -> bool {
    let Some(dirs) = rows.direction_rows(run.clone()) else {
        // One direction for every ray: one octant.
        return true;
    };
    let total = run.len().div_ceil(width);
    let coherent = if width >= 8 {
        coherent_packets::<24>(dirs)
    } else {
        coherent_packets::<12>(dirs)
    };
    4 * coherent >= 3 * total
}

/// How many packets of `F / 3` consecutive directions (`F` floats) in `dirs` are in one octant
/// (a last, shorter packet included): a direction's octant (`stream::order::octant`) is its
/// components' signs, so a packet is in one octant when its floats' sign bits repeat the first
/// direction's three. Read as bits, from the floats as they lie: a whole packet's sign bits are
/// taken eight floats at a time (`f32x8::to_bitmask`), which cost a fifth of comparing each float
/// with the one 3 before it.
fn coherent_packets<const F: usize>(dirs: &[f32]) -> usize {
    let (packets, rest) = dirs.as_chunks::<F>();
    let whole = packets.iter().filter(|p| one_octant(&p[..])).count();
    whole + usize::from(!rest.is_empty() && one_octant(rest))
}

/// Whether the directions in `packet` (3 floats each, at most 10 of them) share one octant.
#[inline(always)]
fn one_octant(packet: &[f32]) -> bool {
    let (eights, rest) = packet.as_chunks::<8>();
    let mut signs = 0u32;
    for (k, e) in eights.iter().enumerate() {
        signs |= f32x8::from(*e).to_bitmask() << (8 * k);
    }
    for (k, x) in rest.iter().enumerate() {
        signs |= (x.to_bits() >> 31) << (8 * eights.len() + k);
    }
    // The first direction's three sign bits, repeated for every direction.
    let repeated = (signs & 7) * 0o1_111_111_111;
    let all = (1u32 << packet.len()) - 1;
    signs == repeated & all
}

/// Traces piece `p` of `batch` into its answers, a run at a time; false (and the rest of the
/// piece untraced) at a ray that [`Batch::check_values`] refuses.
fn trace_piece(scene: &Scene, batch: &Batch, mode: Mode, mut p: Piece) -> bool {
    let end = p.start + p.t.len();
    let rows = batch.rows();
    let lanes = kdray_core::isa::lanes();
    BUFFERS.with_borrow_mut(|b| {
        let mut start = p.start;
        while start < end {
            let run = start..end.min(start + RUN);
            if in_packets(&rows, run.clone(), lanes) {
                let traced = if lanes >= 8 {
                    trace_packets::<f32x8>(scene, batch, &rows, mode, b, &mut p, run.clone())
                } else {
                    trace_packets::<f32x4>(scene, batch, &rows, mode, b, &mut p, run.clone())
                };
                if !traced {
                    return false;
                }
                start = run.end;
            } else {
                // The rest of the piece as one stream: the longer, the more coherent runs its
                // sort finds.
                b.rays.clear();
                b.lengths.clear();
                if !batch.convert(run.start..end, &mut b.rays, &mut b.lengths) {
                    return false;
                }
                b.hits.clear();
                b.hits.resize(b.rays.len(), Hit::MISS);
                b.scratch.resize(stream::scratch_words(b.rays.len()), 0);
                let config = Config {
                    mode,
                    ..Config::default()
                };
                // The lengths match by construction, so this cannot fail.
                let _ = stream::intersect(scene, &config, &b.rays, &mut b.hits, &mut b.scratch);
                answer(scene, batch, &mut p, run.start, &b.hits, &b.lengths);
                start = end;
            }
        }
        true
    })
}

/// Traces rays `run` of `batch` as packets of `L::WIDTH` consecutive rays and writes their
/// answers into `p`, as `kdray trace --packet` traces them (`kdray::rays::trace_packets_in`: the
/// same packets, from rays at multiples of the width); false at a ray that
/// [`Batch::check_values`] refuses.
///
/// Each packet is read from the arrays as given into lanes ([`Rows::packet`]) and its rays
/// checked lane by lane (the checks of [`Batch::convert`], and unit directions); a packet that
/// passes, as nearly every one does, is traced as it is, and its hits written from the lanes
/// into the answers: no buffer of rays or hits between the arrays and the walk, which cost a
/// third as much as the walk itself on the bunny's primary rays. The other packets' rays are
/// converted one by one as every other path converts them.
fn trace_packets<L: Columns>(
    scene: &Scene,
    batch: &Batch,
    rows: &Rows,
    mode: Mode,
    b: &mut Buffers,
    p: &mut Piece,
    run: Range<usize>,
) -> bool {
    let (one, unit) = (L::splat(1.0), L::splat(UNIT));
    let (inf, neg_inf) = (L::splat(f32::INFINITY), L::splat(f32::NEG_INFINITY));
    let geometry = p.points.is_some() || p.normals.is_some();
    b.hits.clear();
    b.lengths.clear();
    let mut lengths = [1.0f64; 8];
    for i in run.clone().step_by(L::WIDTH) {
        let k = L::WIDTH.min(run.end - i);
        let mut packet = if k == L::WIDTH {
            rows.packet::<L>(i)
        } else {
            let mut given = [IDLE; 8];
            for (j, ray) in given[..k].iter_mut().enumerate() {
                *ray = rows.given(i + j);
            }
            RayPacket::<L>::from_rays(&given[..k])
        };
        // `traced`'s test for a unit direction, lane by lane in the same order of operations.
        let length2 = packet.dir.dot(packet.dir);
        let ok = packet.active
            & packet.tmin.abs().lt(inf)
            & packet.tmax.ne(neg_inf)
            & packet.tmin.le(packet.tmax)
            & (length2 - one).abs().le(unit);
        let present = (1u32 << k) - 1;
        let scaled = ok.bitmask() & present != present;
        if scaled {
            b.rays.clear();
            let from = b.lengths.len();
            if !batch.convert(i..i + k, &mut b.rays, &mut b.lengths) {
                return false;
            }
            lengths[..k].copy_from_slice(&b.lengths[from..]);
            b.lengths.truncate(from);
            packet = RayPacket::<L>::from_rays(&b.rays);
        }
        // Every present lane is active now (checked, or converted: an inactive lane, a ray whose
        // scaled interval overflowed, holds a miss), so the lanes are the hits, misses included.
        let hits = scene.intersect_packet_in(mode, &packet);
        let (t, prim, u, v) = (
            hits.t.to_array(),
            L::index_to_array(hits.prim),
            hits.u.to_array(),
            hits.v.to_array(),
        );
        let at = i - p.start;
        if k == L::WIDTH && !scaled && !geometry {
            // A whole packet of unit directions (nearly every one): its lanes straight into
            // the answers, with no branch a lane.
            // A missed lane holds `Hit::MISS`, whose `t` is +inf, `u` and `v` 0.
            put(&mut p.t[at..at + k], t.as_ref());
            put(&mut p.u[at..at + k], u.as_ref());
            put(&mut p.v[at..at + k], v.as_ref());
            let prim = prim.as_ref();
            for (j, out) in p.prim[at..at + k].iter_mut().enumerate() {
                out.write(prim_of(scene, prim[j]));
            }
            continue;
        }
        let rows = p.t[at..at + k]
            .iter_mut()
            .zip(&mut p.prim[at..at + k])
            .zip(&mut p.u[at..at + k])
            .zip(&mut p.v[at..at + k]);
        for (j, (((t_out, prim_out), u_out), v_out)) in rows.enumerate() {
            let h = Hit {
                t: t.as_ref()[j],
                prim: prim.as_ref()[j],
                u: u.as_ref()[j],
                v: v.as_ref()[j],
            };
            let len = if scaled { lengths[j] } else { 1.0 };
            t_out.write(if scaled {
                t_of(&h, len)
            } else if h.is_hit() {
                h.t
            } else {
                f32::INFINITY
            });
            prim_out.write(prim_of(scene, h.prim));
            u_out.write(h.u);
            v_out.write(h.v);
            if geometry {
                b.hits.push(h);
                b.lengths.push(len);
            }
        }
    }
    if geometry {
        answer_geometry(scene, batch, p, run.start, &b.hits, &b.lengths);
    }
    true
}

/// Writes `src` into `out` (of the same length).
#[inline(always)]
fn put(out: &mut [MaybeUninit<f32>], src: &[f32]) {
    for (o, x) in out.iter_mut().zip(src) {
        o.write(*x);
    }
}

/// `t` in units of the direction given, whose length is `len` (+inf for a miss).
#[inline(always)]
fn t_of(h: &Hit, len: f64) -> f32 {
    if !h.is_hit() {
        f32::INFINITY
    } else if len == 1.0 {
        h.t
    } else {
        (f64::from(h.t) / len) as f32
    }
}

/// The triangle `prim` a hit reports, in input order (−1 for a miss, `Hit::MISS_PRIM`).
#[inline(always)]
fn prim_of(scene: &Scene, prim: u32) -> i64 {
    if prim != Hit::MISS_PRIM {
        i64::from(scene.input_id(prim))
    } else {
        -1
    }
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
    for ((((t, prim), u), v), (h, l)) in rows.zip(hits.iter().zip(lengths)) {
        t.write(t_of(h, *l));
        prim.write(prim_of(scene, h.prim));
        u.write(h.u);
        v.write(h.v);
    }
    answer_geometry(scene, batch, p, from, hits, lengths);
}

/// Writes the hit points and normals of `hits` (as [`answer`]) into `p`, where asked for.
fn answer_geometry(
    scene: &Scene,
    batch: &Batch,
    p: &mut Piece,
    from: usize,
    hits: &[Hit],
    lengths: &[f64],
) {
    let at = from - p.start;
    let len = hits.len();
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
