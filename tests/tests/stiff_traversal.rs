//! Stiff traversal cases, in fast and watertight mode, scalar walk and 8- and 4-wide packets, on
//! the closed unit icosphere (`kdray_tests::closed`, 1,280 triangles): ray origins exactly on the
//! tree's split planes, direction components `0.0` and `-0.0`, and NaN, infinite and zero rays.
//! Each test states its expectation; fast mode's disagreements, where not asserted, are printed.

use glam::Vec3;
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8};
use kdray_core::traverse::{Contents, Mixed, Mode, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::closed::icosphere;

fn sphere_words() -> Vec<u32> {
    icosphere(3).scene_words()
}

/// `rays` in `mode` by the scalar walk, then by packets of `L` (consecutive rays).
fn packet_hits<L: Lanes>(scene: &Scene, rays: &[Ray], mode: Mode) -> Vec<Hit> {
    let mut out = vec![Hit::MISS; rays.len()];
    for (r, h) in rays.chunks(L::WIDTH).zip(out.chunks_mut(L::WIDTH)) {
        let packet = RayPacket::<L>::from_rays(r);
        scene
            .intersect_packet_in(mode, &packet)
            .write_active(&packet, h);
    }
    out
}

/// The closest `t` over all triangles with `C`'s kernel.
fn brute_t<C: Contents>(scene: &Scene, ray: &Ray) -> f32 {
    (0..scene.prim_count())
        .filter_map(|p| scene.intersect_prim::<C>(p, ray))
        .map(|h| h.0)
        .fold(f32::INFINITY, f32::min)
}

/// Traces `rays` every way in `mode`. Asserts that the 8- and 4-wide packets find the scalar
/// walk's `t` for every ray; returns the scalar hits and how many differ from brute force.
fn trace_every_way<C: Contents>(scene: &Scene, rays: &[Ray], mode: Mode) -> (Vec<Hit>, usize) {
    let scalar: Vec<Hit> = rays.iter().map(|r| scene.intersect_in(mode, r)).collect();
    for (width, hits) in [
        (8, packet_hits::<f32x8>(scene, rays, mode)),
        (4, packet_hits::<f32x4>(scene, rays, mode)),
    ] {
        for ((ray, s), p) in rays.iter().zip(&scalar).zip(&hits) {
            assert!(
                s.t == p.t,
                "{mode:?} {width}-wide: {p:?}, scalar {s:?}, ray {ray:?}"
            );
        }
    }
    let off = rays
        .iter()
        .zip(&scalar)
        .filter(|(r, h)| h.t != brute_t::<C>(scene, r))
        .count();
    (scalar, off)
}

/// Directions along and between the axes, each with its zero components `+0.0` and `-0.0`.
fn axis_directions() -> Vec<Vec3> {
    let mut dirs = Vec::new();
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            for zeros in [[0.0f32, 0.0], [-0.0, -0.0], [0.0, -0.0], [-0.0, 0.0]] {
                let mut d = [0.0f32; 3];
                d[axis] = sign;
                d[(axis + 1) % 3] = zeros[0];
                d[(axis + 2) % 3] = zeros[1];
                dirs.push(Vec3::from(d));
                // And a diagonal in the plane of this axis and the next, the third zero.
                let mut e = d;
                e[(axis + 1) % 3] = sign * core::f32::consts::FRAC_1_SQRT_2;
                e[axis] = core::f32::consts::FRAC_1_SQRT_2;
                dirs.push(Vec3::from(e));
            }
        }
    }
    dirs
}

