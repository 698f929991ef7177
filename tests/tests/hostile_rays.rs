//! Rays and triangles at the edges of f32 (issue 29), through every kernel (scalar, 4- and
//! 8-wide packets, groups; each SIMD lane bit for bit the scalar's) and every walk (one ray over
//! nodes or wide nodes, groups, stream, packets):
//!
//! - a ray starting on the scene box with a subnormal direction component, whose `1/d`
//!   overflows, is traced, fast and watertight;
//! - a ray leaving the surface of a closed mesh of huge triangles, from an origin within rounding
//!   of a face, gets no hit behind it in watertight mode (the `t` error bound of
//!   `kdray_core::watertight`);
//! - triangles so far from the ray origin that the kernels' f32 products overflow are hit, with
//!   the f64 reference's `t`, in both modes (`kdray_core::far`).

use glam::Vec3;
use kdray::Geometry;
use kdray::build::build;
use kdray::f64ref::{DVec3, dv};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::group::pack;
use kdray_core::simd::group::{intersect_group, intersect_group_watertight};
use kdray_core::simd::{
    Lanes, RayPacket, ShearX, f32x4, f32x8, f32x16, intersect_triangle_watertight, kernels,
};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config, Packets};
use kdray_core::watertight::{self, Shear};
use kdray_core::{Hit, Ray, Scene, Triangle};
use kdray_tests::Lcg;

/// The closed cube `[−1, 1]³`, two triangles a face.
fn cube() -> Geometry {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        )
    };
    let quads = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| {
            [
                [corner(q[0]), corner(q[1]), corner(q[2])],
                [corner(q[0]), corner(q[2]), corner(q[3])],
            ]
        })
        .collect();
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

/// Every way of storing the cube's tree: nodes or blocks, index lists or groups.
fn cube_scenes() -> Vec<(String, Vec<u32>)> {
    scenes_of(&cube())
}

/// Every way of storing `geom`'s tree: nodes or blocks, index lists or groups.
fn scenes_of(geom: &Geometry) -> Vec<(String, Vec<u32>)> {
    let mut out = Vec::new();
    for leaves in [Leaves::List, Leaves::Groups] {
        let params = kdray::build::BuildParams {
            parallel: false,
            // Small leaves, so the walk takes several steps.
            intersect_cost: 80.0,
            ..leaves.build_params()
        };
        let tree = build(geom, &params, None).expect("the scene builds");
        for layout in [Layout::Nodes, Layout::Wide] {
            let words = serialize_as(&tree, geom, 0.0, layout, leaves).expect("fits");
            out.push((format!("{leaves:?} {layout:?}"), words));
        }
    }
    out
}

/// `rays` by every walk in `mode`: one ray at a time, the stream without packets,
/// 8-wide packets; the name of each walk with its hits.
fn every_walk(scene: &Scene, rays: &[Ray], mode: Mode) -> Vec<(&'static str, Vec<Hit>)> {
    let n = rays.len();
    let single = rays.iter().map(|r| scene.intersect_in(mode, r)).collect();
    let config = Config {
        mode,
        packets: Packets::Off,
        ..Config::default()
    };
    let mut streamed = vec![Hit::MISS; n];
    let mut scratch = vec![0u64; stream::scratch_words(n)];
    stream::intersect(scene, &config, rays, &mut streamed, &mut scratch).unwrap();
    let mut packets = vec![Hit::MISS; n];
    for (r, h) in rays.chunks(8).zip(packets.chunks_mut(8)) {
        let packet = RayPacket::<f32x8>::from_rays(r);
        scene
            .intersect_packet_in(mode, &packet)
            .write_active(&packet, h);
    }
    vec![
        ("single", single),
        ("stream", streamed),
        ("packets", packets),
    ]
}

