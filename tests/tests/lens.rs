//! Rukin's lens cameras: the thick lens against the lensmaker's equation (through f64 ray
//! transfer matrices written here, not the code under test), its axis, rim and weight; the lens
//! array's elemental images where the geometry puts them.

use glam::Vec3;
use kdray::Geometry;
use kdray_core::Scene;
use kdray_core::camera::{Camera, Frame, LensArray, LensShape, ThickLens};
use kdray_core::render::{self, Bounces, Material, MaterialKind, Settings};
use kdray_core::traverse::Mode;
use kdray_tests::strategies::scene_words;

/// A camera frame at the origin looking down +z with +y up: `right` is then −x.
fn frame() -> Frame {
    Frame::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y).unwrap()
}

/// The centres of an `n × n` grid of cells over `[−a, a]²` that lie inside the disk of radius `a`:
/// lens points spread evenly over the aperture.
fn disk_grid(a: f32, n: usize) -> impl Iterator<Item = [f32; 2]> {
    let at = move |k: usize| a * (2.0 * (k as f32 + 0.5) / n as f32 - 1.0);
    (0..n * n)
        .map(move |k| [at(k / n), at(k % n)])
        .filter(move |p| p[0] * p[0] + p[1] * p[1] <= a * a)
}

/// A biconvex lens: R1 = R2 = 0.1, 1 cm thick, n = 1.5, aperture radius `a` (f ≈ 0.1).
fn lens(a: f32) -> LensShape {
    LensShape::new(0.1, 0.1, 0.005, 0.005, 1.5, a).unwrap()
}

/// The paraxial system matrix of the lens in f64 (Hecht §6.4: refraction `[[1, 0], [−(n2 − n1)/R,
/// 1]]` acting on (height, n·angle), translation `[[1, d/n], [0, 1]]`), crossing from the sensor
/// side: surface R1 (centre behind it, +R1), glass of thickness l1 + l2, surface −R2.
fn system_matrix(r1: f64, r2: f64, d: f64, n: f64) -> [[f64; 2]; 2] {
    let mul = |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| {
        [
            [
                a[0][0] * b[0][0] + a[0][1] * b[1][0],
                a[0][0] * b[0][1] + a[0][1] * b[1][1],
            ],
            [
                a[1][0] * b[0][0] + a[1][1] * b[1][0],
                a[1][0] * b[0][1] + a[1][1] * b[1][1],
            ],
        ]
    };
    let refraction = |n1: f64, n2: f64, r: f64| [[1.0, 0.0], [-(n2 - n1) / r, 1.0]];
    let gap = [[1.0, d / n], [0.0, 1.0]];
    mul(refraction(n, 1.0, -r2), mul(gap, refraction(1.0, n, r1)))
}

/// The sensor distance behind the front vertex that focuses the plane `focus` in front of the
/// lens's centre, from the system matrix: the matrix from the sensor plane to the focus plane
/// must map every angle at a point to the same point (its B entry is 0).
fn sensor_distance_f64(l: &LensShape, focus: f64) -> f64 {
    let (l1, l2) = (f64::from(l.l1), f64::from(l.l2));
    let m = system_matrix(f64::from(l.r1), f64::from(l.r2), l1 + l2, f64::from(l.ior));
    let z = focus - l2; // from the rear vertex to the focus plane
    // [[1, z], [0, 1]] · M · [[1, s], [0, 1]]: B = (A + zC)·s + (B + zD) = 0.
    let (a, b, c, d) = (m[0][0], m[0][1], m[1][0], m[1][1]);
    -(b + z * d) / (a + z * c)
}

