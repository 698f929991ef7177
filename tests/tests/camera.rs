//! Cameras: Rukin's fisheye (§3.2) and parallel (§3.3) examples reproduced pixel by pixel
//! against f64 evaluations of equations (3)–(5), the `{start, middle, end}` spans as corrected, and
//! the pinhole camera's aim and field of view.

use glam::Vec3;
use kdray_core::camera::{Camera, CameraError, Fisheye, Parallel, Pinhole, Span, spherical_dir};
use kdray_tests::f64ref::{self, DVec3, dv};
use proptest::prelude::*;

/// Image sizes with a middle pixel: Rukin's examples at a tiny and a realistic resolution.
const SIZES: [(u32, u32); 3] = [(5, 3), (101, 51), (3, 5)];

/// Rukin's fisheye example: origin (−1, −2, 1), φ {90, 30, −30}, θ {70, 110, 150} (degrees).
fn seed_fisheye() -> Fisheye {
    Fisheye {
        origin: Vec3::new(-1.0, -2.0, 1.0),
        phi: Span::from_triple([90.0, 30.0, -30.0]).unwrap(),
        theta: Span::from_triple([70.0, 110.0, 150.0]).unwrap(),
    }
}

/// Rukin's parallel example: origin (0, −1, 0), rotation φ = θ = 110°, ranges {−2, 0, 2}.
fn seed_parallel() -> Parallel {
    let range = Span::from_triple([-2.0, 0.0, 2.0]).unwrap();
    Parallel::new(Vec3::new(0.0, -1.0, 0.0), 110.0, 110.0, range, range)
}

/// The value of an evenly spaced `{start, …, end}` at pixel `k` of `n`, in f64.
fn lerp_pixel(start: f64, end: f64, k: u32, n: u32) -> f64 {
    start + (end - start) * f64::from(k) / f64::from(n - 1)
}

#[test]
fn span_from_triple_accepts_midpoints_only() {
    let phi = Span::from_triple([90.0, 30.0, -30.0]).unwrap();
    assert_eq!((phi.start, phi.end), (90.0, -30.0));
    let theta = Span::from_triple([70.0, 110.0, 150.0]).unwrap();
    assert_eq!((theta.start, theta.end), (70.0, 150.0));
    // The middle is checked to 1e-4 of the span's length (at least 1e-4).
    assert!(Span::from_triple([0.0, 0.500_05, 1.0]).is_ok());
    assert_eq!(
        Span::from_triple([0.0, 0.5002, 1.0]),
        Err(CameraError::MiddleNotMidpoint)
    );
    assert_eq!(
        Span::from_triple([90.0, 0.0, -30.0]),
        Err(CameraError::MiddleNotMidpoint)
    );
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for i in 0..3 {
            let mut v = [-2.0, 0.0, 2.0];
            v[i] = bad;
            assert_eq!(Span::from_triple(v), Err(CameraError::Degenerate), "{v:?}");
        }
    }
}

/// Middle pixel: the middle angles; corner pixels: the end angles; all bit-exact, because the
/// spans land on them exactly (pixel centres at `start + (end − start)·k/(n − 1)`).
#[test]
fn fisheye_seed_example_middle_and_corners() {
    let cam = seed_fisheye();
    for (w, h) in SIZES {
        let ray = |i, j| cam.pixel_ray(i, j, w, h);
        assert_eq!(ray(w / 2, h / 2).dir, spherical_dir(30.0, 110.0), "{w}×{h}");
        assert_eq!(ray(0, 0).dir, spherical_dir(90.0, 70.0), "{w}×{h} top left");
        assert_eq!(
            ray(w - 1, 0).dir,
            spherical_dir(-30.0, 70.0),
            "{w}×{h} top right"
        );
        assert_eq!(
            ray(0, h - 1).dir,
            spherical_dir(90.0, 150.0),
            "{w}×{h} bottom left"
        );
        assert_eq!(
            ray(w - 1, h - 1).dir,
            spherical_dir(-30.0, 150.0),
            "{w}×{h} bottom right"
        );
        // And those are Rukin's equation (3).
        let middle = dv(ray(w / 2, h / 2).dir);
        assert!(middle.max_abs_diff(f64ref::spherical_dir(30.0, 110.0)) <= 1e-6);
    }
    // A single pixel looks along the middle.
    assert_eq!(cam.pixel_ray(0, 0, 1, 1).dir, spherical_dir(30.0, 110.0));
}

/// Every pixel: origin exactly the given one, unit direction at (φ_i, θ_j) evenly spaced from
/// start to end, φ across the width (left to right), θ down the height (top to bottom).
#[test]
fn fisheye_every_pixel_matches_equation_3() {
    let cam = seed_fisheye();
    for (w, h) in SIZES {
        for j in 0..h {
            for i in 0..w {
                let ray = cam.pixel_ray(i, j, w, h);
                assert_eq!(ray.origin, Vec3::new(-1.0, -2.0, 1.0));
                let (phi, theta) = (lerp_pixel(90.0, -30.0, i, w), lerp_pixel(70.0, 150.0, j, h));
                let want = f64ref::spherical_dir(phi, theta);
                let got = dv(ray.dir);
                assert!(
                    got.max_abs_diff(want) <= 1e-6,
                    "{w}×{h} pixel ({i}, {j}): {got:?} vs d({phi}, {theta}) = {want:?}"
                );
                assert!((got.length() - 1.0).abs() <= 1e-6);
            }
        }
    }
}