/// The ray — from (0.3, 1, 0.2) on the cube's top face, direction (0, −1e−39, −1) — and
/// the same on every face, with subnormals down to the smallest, into the cube: each walk hits
/// the face ahead at `t = 1.2` (was: lost by every single-ray walk, `0·∞ = NaN` in the box
/// entry).
#[test]
fn rays_on_the_box_with_subnormal_direction_components_hit() {
    let mut rays = Vec::new();
    let mut want_t = Vec::new();
    for tiny in [1e-39f32, f32::from_bits(1), 1e-42] {
        for axis in 0..3 {
            for face in [-1.0f32, 1.0] {
                // Origin on the face `axis = face`, moving along the next axis towards −1,
                // with a subnormal component along `axis`, into the cube.
                let along = (axis + 1) % 3;
                let mut o = [0.3f32, 0.3, 0.3];
                o[axis] = face;
                o[along] = 0.2;
                let mut d = [0.0f32; 3];
                d[axis] = -face * tiny;
                d[along] = -1.0;
                rays.push(Ray::new(Vec3::from(o), Vec3::from(d)));
                want_t.push(1.2f32);
            }
        }
    }
    for (name, words) in cube_scenes() {
        let scene = Scene::from_words(&words).unwrap();
        for mode in [Mode::Fast, Mode::Watertight] {
            for (walk, hits) in every_walk(&scene, &rays, mode) {
                for ((ray, hit), want) in rays.iter().zip(&hits).zip(&want_t) {
                    assert!(
                        (hit.t - want).abs() < 1e-6,
                        "{name}, {mode:?}, {walk}: {hit:?} for {ray:?}, want t = {want}"
                    );
                }
            }
        }
    }
}

/// A hit as bits, to compare kernels exactly.
type Bits = Option<(u32, u32, u32)>;

fn bits(h: Option<(f32, f32, f32)>) -> Bits {
    h.map(|(t, u, v)| (t.to_bits(), u.to_bits(), v.to_bits()))
}

/// Lane `lane` of a `L`-wide packet kernel with `ray` in every lane.
fn packet_lane<L: Lanes>(v: &[Vec3; 3], ray: &Ray, mode: Mode, lane: usize) -> Bits {
    let rays = RayPacket::<L>::from_rays(&vec![*ray; L::WIDTH]);
    let found = match mode {
        Mode::Fast => {
            kernels::intersect_triangle(&Triangle::from_vertices(v[0], v[1], v[2]), &rays)
        }
        Mode::Watertight => intersect_triangle_watertight(v, &rays, &ShearX::new(&rays)),
    };
    let at = |x: L| x.to_array().as_ref()[lane];
    bits((found.mask.bitmask() >> lane & 1 == 1).then(|| (at(found.t), at(found.u), at(found.v))))
}

/// Every triangle kernel of `mode` on one ray and triangle: the scalar kernel's answer, after
/// asserting that lane 3 of a 4-wide packet, lane 5 of an 8-wide one, lane 13 of a 16-wide one
/// (the ray in every lane) and lane 2 of a group (the triangle in every lane) return exactly the
/// same bits.
fn every_kernel(v: &[Vec3; 3], ray: &Ray, mode: Mode) -> Option<(f32, f32, f32)> {
    let tri = Triangle::from_vertices(v[0], v[1], v[2]);
    let scalar = match mode {
        Mode::Fast => tri.intersect(ray),
        Mode::Watertight => watertight::intersect(v, ray),
    };
    let g = pack(&[(0, *v, tri.min_det2()); 4]);
    let group = match mode {
        Mode::Fast => intersect_group(&g, ray),
        Mode::Watertight => intersect_group_watertight(&g, ray, &Shear::new(ray.dir)),
    };
    let at = |x: f32x4| x.to_array()[2];
    let group =
        (group.mask.bitmask() >> 2 & 1 == 1).then(|| (at(group.t), at(group.u), at(group.v)));
    for (name, got) in [
        ("x4", packet_lane::<f32x4>(v, ray, mode, 3)),
        ("x8", packet_lane::<f32x8>(v, ray, mode, 5)),
        ("x16", packet_lane::<f32x16>(v, ray, mode, 13)),
        ("group", bits(group)),
    ] {
        assert_eq!(
            got,
            bits(scalar),
            "{mode:?} {name} differs from scalar on {v:?}, {ray:?}"
        );
    }
    scalar
}

