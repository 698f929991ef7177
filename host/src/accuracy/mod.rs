//! `kdray accuracy`: every intersection kernel's error against its run time.
//!
//! Each kernel variant — Möller–Trumbore scalar / 4 / 8, watertight scalar / 4 / 8, sphere
//! scalar / 4 / 8, and the f64
//! references — runs over the same [`sets`]; per set and variant the report gives the nanoseconds
//! per ray–primitive test (median over alternating rounds, of this thread's CPU time where Linux
//! reports it: see [`clock_name`]), the mean and largest relative error of `t` against the f64
//! reference, and the false-miss and false-hit rates against the reference's verdict.
//!
//! Triangles are tested closest-hit over a case's candidates (shrinking `tmax` as traversal
//! does); the per-ray set-up that traversal does once for many triangles (packet transposes) is
//! done once outside the timing.

pub mod sets;

use crate::f64ref;
use core::hint::black_box;
use glam::Vec3;
use kdray_core::simd::{
    HitPacket, Lanes, RayPacket, ShearX, f32x4, f32x8, intersect_triangle_watertight_prepared,
    kernels,
};
use kdray_core::watertight::{self, Shear};
use kdray_core::{Sphere, Triangle};
use sets::{LANES, RaySet};
use std::time::Instant;

/// A kernel variant the report measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// Möller–Trumbore, scalar (`Triangle::intersect_prepared`).
    Mt1,
    /// Möller–Trumbore, 4-wide packets.
    Mt4,
    /// Möller–Trumbore, 8-wide packets.
    Mt8,
    /// Möller–Trumbore in f64 on the exact vertices: the triangles' reference.
    MtF64,
    /// Watertight (Woop, Benthin & Wald 2013), scalar (`watertight::intersect_sheared`).
    Wt1,
    /// Watertight, 4-wide packets (`simd::intersect_triangle_watertight`).
    Wt4,
    /// Watertight, 8-wide packets.
    Wt8,
    /// The cancellation-free sphere, scalar (`Sphere::intersect`).
    Sphere1,
    /// The sphere, 4-wide.
    Sphere4,
    /// The sphere, 8-wide.
    Sphere8,
    /// The sphere in f64: the spheres' reference.
    SphereF64,
}

impl Variant {
    /// Every variant, in report order.
    pub const ALL: [Variant; 11] = [
        Variant::Mt1,
        Variant::Mt4,
        Variant::Mt8,
        Variant::MtF64,
        Variant::Wt1,
        Variant::Wt4,
        Variant::Wt8,
        Variant::Sphere1,
        Variant::Sphere4,
        Variant::Sphere8,
        Variant::SphereF64,
    ];

    /// The name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Mt1 => "mt scalar",
            Variant::Mt4 => "mt x4",
            Variant::Mt8 => "mt x8",
            Variant::MtF64 => "mt f64 (reference)",
            Variant::Wt1 => "wt scalar",
            Variant::Wt4 => "wt x4",
            Variant::Wt8 => "wt x8",
            Variant::Sphere1 => "sphere scalar",
            Variant::Sphere4 => "sphere x4",
            Variant::Sphere8 => "sphere x8",
            Variant::SphereF64 => "sphere f64 (reference)",
        }
    }

    /// Whether it tests spheres (else triangles).
    pub fn is_sphere(self) -> bool {
        matches!(
            self,
            Variant::Sphere1 | Variant::Sphere4 | Variant::Sphere8 | Variant::SphereF64
        )
    }

    fn reference(self) -> Variant {
        if self.is_sphere() {
            Variant::SphereF64
        } else {
            Variant::MtF64
        }
    }
}

/// A ray set with what each variant needs built once, outside the timing.
struct Prepared<'a> {
    set: &'a RaySet,
    /// `(v0, e1, e2)` and the parallel threshold, as the flat format stores them.
    mt: Vec<(Triangle, f32)>,
    packets4: Vec<[RayPacket<f32x4>; 2]>,
    packets8: Vec<RayPacket<f32x8>>,
}

impl<'a> Prepared<'a> {
    fn new(set: &'a RaySet) -> Self {
        let mt = set
            .tris
            .iter()
            .map(|v| {
                let tri = Triangle::from_vertices(v[0], v[1], v[2]);
                (tri, tri.min_det2())
            })
            .collect();
        let packets4 = set
            .cases
            .iter()
            .map(|c| {
                [
                    RayPacket::from_rays(&c.rays[..4]),
                    RayPacket::from_rays(&c.rays[4..]),
                ]
            })
            .collect();
        let packets8 = set
            .cases
            .iter()
            .map(|c| RayPacket::from_rays(&c.rays))
            .collect();
        Self {
            set,
            mt,
            packets4,
            packets8,
        }
    }

