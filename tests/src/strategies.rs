//! proptest strategies shared by the test binaries.

use crate::EDGES;
use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray_core::Ray;
use proptest::prelude::*;

/// Unit roundoff of f32, 2⁻²⁴.
pub const U: f64 = f32::EPSILON as f64 / 2.0;

/// A vector with components uniform in `lo..hi`.
pub fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A unit vector (from a cube sample long enough to normalize well).
pub fn unit_vec3() -> impl Strategy<Value = Vec3> {
    vec3(-1.0, 1.0)
        .prop_filter("not too short to normalize", |v| v.length() > 0.1)
        .prop_map(Vec3::normalize)
}

/// Any f32 at all (NaN, ±inf, denormals included), or one of the listed edge values.
pub fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![prop::num::f32::ANY, prop::sample::select(&EDGES[..])]
}

/// A vector of [`any_f32`] components.
pub fn any_vec3() -> impl Strategy<Value = Vec3> {
    (any_f32(), any_f32(), any_f32()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A coordinate on a coarse grid (multiples of 1/4 in `[-2, 2]`), so that split planes, shared
/// edges, coplanar and axis-aligned triangles and ray origins on planes are common.
pub fn grid() -> impl Strategy<Value = f32> {
    (-8i32..=8).prop_map(|k| k as f32 * 0.25)
}

/// A point on the [`grid`].
pub fn grid_point() -> impl Strategy<Value = Vec3> {
    (grid(), grid(), grid()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Triangles with grid vertices: general ones, axis-aligned ones, degenerate ones (a repeated
/// vertex, three collinear points), and clusters of several in one axis-aligned plane.
pub fn grid_triangles() -> impl Strategy<Value = Vec<[Vec3; 3]>> {
    let one = prop_oneof![
        4 => [grid_point(), grid_point(), grid_point()],
        2 => (grid_point(), grid_point(), grid_point(), 0usize..3).prop_map(|(a, mut b, mut c, k)| {
            b[k] = a[k];
            c[k] = a[k];
            [a, b, c]
        }),
        1 => (grid_point(), grid_point()).prop_map(|(a, b)| [a, b, a]),
        1 => (grid_point(), grid_point()).prop_map(|(a, b)| [a, b, a + 2.0 * (b - a)]),
    ];
    let coplanar = (
        0usize..3,
        grid(),
        prop::collection::vec([grid_point(), grid_point(), grid_point()], 2..6),
    )
        .prop_map(|(k, c, tris)| {
            tris.into_iter()
                .map(|t| {
                    t.map(|mut v| {
                        v[k] = c;
                        v
                    })
                })
                .collect::<Vec<_>>()
        });
    prop::collection::vec(
        prop_oneof![4 => one.prop_map(|t| vec![t]), 1 => coplanar],
        0..40,
    )
    .prop_map(|groups| groups.into_iter().flatten().collect())
}

/// A sphere centred on the grid with a radius in `1/8 ..= 7/8`.
pub fn grid_sphere() -> impl Strategy<Value = (Vec3, f32)> {
    (grid_point(), 1u32..8).prop_map(|(c, r)| (c, r as f32 * 0.125))
}

/// A non-empty scene of [`grid_triangles`] and up to `max_spheres - 1` [`grid_sphere`]s.
pub fn grid_geometry(max_spheres: usize) -> impl Strategy<Value = Geometry> {
    (
        grid_triangles(),
        prop::collection::vec(grid_sphere(), 0..max_spheres),
    )
        .prop_filter("empty scene", |(t, s)| !t.is_empty() || !s.is_empty())
        .prop_map(|(triangles, spheres)| Geometry {
            triangles,
            spheres,
            ..Geometry::default()
        })
}

/// The flat words of `geom` built single-threaded with the given intersection cost.
pub fn scene_words(geom: &Geometry, intersect_cost: f64) -> Vec<u32> {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        ..BuildParams::default()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    serialize(&tree, geom, 0.0).expect("small trees fit the format")
}

/// A direction component: mostly uniform in `[-1, 1)`, sometimes a zero of either sign.
fn component() -> impl Strategy<Value = f32> {
    prop_oneof![4 => -1.0f32..1.0, 1 => Just(0.0f32), 1 => Just(-0.0f32)]
}

/// A packet's rays (1 to 8): coherent (one origin region, directions near one), or arbitrary (mixed
/// signs, grid origins on split planes, NaN rays, negative tmin).
pub fn packet_rays() -> impl Strategy<Value = Vec<Ray>> {
    let coherent = (
        grid_point(),
        (component(), component(), component()),
        prop::collection::vec((grid_point(), -0.2f32..0.2), 1..9),
    )
        .prop_filter_map("zero direction", |(o, (x, y, z), jitter)| {
            let d = Vec3::new(x, y, z).try_normalize()?;
            Some(
                jitter
                    .iter()
                    .map(|(p, s)| Ray::new(o + 0.1 * *p, (d + Vec3::splat(*s)).normalize_or(d)))
                    .collect::<Vec<_>>(),
            )
        });
    let any_ray = (
        grid_point(),
        (component(), component(), component()),
        prop_oneof![
            4 => Just((0.0f32, f32::INFINITY)),
            1 => (-2.0f32..2.0, 0.5f32..6.0).prop_map(|(a, b)| (a, a + b)),
            1 => Just((f32::NAN, f32::INFINITY)),
        ],
    )
        .prop_filter_map("zero direction", |(o, (x, y, z), (t0, t1))| {
            Some(Ray::new(o, Vec3::new(x, y, z).try_normalize()?).with_range(t0, t1))
        });
    prop_oneof![coherent, prop::collection::vec(any_ray, 1..9)]
}

/// A unit direction whose components are often ±0 (rays parallel to split planes).
pub fn axis_biased_direction() -> impl Strategy<Value = Vec3> {
    (component(), component(), component()).prop_filter_map("zero direction", |(x, y, z)| {
        Vec3::new(x, y, z).try_normalize()
    })
}

/// A ray for traversal tests: from a grid point or anywhere near the grid scenes, an
/// [`axis_biased_direction`], the whole positive range or a band that may start before 0.
pub fn traversal_ray() -> impl Strategy<Value = Ray> {
    let origin = prop_oneof![
        grid_point(),
        (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0).prop_map(Vec3::from)
    ];
    let range = prop_oneof![
        3 => Just((0.0f32, f32::INFINITY)),
        1 => (-2.0f32..2.0, 0.5f32..6.0).prop_map(|(a, b)| (a, a + b)),
    ];
    (origin, axis_biased_direction(), range)
        .prop_map(|(o, d, (t0, t1))| Ray::new(o, d).with_range(t0, t1))
}

/// The first `n` of 300 triangles scattered on a grid, many overlapping, so that leaves hold
/// several and trees are several levels deep (the blocks' and the groups' tests).
pub fn scattered_triangles(n: usize) -> Geometry {
    let triangles = (0..n)
        .map(|i| {
            let p = Vec3::new(
                (i * 7 % 9) as f32,
                (i * 11 % 7) as f32,
                (i * 13 % 11) as f32,
            );
            [
                p,
                p + Vec3::new(1.7, 0.1, 0.0),
                p + Vec3::new(0.0, 1.6, 0.3),
            ]
        })
        .collect();
    Geometry {
        triangles,
        ..Geometry::default()
    }
}