/// The parallel camera's axes are Rukin's equations (4)–(5), orthonormal with the viewing
/// direction, and right-handed: `vec1 × vec2 = d` (θ̂ × φ̂ = r̂ of spherical coordinates), which
/// pins the signs of both.
#[test]
fn parallel_axes_are_equations_4_and_5() {
    let cam = seed_parallel();
    let (vec2, vec1) = cam.axes();
    let (want1, want2) = f64ref::parallel_axes(110.0, 110.0);
    assert!(dv(vec1).max_abs_diff(want1) <= 1e-6, "vec1 = {vec1}");
    assert!(dv(vec2).max_abs_diff(want2) <= 1e-6, "vec2 = {vec2}");
    let d = dv(cam.dir());
    assert!(d.max_abs_diff(f64ref::spherical_dir(110.0, 110.0)) <= 1e-6);
    for (a, b) in [(d, want1), (d, want2), (want1, want2)] {
        assert!(a.dot(b).abs() <= 1e-6);
    }
    assert!(want1.cross(want2).max_abs_diff(d) <= 1e-6);
    assert!(dv(vec1).cross(dv(vec2)).max_abs_diff(d) <= 1e-6);
}

/// Every pixel: the one shared direction d(110°, 110°), origins `o + h·vec2 + v·vec1` with h from
/// −2 (left) to 2 (right) and v from −2 (top) to 2 (bottom); the middle pixel is the origin
/// itself and the corners are the ends of both ranges.
#[test]
fn parallel_seed_example_every_pixel() {
    let cam = seed_parallel();
    let o = DVec3::new(0.0, -1.0, 0.0);
    let (vec1, vec2) = f64ref::parallel_axes(110.0, 110.0);
    let dir = spherical_dir(110.0, 110.0);
    for (w, h) in SIZES {
        assert_eq!(
            cam.pixel_ray(w / 2, h / 2, w, h).origin,
            Vec3::new(0.0, -1.0, 0.0)
        );
        let corners = [
            ((0, 0), (-2.0, -2.0)),
            ((w - 1, 0), (2.0, -2.0)),
            ((0, h - 1), (-2.0, 2.0)),
            ((w - 1, h - 1), (2.0, 2.0)),
        ];
        for ((i, j), (hz, vt)) in corners {
            let got = dv(cam.pixel_ray(i, j, w, h).origin);
            let want = o + hz * vec2 + vt * vec1;
            assert!(
                got.max_abs_diff(want) <= 1e-5,
                "{w}×{h} corner ({i}, {j}): {got:?}"
            );
        }
        for j in 0..h {
            for i in 0..w {
                let ray = cam.pixel_ray(i, j, w, h);
                assert_eq!(ray.dir, dir, "{w}×{h} pixel ({i}, {j}): direction differs");
                let (hz, vt) = (lerp_pixel(-2.0, 2.0, i, w), lerp_pixel(-2.0, 2.0, j, h));
                let want = o + hz * vec2 + vt * vec1;
                let got = dv(ray.origin);
                assert!(
                    got.max_abs_diff(want) <= 1e-5,
                    "{w}×{h} pixel ({i}, {j}): {got:?} vs {want:?}"
                );
            }
        }
    }
}

/// The top of the image is up: for both seed cameras the top row looks (fisheye) or sits
/// (parallel, whose vec1 points down: −sin 110° < 0) higher in z than the bottom row.
#[test]
fn top_row_is_up() {
    let (fish, par) = (seed_fisheye(), seed_parallel());
    let (w, h) = (5, 3);
    for i in 0..w {
        assert!(fish.pixel_ray(i, 0, w, h).dir.z > fish.pixel_ray(i, h - 1, w, h).dir.z);
        assert!(par.pixel_ray(i, 0, w, h).origin.z > par.pixel_ray(i, h - 1, w, h).origin.z);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(1000)))]

    /// `spherical_dir` is equation (3): unit, and equal to the f64 formula (to the rounding of a
    /// degree-to-radian conversion of angles up to 360°: ~4e-7).
    #[test]
    fn spherical_dir_matches_f64(phi in -360.0f32..360.0, theta in -180.0f32..180.0) {
        let got = dv(spherical_dir(phi, theta));
        let want = f64ref::spherical_dir(phi.into(), theta.into());
        prop_assert!(got.max_abs_diff(want) <= 2e-6, "{:?} vs {:?}", got, want);
        prop_assert!((got.length() - 1.0).abs() <= 1e-6);
    }
}