    /// One pass of `variant` over the set: `out[i]` is ray `i`'s `t`, `+inf` for a miss.
    fn run(&self, variant: Variant, out: &mut [f64]) {
        let cases = self.set.cases.iter().enumerate();
        match variant {
            Variant::Mt1 => {
                for (c, case) in cases {
                    for (lane, ray) in case.rays.iter().enumerate() {
                        let mut ray = *ray;
                        for (tri, min_det2) in &self.mt[case.tris.clone()] {
                            if let Some((t, _, _)) = tri.intersect_prepared(&ray, *min_det2) {
                                ray.tmax = t;
                            }
                        }
                        out[c * LANES + lane] = f64::from(ray.tmax);
                    }
                }
            }
            Variant::Mt4 => {
                for (c, case) in cases {
                    for (half, packet) in self.packets4[c].iter().enumerate() {
                        let t = mt_packet(packet, &self.mt[case.tris.clone()]);
                        store(&mut out[c * LANES + 4 * half..][..4], t);
                    }
                }
            }
            Variant::Mt8 => {
                for (c, case) in cases {
                    let t = mt_packet(&self.packets8[c], &self.mt[case.tris.clone()]);
                    store(&mut out[c * LANES..][..LANES], t);
                }
            }
            Variant::Wt1 => {
                for (c, case) in cases {
                    for (lane, ray) in case.rays.iter().enumerate() {
                        let (mut ray, shear) = (*ray, Shear::new(ray.dir));
                        let tris = &self.set.tris[case.tris.clone()];
                        for (v, (_, min_det2)) in tris.iter().zip(&self.mt[case.tris.clone()]) {
                            if let Some((t, _, _)) =
                                watertight::intersect_sheared(v, *min_det2, &ray, &shear)
                            {
                                ray.tmax = t;
                            }
                        }
                        out[c * LANES + lane] = f64::from(ray.tmax);
                    }
                }
            }
            Variant::Wt4 => {
                for (c, case) in cases {
                    for (half, packet) in self.packets4[c].iter().enumerate() {
                        let t = wt_packet(
                            packet,
                            &self.set.tris[case.tris.clone()],
                            &self.mt[case.tris.clone()],
                        );
                        store(&mut out[c * LANES + 4 * half..][..4], t);
                    }
                }
            }
            Variant::Wt8 => {
                for (c, case) in cases {
                    let t = wt_packet(
                        &self.packets8[c],
                        &self.set.tris[case.tris.clone()],
                        &self.mt[case.tris.clone()],
                    );
                    store(&mut out[c * LANES..][..LANES], t);
                }
            }
            Variant::MtF64 => {
                for (c, case) in cases {
                    for (lane, ray) in case.rays.iter().enumerate() {
                        let mut best = f64::INFINITY;
                        for v in &self.set.tris[case.tris.clone()] {
                            if let Some(t) = f64ref::mt_hit(ray, v).filter(|&t| t < best) {
                                best = t;
                            }
                        }
                        out[c * LANES + lane] = best;
                    }
                }
            }
            Variant::Sphere1 => {
                for (c, case) in cases {
                    for (lane, ray) in case.rays.iter().enumerate() {
                        let t = case.sphere.intersect(ray).unwrap_or(f32::INFINITY);
                        out[c * LANES + lane] = f64::from(t);
                    }
                }
            }
            Variant::Sphere4 => {
                for (c, case) in cases {
                    for (half, packet) in self.packets4[c].iter().enumerate() {
                        let t = sphere_packet(packet, &case.sphere);
                        store(&mut out[c * LANES + 4 * half..][..4], t);
                    }
                }
            }
            Variant::Sphere8 => {
                for (c, case) in cases {
                    let t = sphere_packet(&self.packets8[c], &case.sphere);
                    store(&mut out[c * LANES..][..LANES], t);
                }
            }
            Variant::SphereF64 => {
                for (c, case) in cases {
                    for (lane, ray) in case.rays.iter().enumerate() {
                        out[c * LANES + lane] = f64ref::sphere_hit(ray, &case.sphere);
                    }
                }
            }
        }
    }

    fn tests(&self, variant: Variant) -> usize {
        if variant.is_sphere() {
            self.set.sphere_tests()
        } else {
            self.set.tri_tests()
        }
    }
}

