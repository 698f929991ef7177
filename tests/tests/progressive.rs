//! The host's progressive render (kdray::progressive) against the core's one-call render: the
//! same pixels bit for bit whatever the passes and bands, and a noise estimate that matches the
//! error it estimates.

use core::sync::atomic::AtomicU64;
use glam::Vec3;
use kdray::Geometry;
use kdray::progressive::{self, Plan, Stop};
use kdray_core::Scene;
use kdray_core::camera::Pinhole;
use kdray_core::render::{
    self, Bounces, Frame, Material, MaterialKind, PixelSamples, RenderError, SampleSums, Settings,
    Wavefront,
};
use kdray_core::traverse::Mode;
use kdray_tests::strategies::scene_words;

fn material(kind: MaterialKind, albedo: f32, emission: f32) -> Material {
    Material {
        kind,
        albedo: Vec3::splat(albedo),
        emission: Vec3::splat(emission),
        ior: 1.5,
        two_sided: false,
    }
}

/// A floor, a glass and a diffuse sphere and a small lamp: paths of every length.
fn room() -> (Geometry, Vec<Material>) {
    let p = |x: f32, z: f32| Vec3::new(x, 0.0, z);
    let geom = Geometry {
        triangles: vec![
            [p(-3.0, -3.0), p(-3.0, 3.0), p(3.0, 3.0)],
            [p(-3.0, -3.0), p(3.0, 3.0), p(3.0, -3.0)],
            // The lamp, facing down at the floor (lights are one-sided).
            [
                Vec3::new(-0.3, 1.5, -0.3),
                Vec3::new(0.3, 1.5, -0.3),
                Vec3::new(0.0, 1.5, 0.3),
            ],
        ],
        tri_materials: vec![0, 0, 2],
        spheres: vec![
            (Vec3::new(0.0, 0.3, 0.0), 0.3),
            (Vec3::new(0.6, 0.2, 0.3), 0.2),
        ],
        sphere_materials: vec![1, 0],
        ..Geometry::default()
    };
    let materials = vec![
        material(MaterialKind::Diffuse, 0.7, 0.0),
        material(MaterialKind::Glass, 1.0, 0.0),
        material(MaterialKind::Emissive, 0.5, 20.0),
    ];
    (geom, materials)
}

fn camera() -> Pinhole {
    Pinhole::look_at(
        Vec3::new(0.3, 1.2, 2.0),
        Vec3::new(0.0, 0.3, 0.0),
        Vec3::Y,
        60.0,
    )
    .unwrap()
}

fn settings(spp: u32) -> Settings {
    Settings {
        width: 9,
        height: 7,
        spp,
        max_depth: 6,
        background: Vec3::splat(0.2),
        seed: 3,
        bounces: Bounces::Packets,
        mode: Mode::Fast,
    }
}

fn stop(spp: u32) -> Stop {
    Stop {
        spp,
        seconds: None,
        noise: None,
    }
}

/// The room's scene words, its materials and its lights.
fn lit_room() -> (Vec<u32>, Vec<Material>, Vec<u32>) {
    let (geom, materials) = room();
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    (words, materials, lights)
}

fn bits(px: &[[f32; 3]]) -> Vec<u32> {
    px.iter().flatten().map(|v| v.to_bits()).collect()
}