#[test]
fn focal_length_and_focus_helper_match_the_matrix_method() {
    for l in [
        lens(0.01),
        LensShape::new(0.05, 0.2, 0.002, 0.006, 1.7, 0.02).unwrap(),
    ] {
        let m = system_matrix(
            f64::from(l.r1),
            f64::from(l.r2),
            f64::from(l.l1 + l.l2),
            f64::from(l.ior),
        );
        let f = -1.0 / m[1][0];
        let rel = (f64::from(l.focal_length()) - f).abs() / f;
        assert!(rel < 1e-5, "f = {} against {f}", l.focal_length());
        for focus in [0.5, 1.0, 3.0, 100.0] {
            let s = l.sensor_distance(focus).unwrap();
            let expect = sensor_distance_f64(&l, f64::from(focus));
            let rel = (f64::from(s) - expect).abs() / expect;
            assert!(rel < 1e-4, "focus {focus}: sensor {s} against {expect}");
        }
        // Nothing nearer than the focal length can be focused.
        assert_eq!(l.sensor_distance(0.5 * l.focal_length()), None);
    }
}

#[test]
fn a_ray_along_the_axis_passes_undeviated() {
    let cam = ThickLens::focused(frame(), lens(0.01), 3.0, 30.0).unwrap();
    let (ray, weight) = cam.ray_through(50.0, 40.0, 100, 80, [0.0, 0.0]).unwrap();
    assert!((ray.dir - Vec3::Z).length() < 1e-6, "{ray:?}");
    assert!(ray.origin.truncate().length() < 1e-6, "{ray:?}");
    assert!(
        (ray.origin.z - 0.005).abs() < 1e-6,
        "leaves at the rear vertex: {ray:?}"
    );
    assert!((weight - 1.0).abs() < 1e-6, "{weight}");
    assert_eq!(cam.ray(50.0, 40.0, 100, 80), ray, "the chief ray");
}

/// Where the rays from the centre of the sensor, through a grid of lens points, cross the axis
/// closest together, for aperture `a`, the lens focused at 2 m by the helper: `(distance, spread
/// there, spread at 1.8 m and 2.2 m)`. By the reversibility of light paths a point source at that
/// distance makes its smallest spot on the sensor's centre.
fn best_focus(a: f32) -> (f32, f32, f32) {
    let l = lens(a);
    let focus = 2.0f32;
    let cam = ThickLens::focused(frame(), l, focus, 20.0).unwrap();
    let n = 24;
    let rays: Vec<_> = disk_grid(a, n)
        .filter_map(|p| cam.ray_through(32.0, 32.0, 64, 64, p))
        .map(|(ray, _)| ray)
        .collect();
    assert!(rays.len() > n * n / 2, "most of the aperture passes");
    // The RMS distance from the axis where the rays cross the plane z.
    let spread = |z: f32| {
        let sum: f32 = rays
            .iter()
            .map(|r| r.at((z - r.origin.z) / r.dir.z).truncate().length_squared())
            .sum();
        (sum / rays.len() as f32).sqrt()
    };
    let (best, _) = (0..=400)
        .map(|k| focus * (0.8 + 0.001 * k as f32))
        .map(|z| (z, spread(z)))
        .fold((0.0, f32::MAX), |b, c| if c.1 < b.1 { c } else { b });
    (
        best,
        spread(best),
        spread(0.9 * focus).min(spread(1.1 * focus)),
    )
}

/// The lensmaker's equation is paraxial: at f/100 (a = 0.5 mm, f ≈ 0.1 m) the smallest spot lies
/// within 0.3 % of where it puts the focus (the scan's step is 0.1 %), and it is a real focus, far
/// smaller than 10 % nearer or farther. Opened up to f/12.5, spherical aberration (a biconvex lens
/// is undercorrected: marginal rays focus nearer the lens) moves the best focus nearer, by about
/// 3 % at 2 m.
#[test]
fn a_point_comes_to_focus_where_the_lensmakers_equation_says() {
    let (best, at, off) = best_focus(0.0005);
    assert!(
        (best - 2.0).abs() < 0.006,
        "the spot is smallest at {best}, not 2"
    );
    assert!(
        at * 5.0 < off,
        "spread {at} at the focus, {off} 10 % off it"
    );
    let (wide, _, _) = best_focus(0.004);
    assert!(
        wide < best && wide > 1.9,
        "at f/12.5 the best focus is at {wide}"
    );
}