/// The pinhole model in f64: the direction through continuous image point `(x, y)` of a `w × h`
/// image, for a camera at `eye` looking at `target` with vertical field of view `vfov` degrees.
fn pinhole_f64(
    [eye, target, up]: [Vec3; 3],
    vfov: f64,
    (x, y): (f64, f64),
    (w, h): (u32, u32),
) -> DVec3 {
    let forward = (dv(target) - dv(eye)).normalize();
    let right = forward.cross(dv(up)).normalize();
    let up = right.cross(forward);
    let tan = (0.5 * vfov).to_radians().tan();
    let (w, h) = (f64::from(w), f64::from(h));
    let sx = (2.0 * x / w - 1.0) * tan * w / h;
    let sy = (1.0 - 2.0 * y / h) * tan;
    (forward + sx * right + sy * up).normalize()
}

/// The centre pixel of an odd image looks at the target; the image edges are at ±vfov/2
/// vertically and ±atan(aspect·tan(vfov/2)) horizontally, up at the top and right on the right;
/// every pixel matches the f64 model.
#[test]
fn pinhole_centre_looks_at_target_and_edges_span_the_fov() {
    let (eye, target, up) = (Vec3::new(1.0, -4.0, 2.0), Vec3::new(0.5, 3.0, 1.0), Vec3::Z);
    let cam = Pinhole::look_at(eye, target, up, 50.0).unwrap();
    let vfov = 50.0f64;
    let forward = (dv(target) - dv(eye)).normalize();
    let right = forward.cross(dv(up)).normalize();
    let true_up = right.cross(forward);
    for (w, h) in SIZES {
        let centre = cam.pixel_ray(w / 2, h / 2, w, h);
        assert_eq!(centre.origin, eye);
        assert!(
            dv(centre.dir).max_abs_diff(forward) <= 1e-6,
            "{w}×{h}: centre {}",
            centre.dir
        );
        let (wf, hf) = (w as f32, h as f32);
        let hfov_half = ((f64::from(w) / f64::from(h)) * (0.5 * vfov).to_radians().tan())
            .atan()
            .to_degrees();
        let edges = [
            ((0.5 * wf, 0.0), 0.5 * vfov, true_up),
            ((0.5 * wf, hf), 0.5 * vfov, -true_up),
            ((0.0, 0.5 * hf), hfov_half, -right),
            ((wf, 0.5 * hf), hfov_half, right),
        ];
        for ((x, y), angle, side) in edges {
            let d = dv(cam.ray(x, y, w, h).dir);
            let got = f64ref::angle_deg(d, forward);
            assert!(
                (got - angle).abs() <= 1e-4,
                "{w}×{h} edge ({x}, {y}): {got}° vs {angle}°"
            );
            assert!(
                d.dot(side) > 0.0,
                "{w}×{h} edge ({x}, {y}) on the wrong side"
            );
        }
        // The image corners: the diagonal field of view.
        let tan = (0.5 * vfov).to_radians().tan();
        let diag = (tan * (1.0 + (f64::from(w) / f64::from(h)).powi(2)).sqrt())
            .atan()
            .to_degrees();
        for (x, y) in [(0.0, 0.0), (wf, 0.0), (0.0, hf), (wf, hf)] {
            let got = f64ref::angle_deg(dv(cam.ray(x, y, w, h).dir), forward);
            assert!(
                (got - diag).abs() <= 1e-4,
                "{w}×{h} corner ({x}, {y}): {got}° vs {diag}°"
            );
        }
        for j in 0..h {
            for i in 0..w {
                let got = dv(cam.pixel_ray(i, j, w, h).dir);
                let (x, y) = (f64::from(i) + 0.5, f64::from(j) + 0.5);
                let want = pinhole_f64([eye, target, up], vfov, (x, y), (w, h));
                assert!(got.max_abs_diff(want) <= 1e-6, "{w}×{h} pixel ({i}, {j})");
            }
        }
    }
}

#[test]
fn pinhole_rejects_degenerate_setups() {
    let (eye, target) = (Vec3::ZERO, Vec3::Y);
    let bad = Err(CameraError::Degenerate);
    assert_eq!(Pinhole::look_at(eye, eye, Vec3::Z, 60.0), bad);
    assert_eq!(Pinhole::look_at(eye, target, Vec3::Y, 60.0), bad);
    assert_eq!(Pinhole::look_at(eye, target, Vec3::ZERO, 60.0), bad);
    for vfov in [0.0, 180.0, -10.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            Pinhole::look_at(eye, target, Vec3::Z, vfov),
            bad,
            "vfov {vfov}"
        );
    }
    assert_eq!(Pinhole::look_at(Vec3::NAN, target, Vec3::Z, 60.0), bad);
    assert_eq!(Pinhole::look_at(Vec3::INFINITY, target, Vec3::Z, 60.0), bad);
    assert!(Pinhole::look_at(eye, target, Vec3::Z, 60.0).is_ok());
}
