//! Each benchmark peer against a brute-force loop over all triangles (kdray's scalar
//! Möller–Trumbore), ray by ray: same primitive, or — where two primitives are hit at the same
//! distance (a shared edge, a duplicated triangle) — the same `t` to within 1e-4 relative.
//!
//! The mesh and rays are pseudo-random from fixed seeds, so a failure reproduces.

use glam::Vec3;
use kdray_benches::peer_bvh::BvhPeer;
use kdray_core::{Hit, Ray, Triangle};

/// SplitMix64 (Steele, Lea, Flood 2014): enough randomness for test scenes, no dependency.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    fn vec_in(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }

    fn unit(&mut self) -> Vec3 {
        loop {
            let v = self.vec_in(-1.0, 1.0);
            if let Some(u) = v.try_normalize().filter(|_| v.length_squared() <= 1.0) {
                return u;
            }
        }
    }
}

/// Triangles of mixed sizes in [-1, 1]³, plus the cases a traversal can get wrong: a duplicate of
/// an earlier triangle (an exact tie), two triangles sharing an edge, a degenerate one and a large
/// one that spans the scene.
fn random_mesh(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    let mut tris: Vec<[Vec3; 3]> = (0..n)
        .map(|i| {
            let size = if i % 10 == 0 { 0.6 } else { 0.15 };
            let c = rng.vec_in(-1.0, 1.0);
            [
                c + size * rng.unit(),
                c + size * rng.unit(),
                c + size * rng.unit(),
            ]
        })
        .collect();
    let dup = tris[n / 2];
    tris.push(dup);
    let (a, b) = (Vec3::new(-0.5, -0.5, 0.3), Vec3::new(0.5, 0.5, 0.3));
    tris.push([a, b, Vec3::new(0.5, -0.5, 0.3)]);
    tris.push([a, Vec3::new(-0.5, 0.5, 0.3), b]);
    tris.push([Vec3::ZERO, Vec3::ONE, Vec3::splat(0.5)]);
    tris.push([
        Vec3::new(-2.0, -2.0, -0.9),
        Vec3::new(2.0, -2.0, -0.9),
        Vec3::new(0.0, 2.0, -0.9),
    ]);
    tris
}

/// Rays from inside and outside the scene towards random points in it, with a mix of intervals,
/// plus two rays that are not finite; `n` is deliberately not a multiple of 8.
fn random_rays(rng: &mut Rng, n: usize) -> Vec<Ray> {
    let mut rays: Vec<Ray> = (0..n)
        .map(|i| {
            let origin = if i % 3 == 0 {
                rng.vec_in(-1.0, 1.0)
            } else {
                3.0 * rng.unit()
            };
            let target = rng.vec_in(-1.0, 1.0);
            let dir = (target - origin).try_normalize().unwrap_or(Vec3::Z);
            let ray = Ray::new(origin, dir);
            match i % 5 {
                0 => ray.with_range(0.0, rng.range(0.5, 3.0)),
                1 => ray.with_range(rng.range(0.0, 1.0), f32::INFINITY),
                _ => ray,
            }
        })
        .collect();
    rays.push(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z));
    rays.push(Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)));
    rays
}

/// The closest hit by testing every triangle; the first in input order wins a tie.
fn brute_force(tris: &[Triangle], ray: &Ray) -> Hit {
    let mut best = Hit::MISS;
    if !ray.is_finite() {
        return best;
    }
    let mut r = *ray;
    for (prim, tri) in (0u32..).zip(tris) {
        if let Some((t, u, v)) = tri.intersect(&r) {
            r.tmax = t;
            best = Hit { t, prim, u, v };
        }
    }
    best
}

/// Compares `hits` with the brute-force answers. When the primitive matches, |Δu| and |Δv| must be
/// at most `uv_tol / |sin θ|`, θ the angle between the ray and the triangle's plane (the
/// barycentrics' condition number grows like 1 / sin θ for grazing rays); `uv_tol` is 0 for a peer
/// that runs kdray's own kernel.
fn check(peer: &str, mesh: &[[Vec3; 3]], rays: &[Ray], hits: &[Hit], uv_tol: f32) {
    assert_eq!(hits.len(), rays.len(), "{peer}: one hit per ray");
    let tris: Vec<Triangle> = mesh
        .iter()
        .map(|&[a, b, c]| Triangle::from_vertices(a, b, c))
        .collect();
    let mut bad = Vec::new();
    let mut n_hits = 0;
    for (i, (ray, got)) in rays.iter().zip(hits).enumerate() {
        let want = brute_force(&tris, ray);
        n_hits += usize::from(want.is_hit());
        let ok = match (want.is_hit(), got.is_hit()) {
            (false, false) => true,
            (true, true) if got.prim == want.prim => {
                let tri = &tris[want.prim as usize];
                let sin = tri.geometric_normal().normalize().dot(ray.dir).abs();
                let tol = uv_tol / sin;
                (got.t - want.t).abs() <= 1e-4 * want.t.abs()
                    && (got.u - want.u).abs() <= tol
                    && (got.v - want.v).abs() <= tol
            }
            // A different primitive at the same distance: either is the closest hit.
            (true, true) => (got.t - want.t).abs() <= 1e-4 * want.t.abs(),
            _ => false,
        };
        if !ok {
            bad.push(format!("ray {i} {ray:?}: want {want:?}, got {got:?}"));
        }
    }
    assert!(
        bad.is_empty(),
        "{peer}: {} of {} rays differ from brute force:\n{}",
        bad.len(),
        rays.len(),
        bad[..bad.len().min(10)].join("\n")
    );
    // The scene must actually exercise hits and misses.
    assert!(
        n_hits > rays.len() / 4 && n_hits < rays.len(),
        "{peer}: {n_hits} hits"
    );
}

