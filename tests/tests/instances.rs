//! The top level of instances (`kdray_core::instance`, `kdray::instances`): the two-level walk
//! against brute force over every instance's triangles in f64, with random transforms (mirrors,
//! shears, scales from 10⁻⁴ to 10⁴); translations that are exact in f32 against the merged mesh's
//! walk, bit for bit; and damaged top levels refused.

use glam::{DVec3, Vec3};
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray::instances::{Placement, top_level};
use kdray_core::instance::{Affine, InstancedScene};
use kdray_core::traverse::{Mode, Triangles, Watertight};
use kdray_core::{Ray, Scene};
use kdray_tests::strategies::{grid_point, grid_triangles, unit_vec3};
use kdray_tests::walks::node_words;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A transform: a random linear part (entries in [-1, 1]: rotations, shears and mirrors alike)
/// times a scale from 10⁻⁴ to 10⁴ of either sign, and a translation of the scale's order.
fn transform() -> impl Strategy<Value = Affine> {
    let scale = prop_oneof![
        Just(1.0f32),
        Just(-1.0),
        Just(1.0e-4),
        Just(-3.0e-3),
        Just(250.0),
        Just(-1.0e4),
        0.5f32..2.0
    ];
    (
        prop::array::uniform9(-1.0f32..1.0),
        scale,
        prop::array::uniform3(-4.0f32..4.0),
    )
        .prop_filter_map("nearly singular", |(m, s, t)| {
            let a = Affine([
                m[0] * s,
                m[1] * s,
                m[2] * s,
                t[0] * s,
                m[3] * s,
                m[4] * s,
                m[5] * s,
                t[1] * s,
                m[6] * s,
                m[7] * s,
                m[8] * s,
                t[2] * s,
            ]);
            // Well conditioned enough that f32's rounding of the moved ray stays far below the
            // tolerances below (the condition number's bound: |A|_F·|A⁻¹|_F ≤ 30).
            let inv = a.inverse()?;
            let f = |x: &Affine| {
                (0..12)
                    .filter(|i| i % 4 != 3)
                    .map(|i| (x.0[i] as f64).powi(2))
                    .sum::<f64>()
                    .sqrt()
            };
            (f(&a) * f(&inv) <= 30.0).then_some(a)
        })
}

/// Möller–Trumbore in f64, without the inside test: `(t, margin, sin, h)`: `margin` the smallest
/// of the three barycentric coordinates (negative outside), `sin` that of the ray's angle with
/// the plane, `h` the triangle's smallest altitude (so `margin·h` is at most the distance to the
/// nearest edge); `None` when the ray is parallel or the triangle degenerate.
fn f64_hit(v: [DVec3; 3], o: DVec3, d: DVec3) -> Option<(f64, f64, f64, f64)> {
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let n = e1.cross(e2);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || n.length() == 0.0 {
        return None;
    }
    let s = o - v[0];
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let w = d.dot(q) / det;
    let t = e2.dot(q) / det;
    let sin = det.abs() / (n.length() * d.length());
    let longest = e1.length().max(e2.length()).max((v[2] - v[1]).length());
    Some((t, u.min(w).min(1.0 - u - w), sin, n.length() / longest))
}

