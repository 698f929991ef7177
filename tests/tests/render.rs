//! The render kernel against cases whose radiance is known exactly (furnaces, a white sky, a
//! mirror), next-event estimation against plain path tracing, determinism and argument checks.

use glam::Vec3;
use kdray::Geometry;
use kdray_core::Scene;
use kdray_core::camera::Pinhole;
use kdray_core::render::{self, Bounces, Material, MaterialKind, RenderError, Settings};
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

fn settings(size: u32, spp: u32, max_depth: u32, background: f32) -> Settings {
    Settings {
        width: size,
        height: size,
        spp,
        max_depth,
        background: Vec3::splat(background),
        seed: 7,
        bounces: Bounces::Packets,
        mode: Mode::Fast,
    }
}

/// A square in the plane `y = height`, side `2·half`, centred on the y axis; normal +y.
fn floor(half: f32, height: f32, material: u32) -> (Vec<[Vec3; 3]>, Vec<u32>) {
    let p = |x: f32, z: f32| Vec3::new(x, height, z);
    let (a, b, c, d) = (
        p(-half, -half),
        p(-half, half),
        p(half, half),
        p(half, -half),
    );
    (vec![[a, b, c], [a, c, d]], vec![material; 2])
}

/// A floor of material 0 reaching far beyond the view of [`looking_down`].
fn wide_floor() -> Geometry {
    let (triangles, tri_materials) = floor(100.0, 0.0, 0);
    Geometry {
        triangles,
        tri_materials,
        ..Geometry::default()
    }
}

/// Renders the whole image in one call, with the lights `render::emitters` finds.
fn render_image(
    geom: &Geometry,
    camera: &Pinhole,
    materials: &[Material],
    settings: &Settings,
) -> Vec<Vec3> {
    let words = scene_words(geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let mut lights = vec![0; render::emitters(&scene, materials, &mut [])];
    render::emitters(&scene, materials, &mut lights);
    render_with_lights(&scene, camera, materials, &lights, settings)
}

fn render_with_lights(
    scene: &Scene,
    camera: &Pinhole,
    materials: &[Material],
    lights: &[u32],
    settings: &Settings,
) -> Vec<Vec3> {
    let mut out = vec![[0.0; 3]; (settings.width * settings.height) as usize];
    render::render_rows(scene, camera, materials, lights, settings, 0, &mut out).unwrap();
    out.into_iter().map(Vec3::from).collect()
}

fn looking_down() -> Pinhole {
    Pinhole::look_at(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Z, 40.0).unwrap()
}

/// Inside a sphere that emits `E` everywhere and reflects `ρ`, every path sees `E` at the camera
/// ray's hit and next-event estimation adds `ρᵏE` at its k-th hit. Sampling the sphere uniformly
/// by area from a point on it makes each estimate exactly `E` (both cosines are `d/2R`), so
/// every pixel is `E·(1 + ρ + … + ρᴰ)` up to rounding, with `D = max_depth`.
#[test]
fn emitting_sphere_furnace_is_exact() {
    let geom = Geometry {
        spheres: vec![(Vec3::ZERO, 1.0)],
        ..Geometry::default()
    };
    let camera = Pinhole::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 90.0).unwrap();
    let (rho, e, depth) = (0.5f32, 2.0f32, 6);
    let expected: f32 = (0..=depth).map(|k| e * rho.powi(k as i32)).sum();
    let image = render_image(
        &geom,
        &camera,
        &[Material {
            two_sided: true,
            ..material(MaterialKind::Emissive, rho, e)
        }],
        &settings(8, 16, depth, 0.0),
    );
    for (i, px) in image.iter().enumerate() {
        let err = (*px - Vec3::splat(expected)).abs().max_element() / expected;
        assert!(err < 1e-4, "pixel {i}: {px} against {expected}");
    }
}

