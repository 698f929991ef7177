//! Stiff cases for watertight mode on long, large and far geometry (issue 39): closed boxes of
//! aspect up to 10⁶ (two triangles a face, and a bar of long fans), icospheres stretched 10⁶
//! times along one axis, ground triangles of half-size up to 4·10⁹ seen at 5–30°, and random
//! affine stretches of closed meshes. Every walk ([`kdray_tests::walks`]: wide nodes, binary
//! nodes, 4- and 8-wide packets, the stream) with index lists and with triangle groups, and the
//! triangle kernels alone (scalar, 4- and 8-wide).
//!
//! Before issue 39 the watertight kernel took `t` from the vertices' depths, whose error grows
//! with the triangle's extent along the ray: 72–100 % of grazing rays escaped the long boxes
//! (a wrong `t`, often behind the origin, then dropped), and every ray missed the 4·10⁹ ground
//! triangle. Now `t` comes from the plane in f64 (`kdray_core::distance`).

use glam::{DVec3, Vec3};
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8, intersect_triangle_watertight};
use kdray_core::traverse::Mode;
use kdray_core::{Hit, Ray, Scene, watertight};
use kdray_tests::closed::{Aim, Mesh, icosphere, skinny_box};
use kdray_tests::walks::{WALKS, trace_all, wide_words};
use proptest::prelude::*;

/// Directions at angle `asin(s)` to the `±x` axis, for `s` from 10⁻² to 10⁻⁵, eight azimuths
/// around it, normalized in f32.
fn grazing_dirs() -> Vec<Vec3> {
    let mut dirs = Vec::new();
    for s in [1e-2f64, 1e-3, 1e-4, 1e-5] {
        let c = (1.0 - s * s).sqrt();
        for k in 0..8 {
            let phi = f64::from(k) * core::f64::consts::PI / 4.0 + 0.1;
            for sign in [1.0, -1.0] {
                let d = DVec3::new(sign * c, s * phi.cos(), s * phi.sin());
                dirs.push(d.as_vec3().normalize());
            }
        }
    }
    dirs
}

/// The exact distance (f64, from the f32 ray) at which `ray` leaves the box `[lo, hi]` it starts
/// in, and whether another face is within 10⁻³ of it (near an edge of the box, where the hit of
/// a ray a rounding away may be on the other face).
fn box_exit(ray: &Ray, lo: Vec3, hi: Vec3) -> (f64, bool) {
    let mut exits: Vec<f64> = (0..3)
        .filter(|&k| ray.dir[k] != 0.0)
        .map(|k| {
            let wall = if ray.dir[k] > 0.0 { hi[k] } else { lo[k] };
            (f64::from(wall) - f64::from(ray.origin[k])) / f64::from(ray.dir[k])
        })
        .collect();
    exits.sort_by(f64::total_cmp);
    let near_edge = exits.len() > 1 && exits[1] - exits[0] <= 1e-3 * exits[0];
    (exits[0], near_edge)
}

/// Asserts that every walk of both layouts of `mesh` hits every ray in watertight mode, and
/// returns the hits of the first walk for further checks.
fn no_escape(name: &str, mesh: &Mesh, rays: &[Ray]) -> Vec<Hit> {
    assert!(mesh.is_closed());
    let mut first = None;
    for groups in [false, true] {
        let words = wide_words(mesh.triangles(), groups);
        let scene = Scene::from_words(&words).expect("valid scene");
        for (walk, hits) in WALKS.iter().zip(trace_all(&scene, rays, Mode::Watertight)) {
            let lost = rays.iter().zip(&hits).filter(|(_, h)| !h.is_hit()).count();
            assert_eq!(
                lost, 0,
                "{name}, {walk}, groups {groups}: {lost} rays escaped"
            );
            first.get_or_insert(hits);
        }
    }
    first.expect("one walk at least")
}

