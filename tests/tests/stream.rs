//! The ray-stream API against the one-ray walk, ray by ray, on random scenes stored with nodes
//! only or with wide nodes: a stream without packets gives exactly the one-ray walk's hits (`t`,
//! primitive, `u`, `v`, bit for bit) and occlusion; a stream with packets the same `t` bits, and
//! either primitive where two tie at that `t` (as the packet walks do); the single rays over wide
//! nodes walked in turns or one by one alike. Short slices are errors, not panics.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::traverse::stream::{self, Coherence, Config, Packets, StreamError, Turns};
use kdray_core::traverse::{Mixed, Mode, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::strategies::{grid_geometry, packet_rays, scene_words};
use proptest::prelude::*;

/// `geom`'s tree (index lists: the scenes mix triangles and spheres) with `layout`.
fn words_with(geom: &Geometry, intersect_cost: f64, layout: Layout) -> Vec<u32> {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        ..BuildParams::default()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    serialize_as(&tree, geom, 0.0, layout, Leaves::List).expect("small trees fit the format")
}

/// A stream: runs of coherent and of arbitrary rays, concatenated (so that both the input pass
/// and the sorted pass find packets to form).
fn stream_rays() -> impl Strategy<Value = Vec<Ray>> {
    prop::collection::vec(packet_rays(), 1..16).prop_map(|runs| runs.concat())
}

/// The coherence rules tried: the default (any two rays of an octant, so that most of a random
/// stream becomes packets), and a strict one (directions within ~25°, origins within 5 % of the
/// scene's diagonal) under which runs break off part way.
fn rules() -> impl Strategy<Value = Coherence> {
    prop_oneof![
        Just(Config::default().coherence),
        Just(Coherence {
            min_cos: 0.9,
            max_origin: 0.05,
        }),
    ]
}

fn bits(h: &Hit) -> (u32, u32, u32, u32) {
    (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())
}

macro_rules! stream_matches_scalar {
    ($name:ident, $mode:expr, $contents:ty) => {
        proptest! {
            #![proptest_config(ProptestConfig { cases: kdray_tests::cases(200), max_local_rejects: 1 << 24, ..ProptestConfig::default() })]
            #[test]
            fn $name(geom in grid_geometry(4), isect in prop_oneof![Just(80.0), Just(4.0)], wide in any::<bool>(), rays in stream_rays(), coherence in rules()) {
                let words = words_with(&geom, isect, if wide { Layout::Wide } else { Layout::Nodes });
                let scene = Scene::from_words(&words).unwrap();
                prop_assert_eq!(scene.wide_nodes().is_empty(), !wide);
                let want: Vec<Hit> = rays.iter().map(|r| scene.intersect_in($mode, r)).collect();
                let want_occ: Vec<bool> = rays.iter().map(|r| scene.occluded_in($mode, r)).collect();
                let n = rays.len();
                // Every packet width, and the single rays over wide nodes in turns and one by one
                // (these scenes are far below the size from which `Turns::Auto` takes turns).
                let ways = [Packets::Off, Packets::Four, Packets::Eight]
                    .into_iter()
                    .flat_map(|p| [Turns::Always, Turns::Never].map(|t| (p, t)));
                for (packets, turns) in ways {
                    let config = Config { mode: $mode, packets, coherence, turns };
                    let mut scratch = vec![u64::MAX; stream::scratch_words(n)];
                    let mut hits = vec![Hit { t: -7.0, prim: 77, u: 7.0, v: 7.0 }; n];
                    stream::intersect(&scene, &config, &rays, &mut hits, &mut scratch).unwrap();
                    for i in 0..n {
                        let (got, want, ray) = (hits[i], want[i], rays[i]);
                        if packets == Packets::Off || got.prim == want.prim {
                            prop_assert_eq!(bits(&got), bits(&want), "{:?} ray {} {:?}", config, i, ray);
                        } else {
                            prop_assert_eq!(got.t.to_bits(), want.t.to_bits(), "{:?} ray {} {:?}", config, i, ray);
                            let own = scene.intersect_prim::<$contents>(got.prim, &ray).map(|h| h.0);
                            prop_assert_eq!(own, Some(want.t), "ray {}: prim {} is not a tie", i, got.prim);
                        }
                    }
                    let mut occ = vec![true; n];
                    stream::occluded(&scene, &config, &rays, &mut occ, &mut scratch).unwrap();
                    prop_assert_eq!(&occ, &want_occ, "stream occlusion {:?}", config);
                }
            }
        }
    };
}

stream_matches_scalar!(stream_matches_scalar, Mode::Fast, Mixed);
stream_matches_scalar!(
    watertight_stream_matches_scalar,
    Mode::Watertight,
    Watertight<Mixed>
);

#[test]
fn short_slices_are_errors() {
    let geom = kdray::Geometry {
        triangles: vec![[Vec3::ZERO, Vec3::X, Vec3::Y]],
        ..kdray::Geometry::default()
    };
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let rays = vec![Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z); 5];
    let config = Config::default();
    let mut hits = vec![Hit::MISS; 4];
    let mut scratch = vec![0; stream::scratch_words(5)];
    assert_eq!(
        stream::intersect(&scene, &config, &rays, &mut hits, &mut scratch),
        Err(StreamError::Length {
            rays: 5,
            answers: 4
        })
    );
    let mut occluded = vec![false; 4];
    assert_eq!(
        stream::occluded(&scene, &config, &rays, &mut occluded, &mut scratch),
        Err(StreamError::Length {
            rays: 5,
            answers: 4
        })
    );
    let mut hits = vec![Hit::MISS; 5];
    let mut short = vec![0; stream::scratch_words(5) - 1];
    assert_eq!(
        stream::intersect(&scene, &config, &rays, &mut hits, &mut short),
        Err(StreamError::Scratch {
            needed: 10,
            given: 9
        })
    );
    assert!(hits.iter().all(|h| !h.is_hit()), "nothing traced on error");
    // Enough scratch: every ray hits the triangle at t = 1.
    stream::intersect(&scene, &config, &rays, &mut hits, &mut scratch).unwrap();
    assert!(hits.iter().all(|h| h.prim == 0 && h.t == 1.0));
    let mut occ = vec![false; 5];
    stream::occluded(&scene, &config, &rays, &mut occ, &mut scratch).unwrap();
    assert_eq!(occ, [true; 5]);
}