/// A Lambertian floor of albedo `ρ` under a uniform sky `B` and nothing else: every bounce
/// escapes to the sky, so each sample is exactly `ρB` where the floor is seen.
#[test]
fn white_sky_over_a_diffuse_floor_is_albedo_times_sky() {
    let geom = wide_floor();
    let image = render_image(
        &geom,
        &looking_down(),
        &[material(MaterialKind::Diffuse, 0.6, 0.0)],
        &settings(8, 8, 4, 1.5),
    );
    for (i, px) in image.iter().enumerate() {
        assert!(
            (*px - Vec3::splat(0.9)).abs().max_element() < 1e-5,
            "pixel {i}: {px}"
        );
    }
    // With only one hit allowed the bounce is cut off before it reaches the sky: black.
    let cut = render_image(
        &geom,
        &looking_down(),
        &[material(MaterialKind::Diffuse, 0.6, 0.0)],
        &settings(4, 4, 1, 1.5),
    );
    assert!(cut.iter().all(|px| *px == Vec3::ZERO), "{cut:?}");
}

/// A mirror floor reflects the sky once: `albedo · B`, exactly, in every pixel.
#[test]
fn mirror_reflects_the_sky_tinted_by_its_albedo() {
    let geom = wide_floor();
    let image = render_image(
        &geom,
        &looking_down(),
        &[material(MaterialKind::Mirror, 0.25, 0.0)],
        &settings(8, 2, 2, 2.0),
    );
    assert!(image.iter().all(|px| *px == Vec3::splat(0.5)), "{image:?}");
}

/// A clear glass sphere (albedo 1) in a uniform sky neither creates nor absorbs light: every
/// path that gets out brings back `B`, whichever way Fresnel sent it.
#[test]
fn clear_glass_in_a_uniform_sky_conserves_energy() {
    let geom = Geometry {
        spheres: vec![(Vec3::new(0.0, 0.0, 0.0), 1.0)],
        ..Geometry::default()
    };
    let camera = Pinhole::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    let image = render_image(
        &geom,
        &camera,
        &[material(MaterialKind::Glass, 1.0, 0.0)],
        &settings(16, 8, 64, 1.0),
    );
    for (i, px) in image.iter().enumerate() {
        let err = (*px - Vec3::ONE).abs().max_element();
        assert!(err < 1e-3, "pixel {i}: {px}");
    }
}

/// The mean of a floor lit by an emitting quad above it (facing up, or down when `down`; emitting
/// from one side or both), rendered with the light list (next-event estimation) and without it
/// (plain path tracing, emission counted where paths land).
fn lamp_over_floor(two_sided: bool, down: bool) -> (Vec3, Vec3) {
    let (mut triangles, mut tri_materials) = floor(1.0, 0.0, 0);
    let (lamp, lamp_materials) = floor(0.3, 1.0, 1);
    let flip = |[a, b, c]: [Vec3; 3]| if down { [a, c, b] } else { [a, b, c] };
    triangles.extend(lamp.into_iter().map(flip));
    tri_materials.extend(lamp_materials);
    let geom = Geometry {
        triangles,
        tri_materials,
        ..Geometry::default()
    };
    let lamp = Material {
        two_sided,
        ..material(MaterialKind::Emissive, 0.5, 4.0)
    };
    let materials = [material(MaterialKind::Diffuse, 0.7, 0.0), lamp];
    // Looking down at the floor, the lamp out of view: the image is all reflected light.
    let camera = Pinhole::look_at(Vec3::new(0.0, 0.6, 1.6), Vec3::ZERO, Vec3::Y, 50.0).unwrap();
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    assert_eq!(lights.len(), 2, "the two lamp triangles");
    let mean = |img: Vec<Vec3>| img.iter().copied().sum::<Vec3>() / img.len() as f32;
    let with_nee = mean(render_with_lights(
        &scene,
        &camera,
        &materials,
        &lights,
        &settings(8, 256, 4, 0.0),
    ));
    let without = mean(render_with_lights(
        &scene,
        &camera,
        &materials,
        &[],
        &settings(8, 2048, 4, 0.0),
    ));
    (with_nee, without)
}

