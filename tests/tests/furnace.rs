//! The white furnace: a closed enclosure, every face diffuse with albedo `a` and emitting `Le`, has
//! radiance `Le/(1 − a)` everywhere (each bounce adds `a` times what the last one saw). The
//! renderer cuts paths after `D` hits, so it must give `Le·(1 − a^(D+1))/(1 − a)`; it is a Monte
//! Carlo estimate (next-event estimation picks points on the cube's faces), so it is tested within
//! a statistical bound from the per-pixel sample variance, and that variance estimate itself is
//! checked: the pixels' standardized errors have a mean square near 1.

use core::sync::atomic::AtomicU64;
use glam::Vec3;
use kdray::Geometry;
use kdray::progressive::{self, Plan, Stop};
use kdray_core::Scene;
use kdray_core::camera::Pinhole;
use kdray_core::render::{self, Bounces, Frame, Material, MaterialKind, Settings};
use kdray_core::traverse::Mode;
use kdray_tests::strategies::scene_words;

/// A sphere of radius 1 with a sphere of radius 0.35 inside, off centre: an enclosure whose
/// next-event estimates are all bounded (kdray::converge's furnace doc says why not a cube).
fn enclosure() -> Geometry {
    Geometry {
        spheres: vec![(Vec3::ZERO, 1.0), (Vec3::new(0.15, -0.1, -0.3), 0.35)],
        sphere_materials: vec![0, 0],
        ..Geometry::default()
    }
}

/// Renders the furnace of albedo `a` and emission `le` and checks it against the analytic value.
fn check_furnace(a: f32, le: f32, max_depth: u32, spp: u32) {
    let geom = enclosure();
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let materials = [Material {
        kind: MaterialKind::Emissive,
        albedo: Vec3::splat(a),
        emission: Vec3::splat(le),
        ior: 1.5,
        // The big sphere emits from its inside, the back of its outward normal.
        two_sided: true,
    }];
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    assert_eq!(lights.len(), 2);
    // From off the centre, so that the faces are seen at many distances and angles.
    let camera = Pinhole::look_at(
        Vec3::new(0.0, 0.0, 0.55),
        Vec3::new(0.1, -0.1, -1.0),
        Vec3::Y,
        100.0,
    )
    .unwrap();
    let settings = Settings {
        width: 8,
        height: 8,
        spp,
        max_depth,
        background: Vec3::ZERO,
        seed: 9,
        bounces: Bounces::Packets,
        mode: Mode::Fast,
    };
    let frame = Frame {
        scene: &scene,
        camera: &camera,
        materials: &materials,
        lights: &lights,
        settings: &settings,
    };
    let plan = Plan {
        rows: 0..8,
        stop: Stop {
            spp,
            seconds: None,
            noise: None,
        },
        adaptive: false,
    };
    let (film, _) = progressive::render(&frame, &plan, &AtomicU64::new(0)).unwrap();
    let (a64, le64) = (f64::from(a), f64::from(le));
    let expected = le64 * (1.0 - a64.powi(max_depth as i32 + 1)) / (1.0 - a64);
    let means = film.mean();
    let pixels = means.len() as f64;
    let (mut sum, mut var_of_sum, mut z2) = (0.0, 0.0, 0.0);
    for (k, m) in means.iter().enumerate() {
        let var_of_mean = film.variance(k)[0] / f64::from(film.count[k]);
        assert!(var_of_mean > 0.0, "pixel {k}: no noise, a degenerate test");
        let err = f64::from(m[0]) - expected;
        sum += f64::from(m[0]);
        var_of_sum += var_of_mean;
        z2 += err * err / var_of_mean;
        assert_eq!(m[0], m[1], "grey in, grey out");
    }
    let mean = sum / pixels;
    let se = var_of_sum.sqrt() / pixels;
    let mean_z2 = z2 / pixels;
    eprintln!(
        "a {a}, Le {le}, D {max_depth}: mean {mean:.5} ± {se:.5}, expected {expected:.5}, \
         mean z² {mean_z2:.3}"
    );
    assert!(se < 0.01 * expected, "too noisy to test: SE {se}");
    assert!(
        (mean - expected).abs() < 5.0 * se,
        "mean {mean} ± {se}, expected {expected}"
    );
    assert!((0.6..1.5).contains(&mean_z2), "mean z² {mean_z2}");
}

#[test]
fn white_furnace_is_le_over_one_minus_albedo() {
    // Le/(1 − a) = 1 in both, up to a^(D+1): 7.8e-3 and 0.13.
    check_furnace(0.5, 0.5, 6, 32);
    check_furnace(0.8, 0.2, 8, 32);
}
