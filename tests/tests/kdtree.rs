//! Closest-hit and any-hit traversal of built kd-trees against brute force over all primitives,
//! on random scenes built to hit the hard cases: vertices and ray origins snapped to a coarse grid
//! (so split planes, axis-aligned and coplanar triangles, shared edges and origins on planes are
//! common), degenerate triangles, spheres, and axis-parallel directions with ±0 components.

use glam::Vec3;
use kdray::build::fast::FastParams;
use kdray::build::{BuildParams, Quality, build};
use kdray::flat::serialize;
use kdray_core::traverse::{Contents, Mixed, Mode, Watertight};
use kdray_core::{Ray, Scene};
use kdray_tests::brute_force;
use kdray_tests::strategies::{grid_geometry, traversal_ray};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

fn params() -> impl Strategy<Value = BuildParams> {
    // Cheap traversal makes deep trees with many straddling primitives; 80/1 is the default.
    // Both qualities; `fast` also with every node binned into 2–40 bins (the grid scenes are
    // smaller than its binning threshold) and with boxes cut by the cell instead of clipped.
    let fast = prop_oneof![
        Just(None),
        (2usize..40, any::<bool>()).prop_map(|(bins, cut)| Some(FastParams {
            bins,
            bin_min: 0,
            clip_min: if cut { usize::MAX } else { 0 },
        })),
    ];
    let quality = prop_oneof![Just(Quality::High), Just(Quality::Fast)];
    (
        prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
        quality,
        fast,
    )
        .prop_map(|(isect, quality, fast)| BuildParams {
            intersect_cost: isect,
            parallel: false,
            fast: fast.unwrap_or_default(),
            ..BuildParams::default().with_quality(quality)
        })
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
    #![proptest_config(ProptestConfig { cases: kdray_tests::cases(400), max_local_rejects: 1 << 24, ..ProptestConfig::default() })]

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

/// The first failure of `traversal_equals_brute_force` on a fresh clone: a zero-area (collinear)
/// triangle that the builder leaves out of the tree, which the watertight kernel hit by brute
/// force (at t = 1.48e-8, from an origin on its segment) while the walk, which never sees it,
/// missed. A degenerate triangle is now never hit, by any kernel in either mode, so the walk and
/// brute force agree on every ray from that origin, and from points along the segment.
#[test]
fn zero_area_triangles_are_never_hit_by_walk_or_brute_force() {
    let p = |x, y, z| Vec3::new(x, y, z);
    let geom = kdray::Geometry {
        triangles: vec![
            [p(0.0, 1.25, 0.0); 3],
            [p(1.75, 1.25, 0.5), p(-0.25, 1.25, 0.5), p(0.25, 1.25, 0.5)],
        ],
        ..kdray::Geometry::default()
    };
    let tree = build(&geom, &BuildParams::default(), None).unwrap();
    let words = serialize(&tree, &geom, 0.0).unwrap();
    let scene = Scene::from_words(&words).unwrap();
    // Random directions (as the proptest draws them) from origins on the segment and near it.
    let mut rng = kdray_tests::Lcg::new(20);
    let mut rays = 0;
    for origin in [p(1.5, 1.25, 0.5), p(0.0, 1.25, 0.5), p(1.0, 1.0, 0.25)] {
        for _ in 0..1000 {
            let mut c = || 2.0 * rng.next_f32() - 1.0;
            let Some(dir) = p(c(), c(), c()).try_normalize() else {
                continue;
            };
            for (t0, t1) in [(0.0, f32::INFINITY), (-1.0, 2.0)] {
                let ray = Ray::new(origin, dir).with_range(t0, t1);
                check_walk::<Mixed>(&scene, &geom, &ray, Mode::Fast).unwrap();
                check_walk::<Watertight<Mixed>>(&scene, &geom, &ray, Mode::Watertight).unwrap();
                assert!(!scene.intersect_in(Mode::Watertight, &ray).is_hit());
                rays += 1;
            }
        }
    }
    assert!(rays > 5000);
}

/// A scene scaled by 1e10 (edges whose `|e1 × e2|²` overflows f32) is traced in both modes, by
/// the walk as by brute force: before, its triangles' thresholds were `+inf`, so fast mode never
/// hit them (and the render showed only background), while watertight mode did. Triangles whose
/// threshold still overflows are refused by the builder with a message, not stored unhittable.
#[test]
fn scenes_scaled_by_1e10_are_hit_in_both_modes() {
    let p = |x, y, z| Vec3::new(x, y, z) * 1.0e10;
    let geom = kdray::Geometry {
        triangles: vec![
            [p(-4.0, -4.0, 0.0), p(4.0, -4.0, 0.0), p(0.0, 4.0, 0.0)],
            [p(-4.0, -4.0, -1.0), p(4.0, -4.0, -1.0), p(0.0, 4.0, -1.0)],
        ],
        ..kdray::Geometry::default()
    };
    let tree = build(&geom, &BuildParams::default(), None).unwrap();
    let words = serialize(&tree, &geom, 0.0).unwrap();
    let scene = Scene::from_words(&words).unwrap();
    for (o, d) in [
        (p(0.0, 0.0, 1.0), Vec3::NEG_Z),
        (p(0.5, -1.0, 3.0), Vec3::new(0.1, 0.2, -1.0).normalize()),
        (p(0.0, 0.0, -3.0), Vec3::Z),
    ] {
        let ray = Ray::new(o, d);
        for mode in [Mode::Fast, Mode::Watertight] {
            let hit = scene.intersect_in(mode, &ray);
            assert!(hit.is_hit(), "{mode:?} missed {ray:?}");
        }
        check_walk::<Mixed>(&scene, &geom, &ray, Mode::Fast).unwrap();
        check_walk::<Watertight<Mixed>>(&scene, &geom, &ray, Mode::Watertight).unwrap();
    }
    let too_large = kdray::Geometry {
        triangles: vec![[
            Vec3::ZERO,
            Vec3::new(1.0e13, 0.0, 0.0),
            Vec3::new(0.0, 1.0e13, 0.0),
        ]],
        ..kdray::Geometry::default()
    };
    let err = build(&too_large, &BuildParams::default(), None).unwrap_err();
    assert!(err.contains("triangle 0 is too large"), "{err}");
}