/// Passes of 8 samples (and a last partial one) give render_rows' pixels exactly, and so does
/// every band of rows rendered alone: the pixels firmware checksums and `--tile` relies on.
#[test]
fn passes_and_bands_give_render_rows_pixels_bit_for_bit() {
    let (words, materials, lights) = lit_room();
    let scene = Scene::from_words(&words).unwrap();
    let cam = camera();
    for (spp, bounces) in [
        (1, Bounces::Packets),
        (8, Bounces::Packets),
        (21, Bounces::Packets),
        (1, Bounces::Stream),
        (21, Bounces::Stream),
    ] {
        let s = Settings {
            bounces,
            ..settings(spp)
        };
        let mut whole = vec![[0.0f32; 3]; 63];
        render::render_rows(&scene, &cam, &materials, &lights, &s, 0, &mut whole).unwrap();
        let lum: Vec<f32> = whole.iter().map(|p| p[0] + p[1] + p[2]).collect();
        let (lo, hi) = lum
            .iter()
            .fold((f32::MAX, 0.0f32), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(
            hi > 2.0 * lo && hi > 0.0,
            "a flat image proves little: {lo} .. {hi}"
        );
        let frame = Frame {
            scene: &scene,
            camera: &cam,
            materials: &materials,
            lights: &lights,
            settings: &s,
        };
        let done = AtomicU64::new(0);
        let mut banded = Vec::new();
        for rows in [0..3, 3..4, 4..7] {
            let plan = Plan {
                rows,
                stop: stop(spp),
                adaptive: false,
            };
            let (film, stats) = progressive::render(&frame, &plan, &done).unwrap();
            assert_eq!(stats.passes, spp.div_ceil(8));
            banded.extend(film.mean());
        }
        assert_eq!(bits(&whole), bits(&banded), "spp {spp}, {bounces:?}");
    }
}

/// `Frame::add_pixels` with a wavefront smaller than a pixel's samples (paths of one pixel split
/// between wavefronts, pixels in any order, one pixel twice) adds what `add_samples` adds, bit
/// for bit; bad jobs are refused before anything is rendered.
#[test]
fn wavefronts_add_what_single_pixels_add() {
    let (words, materials, lights) = lit_room();
    let scene = Scene::from_words(&words).unwrap();
    let cam = camera();
    let s = Settings {
        bounces: Bounces::Stream,
        ..settings(8)
    };
    let frame = Frame {
        scene: &scene,
        camera: &cam,
        materials: &materials,
        lights: &lights,
        settings: &s,
    };
    let jobs: Vec<PixelSamples> = [(4, 3, 0..13), (0, 0, 5..9), (8, 6, 0..1), (4, 3, 13..20)]
        .into_iter()
        .map(|(x, y, samples)| PixelSamples { x, y, samples })
        .collect();
    let mut wave = Wavefront::<5>::new();
    let mut sums = vec![SampleSums::default(); jobs.len()];
    frame.add_pixels(&jobs, &mut sums, &mut wave).unwrap();
    let packets = Settings {
        bounces: Bounces::Packets,
        ..s
    };
    let one_by_one = Frame {
        settings: &packets,
        ..frame
    };
    for (job, got) in jobs.iter().zip(&sums) {
        let mut want = SampleSums::default();
        one_by_one
            .add_samples(job.x, job.y, job.samples.clone(), &mut want)
            .unwrap();
        assert!(want.rays > 0);
        assert_eq!(
            (bits(&[got.sum.to_array(), got.sum_sq.to_array()]), got.rays),
            (
                bits(&[want.sum.to_array(), want.sum_sq.to_array()]),
                want.rays
            ),
            "{job:?}"
        );
    }
    let outside = [PixelSamples {
        x: 9,
        y: 0,
        samples: 0..1,
    }];
    let mut one = [SampleSums::default()];
    assert_eq!(
        frame.add_pixels(&outside, &mut one, &mut wave),
        Err(RenderError::BufferSize)
    );
    assert_eq!(
        frame.add_pixels(&jobs, &mut one, &mut wave),
        Err(RenderError::BufferSize)
    );
    assert_eq!(one[0], SampleSums::default());
}

/// The estimated RMSE is the error against the converged image: rendered against a
/// 16× longer render of another seed, the measured RMSE (corrected for the reference's own
/// noise) lies within 25 % of the estimate.
#[test]
fn estimated_rmse_matches_the_measured_error() {
    let (geom, mut materials) = room();
    // A dimmer lamp: large fireflies would make the test depend on a few samples.
    materials[2].emission = Vec3::splat(2.0);
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    let cam = camera();
    let render = |spp: u32, seed: u64| {
        let s = Settings {
            width: 24,
            height: 16,
            seed,
            ..settings(spp)
        };
        let frame = Frame {
            scene: &scene,
            camera: &cam,
            materials: &materials,
            lights: &lights,
            settings: &s,
        };
        let plan = Plan {
            rows: 0..16,
            stop: stop(spp),
            adaptive: false,
        };
        progressive::render(&frame, &plan, &AtomicU64::new(0)).unwrap()
    };
    let (film, stats) = render(32, 1);
    let (reference, ref_stats) = render(512, 2);
    let (a, b) = (film.mean(), reference.mean());
    let mse: f64 = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum::<f64>()
        / (3 * a.len()) as f64;
    let measured = (mse - ref_stats.rmse.powi(2)).max(0.0).sqrt();
    let ratio = measured / stats.rmse;
    eprintln!(
        "estimated {:.5}, measured {measured:.5}, ratio {ratio:.3}",
        stats.rmse
    );
    assert!((0.75..1.25).contains(&ratio), "ratio {ratio}");
}
