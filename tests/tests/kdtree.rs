//! Closest-hit and any-hit traversal of built kd-trees against brute force over all primitives,
//! on random scenes built to hit the hard cases: vertices and ray origins snapped to a coarse grid
//! (so split planes, axis-aligned and coplanar triangles, shared edges and origins on planes are
//! common), degenerate triangles, spheres, and axis-parallel directions with ±0 components.

use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray_core::traverse::{Contents, Mixed, Mode, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::strategies::{grid_geometry, traversal_ray};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

fn params() -> impl Strategy<Value = BuildParams> {
    // Cheap traversal makes deep trees with many straddling primitives; 80/1 is the default.
    prop_oneof![Just(80.0), Just(2.0), Just(20.0)].prop_map(|isect| BuildParams {
        intersect_cost: isect,
        parallel: false,
        ..BuildParams::default()
    })
}

/// The closest hit by testing every primitive with `C`'s kernels.
fn brute_force<C: Contents>(scene: &Scene, ray: &Ray) -> Hit {
    let mut best = Hit::MISS;
    for prim in 0..scene.prim_count() {
        if let Some((t, u, v)) = scene.intersect_prim::<C>(prim, ray)
            && t < best.t
        {
            best = Hit { t, prim, u, v };
        }
    }
    best
}

/// The walk in `mode` against brute force with the same kernels (`C`): the same closest `t`
/// (ties at a shared edge may name either primitive) and the same any-hit answer.
fn check_walk<C: Contents>(
    scene: &Scene,
    geom: &kdray::Geometry,
    ray: &Ray,
    mode: Mode,
) -> Result<(), TestCaseError> {
    let expect = brute_force::<C>(scene, ray);
    let got = scene.intersect_in(mode, ray);
    // The same t exactly (as numbers: primitives tying at the origin give 0 and -0).
    prop_assert!(
        got.t == expect.t,
        "{:?} ray {:?}: got {:?}, brute force {:?}\ntris {:?}\nspheres {:?}",
        mode,
        ray,
        got,
        expect,
        geom.triangles
            .iter()
            .map(|t| t.map(|v| v.to_array()))
            .collect::<Vec<_>>(),
        geom.spheres
    );
    if got.prim != expect.prim {
        // A tie at the same t (shared edge, coincident primitives): both are correct.
        let own = scene.intersect_prim::<C>(got.prim, ray).map(|h| h.0);
        prop_assert_eq!(
            own,
            Some(expect.t),
            "{:?} ray {:?}: prim {} is not a tie",
            mode,
            ray,
            got.prim
        );
    }
    prop_assert_eq!(
        scene.occluded_in(mode, ray),
        expect.is_hit(),
        "{:?} any-hit disagrees for {:?}",
        mode,
        ray
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, max_local_rejects: 1 << 24, ..ProptestConfig::default() })]

    #[test]
    fn traversal_equals_brute_force(
        geom in grid_geometry(6),
        params in params(),
        rays in prop::collection::vec(traversal_ray(), 1..40),
    ) {
        let tree = build(&geom, &params, None).unwrap();
        let words = serialize(&tree, &geom, 0.0).unwrap();
        let scene = Scene::from_words(&words).unwrap();
        for ray in &rays {
            check_walk::<Mixed>(&scene, &geom, ray, Mode::Fast)?;
            check_walk::<Watertight<Mixed>>(&scene, &geom, ray, Mode::Watertight)?;
        }
    }
}
