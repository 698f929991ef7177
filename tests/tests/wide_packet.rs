//! Packets over wide nodes (`kdray_core::traverse::wide::packet`): each lane of a 4- or 8-wide
//! packet gets exactly its ray's single-ray wide walk answer — the same `t`, primitive and `u`,
//! `v` bits, ties included — closest and any hit, fast and watertight, on the random grid scenes
//! of the brute-force tests with index lists (spheres too) and with groups, for incoherent rays
//! (packets split by direction octant) and coherent fans.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::build;
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::strategies::{grid_geometry, traversal_ray};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// `geom`'s tree with wide nodes and `leaves`.
fn wide_words(geom: &Geometry, leaves: Leaves) -> Vec<u32> {
    let params = kdray::build::BuildParams {
        parallel: false,
        ..leaves.build_params()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    serialize_as(&tree, geom, 0.0, Layout::Wide, leaves).expect("fits the format")
}

fn bits(h: &Hit) -> (u32, u32, u32, u32) {
    (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())
}

/// Every lane of every packet of `rays` against the single-ray walk.
fn check_packets<L: Lanes>(scene: &Scene, rays: &[Ray]) -> Result<(), TestCaseError> {
    for chunk in rays.chunks(L::WIDTH) {
        let packet = RayPacket::<L>::from_rays(chunk);
        for mode in [Mode::Fast, Mode::Watertight] {
            let hits = scene.intersect_packet_in(mode, &packet);
            let occluded = scene.occluded_packet_in(mode, &packet).bitmask();
            for (i, ray) in chunk.iter().enumerate() {
                let want = scene.intersect_in(mode, ray);
                prop_assert_eq!(
                    bits(&hits.hit(i)),
                    bits(&want),
                    "{:?} lane {} of {}: {:?}",
                    mode,
                    i,
                    L::WIDTH,
                    ray
                );
                prop_assert_eq!(
                    occluded >> i & 1 == 1,
                    scene.occluded_in(mode, ray),
                    "{:?} occlusion, lane {}: {:?}",
                    mode,
                    i,
                    ray
                );
            }
        }
    }
    Ok(())
}

/// Eight rays from `origin` in directions spread a little around `dir`.
fn fan(origin: Vec3, dir: Vec3, spread: f32) -> Vec<Ray> {
    (0..8)
        .map(|k| {
            let (a, b) = ((k % 4) as f32 - 1.5, (k / 4) as f32 - 0.5);
            let d = dir + Vec3::new(a * spread, b * spread, (a - b) * spread * 0.5);
            Ray::new(origin, d.normalize_or(Vec3::X))
        })
        .collect()
}

fn coherent_rays() -> impl Strategy<Value = Vec<Ray>> {
    prop::collection::vec(
        (traversal_ray(), 0.001f32..0.2).prop_map(|(r, s)| fan(r.origin, r.dir, s)),
        3,
    )
    .prop_map(|fans| fans.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(96)))]

    #[test]
    fn packets_over_wide_nodes_answer_as_single_rays(
        geom in grid_geometry(3),
        random in prop::collection::vec(traversal_ray(), 24),
        coherent in coherent_rays(),
    ) {
        let words = wide_words(&geom, Leaves::List);
        let scene = Scene::from_words(&words).unwrap();
        prop_assert!(!scene.wide_nodes().is_empty());
        for rays in [&random, &coherent] {
            check_packets::<f32x8>(&scene, rays)?;
            check_packets::<f32x4>(&scene, rays)?;
        }
    }

    #[test]
    fn packets_over_wide_groups_answer_as_single_rays(
        geom in grid_geometry(1),
        random in prop::collection::vec(traversal_ray(), 24),
        coherent in coherent_rays(),
    ) {
        prop_assume!(!geom.triangles.is_empty());
        let words = wide_words(&geom, Leaves::Groups);
        let scene = Scene::from_words(&words).unwrap();
        for rays in [&random, &coherent] {
            check_packets::<f32x8>(&scene, rays)?;
            check_packets::<f32x4>(&scene, rays)?;
        }
    }
}