#[test]
fn rays_past_the_rim_are_dropped() {
    let a = 0.01;
    let cam = ThickLens::focused(frame(), lens(a), 3.0, 90.0).unwrap();
    // A lens point outside the aperture is refused whatever the pixel.
    assert!(
        cam.ray_through(32.0, 32.0, 64, 64, [1.01 * a, 0.0])
            .is_none()
    );
    assert!(
        cam.ray_through(32.0, 32.0, 64, 64, [0.9 * a, 0.0])
            .is_some()
    );
    // From the image's corner, rays through the far side of the front surface leave the rear
    // surface outside its rim (mechanical vignetting): much of the aperture is lost there, and a
    // thin ring of it at the centre (the rays still diverge inside the glass).
    let kept = |x: f32, y: f32| {
        disk_grid(a, 40)
            .filter(|&p| cam.ray_through(x, y, 64, 64, p).is_some())
            .count()
    };
    let (centre, corner) = (kept(32.0, 32.0), kept(0.5, 0.5));
    assert!(corner < centre * 9 / 10, "corner {corner}, centre {centre}");
    assert!(corner > 0, "the corner still sees through part of the lens");
}

/// A sky of radiance 1 seen from the sensor's centre gives the normalized irradiance
/// `E / (π a²/s²)`, `E = ∫cosθ dω = π sin²α` over the cone from the sensor's centre to the front
/// surface's rim circle (radius `a`, `s + sag` away, `tan α = a/(s + sag)`), divided by the
/// paraxial `π a²/s²`: the mean weight over the aperture must be that. The lens bends the rays
/// from there together inside the glass, so the rear rim drops none of them.
#[test]
fn the_weight_is_the_normalized_irradiance() {
    let a = 0.01f32;
    let l = LensShape::new(0.05, 0.05, 0.005, 0.005, 1.5, a).unwrap();
    let cam = ThickLens::new(frame(), l, 0.1, 20.0).unwrap();
    let (s, a64, r1) = (
        f64::from(cam.sensor_distance()),
        f64::from(a),
        f64::from(l.r1),
    );
    let weights: Vec<f64> = disk_grid(a, 400)
        .map(|p| {
            let (_, w) = cam
                .ray_through(8.0, 8.0, 16, 16, p)
                .expect("no ray dropped");
            f64::from(w)
        })
        .collect();
    let mean = weights.iter().sum::<f64>() / weights.len() as f64;
    let sag = r1 - (r1 * r1 - a64 * a64).sqrt();
    let alpha = (a64 / (s + sag)).atan();
    let expect = alpha.sin().powi(2) * s * s / (a64 * a64);
    assert!((mean - expect).abs() < 1e-3, "{mean} against {expect}");
    // Not a vacuous bound: a flat aperture (cos⁴θ alone) would give s²/(s² + a²).
    assert!((s * s / (s * s + a64 * a64) - expect).abs() > 1e-2);
}

