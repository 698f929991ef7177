//! Packet traversal (4, 8 and 16 lanes) against scalar traversal, ray by ray, on random scenes:
//! the same primitive and the same `t` (exactly: the packet kernels round as the scalar ones do),
//! or, where two primitives tie at that `t`, either of them; occlusion the same per lane; inactive
//! lanes never written.

use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8, f32x16};
use kdray_core::traverse::{Mixed, Mode, Watertight};
use kdray_core::{Hit, Scene};
use kdray_tests::strategies::{grid_geometry, packet_rays as rays, scene_words};
use proptest::prelude::*;

macro_rules! packet_matches_scalar {
    ($name:ident, $lanes:ty, $w:expr, $mode:expr, $contents:ty) => {
        proptest! {
            #![proptest_config(ProptestConfig { cases: kdray_tests::cases(300), max_local_rejects: 1 << 24, ..ProptestConfig::default() })]
            #[test]
            fn $name(geom in grid_geometry(4), isect in prop_oneof![Just(80.0), Just(4.0)], packets in prop::collection::vec(rays(), 1..12)) {
                let words = scene_words(&geom, isect);
                let scene = Scene::from_words(&words).unwrap();
                // Up to eight rays a set: 16 lanes take all the sets as one, so that most of their
                // packets are whole ones (the transposing load), each of several sets.
                let per = if $w > 8 { packets.len() } else { 1 };
                let sets: Vec<Vec<_>> = packets.chunks(per).map(|p| p.concat()).collect();
                for rays in &sets {
                    for chunk in rays.chunks($w) {
                        let packet = RayPacket::<$lanes>::from_rays(chunk);
                        let sentinel = Hit { t: -7.0, prim: 77, u: 7.0, v: 7.0 };
                        let mut out = [sentinel; 16];
                        scene.intersect_packet_in($mode, &packet).write_active(&packet, &mut out[..$w]);
                        let occluded = scene.occluded_packet_in($mode, &packet).bitmask();
                        for (i, ray) in chunk.iter().enumerate() {
                            let want = scene.intersect_in($mode, ray);
                            let got = out[i];
                            if !ray.is_finite() {
                                prop_assert_eq!(got, sentinel, "inactive lane {} written", i);
                                continue;
                            }
                            prop_assert!(got.t == want.t, "lane {} ray {:?}: packet {:?} scalar {:?}", i, ray, got, want);
                            if got.prim != want.prim {
                                let own = scene.intersect_prim::<$contents>(got.prim, ray).map(|h| h.0);
                                prop_assert_eq!(own, Some(want.t), "lane {}: prim {} is not a tie", i, got.prim);
                            }
                            prop_assert_eq!(occluded >> i & 1 == 1, scene.occluded_in($mode, ray), "occlusion lane {} ray {:?}", i, ray);
                        }
                        for (i, slot) in out.iter().enumerate().skip(chunk.len()) {
                            prop_assert_eq!(*slot, sentinel, "lane {} past the rays written", i);
                        }
                    }
                }
            }
        }
    };
}

packet_matches_scalar!(packet4_matches_scalar, f32x4, 4, Mode::Fast, Mixed);
packet_matches_scalar!(packet8_matches_scalar, f32x8, 8, Mode::Fast, Mixed);
packet_matches_scalar!(packet16_matches_scalar, f32x16, 16, Mode::Fast, Mixed);
// Watertight mode: the packet walks against the scalar walk, both watertight.
packet_matches_scalar!(
    watertight_packet4_matches_scalar,
    f32x4,
    4,
    Mode::Watertight,
    Watertight<Mixed>
);
packet_matches_scalar!(
    watertight_packet8_matches_scalar,
    f32x8,
    8,
    Mode::Watertight,
    Watertight<Mixed>
);
packet_matches_scalar!(
    watertight_packet16_matches_scalar,
    f32x16,
    16,
    Mode::Watertight,
    Watertight<Mixed>
);