/// Brute force over every instance's triangles in world space, in f64, against the walk.
///
/// f32 cannot place a ray better than a few ULPs of its origin, the instance's translation and
/// the distance travelled (times the transform's condition, ≤ 30 here): `δ = 4·10⁻⁶·(|o| + |b| +
/// |t|)` world units, about twice that bound. A *robust* f64 hit lies at least `4δ` inside its
/// triangle's edges (and `10⁻³` of its barycentric range), at least `10⁻³` from parallel, and
/// clear of the ray's range ends; the walk must find a hit no farther than the closest robust
/// one, and miss only when there is none. Whatever it reports must be a real triangle of its
/// instance, at most `4δ` outside it, at its f64 `t` within `4δ/sin`; and any hit must agree
/// with closest hit. The user id must be that of the placement whose transform the record holds,
/// and the world normal that of the triangle as placed.
fn check_ray(
    top: &InstancedScene,
    meshes: &[Vec<[Vec3; 3]>],
    placements: &[Placement],
    ray: &Ray,
    mode: Mode,
) -> Result<(), TestCaseError> {
    let got = top.intersect_in(mode, ray);
    prop_assert_eq!(
        top.occluded_in(mode, ray),
        got.is_hit(),
        "any hit vs closest, {:?}",
        ray
    );
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let world = |i: u32, tri: &[Vec3; 3]| {
        let m = top.instance(i).transform;
        tri.map(|v| DVec3::from_array(m.point64(v.as_dvec3().to_array())))
    };
    let delta = |i: u32, t: f64| {
        let m = top.instance(i).transform.0;
        let b = DVec3::new(m[3] as f64, m[7] as f64, m[11] as f64);
        4.0e-6 * (o.length() + b.length() + t.abs())
    };
    let mut robust_best = f64::INFINITY;
    for i in 0..top.instance_count() {
        let bottom = top.instance(i).bottom as usize;
        for tri in &meshes[bottom] {
            if let Some((t, margin, sin, h)) = f64_hit(world(i, tri), o, d) {
                let dl = delta(i, t);
                let slack = 4.0 * dl / sin.max(1e-3);
                if margin >= 1.0e-3
                    && margin * h >= 4.0 * dl
                    && sin >= 1.0e-3
                    && t > ray.tmin as f64 + slack
                    && t < ray.tmax as f64 - slack
                {
                    robust_best = robust_best.min(t + slack);
                }
            }
        }
    }
    if !got.is_hit() {
        prop_assert!(
            robust_best.is_infinite(),
            "{:?} missed a hit at {} along {:?}",
            mode,
            robust_best,
            ray
        );
        return Ok(());
    }
    let record = top.instance(got.instance);
    let placement = &placements[(got.user_id - 1000) as usize];
    prop_assert_eq!(
        placement.transform,
        record.transform,
        "user id of another instance"
    );
    prop_assert_eq!(placement.bottom, record.bottom);
    let bottom = top.bottom_of(got.instance);
    let tri = meshes[record.bottom as usize][bottom.input_id(got.prim) as usize];
    let (t, margin, sin, h) =
        f64_hit(world(got.instance, &tri), o, d).expect("a hit on a parallel triangle");
    let dl = delta(got.instance, t);
    // The normal in world space: e1 × e2 of the triangle as placed, up to a positive factor.
    let w = world(got.instance, &tri);
    let want = (w[1] - w[0]).cross(w[2] - w[0]).normalize();
    let normal = top.geometric_normal(&got, ray).as_dvec3().normalize();
    prop_assert!(
        normal.dot(want) > 0.999,
        "normal {:?}, want {:?} ({:?})",
        normal,
        want,
        got
    );
    prop_assert!(
        margin * h >= -4.0 * dl - 1.0e-3 * h,
        "{:?} hit outside its triangle: {:?} {:?}",
        mode,
        got,
        ray
    );
    prop_assert!(
        (got.t as f64 - t).abs() <= 4.0 * dl / sin,
        "{:?} t {} against f64 {} ({:?})",
        mode,
        got.t,
        t,
        ray
    );
    prop_assert!(
        (got.t as f64) <= robust_best,
        "{:?} {:?} beyond a robust hit at {}",
        mode,
        got,
        robust_best
    );
    Ok(())
}