/// Next-event estimation is unbiased: the same mean with the light list as without, within the
/// noise of the two estimates (a two-sided lamp facing away from the floor lights it anyway).
#[test]
fn next_event_estimation_agrees_with_plain_path_tracing() {
    let (with_nee, without) = lamp_over_floor(true, false);
    let rel = ((with_nee - without) / without).abs().max_element();
    assert!(with_nee.x > 0.05, "the floor is lit: {with_nee}");
    assert!(rel < 0.03, "with NEE {with_nee}, without {without}");
}

/// Emission and next-event estimation agree on which side a one-sided light emits from: facing
/// the floor it lights it as a two-sided lamp does (the floor sees only the side facing it),
/// facing away it leaves it black under both estimators, not only under one.
#[test]
fn one_sided_lights_emit_from_the_front_under_both_estimators() {
    let (two_nee, two_plain) = lamp_over_floor(true, false);
    let (down_nee, down_plain) = lamp_over_floor(false, true);
    for (name, v) in [("with NEE", down_nee), ("without", down_plain)] {
        let rel = ((v - two_nee) / two_nee).abs().max_element();
        assert!(
            rel < 0.03,
            "facing down, {name}: {v} against two-sided {two_nee} / {two_plain}"
        );
    }
    let (up_nee, up_plain) = lamp_over_floor(false, false);
    assert_eq!(up_nee, Vec3::ZERO, "facing away, with NEE");
    assert_eq!(up_plain, Vec3::ZERO, "facing away, without NEE");
}

#[test]
fn rows_render_the_same_whatever_the_split() {
    let (triangles, tri_materials) = floor(1.0, 0.0, 0);
    let geom = Geometry {
        triangles,
        tri_materials,
        spheres: vec![(Vec3::new(0.0, 0.5, 0.0), 0.25)],
        sphere_materials: vec![1],
        ..Geometry::default()
    };
    let materials = [
        material(MaterialKind::Diffuse, 0.7, 0.0),
        material(MaterialKind::Emissive, 0.7, 3.0),
    ];
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let camera = looking_down();
    let lights = [2]; // the sphere: primitives count triangles first
    let s = settings(6, 3, 4, 0.1);
    let whole = render_with_lights(&scene, &camera, &materials, &lights, &s);
    let mut rows = vec![[0.0f32; 3]; 36];
    for (r, chunk) in rows.chunks_mut(6).enumerate() {
        render::render_rows(&scene, &camera, &materials, &lights, &s, r as u32, chunk).unwrap();
    }
    let split: Vec<Vec3> = rows.into_iter().map(Vec3::from).collect();
    assert_eq!(whole, split);
    let reseeded = render_with_lights(
        &scene,
        &camera,
        &materials,
        &lights,
        &Settings { seed: 8, ..s },
    );
    assert_ne!(whole, reseeded);
}

#[test]
fn bad_buffers_and_empty_images_are_refused() {
    let (triangles, _) = floor(1.0, 0.0, 0);
    let words = scene_words(
        &Geometry {
            triangles,
            ..Geometry::default()
        },
        80.0,
    );
    let scene = Scene::from_words(&words).unwrap();
    let camera = looking_down();
    let m = [material(MaterialKind::Diffuse, 0.5, 0.0)];
    let s = settings(4, 1, 2, 0.0);
    let call = |s: &Settings, first_row: u32, len: usize| {
        let mut out = vec![[0.0f32; 3]; len];
        render::render_rows(&scene, &camera, &m, &[], s, first_row, &mut out)
    };
    assert_eq!(call(&s, 0, 16), Ok(()));
    let stream = Settings {
        bounces: Bounces::Stream,
        ..s
    };
    assert_eq!(call(&stream, 0, 15), Err(RenderError::BufferSize));
    assert_eq!(call(&stream, 1, 16), Err(RenderError::BufferSize));
    assert_eq!(call(&s, 0, 15), Err(RenderError::BufferSize));
    assert_eq!(call(&s, 1, 16), Err(RenderError::BufferSize));
    assert_eq!(call(&s, 3, 4), Ok(()));
    assert_eq!(
        call(&Settings { spp: 0, ..s }, 0, 16),
        Err(RenderError::EmptyImage)
    );
    assert_eq!(
        call(&Settings { width: 0, ..s }, 0, 0),
        Err(RenderError::EmptyImage)
    );
}