/// Closest hit of a packet over `tris`: each lane's `t` (`+inf` where it missed).
#[inline]
fn mt_packet<L: Lanes>(packet: &RayPacket<L>, tris: &[(Triangle, f32)]) -> L {
    let (mut rays, mut hits) = (*packet, HitPacket::<L>::miss());
    for (k, (tri, min_det2)) in tris.iter().enumerate() {
        let found = kernels::intersect_triangle_prepared(tri, *min_det2, &rays);
        kernels::record_closest(&mut hits, &mut rays, &found, k as u32);
    }
    hits.t
}

/// Closest hit of a packet over `tris` by the watertight kernel: each lane's `t` (`+inf` where it
/// missed). The shear is per packet, as traversal computes it once per packet; the thresholds
/// (`prepared`, the same triangles' [`Triangle::min_det2`]) are known, as the flat format stores
/// them.
#[inline]
fn wt_packet<L: Lanes>(
    packet: &RayPacket<L>,
    tris: &[[Vec3; 3]],
    prepared: &[(Triangle, f32)],
) -> L {
    let (mut rays, mut hits) = (*packet, HitPacket::<L>::miss());
    let shear = ShearX::new(packet);
    for (k, (verts, (_, min_det2))) in tris.iter().zip(prepared).enumerate() {
        let found = intersect_triangle_watertight_prepared(verts, *min_det2, &rays, &shear);
        kernels::record_closest(&mut hits, &mut rays, &found, k as u32);
    }
    hits.t
}

/// A sphere against a packet: each lane's `t` (`+inf` where it missed).
#[inline]
fn sphere_packet<L: Lanes>(packet: &RayPacket<L>, sphere: &Sphere) -> L {
    let found = kernels::intersect_sphere(sphere, packet);
    found.mask.select(found.t, L::splat(f32::INFINITY))
}

/// The lanes of `t` into `out`.
#[inline]
fn store<L: Lanes>(out: &mut [f64], t: L) {
    for (o, &t) in out.iter_mut().zip(t.to_array().as_ref()) {
        *o = f64::from(t);
    }
}

/// One line of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub set: &'static str,
    pub kernel: &'static str,
    pub rays: usize,
    /// Ray–primitive tests per pass.
    pub tests: usize,
    /// Median nanoseconds per test.
    pub ns_per_test: f64,
    /// Mean and largest `|t − t_ref| / t_ref` over the rays both hit.
    pub mean_rel_err: f64,
    pub max_rel_err: f64,
    /// Rays the reference hits and this variant misses, and the rate among the reference's hits.
    pub false_misses: usize,
    pub false_miss_rate: f64,
    /// Rays the reference misses and this variant hits, and the rate among the reference's misses.
    pub false_hits: usize,
    pub false_hit_rate: f64,
}

/// How much work a report does.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Alternating timing rounds (each variant once per round); the median is reported.
    pub rounds: usize,
    /// The least time one timed measurement takes (passes are repeated to reach it): well above
    /// the CPU clock's granularity (a scheduler tick, 1–4 ms).
    pub min_measure_ms: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            rounds: 15,
            min_measure_ms: 40.0,
        }
    }
}

/// Measures every variant on `set`.
pub fn measure(set: &RaySet, settings: &Settings) -> Vec<Row> {
    measure_with(set, settings, &mut |_| {})
}

/// [`measure`], calling `round_done(r)` after timing round `r` (from 1) of `settings.rounds`, so
/// that a caller can show progress (on this thread, between measurements: it adds nothing to the
/// times).
pub fn measure_with(
    set: &RaySet,
    settings: &Settings,
    round_done: &mut dyn FnMut(usize),
) -> Vec<Row> {
    let prepared = Prepared::new(set);
    let n = set.cases.len() * LANES;
    let mut out = vec![0.0; n];
    // Results first (one pass each), then the timing.
    let results: Vec<Vec<f64>> = Variant::ALL
        .iter()
        .map(|&v| {
            prepared.run(v, &mut out);
            out.clone()
        })
        .collect();
    // Each measurement repeats passes until `min_measure_ms` have passed on the clock (the CPU
    // clock advances in scheduler ticks of a few ms, so measurements must be much longer).
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); Variant::ALL.len()];
    for round in 0..settings.rounds.max(1) {
        for (i, &v) in Variant::ALL.iter().enumerate() {
            let start = Clock::now();
            let (mut passes, mut ns) = (0usize, 0.0);
            while passes == 0 || ns < settings.min_measure_ms * 1e6 {
                prepared.run(v, black_box(&mut out));
                passes += 1;
                ns = start.elapsed_ns();
            }
            times[i].push(ns / (passes * prepared.tests(v)) as f64);
        }
        round_done(round + 1);
    }
    Variant::ALL
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let reference = &results[Variant::ALL
                .iter()
                .position(|&r| r == v.reference())
                .unwrap_or(i)];
            row(
                set,
                v,
                &results[i],
                reference,
                median(&mut times[i]),
                prepared.tests(v),
            )
        })
        .collect()
}