/// Closed boxes `L × 1 × 1` (12 triangles, and a bar whose long faces are fans of 32 thin
/// triangles) for `L` = 10⁴, 10⁵, 10⁶, at the origin and centred at `x = 10⁷`, with grazing rays
/// from two points inside. Expectation: watertight mode lets no ray escape in any walk (was 72 %
/// at 10⁴, 100 % at 10⁵ and 10⁶), and `t` is the exact exit distance within 10⁻⁶ (relative),
/// away from the box's edges.
#[test]
fn long_boxes_hold_grazing_rays() {
    for (shape, fan) in [("box", 1), ("bar", 16)] {
        for length in [1e4f32, 1e5, 1e6] {
            for x0 in [0.0f32, 1e7] {
                let size = Vec3::new(length, 1.0, 1.0);
                let centre = Vec3::new(x0, 0.0, 0.0);
                let mesh = skinny_box(fan).mapped(|v| v * size * 0.5 + centre);
                let (lo, hi) = (centre - size * 0.5, centre + size * 0.5);
                let origins = [centre, centre + Vec3::new(0.25 * length, 0.2, -0.1)];
                let rays: Vec<Ray> = origins
                    .iter()
                    .flat_map(|&o| grazing_dirs().into_iter().map(move |d| Ray::new(o, d)))
                    .collect();
                let name = format!("{shape} {length:e} at x = {x0:e}");
                let hits = no_escape(&name, &mesh, &rays);
                for (ray, hit) in rays.iter().zip(&hits) {
                    let (exact, near_edge) = box_exit(ray, lo, hi);
                    let err = (f64::from(hit.t) - exact).abs() / exact;
                    assert!(
                        near_edge || err <= 1e-6,
                        "{name}: ray {ray:?} t = {}, exact {exact}",
                        hit.t
                    );
                }
            }
        }
    }
}

/// `verts` against `ray` by the scalar watertight kernel and lane 0 of the 4- and 8-wide packet
/// kernels (the packet holds the ray alone): the three `t`s, `None` for a miss.
fn kernel_ts(verts: &[Vec3; 3], ray: &Ray) -> [Option<f32>; 3] {
    fn lane0<L: Lanes>(verts: &[Vec3; 3], ray: &Ray) -> Option<f32> {
        let packet = RayPacket::<L>::from_rays(&[*ray]);
        let shear = kdray_core::simd::ShearX::new(&packet);
        let hits = intersect_triangle_watertight(verts, &packet, &shear);
        (hits.mask.bitmask() & 1 != 0).then(|| hits.t.to_array().as_ref()[0])
    }
    [
        watertight::intersect(verts, ray).map(|h| h.0),
        lane0::<f32x4>(verts, ray),
        lane0::<f32x8>(verts, ray),
    ]
}

/// One ground triangle in `z = 0` covering `[−S, S]²`, `S` from 10⁵ to 4·10⁹, and rays from one
/// unit above (over its centre and over a point at `0.37·S`) descending at 5, 10, 20 and 30° in
/// twelve azimuths. Expectation: every kernel and every walk hits every ray, with `t` within
/// 4·10⁻⁷ (relative) of the exact `1/(−d_z)` (was: every ray missed at 4·10⁹, and errors up to
/// 8·10⁻³ at 10⁵, once the shear's axis lay in the plane).
#[test]
fn large_triangles_are_hit_at_grazing_angles() {
    for half in [1e5f32, 1e7, 1e9, 4e9] {
        let verts = [
            Vec3::new(-half, -half, 0.0),
            Vec3::new(3.0 * half, -half, 0.0),
            Vec3::new(-half, 3.0 * half, 0.0),
        ];
        let mut rays = Vec::new();
        for o in [Vec3::Z, Vec3::new(0.37 * half, -0.37 * half, 1.0)] {
            for elevation in [5.0f64, 10.0, 20.0, 30.0] {
                for k in 0..12 {
                    let (e, a) = (elevation.to_radians(), f64::from(k) * 30f64.to_radians());
                    let d = DVec3::new(e.cos() * a.cos(), e.cos() * a.sin(), -e.sin());
                    rays.push(Ray::new(o, d.as_vec3()));
                }
            }
        }
        let exact = |ray: &Ray| f64::from(ray.origin.z) / -f64::from(ray.dir.z);
        let close = |ray: &Ray, t: f32| (f64::from(t) - exact(ray)).abs() <= 4e-7 * exact(ray);
        for ray in &rays {
            for t in kernel_ts(&verts, ray) {
                let t = t.unwrap_or_else(|| panic!("S = {half:e}: a kernel missed {ray:?}"));
                assert!(
                    close(ray, t),
                    "S = {half:e}: {ray:?} t = {t}, exact {}",
                    exact(ray)
                );
            }
        }
        // The walks, on the triangle and its reverse (a closed pair: the walls of a flat box).
        let [a, b, c] = verts;
        let mesh = Mesh {
            vertices: vec![a, b, c],
            faces: vec![[0, 1, 2], [0, 2, 1]],
            centre: Vec3::Z,
        };
        let hits = no_escape(&format!("ground {half:e}"), &mesh, &rays);
        for (ray, hit) in rays.iter().zip(&hits) {
            assert!(close(ray, hit.t), "S = {half:e}: {ray:?} t = {}", hit.t);
        }
    }
}