/// The grid step of [`tetrahedron`]`(scale)`: f32's spacing at `scale` (a power of two).
fn grid(scale: f32) -> f32 {
    f32::from_bits(scale.to_bits() & 0xFF80_0000) * f32::EPSILON
}

/// `v` on the integer grid of `step`, exactly: `v / step` (every coordinate below `2²⁶` steps).
fn on_grid(v: Vec3, step: f32) -> [i128; 3] {
    v.to_array().map(|x| {
        let k = x / step;
        assert!(
            k == k.round() && k.abs() < 2f32.powi(26),
            "{x} is off the grid {step}"
        );
        k as i128
    })
}

/// The exact sign of `(o − v0)·((v1 − v0) × (v2 − v0))` for points on the grid of `step`: which
/// side of the triangle's plane `o` is on (0: exactly on it).
fn side(v: &[Vec3; 3], o: Vec3, step: f32) -> i32 {
    let [a, b, c] = v.map(|p| on_grid(p, step));
    let o = on_grid(o, step);
    let sub = |p: [i128; 3], q: [i128; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let (e1, e2, s) = (sub(b, a), sub(c, a), sub(o, a));
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    (s[0] * n[0] + s[1] * n[1] + s[2] * n[2]).signum() as i32
}

/// A closed tetrahedron of edges about `2.4·scale`, no face parallel to an axis plane, its
/// corners on the [`grid`] of `scale`.
fn tetrahedron(scale: f32) -> Geometry {
    let step = grid(scale);
    let p = [
        Vec3::new(1.0, 0.1, -0.7),
        Vec3::new(-0.8, 0.9, -0.6),
        Vec3::new(-0.3, -1.0, -0.5),
        Vec3::new(0.2, 0.15, 1.0),
    ]
    .map(|v| (v * scale / step).round() * step);
    let faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]];
    Geometry {
        triangles: faces.iter().map(|f| f.map(|i| p[i])).collect(),
        ..Geometry::default()
    }
}

/// The triangle's unit normal in f64, pointing away from `inside`.
fn outward(v: &[Vec3; 3], inside: DVec3) -> DVec3 {
    let [a, b, c] = v.map(dv);
    let n = (b - a).cross(c - a).normalize();
    if n.dot(inside - a) > 0.0 { n * -1.0 } else { n }
}

/// The nearest `t > 0` at which `ray` meets one of `tris` other than `skip` in f64
/// (barycentrics at least 10⁻³ inside, so that rounding cannot decide it), with the triangle's
/// index; `None` if it meets none that clearly.
fn reference_hit(tris: &[[Vec3; 3]], skip: usize, ray: &Ray) -> Option<(f64, u32)> {
    let (o, d) = (dv(ray.origin), dv(ray.dir));
    let mut best = None;
    for (i, v) in tris.iter().enumerate().filter(|&(i, _)| i != skip) {
        let [a, b, c] = v.map(dv);
        let n = (b - a).cross(c - a);
        let t = (a - o).dot(n) / d.dot(n);
        let p = o + d * t;
        let area = n.dot(n);
        let bary = [
            (c - b).cross(p - b).dot(n) / area,
            (a - c).cross(p - c).dot(n) / area,
            (b - a).cross(p - a).dot(n) / area,
        ];
        if t > 0.0 && bary.iter().all(|&x| x > 1e-3) && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, i as u32));
        }
    }
    best
}