/// What the timings are measured in: the CPU time of this thread where Linux reports it
/// (`/proc/thread-self/schedstat`, nanoseconds on the CPU), which time spent waiting for a core
/// does not inflate; wall-clock time elsewhere.
pub fn clock_name() -> &'static str {
    if thread_cpu_ns().is_some() {
        "thread-cpu"
    } else {
        "wall"
    }
}

/// A start time on the clock [`clock_name`] names.
enum Clock {
    Cpu(u64),
    Wall(Instant),
}

impl Clock {
    fn now() -> Self {
        match thread_cpu_ns() {
            Some(ns) => Clock::Cpu(ns),
            None => Clock::Wall(Instant::now()),
        }
    }

    /// Nanoseconds since `self`.
    fn elapsed_ns(&self) -> f64 {
        match self {
            Clock::Cpu(start) => thread_cpu_ns().map_or(f64::NAN, |now| (now - start) as f64),
            Clock::Wall(start) => start.elapsed().as_secs_f64() * 1e9,
        }
    }
}

/// The first field of `/proc/thread-self/schedstat`: this thread's time on a CPU, in ns.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs.get(xs.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The error columns of `got` against `reference` (ray by ray).
fn row(set: &RaySet, v: Variant, got: &[f64], reference: &[f64], ns: f64, tests: usize) -> Row {
    let (mut sum, mut max, mut both) = (0.0, 0.0f64, 0usize);
    let (mut ref_hits, mut false_misses, mut false_hits) = (0usize, 0usize, 0usize);
    for (&t, &r) in got.iter().zip(reference) {
        match (t.is_finite(), r.is_finite()) {
            (true, true) => {
                let e = (t - r).abs() / r.abs();
                sum += e;
                max = max.max(e);
                both += 1;
                ref_hits += 1;
            }
            (false, true) => {
                false_misses += 1;
                ref_hits += 1;
            }
            (true, false) => false_hits += 1,
            (false, false) => {}
        }
    }
    let ref_misses = got.len() - ref_hits;
    let rate = |k: usize, of: usize| if of > 0 { k as f64 / of as f64 } else { 0.0 };
    Row {
        set: set.name,
        kernel: v.name(),
        rays: got.len(),
        tests,
        ns_per_test: ns,
        mean_rel_err: if both > 0 { sum / both as f64 } else { 0.0 },
        max_rel_err: max,
        false_misses,
        false_miss_rate: rate(false_misses, ref_hits),
        false_hits,
        false_hit_rate: rate(false_hits, ref_misses),
    }
}

/// The CSV columns, in order.
pub const CSV_HEADER: &str = "set,kernel,rays,tests,ns_per_test,mean_rel_err,max_rel_err,\
false_misses,false_miss_rate,false_hits,false_hit_rate";

/// The rows as CSV, with [`CSV_HEADER`].
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        out += &format!(
            "{},{},{},{},{:.4},{:.3e},{:.3e},{},{:.6},{},{:.6}\n",
            r.set,
            r.kernel,
            r.rays,
            r.tests,
            r.ns_per_test,
            r.mean_rel_err,
            r.max_rel_err,
            r.false_misses,
            r.false_miss_rate,
            r.false_hits,
            r.false_hit_rate
        );
    }
    out
}

/// The rows as a Markdown table (what the command prints and the README quotes).
pub fn markdown(rows: &[Row]) -> String {
    let mut out = String::from(
        "| rays | kernel | ns/test | mean rel. err. t | max rel. err. t | false misses | false hits |\n\
         |---|---|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        out += &format!(
            "| {} ({}) | {} | {:.2} | {:.1e} | {:.1e} | {} ({:.3}%) | {} ({:.3}%) |\n",
            r.set,
            r.rays,
            r.kernel,
            r.ns_per_test,
            r.mean_rel_err,
            r.max_rel_err,
            r.false_misses,
            100.0 * r.false_miss_rate,
            r.false_hits,
            100.0 * r.false_hit_rate
        );
    }
    out
}
