//! Shared checks of the fuzz targets (`fuzz_targets/`): what every accepted input must then do.

pub mod traversal;

use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize, serialize_as};
use kdray_core::simd::{HitPacket, Lanes, RayPacket, f32x4, f32x8};
use kdray_core::{Hit, Ray, Scene};

/// A mesh a loader accepted must be buildable into a tree whose words validate (with an index
/// list, and with groups when it has no spheres): the loaders'
/// checks (finite vertices, finite edges, at least one triangle, attribute counts) are exactly
/// what the builder and the flat format need. Panics, with the reason, if not.
pub fn build_and_validate(what: &str, geom: &Geometry) -> Vec<u32> {
    assert!(
        !geom.triangles.is_empty() || !geom.spheres.is_empty(),
        "{what}: empty geometry accepted"
    );
    let params = BuildParams {
        parallel: false,
        ..BuildParams::default()
    };
    let tree = build(geom, &params, None).unwrap_or_else(|e| panic!("{what}: build failed: {e}"));
    let words =
        serialize(&tree, geom, 0.0).unwrap_or_else(|e| panic!("{what}: serialize failed: {e}"));
    if let Err(e) = Scene::from_words(&words) {
        panic!("{what}: accepted input serializes to an invalid scene: {e}");
    }
    // A scene of triangles alone also stores (and validates) with its leaves in groups of four.
    if geom.spheres.is_empty() {
        let grouped = serialize_as(&tree, geom, 0.0, Layout::Nodes, Leaves::Groups)
            .unwrap_or_else(|e| panic!("{what}: serialize with groups failed: {e}"));
        if let Err(e) = Scene::from_words(&grouped) {
            panic!("{what}: accepted input serializes to an invalid grouped scene: {e}");
        }
    }
    words
}

/// Traces `rays` through `scene` scalar, then in 4- and 8-wide packets of consecutive rays, and
/// panics unless all three agree: the same `t` bits, a different primitive only as a tie at that
/// `t` (both hit), and the same occlusion answer. Returns the scalar hits.
pub fn packets_agree_with_scalar(scene: &Scene, rays: &[Ray]) -> Vec<Hit> {
    let scalar: Vec<Hit> = rays.iter().map(|r| scene.intersect(r)).collect();
    let occluded: Vec<bool> = rays.iter().map(|r| scene.occluded(r)).collect();
    check::<f32x4>(scene, rays, &scalar, &occluded);
    check::<f32x8>(scene, rays, &scalar, &occluded);
    scalar
}

fn check<L: Lanes>(scene: &Scene, rays: &[Ray], scalar: &[Hit], occluded: &[bool]) {
    for (k, chunk) in rays.chunks(L::WIDTH).enumerate() {
        let packet = RayPacket::<L>::from_rays(chunk);
        let mut hits = vec![Hit::MISS; chunk.len()];
        let found: HitPacket<L> = scene.intersect_packet(&packet);
        found.write_active(&packet, &mut hits);
        let any = scene.occluded_packet(&packet).bitmask();
        for (i, hit) in hits.iter().enumerate() {
            let (want, ray, w) = (scalar[k * L::WIDTH + i], chunk[i], L::WIDTH);
            assert_eq!(
                hit.t.to_bits(),
                want.t.to_bits(),
                "t, {w}-wide lane {i} of {ray:?}"
            );
            assert!(
                hit.prim == want.prim || (hit.is_hit() && want.is_hit()),
                "prim, {w}-wide lane {i} of {ray:?}: {} vs scalar {}",
                hit.prim,
                want.prim
            );
            let occ = occluded[k * L::WIDTH + i];
            assert_eq!(
                any >> i & 1 == 1,
                occ,
                "occlusion, {w}-wide lane {i} of {ray:?}"
            );
        }
    }
}

/// Traces `rays` through the ray-stream API (without packets, and with 8-wide packets under a
/// rule that admits any two rays of an octant, so that most rays become packets), and panics
/// unless each agrees with the scalar walk's `scalar` hits: exactly (every bit, the primitive
/// included) where the answer comes from the single-ray walk, and as
/// [`packets_agree_with_scalar`] requires where packets may form. Occlusion must match too.
pub fn stream_agrees_with_scalar(scene: &Scene, rays: &[Ray], scalar: &[Hit]) {
    use kdray_core::traverse::stream::{self, Coherence, Config, Packets};
    let bits = |h: &Hit| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits());
    let occluded: Vec<bool> = rays.iter().map(|r| scene.occluded(r)).collect();
    let n = rays.len();
    for packets in [Packets::Off, Packets::Eight] {
        let config = Config {
            packets,
            coherence: Coherence {
                min_cos: -1.0,
                max_origin: 10.0,
            },
            ..Config::default()
        };
        let mut scratch = vec![0; stream::scratch_words(n)];
        let mut hits = vec![Hit::MISS; n];
        stream::intersect(scene, &config, rays, &mut hits, &mut scratch).expect("sized");
        let mut occ = vec![false; n];
        stream::occluded(scene, &config, rays, &mut occ, &mut scratch).expect("sized");
        for (i, (h, w)) in hits.iter().zip(scalar).enumerate() {
            if packets == Packets::Off {
                assert_eq!(bits(h), bits(w), "stream {config:?}: ray {i} {:?}", rays[i]);
            } else {
                assert_eq!(
                    h.t.to_bits(),
                    w.t.to_bits(),
                    "stream t: ray {i} {:?}",
                    rays[i]
                );
                assert!(
                    h.prim == w.prim || (h.is_hit() && w.is_hit()),
                    "stream prim: ray {i}"
                );
            }
            assert_eq!(
                occ[i], occluded[i],
                "stream occlusion: ray {i} {:?}",
                rays[i]
            );
        }
    }
}
