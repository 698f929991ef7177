//! Shared checks of the fuzz targets (`fuzz_targets/`): what every accepted input must then do.

pub mod traversal;

use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray_core::simd::{HitPacket, Lanes, RayPacket, f32x4, f32x8};
use kdray_core::{Hit, Ray, Scene};

/// A mesh a loader accepted must be buildable into a tree whose words validate: the loaders'
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
