//! `InstancedScene::from_words` (the top level of a scene of many meshes) on arbitrary bytes,
//! read as little-endian words, over two fixed bottom scenes: it must return, never panic or
//! hang. The input is first re-sealed (its checksum recomputed, as a crafted file would be), so
//! that mutations reach the checks behind the checksum; inputs whose length is 4 more than a
//! multiple of 64 bytes are left as they came, to keep the checksum path covered. A top level it
//! accepts is then traced along a fixed fan of rays through its box, in fast and watertight
//! mode: any hit must agree with closest hit, and a hit must name an instance in range, whose
//! bottom scene hits the ray moved into it at the same `t`.
//!
//! Run: `bash fuzz/run.sh 600 instances` (from the repository root); the corpus starts from
//! `fuzz/seeds/instances/` (a top level of five instances over the two bottom scenes below:
//! mirrored, sheared, scaled by 10³ and 10⁻³).
#![no_main]

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray_core::format::seal;
use kdray_core::instance::{InstancedScene, walk::into_instance};
use kdray_core::traverse::Mode;
use kdray_core::{Ray, Scene};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

/// Two bottom scenes: a unit square of two triangles, and a tetrahedron.
fn bottom_words() -> &'static [Vec<u32>; 2] {
    static WORDS: OnceLock<[Vec<u32>; 2]> = OnceLock::new();
    WORDS.get_or_init(|| {
        let p = |x, y, z| Vec3::new(x, y, z);
        let square = vec![
            [p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0)],
            [p(0.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(0.0, 1.0, 0.0)],
        ];
        let (a, b, c, d) = (
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
        );
        let tetra = vec![[a, c, b], [a, b, d], [a, d, c], [b, c, d]];
        [square, tetra].map(|triangles| {
            let geom = Geometry {
                triangles,
                ..Geometry::default()
            };
            let params = BuildParams {
                parallel: false,
                ..BuildParams::default()
            };
            serialize(&build(&geom, &params, None).unwrap(), &geom, 0.0).unwrap()
        })
    })
}

fuzz_target!(|data: &[u8]| {
    let mut words: Vec<u32> = data
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if data.len() % 64 != 4 {
        seal(&mut words);
    }
    let bottoms: Vec<Scene> = bottom_words()
        .iter()
        .map(|w| Scene::from_words(w).unwrap())
        .collect();
    let Ok(top) = InstancedScene::from_words(&words, &bottoms) else {
        return;
    };
    let [lo, hi] = top.bounds();
    let centre = (lo + hi) * 0.5;
    let extent = (hi - lo).max_element().max(1e-3);
    for i in 0..27 {
        let d = Vec3::new(
            (i % 3) as f32 - 1.0,
            (i / 3 % 3) as f32 - 1.0,
            (i / 9) as f32 - 1.0,
        );
        let Some(d) = d.try_normalize() else { continue };
        for target in [centre, lo, hi, centre + 0.1 * (hi - lo)] {
            let ray = Ray::new(target - d * (2.0 * extent), d);
            for mode in [Mode::Fast, Mode::Watertight] {
                let hit = top.intersect_in(mode, &ray);
                assert_eq!(
                    top.occluded_in(mode, &ray),
                    hit.is_hit(),
                    "{mode:?} {ray:?}"
                );
                if hit.is_hit() {
                    assert!(hit.instance < top.instance_count());
                    let inst = top.instance(hit.instance);
                    let (local, f) = into_instance(&inst.inverse, &ray).unwrap();
                    let own = top.bottom_of(hit.instance).intersect_in(mode, &local);
                    assert!(own.is_hit() && own.t * f <= hit.t, "{mode:?} {ray:?}");
                }
            }
        }
    }
});