/// Rays leaving a face of a closed tetrahedron of huge triangles (edges about 2.4 × 1 to
/// 2.4·10¹²), from origins computed on the face in f32 and put on the corners' grid (so within
/// an ulp of its plane, on either side, or exactly on it), each moving away from the face's
/// plane on its side (the side decided exactly, in integers): such a ray meets that face at no
/// `t > 0`. An outward ray meets nothing; an inward one leaves through another
/// face. Watertight, no kernel and no walk may report the face the ray leaves (was: hits on it at
/// every scale, and list and group trees disagreed), outward rays miss, and inward rays hit the
/// face the f64 reference names, at its `t`.
#[test]
fn rays_leaving_huge_triangles_do_not_hit_them() {
    let mut rng = Lcg::new(29);
    // Per scale: the rays the lone face's kernels hit, and the wrong answers of the walks.
    let (mut counts, mut wrong) = (Vec::new(), Vec::new());
    for scale in [1.0f32, 4e7, 1e9, 1e12] {
        let geom = tetrahedron(scale);
        let tris = geom.triangles.clone();
        // Each of the four corners is in three faces.
        let centre = tris
            .iter()
            .flatten()
            .fold(DVec3::new(0.0, 0.0, 0.0), |a, &v| a + dv(v))
            * (1.0 / 12.0);
        let (mut rays, mut left, mut out) = (Vec::new(), Vec::new(), Vec::new());
        let step = grid(scale);
        for (f, v) in tris.iter().enumerate() {
            let n = outward(v, centre);
            // `side` counts along `(v1 − v0) × (v2 − v0)`: +1 where that is `n`, −1 where `−n`.
            let winding = (dv(v[1]) - dv(v[0])).cross(dv(v[2]) - dv(v[0])).dot(n);
            while rays.len() < 250 * (f + 1) {
                let (a, b) = (0.2 + 0.2 * rng.next_f32(), 0.2 + 0.2 * rng.next_f32());
                let o = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
                let o = (o / step).round() * step;
                let r = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let mut d = (r * 2.0 - Vec3::ONE).normalize();
                if dv(d).dot(n).abs() < 0.1 {
                    continue;
                }
                // Away from the plane on the origin's side (either way for an origin on it).
                if winding * f64::from(side(v, o, step)) * dv(d).dot(n) < 0.0 {
                    d = -d;
                }
                rays.push(Ray::new(o, d));
                left.push(f as u32);
                out.push(dv(d).dot(n) > 0.0);
            }
        }
        let kernel_hits = rays
            .iter()
            .zip(&left)
            .filter(|&(ray, &f)| every_kernel(&tris[f as usize], ray, Mode::Watertight).is_some())
            .count();
        counts.push((scale, kernel_hits));
        for (name, words) in scenes_of(&geom) {
            let scene = Scene::from_words(&words).unwrap();
            for (walk, hits) in every_walk(&scene, &rays, Mode::Watertight) {
                let mut bad = 0;
                for (i, (ray, hit)) in rays.iter().zip(&hits).enumerate() {
                    let prim = scene.input_id(hit.prim);
                    let right = if out[i] {
                        !hit.is_hit()
                    } else if let Some((t, want)) = reference_hit(&tris, left[i] as usize, ray) {
                        prim == want && (f64::from(hit.t) - t).abs() <= 1e-5 * t
                    } else {
                        prim != left[i]
                    };
                    if !right {
                        if bad == 0 {
                            eprintln!("{scale:e}, {name}, {walk}: {ray:?} got {hit:?}");
                        }
                        bad += 1;
                    }
                }
                if bad > 0 {
                    wrong.push(format!("{scale:e} {name} {walk}: {bad}"));
                }
            }
        }
    }
    assert!(
        counts.iter().all(|c| c.1 == 0) && wrong.is_empty(),
        "of 1,000 rays a scale, the face left is hit by its kernels (scale, rays): {counts:?}; \
         walks wrong (scale, tree, walk: rays): {wrong:?}"
    );
}

/// `t` of the line of `ray` with the plane of `v`, in f64.
fn plane_t(v: &[Vec3; 3], ray: &Ray) -> f64 {
    let [a, b, c] = v.map(dv);
    let n = (b - a).cross(c - a);
    (a - dv(ray.origin)).dot(n) / dv(ray.dir).dot(n)
}

