//! The packet kernels against the scalar ones: closest hit of 1024 rays over 1024 triangles (or
//! 1024 spheres) by brute force, no tree, so the figure is the kernels' own cost.
//!
//! Throughput is rays per second, each ray tested against all 1024 primitives (multiply by 1024
//! for primitive tests per second). The group name carries `kdray_core::isa::name()`, the
//! instruction set `wide` compiled to: compare a default build with `RUSTFLAGS="-C
//! target-cpu=native"`.
//!
//! Scene: small random triangles (edge components within ±0.15) and spheres (radius 0.01–0.05)
//! in the box [−1, 1]² × [2, 4], seen by rays from a pinhole at the origin through a 32 × 32 grid
//! whose consecutive 8 rays form a 2 × 4 tile (the benchmark protocol's primary-ray order, docs/BENCHMARKS.md); about half the rays
//! hit something, and most ray/primitive tests miss, as in a kd-tree leaf. Every variant writes `Hit`s, and the scalar and packet answers are checked to
//! agree before timing.

use core::hint::black_box;
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use kdray_core::simd::{
    HitPacket, Lanes, PrimHits, RayPacket, f32x4, f32x8, intersect_sphere, intersect_triangle,
    record_closest,
};
use kdray_core::{Hit, Ray, Sphere, Triangle};

const PRIMS: usize = 1024;
const SIDE: usize = 32;

/// xorshift64*: a fixed, dependency-free sequence.
struct Rng(u64);

impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    fn in_box(&mut self) -> Vec3 {
        Vec3::new(
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(2.0, 4.0),
        )
    }

    fn small(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}

fn triangles() -> Vec<Triangle> {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    (0..PRIMS)
        .map(|_| {
            let v0 = rng.in_box();
            Triangle::from_vertices(v0, v0 + rng.small(0.15), v0 + rng.small(0.15))
        })
        .collect()
}

fn spheres() -> Vec<Sphere> {
    let mut rng = Rng(0xd1b5_4a32_d192_ed03);
    (0..PRIMS)
        .map(|_| Sphere {
            center: rng.in_box(),
            radius: rng.range(0.01, 0.05),
        })
        .collect()
}

/// A 32 × 32 pinhole grid over [−0.4, 0.4]² at z = 1, in 2 × 4 tiles of 8 consecutive rays.
fn rays() -> Vec<Ray> {
    let mut rays = Vec::with_capacity(SIDE * SIDE);
    for ty in (0..SIDE).step_by(4) {
        for tx in (0..SIDE).step_by(2) {
            for y in ty..ty + 4 {
                for x in tx..tx + 2 {
                    let p = |i: usize| (i as f32 + 0.5) / SIDE as f32 * 0.8 - 0.4;
                    rays.push(Ray::new(Vec3::ZERO, Vec3::new(p(x), p(y), 1.0).normalize()));
                }
            }
        }
    }
    rays
}

fn trace_scalar<P>(
    prims: &[P],
    rays: &[Ray],
    out: &mut [Hit],
    isect: impl Fn(&P, &Ray) -> Option<(f32, f32, f32)>,
) {
    for (ray, hit) in rays.iter().zip(out.iter_mut()) {
        let mut r = *ray;
        *hit = Hit::MISS;
        for (k, prim) in prims.iter().enumerate() {
            if let Some((t, u, v)) = isect(prim, &r) {
                *hit = Hit {
                    t,
                    prim: k as u32,
                    u,
                    v,
                };
                r.tmax = t;
            }
        }
    }
}

fn trace_packets<L: Lanes, P>(
    prims: &[P],
    rays: &[Ray],
    out: &mut [Hit],
    kernel: impl Fn(&P, &RayPacket<L>) -> PrimHits<L>,
) {
    for (rays, out) in rays.chunks(L::WIDTH).zip(out.chunks_mut(L::WIDTH)) {
        let mut packet = RayPacket::<L>::from_rays(rays);
        let mut hits = HitPacket::<L>::miss();
        for (k, prim) in prims.iter().enumerate() {
            let found = kernel(prim, &packet);
            record_closest(&mut hits, &mut packet, &found, k as u32);
        }
        hits.write_active(&packet, out);
    }
}

fn scalar_triangle(tri: &Triangle, ray: &Ray) -> Option<(f32, f32, f32)> {
    tri.intersect(ray)
}

fn scalar_sphere(s: &Sphere, ray: &Ray) -> Option<(f32, f32, f32)> {
    s.intersect(ray).map(|t| (t, 0.0, 0.0))
}

fn kernels(c: &mut Criterion) {
    let (tris, spheres, rays) = (triangles(), spheres(), rays());
    let mut g = c.benchmark_group(format!("kernels-{}", kdray_core::isa::name()));
    g.throughput(Throughput::Elements(rays.len() as u64));
    let kind = Kind {
        name: "triangle",
        scalar: scalar_triangle,
        x4: intersect_triangle::<f32x4>,
        x8: intersect_triangle::<f32x8>,
    };
    kind.bench(&mut g, &tris, &rays);
    let kind = Kind {
        name: "sphere",
        scalar: scalar_sphere,
        x4: intersect_sphere::<f32x4>,
        x8: intersect_sphere::<f32x8>,
    };
    kind.bench(&mut g, &spheres, &rays);
    g.finish();
}

/// One kind of primitive: its scalar kernel and its two packet kernels. The kernels are function
/// items (zero-sized types), so each `trace_*` instance calls them statically and can inline them.
struct Kind<S, K4, K8> {
    name: &'static str,
    scalar: S,
    x4: K4,
    x8: K8,
}

impl<S, K4, K8> Kind<S, K4, K8> {
    /// Checks that the packet answers are the scalar ones, then times `name/scalar`, `name/x4`,
    /// `name/x8` on the same rays.
    fn bench<P>(self, g: &mut BenchmarkGroup<'_, WallTime>, prims: &[P], rays: &[Ray])
    where
        S: Fn(&P, &Ray) -> Option<(f32, f32, f32)> + Copy,
        K4: Fn(&P, &RayPacket<f32x4>) -> PrimHits<f32x4> + Copy,
        K8: Fn(&P, &RayPacket<f32x8>) -> PrimHits<f32x8> + Copy,
    {
        let name = self.name;
        let mut reference = vec![Hit::MISS; rays.len()];
        let mut out = reference.clone();
        trace_scalar(prims, rays, &mut reference, self.scalar);
        trace_packets(prims, rays, &mut out, self.x4);
        assert!(out == reference, "{name}: 4-wide and scalar hits differ");
        trace_packets(prims, rays, &mut out, self.x8);
        assert!(out == reference, "{name}: 8-wide and scalar hits differ");
        let hits = reference.iter().filter(|h| h.is_hit()).count();
        println!(
            "kernels ({}): {} rays x {} {name}s, {hits} rays hit",
            kdray_core::isa::name(),
            rays.len(),
            prims.len(),
        );

        g.bench_function(format!("{name}/scalar"), |b| {
            b.iter(|| trace_scalar(black_box(prims), black_box(rays), &mut out, self.scalar))
        });
        g.bench_function(format!("{name}/x4"), |b| {
            b.iter(|| trace_packets(black_box(prims), black_box(rays), &mut out, self.x4))
        });
        g.bench_function(format!("{name}/x8"), |b| {
            b.iter(|| trace_packets(black_box(prims), black_box(rays), &mut out, self.x8))
        });
        black_box(&out);
    }
}

criterion_group!(benches, kernels);
criterion_main!(benches);
