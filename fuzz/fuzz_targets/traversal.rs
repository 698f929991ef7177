//! Traversal on arbitrary rays through one small valid scene: scalar, 4-wide and 8-wide packets
//! must agree exactly (the same `t` bits; a different primitive only as a tie at that `t`), for
//! closest hits and for occlusion, whatever the rays.
//!
//! The scene is a closed box of 12 triangles, a fan of triangles sharing edges and vertices on a
//! split-prone plane, and two spheres, all with coordinates on a grid of 1/2. Each ray takes 8
//! bytes: an origin on a grid of 1/8 in [-16, 16), a direction with integer components in
//! [-8, 8] (zeros of both signs, normalized or not by a flag bit), and a choice of `tmin/tmax`
//! band; snapping to these grids makes rays through vertices, along edges and in split planes
//! common instead of measure-zero. NaN and infinite rays come from one flag value too.
//!
//! Run: `cargo +nightly fuzz run traversal fuzz/corpus/traversal` (from `fuzz/`).
#![no_main]

use glam::Vec3;
use kdray::Geometry;
use kdray_core::{Ray, Scene};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

fn scene_words() -> &'static [u32] {
    static WORDS: OnceLock<Vec<u32>> = OnceLock::new();
    WORDS.get_or_init(|| {
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let c: Vec<Vec3> = (0..8)
            .map(|i| {
                v(
                    if i & 1 == 0 { -2.0 } else { 2.0 },
                    if i & 2 == 0 { -2.0 } else { 2.0 },
                    if i & 4 == 0 { -2.0 } else { 2.0 },
                )
            })
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let mut triangles = Vec::new();
        for q in quads {
            triangles.push([c[q[0]], c[q[1]], c[q[2]]]);
            triangles.push([c[q[0]], c[q[2]], c[q[3]]]);
        }
        // A fan in the plane z = 0.5 around (0.5, 0, 0.5), inside the box.
        let centre = v(0.5, 0.0, 0.5);
        for k in 0..6 {
            let a = |k: i32| {
                [
                    v(1.5, 0.0, 0.5),
                    v(1.0, 1.0, 0.5),
                    v(-0.5, 1.0, 0.5),
                    v(-0.5, -1.0, 0.5),
                    v(0.5, -1.5, 0.5),
                    v(1.5, -1.0, 0.5),
                ][k.rem_euclid(6) as usize]
            };
            triangles.push([centre, a(k), a(k + 1)]);
        }
        let geom = Geometry {
            triangles,
            spheres: vec![(v(-1.0, -1.0, -1.0), 0.5), (v(1.0, 1.0, -1.0), 1.0)],
            ..Geometry::default()
        };
        kdray_fuzz::build_and_validate("traversal scene", &geom)
    })
}

fn ray_of(b: &[u8]) -> Ray {
    let o = |k: usize| f32::from(b[k] as i8) / 8.0;
    let d = |k: usize| match b[k] % 18 {
        17 => -0.0,
        n => f32::from(n) - 8.0,
    };
    let mut dir = Vec3::new(d(3), d(4), d(5));
    if b[6] & 1 == 1 {
        dir = dir.normalize_or_zero();
    }
    let mut origin = Vec3::new(o(0), o(1), o(2));
    if b[6] & 0x80 != 0 && b[7] == 0xff {
        origin.x = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][usize::from(b[6] >> 1 & 3) % 3];
    }
    let (tmin, tmax) = match b[7] % 4 {
        0 => (0.0, f32::INFINITY),
        1 => (1e-3, 8.0),
        2 => (f32::from(b[6] >> 2) / 4.0, f32::INFINITY),
        _ => (-4.0, 4.0),
    };
    Ray::new(origin, dir).with_range(tmin, tmax)
}

fuzz_target!(|data: &[u8]| {
    let scene = Scene::from_words(scene_words()).expect("the fixed scene validates");
    let rays: Vec<Ray> = data.chunks_exact(8).take(64).map(ray_of).collect();
    kdray_fuzz::packets_agree_with_scalar(&scene, &rays);
});