fn scene(seed: u64) -> (Vec<[Vec3; 3]>, Vec<Ray>) {
    let mut rng = Rng(seed);
    let mesh = random_mesh(&mut rng, 400);
    let rays = random_rays(&mut rng, 4001);
    (mesh, rays)
}

#[test]
fn bvh_matches_brute_force() {
    for seed in [1, 2, 3] {
        let (mesh, rays) = scene(seed);
        let peer = BvhPeer::build(&mesh);
        assert_eq!(peer.len(), mesh.len());
        check("bvh traverse", &mesh, &rays, &peer.trace(&rays), 0.0);
        let mut hits = vec![Hit::MISS; rays.len()];
        peer.trace_nearest_first_into(&rays, &mut hits);
        check("bvh nearest-first", &mesh, &rays, &hits, 0.0);
    }
}

#[test]
fn bvh_empty_scene_misses() {
    let (_, rays) = scene(4);
    let peer = BvhPeer::build(&[]);
    assert!(peer.is_empty());
    assert!(peer.trace(&rays).iter().all(|h| *h == Hit::MISS));
}

#[cfg(feature = "embree")]
mod embree {
    use super::*;
    use kdray_benches::peer_embree::{Coherence, EmbreeDevice};

    /// Embree's triangle test is not kdray's: u, v agree to rounding only (see `check`).
    const UV_TOL: f32 = 1e-5;

    #[test]
    fn embree_matches_brute_force() {
        let device = EmbreeDevice::new().expect("Embree device");
        assert!(device.version().starts_with("3."), "{}", device.version());
        assert!(!device.backface_culling());
        for seed in [1, 2, 3] {
            let (mesh, rays) = scene(seed);
            let scene = device.build(&mesh).expect("Embree build");
            assert_eq!(scene.len(), mesh.len());
            check(
                "embree rtcIntersect1",
                &mesh,
                &rays,
                &scene.trace1(&rays),
                UV_TOL,
            );
            check(
                "embree rtcIntersect8",
                &mesh,
                &rays,
                &scene.trace8(&rays),
                UV_TOL,
            );
            // Twice the rays, so that a stream crosses a batch boundary (STREAM_BATCH = 4096).
            let twice = rays.repeat(2);
            for coherence in [Coherence::Coherent, Coherence::Incoherent] {
                check(
                    "embree rtcIntersect1M",
                    &mesh,
                    &twice,
                    &scene.trace1m(&twice, coherence),
                    UV_TOL,
                );
            }
        }
    }

    #[test]
    fn embree_empty_scene_misses() {
        let device = EmbreeDevice::new().expect("Embree device");
        let (_, rays) = scene(4);
        let scene = device.build(&[]).expect("Embree build");
        assert!(scene.is_empty());
        assert!(scene.trace1(&rays).iter().all(|h| *h == Hit::MISS));
        assert!(scene.trace8(&rays).iter().all(|h| *h == Hit::MISS));
        let stream = scene.trace1m(&rays, Coherence::Incoherent);
        assert!(stream.iter().all(|h| *h == Hit::MISS));
    }

    #[test]
    fn embree_bad_config_is_an_error() {
        let e = EmbreeDevice::with_config("threads=1\0").expect_err("NUL in config");
        assert!(e.to_string().contains("rtcNewDevice"), "{e}");
        let e = EmbreeDevice::with_config("threads=").expect_err("malformed config");
        assert!(e.to_string().contains("rtcNewDevice"), "{e}");
    }

    #[test]
    fn embree_scene_can_be_shared_between_threads() {
        fn sync<T: Sync + Send>(_: &T) {}
        let device = EmbreeDevice::new().expect("Embree device");
        let (mesh, rays) = scene(5);
        let scene = device.build(&mesh).expect("Embree build");
        sync(&scene);
        let whole = scene.trace1(&rays);
        let halves: Vec<Vec<Hit>> = std::thread::scope(|s| {
            let (a, b) = rays.split_at(rays.len() / 2);
            let ha = s.spawn(|| scene.trace1(a));
            let hb = s.spawn(|| scene.trace1(b));
            vec![ha.join().unwrap(), hb.join().unwrap()]
        });
        assert_eq!(halves.concat(), whole);
    }
}