fn ray_towards(target: Vec3, dir: Vec3, back: f32) -> Ray {
    Ray::new(target - dir * back, dir)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: kdray_tests::cases(150), max_local_rejects: 1 << 20, ..ProptestConfig::default() })]

    #[test]
    fn two_level_walk_equals_f64_brute_force(
        meshes in prop::collection::vec(grid_triangles(), 1..3),
        placed in prop::collection::vec((0usize..2, transform()), 1..12),
        targets in prop::collection::vec((0usize..12, grid_point(), unit_vec3(), 0.5f32..20.0), 1..24),
    ) {
        let words: Vec<Vec<u32>> = meshes.iter().map(|m| node_words(m.clone())).collect();
        let bottoms: Vec<Scene> = words.iter().map(|w| Scene::from_words(w).unwrap()).collect();
        let placements: Vec<Placement> = placed
            .iter()
            .enumerate()
            .map(|(k, &(b, transform))| Placement {
                bottom: (b % bottoms.len()) as u32,
                transform,
                user_id: 1000 + k as u32,
            })
            .collect();
        let top_words = top_level(&bottoms, &placements).unwrap();
        let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
        for &(k, p, dir, back) in &targets {
            // Aimed at a grid point of one instance, from `back` times its size away.
            let pl = &placements[k % placements.len()];
            let target = pl.transform.point(p);
            let size = {
                let m = &pl.transform.0;
                (m[0].abs() + m[5].abs() + m[10].abs()).max(1e-6)
            };
            let ray = ray_towards(target, dir, back * size);
            check_ray(&top, &meshes, &placements, &ray, Mode::Fast)?;
            check_ray(&top, &meshes, &placements, &ray, Mode::Watertight)?;
            let band = ray.with_range(0.5 * back * size, 1.5 * back * size);
            check_ray(&top, &meshes, &placements, &band, Mode::Fast)?;
        }
    }

    #[test]
    fn translations_give_the_merged_meshs_answers_bit_for_bit(
        mesh in grid_triangles(),
        offsets in prop::collection::vec(prop::array::uniform3(-6i32..=6), 1..10),
        rays in prop::collection::vec((grid_point(), unit_vec3(), -3i32..=3), 1..40),
    ) {
        let words = node_words(mesh.clone());
        let bottoms = [Scene::from_words(&words).unwrap()];
        let offset = |k: usize| Vec3::from_array(offsets[k].map(|x| x as f32));
        let placements: Vec<Placement> = (0..offsets.len())
            .map(|k| {
                let t = offset(k);
                Placement {
                    bottom: 0,
                    transform: Affine([1.0, 0.0, 0.0, t.x, 0.0, 1.0, 0.0, t.y, 0.0, 0.0, 1.0, t.z]),
                    user_id: k as u32,
                }
            })
            .collect();
        let top_words = top_level(&bottoms, &placements).unwrap();
        let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
        let merged: Vec<[Vec3; 3]> = (0..offsets.len())
            .flat_map(|k| mesh.iter().map(move |tri| tri.map(|v| v + offset(k))))
            .collect();
        let merged_words = node_words(merged);
        let merged = Scene::from_words(&merged_words).unwrap();
        // Storage id of each merged input triangle (for the tie check).
        let mut storage = vec![u32::MAX; mesh.len() * offsets.len()];
        for prim in 0..merged.tri_count() {
            storage[merged.input_id(prim) as usize] = prim;
        }
        for &(p, dir, shift) in &rays {
            // Origins on the grid, moved by whole units: every coordinate exact in f32, so the
            // origin moved into an instance is exact too.
            let ray = Ray::new(p + Vec3::splat(shift as f32), dir);
            for mode in [Mode::Fast, Mode::Watertight] {
                let got = top.intersect_in(mode, &ray);
                let want = merged.intersect_in(mode, &ray);
                prop_assert_eq!(got.t.to_bits(), want.t.to_bits(), "{:?} {:?}: {:?} vs {:?}", mode, ray, got, want);
                prop_assert_eq!(top.occluded_in(mode, &ray), merged.occluded_in(mode, &ray));
                if !got.is_hit() {
                    continue;
                }
                let ours = got.user_id as usize * mesh.len() + bottoms[0].input_id(got.prim) as usize;
                if ours as u32 != merged.input_id(want.prim) {
                    // A tie: our triangle, in the merged mesh, is hit at the same t.
                    let own = match mode {
                        Mode::Fast => merged.intersect_prim::<Triangles>(storage[ours], &ray),
                        Mode::Watertight => merged.intersect_prim::<Watertight<Triangles>>(storage[ours], &ray),
                    };
                    prop_assert_eq!(own.map(|h| h.0.to_bits()), Some(got.t.to_bits()), "{:?} {:?}: not a tie", mode, ray);
                }
            }
        }
    }
}