/// Rays from points exactly on the tree's split planes (each interior node's plane, through a
/// point well inside the sphere), along and between the axes with `±0` components and in three
/// generic directions. Expectation: in watertight mode every ray hits (the origins are inside the
/// closed mesh) and the walk finds brute force's closest `t` with the same kernel, scalar and
/// packets alike; in fast mode packets equal the scalar walk, and rays where the walk differs from
/// brute force are counted (printed, not asserted: docs/ROBUSTNESS.md).
#[test]
fn origins_on_split_planes() {
    let words = sphere_words();
    let scene = Scene::from_words(&words).unwrap();
    let mut dirs = axis_directions();
    dirs.extend([
        Vec3::new(0.3, -0.5, 0.8).normalize(),
        Vec3::new(-0.7, 0.1, -0.2).normalize(),
        Vec3::new(0.0, -0.6, 0.8),
    ]);
    let mut rays = Vec::new();
    // Every 7th interior node's plane (about 200 planes; brute force runs on each ray).
    let planes = (0..scene.node_count())
        .map(|i| scene.node(i))
        .filter(|n| !n.is_leaf() && n.split().abs() <= 0.9)
        .step_by(7);
    for node in planes {
        let mut o = Vec3::new(0.05, -0.1, 0.07);
        o[node.axis()] = node.split();
        rays.extend(dirs.iter().map(|&d| Ray::new(o, d)));
    }
    assert!(rays.len() > 2000, "{} rays", rays.len());
    let (hits, off) = trace_every_way::<Watertight<Mixed>>(&scene, &rays, Mode::Watertight);
    assert_eq!(off, 0, "watertight walk differs from brute force");
    let escaped = hits.iter().filter(|h| !h.is_hit()).count();
    assert_eq!(escaped, 0, "watertight rays escaped");
    let (fast, fast_off) = trace_every_way::<Mixed>(&scene, &rays, Mode::Fast);
    let fast_escaped = fast.iter().filter(|h| !h.is_hit()).count();
    println!(
        "{} rays from split planes: fast mode escaped {fast_escaped}, walk differs from brute \
         force on {fast_off}; watertight 0 and 0",
        rays.len()
    );
}

/// Rays from the centre along the axes and the axis-plane diagonals, with each zero component
/// `+0.0` or `-0.0`. Expectation: watertight mode hits every one, and a ray's `t` does not depend
/// on the signs of its zero components; in both modes packets equal the scalar walk.
#[test]
fn zero_direction_components() {
    let words = sphere_words();
    let scene = Scene::from_words(&words).unwrap();
    let dirs = axis_directions();
    let rays: Vec<Ray> = dirs.iter().map(|&d| Ray::new(Vec3::ZERO, d)).collect();
    let (hits, off) = trace_every_way::<Watertight<Mixed>>(&scene, &rays, Mode::Watertight);
    assert_eq!(off, 0);
    for (d, h) in dirs.iter().zip(&hits) {
        assert!(h.is_hit(), "watertight ray {d:?} escaped");
        // The same direction with every zero positive.
        let plus = d.map(|c| if c == 0.0 { 0.0 } else { c });
        let t = scene
            .intersect_in(Mode::Watertight, &Ray::new(Vec3::ZERO, plus))
            .t;
        assert_eq!(h.t, t, "{d:?}: t depends on the sign of a zero");
    }
    let (fast, _) = trace_every_way::<Mixed>(&scene, &rays, Mode::Fast);
    let escaped = fast.iter().filter(|h| !h.is_hit()).count();
    println!("{} axis rays: fast mode escaped {escaped}", rays.len());
}

/// NaN or infinite origins, directions and ranges, and a zero direction. Expectation: every one is
/// a miss in both modes, scalar and 8-/4-wide (in bounded time: the walk rejects non-finite rays
/// before any arithmetic, and a zero direction fails every kernel; this test returning is the
/// check).
#[test]
fn non_finite_rays_miss() {
    let words = sphere_words();
    let scene = Scene::from_words(&words).unwrap();
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let rays = [
        Ray::new(Vec3::new(nan, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::new(0.0, nan, 1.0)),
        Ray::new(Vec3::new(0.0, 0.0, inf), Vec3::NEG_Z),
        Ray::new(Vec3::new(-inf, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::new(inf, 0.0, 0.0)),
        Ray::new(Vec3::ZERO, Vec3::new(1.0, -inf, 0.0)),
        Ray::new(Vec3::ZERO, Vec3::X).with_range(nan, inf),
        Ray::new(Vec3::ZERO, Vec3::X).with_range(0.0, nan),
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray::new(Vec3::ZERO, -Vec3::ZERO),
        Ray::new(Vec3::splat(nan), Vec3::splat(nan)).with_range(nan, nan),
    ];
    for mode in [Mode::Fast, Mode::Watertight] {
        for r in &rays {
            assert!(!scene.intersect_in(mode, r).is_hit(), "{mode:?} {r:?} hit");
            assert!(!scene.occluded_in(mode, r), "{mode:?} {r:?} occluded");
        }
        for hits in [
            packet_hits::<f32x8>(&scene, &rays, mode),
            packet_hits::<f32x4>(&scene, &rays, mode),
        ] {
            assert!(hits.iter().all(|h| !h.is_hit()), "{mode:?}: {hits:?}");
        }
    }
}
