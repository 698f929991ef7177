//! `Scene::from_words` on arbitrary bytes (read as little-endian words) must return, never panic
//! or hang. The input is first re-sealed (its header's checksum recomputed, as a crafted file
//! would be), so that mutations reach the checks behind the checksum instead of all failing it;
//! inputs whose length is 4 more than a multiple of 64 bytes are left as they came, to keep the
//! checksum path covered. A scene it accepts is then traced, scalar and in 4- and 8-wide packets,
//! along a fixed fan of rays through its box, and the three must agree (the same `t` bits; a
//! different primitive only as a tie at that `t`), for closest hits and for occlusion. A scene
//! with triangle groups (format v9) is checked the same way: its single rays test four triangles at once with the group kernels, its packets read the
//! groups' lanes one triangle at a time, and the two must agree. A scene with wide nodes
//! (format v10) is traced over them and over its nodes ([`Scene::without_wide`]): in watertight
//! mode both find the closest hit, so the `t` bits must agree (a different primitive only as a tie
//! at that `t`); in fast mode the node walk may lose a seam ray the boxes keep, so a wide hit must
//! be a real hit at its `t`, and any-hit must agree with closest hit.
//!
//! Run: `cargo +nightly fuzz run from_words fuzz/corpus/from_words` (from the repository root);
//! the corpus starts from small valid scenes (`fuzz/seed.sh`).
#![no_main]

use glam::Vec3;
use kdray_core::format::seal;
use kdray_core::traverse::Mode;
use kdray_core::{Ray, Scene};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut words: Vec<u32> = data
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if data.len() % 64 != 4 {
        seal(&mut words);
    }
    let Ok(scene) = Scene::from_words(&words) else {
        return;
    };
    let rays = fan(&scene);
    kdray_fuzz::packets_agree_with_scalar(&scene, &rays);
    if !scene.wide_nodes().is_empty() {
        wide_agrees_with_nodes(&scene, &rays);
    }
});

/// The wide walk's answers against the node walk's (see the module doc).
fn wide_agrees_with_nodes(scene: &Scene, rays: &[Ray]) {
    let nodes = scene.without_wide();
    for ray in rays {
        for mode in [Mode::Fast, Mode::Watertight] {
            let wide = scene.intersect_in(mode, ray);
            assert_eq!(
                scene.occluded_in(mode, ray),
                wide.is_hit(),
                "{mode:?} {ray:?}"
            );
            if mode == Mode::Watertight {
                let node = nodes.intersect_in(mode, ray);
                assert_eq!(wide.t.to_bits(), node.t.to_bits(), "{ray:?}");
            }
            if wide.is_hit() {
                let own = match mode {
                    Mode::Fast => {
                        scene.intersect_prim::<kdray_core::traverse::Mixed>(wide.prim, ray)
                    }
                    Mode::Watertight => scene.intersect_prim::<kdray_core::traverse::Watertight<
                        kdray_core::traverse::Mixed,
                    >>(wide.prim, ray),
                };
                assert_eq!(
                    own.map(|h| h.0.to_bits()),
                    Some(wide.t.to_bits()),
                    "{mode:?} {ray:?}"
                );
            }
        }
    }
}

/// Rays from outside the box towards its centre and its corners, along the axes (±0 components)
/// and diagonals, plus rays starting at the centre; a fixed `tmin` band exercises clipping.
fn fan(scene: &Scene) -> Vec<Ray> {
    let [lo, hi] = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let extent = (hi - lo).max_element().max(1e-3);
    let mut rays = Vec::new();
    for i in 0..27 {
        let d = Vec3::new(
            (i % 3) as f32 - 1.0,
            (i / 3 % 3) as f32 - 1.0,
            (i / 9) as f32 - 1.0,
        );
        let Some(d) = d.try_normalize() else { continue };
        for target in [centre, lo, hi, centre + 0.1 * (hi - lo)] {
            rays.push(Ray::new(target - d * (2.0 * extent), d));
        }
        rays.push(Ray::new(centre, d).with_range(-extent, extent));
    }
    rays
}