/// `world_box` as its doc defines it: the least and greatest of the eight corners' f64 images
/// (`corners64`), padded and rounded outward (`padded_box`).
fn world_box_from_corners(a: &Affine, bounds: [Vec3; 2]) -> Option<[Vec3; 2]> {
    let corners = a.corners64(bounds);
    let (mut lo, mut hi) = (corners[0], corners[0]);
    for c in &corners[1..] {
        for k in 0..3 {
            (lo[k], hi[k]) = (lo[k].min(c[k]), hi[k].max(c[k]));
        }
    }
    kdray_core::instance::affine::padded_box(lo, hi)
}

proptest! {
    /// The per-row world box (Arvo's) is the eight corners' box bit for bit, and contains the
    /// corners' images as validation checks them.
    #[test]
    fn world_box_is_the_corners_box(
        a in transform(),
        lo in prop::array::uniform3(-1.0e3f32..1.0e3),
        size in prop::array::uniform3(prop_oneof![Just(0.0f32), 0.0f32..100.0]),
    ) {
        let lo = Vec3::from_array(lo);
        let bounds = [lo, lo + Vec3::from_array(size)];
        let got = a.world_box(bounds);
        let want = world_box_from_corners(&a, bounds);
        prop_assert_eq!(got.map(|b| b.map(|v| v.to_array().map(f32::to_bits))),
            want.map(|b| b.map(|v| v.to_array().map(f32::to_bits))));
        if let Some(b) = got {
            prop_assert!(a.box_contains_image(b, bounds));
        }
    }
}