/// The unit icosphere (subdivision 3) stretched 10⁶ times along x, along y, and along x then
/// moved to `x = 10⁷`; rays from its centre to every vertex and edge point and grazing ones
/// along the long axis. Expectation: watertight mode lets no ray escape in any walk.
#[test]
fn stretched_icospheres_let_no_ray_escape() {
    let sphere = icosphere(3);
    for (name, stretch, offset) in [
        ("x 1e6", Vec3::new(1e6, 1.0, 1.0), Vec3::ZERO),
        ("y 1e6", Vec3::new(1.0, 1e6, 1.0), Vec3::ZERO),
        (
            "x 1e6 at 1e7",
            Vec3::new(1e6, 1.0, 1.0),
            Vec3::new(1e7, 0.0, 0.0),
        ),
    ] {
        let mesh = sphere.mapped(|v| v * stretch + offset);
        let mut rays = mesh.seam_rays(mesh.centre, Aim::Normalized);
        let long = if stretch.x > 1.0 { 0 } else { 1 };
        rays.extend(grazing_dirs().into_iter().map(|d| {
            let mut d = d.to_array();
            d.swap(0, long);
            Ray::new(mesh.centre, Vec3::from_array(d))
        }));
        no_escape(name, &mesh, &rays);
    }
}

/// A closed mesh mapped by `v ↦ R·diag(10^e)·v + offset` (rounded once per vertex): `e` the
/// stretch exponents, `angles` the rotation's Euler angles, `offset` the translation.
fn stretched(mesh: &Mesh, e: [f64; 3], angles: [f64; 3], offset: [f64; 3]) -> Mesh {
    let scale = DVec3::from_array(e.map(|x| 10f64.powf(x)));
    let rot = glam::DQuat::from_euler(glam::EulerRot::XYZ, angles[0], angles[1], angles[2]);
    let offset = DVec3::from_array(offset);
    mesh.mapped(|v| (rot * (v.as_dvec3() * scale) + offset).as_vec3())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Random affine stretches (up to 10⁶ along each axis, any rotation, moved by up to 100 times
    /// its thinnest size) of the 12-triangle box, a box of fans and a small icosphere: rays from
    /// the centre to every vertex and edge point, and 64 in random directions. Expectation: no
    /// ray escapes in any walk, with lists or groups.
    #[test]
    fn random_affine_stretches_let_no_ray_escape(
        which in 0usize..3,
        e in prop::array::uniform3(0.0f64..6.0),
        angles in prop::array::uniform3(-3.2f64..3.2),
        far in prop::array::uniform3(-100.0f64..100.0),
        dirs in prop::collection::vec(prop::array::uniform3(-1.0f32..1.0), 64),
    ) {
        let base = [skinny_box(1), skinny_box(4), icosphere(2)][which].clone();
        let thin = 10f64.powf(e[0].min(e[1]).min(e[2]));
        let offset = far.map(|k| k * thin);
        let mesh = stretched(&base, e, angles, offset);
        // The map may fold a thin triangle flat in f32: then the mesh is no longer closed in
        // the sense the walks can prove (the builder leaves degenerate triangles out).
        prop_assume!(mesh.triangles().iter().all(|[a, b, c]| {
            kdray_core::Triangle::from_vertices(*a, *b, *c).min_det2() < f32::INFINITY
        }));
        let mut rays = mesh.seam_rays(mesh.centre, Aim::Normalized);
        rays.extend(
            dirs.iter()
                .map(|d| Vec3::from_array(*d))
                .filter(|d| d.length() > 1e-3)
                .map(|d| Ray::new(mesh.centre, d.normalize())),
        );
        no_escape(&format!("{which} e {e:?} angles {angles:?} offset {offset:?}"), &mesh, &rays);
    }
}