#[test]
fn packed_single_ray_and_stream_paths_render_the_same_image() {
    // A floor, a mirror wall, a glass, a mirror and a diffuse sphere, and a small emissive
    // triangle overhead: paths end after different numbers of bounces (sky, light, depth), so a
    // pixel's packets lose lanes as they go.
    let (mut triangles, mut tri_materials) = floor(3.0, 0.0, 0);
    let wall = |x: f32, z: f32, y: f32| Vec3::new(x, y, z);
    triangles.push([
        wall(-3.0, -1.0, 0.0),
        wall(3.0, -1.0, 0.0),
        wall(3.0, -1.0, 2.0),
    ]);
    triangles.push([
        wall(-3.0, -1.0, 0.0),
        wall(3.0, -1.0, 2.0),
        wall(-3.0, -1.0, 2.0),
    ]);
    tri_materials.extend([1, 1]);
    triangles.push([
        Vec3::new(-0.3, 1.5, -0.3),
        Vec3::new(0.3, 1.5, -0.3),
        Vec3::new(0.0, 1.5, 0.3),
    ]);
    tri_materials.push(3);
    let geom = Geometry {
        triangles,
        tri_materials,
        spheres: vec![
            (Vec3::new(0.0, 0.3, 0.0), 0.3),
            (Vec3::new(0.6, 0.2, 0.3), 0.2),
            (Vec3::new(-0.6, 0.25, 0.2), 0.25),
        ],
        sphere_materials: vec![2, 1, 0],
        ..Geometry::default()
    };
    let materials = [
        material(MaterialKind::Diffuse, 0.7, 0.0),
        material(MaterialKind::Mirror, 0.9, 0.0),
        material(MaterialKind::Glass, 1.0, 0.0),
        material(MaterialKind::Emissive, 0.5, 20.0),
    ];
    let camera = Pinhole::look_at(
        Vec3::new(0.3, 1.2, 2.0),
        Vec3::new(0.0, 0.3, 0.0),
        Vec3::Y,
        60.0,
    )
    .unwrap();
    for (spp, max_depth) in [(11, 6), (8, 1), (3, 0), (1, 3)] {
        let packed = settings(10, spp, max_depth, 0.2);
        let single = Settings {
            bounces: Bounces::SingleRays,
            ..packed
        };
        let stream = Settings {
            bounces: Bounces::Stream,
            ..packed
        };
        let a = render_image(&geom, &camera, &materials, &packed);
        let b = render_image(&geom, &camera, &materials, &single);
        assert!(
            a == b,
            "spp {spp}, max_depth {max_depth}: the images differ"
        );
        // A wavefront of paths whose rays go as streams: the same image again.
        let e = render_image(&geom, &camera, &materials, &stream);
        assert!(
            e == b,
            "stream, spp {spp}, max_depth {max_depth}: the images differ"
        );
        // The same in watertight mode: packets and single rays agree there too.
        let tight = Settings {
            mode: Mode::Watertight,
            ..packed
        };
        let tight_single = Settings {
            mode: Mode::Watertight,
            ..single
        };
        let tight_stream = Settings {
            mode: Mode::Watertight,
            ..stream
        };
        let c = render_image(&geom, &camera, &materials, &tight);
        let d = render_image(&geom, &camera, &materials, &tight_single);
        let f = render_image(&geom, &camera, &materials, &tight_stream);
        assert!(
            c == d && f == d,
            "watertight, spp {spp}, max_depth {max_depth}: the images differ"
        );
        if max_depth > 0 {
            // Not a vacuous comparison: light, sky and shadow all show.
            let lum: Vec<f32> = a.iter().map(|p| p.x + p.y + p.z).collect();
            let (lo, hi) = lum
                .iter()
                .fold((f32::MAX, 0.0f32), |(lo, hi), &l| (lo.min(l), hi.max(l)));
            assert!(hi > 2.0 * lo && hi > 0.0, "a flat image: {lo} .. {hi}");
        }
    }
}