/// A unit square in z = 0 (two triangles), its corner at the origin.
fn square() -> Vec<[Vec3; 3]> {
    let p = |x, y| Vec3::new(x, y, 0.0);
    vec![
        [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
        [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
    ]
}

#[test]
fn mirrors_shears_and_huge_scales_have_known_answers() {
    let words = node_words(square());
    let bottoms = [Scene::from_words(&words).unwrap()];
    let cases = [
        // Mirrored in x, at z = 2: the square covers x in [-1, 0]; (0.25, 0.75) lands at x = -0.25.
        (
            Affine([-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0]),
            Vec3::new(-0.25, 0.75, 10.0),
            8.0,
        ),
        // Sheared, y += x, at z = 3: the point (0.25, 0.75) lands at (0.25, 1.0, 3).
        (
            Affine([1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0]),
            Vec3::new(0.25, 1.0, 10.0),
            7.0,
        ),
        // Scaled by 10⁶ and mirrored in z (the normal flips): the square spans 10⁶ at z = -5.
        (
            Affine([
                1.0e6, 0.0, 0.0, 0.0, 0.0, 1.0e6, 0.0, 0.0, 0.0, 0.0, -1.0e6, -5.0,
            ]),
            Vec3::new(4.0e5, 3.0e5, 10.0),
            15.0,
        ),
        // Scaled by 10⁻⁶: a square of 1e-6 at z = 1.
        (
            Affine([
                1.0e-6, 0.0, 0.0, 0.0, 0.0, 1.0e-6, 0.0, 0.0, 0.0, 0.0, 1.0e-6, 1.0,
            ]),
            Vec3::new(5.0e-7, 2.5e-7, 10.0),
            9.0,
        ),
    ];
    for (k, &(transform, origin, t)) in cases.iter().enumerate() {
        let placements = [Placement {
            bottom: 0,
            transform,
            user_id: 40 + k as u32,
        }];
        let top_words = top_level(&bottoms, &placements).unwrap();
        let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
        let ray = Ray::new(origin, Vec3::NEG_Z);
        for mode in [Mode::Fast, Mode::Watertight] {
            let hit = top.intersect_in(mode, &ray);
            assert_eq!(hit.user_id, 40 + k as u32, "case {k} {mode:?}: {hit:?}");
            assert!(
                (hit.t - t).abs() <= 1e-5 * t,
                "case {k} {mode:?}: t {} for {t}",
                hit.t
            );
            assert!(top.occluded_in(mode, &ray));
            assert!(!top.occluded_in(mode, &ray.with_range(0.0, t * 0.999)));
            // Beside the square: a miss.
            let beside = Ray::new(
                origin + Vec3::new(3.0, 3.0, 0.0) * transform.0[0].abs().max(1.0),
                Vec3::NEG_Z,
            );
            assert!(!top.intersect_in(mode, &beside).is_hit(), "case {k}");
        }
    }
}

/// Non-finite rays and empty intervals are misses, never a panic.
#[test]
fn odd_rays_are_misses() {
    let words = node_words(square());
    let bottoms = [Scene::from_words(&words).unwrap()];
    let placements = [Placement {
        bottom: 0,
        transform: Affine::IDENTITY,
        user_id: 0,
    }];
    let top_words = top_level(&bottoms, &placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let o = Vec3::new(0.5, 0.5, 1.0);
    for ray in [
        Ray::new(Vec3::NAN, Vec3::NEG_Z),
        Ray::new(o, Vec3::new(f32::INFINITY, 0.0, -1.0)),
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::NEG_Z).with_range(2.0, 1.0),
        Ray::new(o, Vec3::NEG_Z).with_range(f32::NAN, 5.0),
    ] {
        assert!(!top.intersect(&ray).is_hit(), "{ray:?}");
        assert!(!top.occluded(&ray), "{ray:?}");
    }
}

/// A bottom scene of one unit sphere, stretched by 2 along x: an ellipsoid, traced in the
/// sphere's own space, with the analytic hit and normal of `x²/4 + y² + z² = 1`.
#[test]
fn spheres_stretched_into_ellipsoids() {
    let geom = Geometry {
        spheres: vec![(Vec3::ZERO, 1.0)],
        ..Geometry::default()
    };
    let tree = build(&geom, &BuildParams::default(), None).unwrap();
    let words = serialize(&tree, &geom, 0.0).unwrap();
    let bottoms = [Scene::from_words(&words).unwrap()];
    let stretch = Affine([2.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let placements = [Placement {
        bottom: 0,
        transform: stretch,
        user_id: 9,
    }];
    let top_words = top_level(&bottoms, &placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let ray = Ray::new(Vec3::new(1.5, 0.0, 10.0), Vec3::NEG_Z);
    let z = (1.0f64 - 0.75 * 0.75).sqrt();
    for mode in [Mode::Fast, Mode::Watertight] {
        let hit = top.intersect_in(mode, &ray);
        assert_eq!(hit.user_id, 9);
        assert!((hit.t as f64 - (10.0 - z)).abs() < 1e-5, "{mode:?} {hit:?}");
        let n = top.geometric_normal(&hit, &ray).as_dvec3().normalize();
        let want = DVec3::new(0.75, 0.0, 2.0 * z).normalize();
        assert!(n.dot(want) > 1.0 - 1e-6, "{n:?} against {want:?}");
        // Within the ellipsoid's reach along x (2) though beyond the unit sphere's (1); then past it.
        assert!(top.occluded_in(mode, &Ray::new(Vec3::new(1.9, 0.0, 10.0), Vec3::NEG_Z)));
        assert!(!top.occluded_in(mode, &Ray::new(Vec3::new(2.1, 0.0, 10.0), Vec3::NEG_Z)));
    }
}