/// Renders `geom` (all one emissive material of radiance 1, lights by `emitters`) with `camera`.
fn render_emitter<C: Camera>(geom: &Geometry, camera: &C, size: u32, spp: u32) -> Vec<f32> {
    let words = scene_words(geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let materials = [Material {
        kind: MaterialKind::Emissive,
        albedo: Vec3::ZERO,
        emission: Vec3::ONE,
        ior: 1.5,
        two_sided: false,
    }];
    let settings = Settings {
        width: size,
        height: size,
        spp,
        max_depth: 1,
        background: Vec3::ZERO,
        seed: 3,
        bounces: Bounces::Packets,
        mode: Mode::Fast,
    };
    let mut out = vec![[0.0; 3]; (size * size) as usize];
    render::render_rows(&scene, camera, &materials, &[], &settings, 0, &mut out).unwrap();
    out.iter().map(|p| p[0]).collect()
}

/// A tiny light on the axis renders as the smallest spot when the camera is focused at its
/// distance by the focus helper: through the whole renderer at f/25, sensor distances 2 % either
/// side give a spot more than twice as large (RMS radius).
#[test]
fn a_rendered_point_light_is_sharpest_at_the_helpers_sensor_distance() {
    let l = lens(0.002);
    let focus = 2.0;
    let geom = Geometry {
        spheres: vec![(Vec3::new(0.0, 0.0, focus), 0.0002)],
        sphere_materials: vec![0],
        ..Geometry::default()
    };
    let size = 48;
    let spot = |sensor: f32| {
        let cam = ThickLens::new(frame(), l, sensor, 0.25).unwrap();
        let img = render_emitter(&geom, &cam, size, 64);
        let (mut sum, mut r2) = (0.0f32, 0.0f32);
        for (k, v) in img.iter().enumerate() {
            let (x, y) = (
                (k as u32 % size) as f32 + 0.5,
                (k as u32 / size) as f32 + 0.5,
            );
            let c = 0.5 * size as f32;
            sum += v;
            r2 += v * ((x - c).powi(2) + (y - c).powi(2));
        }
        assert!(sum > 0.0, "the light is seen at sensor {sensor}");
        (r2 / sum).sqrt()
    };
    let s = l.sensor_distance(focus).unwrap();
    let at = spot(s);
    for k in [0.98, 1.02] {
        let off = spot(s * k);
        assert!(
            off > 2.0 * at,
            "spot {at} px at the helper's sensor, {off} px at x{k}"
        );
    }
}

#[test]
fn elemental_images_lie_where_the_lenslet_geometry_puts_them() {
    // 5 × 5 lenslets, 1 cm apart, 2 cm in front of the display; 100 × 100 pixels, 20 per lenslet.
    let (pitch, gap, size, px) = (0.01f32, 0.02f32, 0.05f32, 100u32);
    let cam = LensArray::new(frame(), [size, size], [pitch, pitch], gap).unwrap();
    // A small light 20 cm in front, right of and above the axis (right is −x in this frame).
    let light = Vec3::new(-0.02, 0.01, 0.2);
    let local = Vec3::new(-light.x, light.y, light.z);
    let geom = Geometry {
        spheres: vec![(light, 0.01)],
        sphere_materials: vec![0],
        ..Geometry::default()
    };
    let img = render_emitter(&geom, &cam, px, 4);
    let per = (px as f32 * pitch / size) as u32;
    for k in -2i32..=2 {
        for l in -2i32..=2 {
            // Lenslet (k, l)'s centre c; the light images through it (a pinhole) at
            // q = c − gap · (P − c) / P.z on the display.
            let c = (k as f32 * pitch, l as f32 * pitch);
            let q = (
                c.0 - gap * (local.x - c.0) / local.z,
                c.1 - gap * (local.y - c.1) / local.z,
            );
            let expect = (
                (q.0 / size + 0.5) * px as f32,
                (0.5 - q.1 / size) * px as f32,
            );
            // The lit pixels' centroid inside this lenslet's block of pixels.
            let (x0, y0) = (((k + 2) as u32) * per, ((2 - l) as u32) * per);
            let (mut sum, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
            for y in y0..y0 + per {
                for x in x0..x0 + per {
                    let v = img[(y * px + x) as usize];
                    sum += v;
                    sx += v * (x as f32 + 0.5);
                    sy += v * (y as f32 + 0.5);
                }
            }
            assert!(sum > 0.0, "lenslet ({k}, {l}) shows the light");
            let got = (sx / sum, sy / sum);
            let err = ((got.0 - expect.0).powi(2) + (got.1 - expect.1).powi(2)).sqrt();
            assert!(
                err < 0.5,
                "lenslet ({k}, {l}): image at {got:?}, geometry says {expect:?}"
            );
        }
    }
}