/// Triangles so far from the ray origin that `|e1|·|e2|·|o − v0|` passes f32's range: the
/// issue's (±3·10¹², …) triangle seen by the framing camera of `kdray rays` (1.3 diagonals from
/// the centre), the same at 10¹², and a 10⁹ triangle seen from 10²⁰ and 10²⁵. Rays aimed at
/// points well inside: every kernel, in both modes, and every walk must hit, with the f64
/// reference's `t` (was: Möller–Trumbore's `e2·q` and the watertight `T` overflowed, `t` was
/// `inf` or NaN, and every kernel missed; `kdray` refuses such scenes, the core did not).
#[test]
fn far_triangles_are_hit_by_every_kernel_and_walk() {
    let mut rng = Lcg::new(2029);
    let mut cases = Vec::new();
    for scale in [1e12f32, 3e12] {
        let v = [
            Vec3::new(-scale, -scale, 0.0),
            Vec3::new(scale, -scale, 0.0),
            Vec3::new(0.0, scale, 0.0),
        ];
        // The framing camera's distance: 1.3 diagonals of the box, off the axis.
        let eye = Vec3::new(0.3, -0.4, 1.0).normalize() * (1.3 * 2.0 * 2f32.sqrt() * scale);
        cases.push((v, vec![eye, -eye]));
    }
    let small = [
        Vec3::new(-1e9, -1e9, 0.0),
        Vec3::new(1e9, -1e9, 0.0),
        Vec3::new(0.0, 1e9, 0.0),
    ];
    cases.push((
        small,
        vec![Vec3::new(0.0, 0.0, 1e20), Vec3::new(0.0, 0.0, -1e25)],
    ));
    let (mut tested, mut overflowing) = (0, 0);
    for (v, eyes) in cases {
        let mut rays = Vec::new();
        for eye in eyes {
            for _ in 0..64 {
                let (a, b) = (0.1 + 0.35 * rng.next_f32(), 0.1 + 0.35 * rng.next_f32());
                let target = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
                // Normalized in f64: `|target − eye|²` overflows f32 from 10²⁰.
                let d = (dv(target) - dv(eye)).normalize();
                rays.push(Ray::new(eye, Vec3::new(d.x as f32, d.y as f32, d.z as f32)));
            }
        }
        let tri = Triangle::from_vertices(v[0], v[1], v[2]);
        for ray in &rays {
            let want = plane_t(&v, ray);
            // The f32 product that overflows: Möller–Trumbore's `e2·q`.
            let q = (ray.origin - v[0]).cross(tri.e1);
            overflowing += usize::from(!tri.e2.dot(q).is_finite());
            tested += 1;
            for mode in [Mode::Fast, Mode::Watertight] {
                let (t, _, _) = every_kernel(&v, ray, mode)
                    .unwrap_or_else(|| panic!("{mode:?}: {ray:?} missed {v:?}"));
                assert!(
                    (f64::from(t) - want).abs() <= 1e-5 * want,
                    "{mode:?}: t {t}, want {want}"
                );
            }
        }
        let geom = Geometry {
            triangles: vec![v],
            ..Geometry::default()
        };
        for (name, words) in scenes_of(&geom) {
            let scene = Scene::from_words(&words).unwrap();
            for mode in [Mode::Fast, Mode::Watertight] {
                for (walk, hits) in every_walk(&scene, &rays, mode) {
                    for (ray, hit) in rays.iter().zip(&hits) {
                        let want = plane_t(&v, ray);
                        assert!(
                            hit.is_hit() && (f64::from(hit.t) - want).abs() <= 1e-5 * want,
                            "{name}, {mode:?}, {walk}: {hit:?} for {ray:?}, want t = {want}"
                        );
                    }
                }
            }
        }
    }
    // Not vacuous: most of these rays overflow f32.
    assert!(
        overflowing * 2 > tested,
        "{overflowing} of {tested} overflow"
    );
}
