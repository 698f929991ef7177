//! What a firmware or WASM target reads besides the scene: the render description (its round trip
//! from a scene file, its validation against corruption and against another scene), the bytes →
//! words view, and the shared sRGB conversion.

use glam::Vec3;
use kdray::scene::{CameraDesc, SceneFile};
use kdray_core::Scene;
use kdray_core::camera::{Camera, Fisheye, Pinhole};
use kdray_core::color::{rgba8, srgb8};
use kdray_core::description::{
    AnyCamera, DescError, Description, MAX_MATERIALS, camera_kind, header,
};
use kdray_core::render::{self, Bounces, Material};
use kdray_core::sampling::Pcg32;
use kdray_core::words::{self, Aligned, WordsError};
use kdray_tests::strategies::scene_words;
use std::path::Path;

/// A small room of inline triangles with a mirror and a glass ball (six materials, a two-triangle
/// ceiling light, 512×512 at 64 spp, a pinhole): the firmware's triangles-only scene with the
/// balls of the first default scene, small enough to parse hundreds of times in a debug test.
const ROOM: &str = concat!(
    include_str!("../../targets/cortex-m4f/scenes/triangles.toml"),
    "
[[sphere]]
center = [-0.45, 0.35, -0.3]
radius = 0.35
material = \"mirror\"

[[sphere]]
center = [0.45, 0.35, 0.25]
radius = 0.35
material = \"glass\"
"
);

fn room_file() -> SceneFile {
    SceneFile::from_toml_str(ROOM, Path::new("room.toml")).unwrap()
}

/// The room built, and its description.
fn room() -> (SceneFile, Vec<u32>, Vec<u32>) {
    let file = room_file();
    let words = scene_words(&file.geometry().unwrap(), 80.0);
    let desc = kdray::description::encode(&file, &words, 1).unwrap();
    (file, words, desc)
}

#[test]
fn a_scene_files_description_round_trips() {
    let (file, words, desc) = room();
    let scene = Scene::from_words(&words).unwrap();
    let d = Description::from_words(&desc, &scene, &words).unwrap();
    let s = d.settings();
    let r = &file.render;
    assert_eq!((s.width, s.height, s.spp, s.max_depth), (512, 512, 64, 8));
    assert_eq!((r.width, r.height, r.spp, r.max_depth), (512, 512, 64, 8));
    assert_eq!((s.background, s.seed), (Vec3::ZERO, 1));
    let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
    assert_eq!(d.materials(), &materials[..]);
    // The room's only emitter is the two-triangle ceiling light.
    assert_eq!(d.lights().len(), 2);
    let mut lights = [0; 8];
    assert_eq!(render::emitters(&scene, &materials, &mut lights), 2);
    assert_eq!(d.lights(), &lights[..2]);
    let CameraDesc::Pinhole {
        eye,
        target,
        up,
        vfov,
    } = file.camera
    else {
        panic!("the room has a pinhole camera");
    };
    let pinhole = Pinhole::look_at(eye.into(), target.into(), up.into(), vfov).unwrap();
    assert_eq!(d.camera::<Pinhole>(), Ok(pinhole));
    assert_eq!(d.camera::<AnyCamera>(), Ok(AnyCamera::Pinhole(pinhole)));
    assert_eq!(
        d.camera::<Fisheye>(),
        Err(DescError::WrongCamera {
            kind: camera_kind::PINHOLE
        })
    );
}

#[test]
fn every_camera_kind_round_trips() {
    let cameras = [
        r#"kind = "fisheye"
origin = [0, 1, 3]
phi = [-100, -90, -80]
theta = [80, 90, 100]"#,
        r#"kind = "parallel"
origin = [0, 1, 3]
phi = 90
theta = 180
horizontal = [-1, 0, 1]
vertical = [-1, 0, 1]"#,
        r#"kind = "thick_lens"
eye = [0, 1, 3]
target = [0, 1, 0]
vfov = 30
aperture = 0.02
focus = 3"#,
        r#"kind = "lens_array"
eye = [0, 1, 3]
target = [0, 1, 0]
size = [0.4, 0.4]
pitch = [0.05, 0.05]
gap = 0.05"#,
    ];
    let kinds = [
        camera_kind::FISHEYE,
        camera_kind::PARALLEL,
        camera_kind::THICK_LENS,
        camera_kind::LENS_ARRAY,
    ];
    // A two-sided light, whose flag travels in the material's kind word.
    let light =
        "[[material]]\nname = \"l\"\nkind = \"emissive\"\nemission = [1, 1, 1]\ntwo_sided = true\n";
    for (camera, kind) in cameras.iter().zip(kinds) {
        let text =
            format!("[camera]\n{camera}\n{light}[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n");
        let file = SceneFile::from_toml_str(&text, Path::new("cam.toml")).unwrap();
        let words = scene_words(&file.geometry().unwrap(), 80.0);
        let scene = Scene::from_words(&words).unwrap();
        let desc = kdray::description::encode(&file, &words, 9).unwrap();
        let d = Description::from_words(&desc, &scene, &words).unwrap();
        assert_eq!(d.camera_kind(), kind);
        assert_eq!(d.settings().seed, 9);
        let any = d.camera::<AnyCamera>().unwrap();
        let host = file.camera().unwrap();
        for (x, y) in [(0.5, 0.5), (10.25, 3.75), (511.5, 511.5)] {
            assert_eq!(any.ray(x, y, 512, 512), host.ray(x, y, 512, 512));
            // The same lens points from the same random numbers.
            let (mut a, mut b) = (Pcg32::new(3, 4), Pcg32::new(3, 4));
            let sample = any.sample(x, y, 512, 512, &mut a);
            assert_eq!(sample, host.sample(x, y, 512, 512, &mut b));
            assert!(
                sample.is_some(),
                "{kind}: the sample at ({x}, {y}) is dropped"
            );
        }
        assert!(d.materials()[0].two_sided);
        assert_eq!(d.materials()[0], file.materials[0].to_core());
        assert_eq!(d.camera::<Pinhole>(), Err(DescError::WrongCamera { kind }));
    }
}

#[test]
fn rendering_through_the_description_is_rendering_the_scene_file() {
    let (file, words, desc) = room();
    let scene = Scene::from_words(&words).unwrap();
    let d = Description::from_words(&desc, &scene, &words).unwrap();
    let mut settings = d.settings();
    (settings.width, settings.height, settings.spp) = (12, 12, 2);
    settings.bounces = Bounces::SingleRays;
    let mut via_desc = vec![[0.0f32; 3]; 144];
    let camera = d.camera::<AnyCamera>().unwrap();
    render::render_rows(
        &scene,
        &camera,
        d.materials(),
        d.lights(),
        &settings,
        0,
        &mut via_desc,
    )
    .unwrap();
    let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    settings.bounces = Bounces::Packets;
    let mut direct = vec![[0.0f32; 3]; 144];
    let host_camera = file.camera().unwrap();
    render::render_rows(
        &scene,
        &host_camera,
        &materials,
        &lights,
        &settings,
        0,
        &mut direct,
    )
    .unwrap();
    let bits = |px: &[[f32; 3]]| px.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&via_desc), bits(&direct));
    assert!(direct.iter().flatten().any(|&c| c > 0.0), "a lit image");
}

#[test]
fn header_corruption_is_named() {
    let (_, words, desc) = room();
    let scene = Scene::from_words(&words).unwrap();
    let parse = |d: &[u32]| Description::from_words(d, &scene, &words).map(|_| ());
    let with = |i: usize, v: u32| {
        let mut d = desc.clone();
        d[i] = v;
        d
    };
    assert_eq!(parse(&desc), Ok(()));
    assert_eq!(parse(&desc[..10]), Err(DescError::TooShort));
    assert_eq!(parse(&with(header::MAGIC, 0)), Err(DescError::BadMagic));
    assert_eq!(
        parse(&with(header::VERSION, 7)),
        Err(DescError::UnsupportedVersion(7))
    );
    assert_eq!(
        parse(&desc[..desc.len() - 1]),
        Err(DescError::LengthMismatch {
            header: desc.len() as u32,
            actual: desc.len() - 1
        })
    );
    assert_eq!(
        parse(&with(header::SCENE_HASH, 1)),
        Err(DescError::OtherScene)
    );
    assert_eq!(
        parse(&with(header::SCENE_WORDS, 5)),
        Err(DescError::OtherScene)
    );
    for (i, v) in [
        (header::WIDTH, 0),
        (header::HEIGHT, 0),
        (header::SPP, 0),
        (header::SPP, (1 << 20) + 1),
        (header::MAX_DEPTH, 1025),
        (header::BACKGROUND, (-1.0f32).to_bits()),
        (header::BACKGROUND + 2, f32::NAN.to_bits()),
    ] {
        assert_eq!(
            parse(&with(i, v)),
            Err(DescError::BadSettings),
            "word {i} = {v}"
        );
    }
    // 2¹³ × 2¹⁴ pixels is more than 2²⁶.
    let mut big = with(header::WIDTH, 1 << 13);
    big[header::HEIGHT] = 1 << 14;
    assert_eq!(parse(&big), Err(DescError::BadSettings));
    assert_eq!(
        parse(&with(header::CAMERA_WORDS, 33)),
        Err(DescError::BadCamera)
    );
}

#[test]
fn materials_and_lights_are_checked_against_the_scene() {
    let (_, words, desc) = room();
    let scene = Scene::from_words(&words).unwrap();
    let parse = |d: &[u32]| Description::from_words(d, &scene, &words).map(|_| ());
    let n_camera = desc[header::CAMERA_WORDS] as usize;
    let count_at = 16 + n_camera;
    let first = count_at + 1;
    let with = |i: usize, v: u32| {
        let mut d = desc.clone();
        d[i] = v;
        d
    };
    assert_eq!(desc[count_at], 6, "the room's six materials");
    assert_eq!(
        parse(&with(first, 4)),
        Err(DescError::BadMaterial { index: 0 })
    );
    let albedo_2 = first + 8 + 1;
    assert_eq!(
        parse(&with(albedo_2, 1.5f32.to_bits())),
        Err(DescError::BadMaterial { index: 1 })
    );
    let ior_3 = first + 2 * 8 + 7;
    assert_eq!(
        parse(&with(ior_3, 0.0f32.to_bits())),
        Err(DescError::BadMaterial { index: 2 })
    );
    let emission_4 = first + 3 * 8 + 4;
    assert_eq!(
        parse(&with(emission_4, f32::INFINITY.to_bits())),
        Err(DescError::BadMaterial { index: 3 })
    );
    assert_eq!(
        parse(&with(count_at, MAX_MATERIALS as u32 + 1)),
        Err(DescError::TooManyMaterials)
    );
    // The light list: the two ceiling triangles, then nothing.
    let lights_at = first + 6 * 8;
    assert_eq!(desc[lights_at], 2);
    let (a, b) = (desc[lights_at + 1], desc[lights_at + 2]);
    assert!(a < b);
    let swapped = {
        let mut d = with(lights_at + 1, b);
        d[lights_at + 2] = a;
        d
    };
    assert_eq!(parse(&swapped), Err(DescError::BadLights));
    assert_eq!(parse(&with(lights_at + 2, a)), Err(DescError::BadLights));
    // One light dropped (and the length fixed up): no longer every emitter.
    let mut short = desc[..desc.len() - 1].to_vec();
    short[lights_at] = 1;
    short[header::TOTAL_WORDS] -= 1;
    assert_eq!(parse(&short), Err(DescError::BadLights));
    // A non-emitter added.
    let extra = (0..scene.prim_count())
        .find(|p| *p != a && *p != b)
        .unwrap();
    let mut long = desc.clone();
    long.push(extra);
    long[lights_at] = 3;
    long[header::TOTAL_WORDS] += 1;
    assert_eq!(parse(&long), Err(DescError::BadLights));
    // The light material made dark: its triangles are no longer lights.
    let light_material = first + 3 * 8;
    let mut dark = desc.clone();
    for k in 4..7 {
        dark[light_material + k] = 0;
    }
    assert_eq!(parse(&dark), Err(DescError::BadLights));
}

#[test]
fn no_truncation_or_word_flip_panics() {
    let (_, words, desc) = room();
    let scene = Scene::from_words(&words).unwrap();
    for n in 0..desc.len() {
        assert!(Description::from_words(&desc[..n], &scene, &words).is_err());
    }
    for i in 0..desc.len() {
        for v in [
            0,
            1,
            0xFFFF_FFFF,
            0x8000_0000,
            f32::NAN.to_bits(),
            desc.len() as u32,
        ] {
            let mut d = desc.clone();
            d[i] = v;
            if let Ok(d) = Description::from_words(&d, &scene, &words) {
                let _ = d.camera::<AnyCamera>();
            }
        }
    }
}

#[test]
fn a_description_is_refused_for_another_scene() {
    let (_, words, desc) = room();
    let text = "[camera]\nkind = \"pinhole\"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n\
                [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";
    let file = SceneFile::from_toml_str(text, Path::new("ball.toml")).unwrap();
    let other = scene_words(&file.geometry().unwrap(), 80.0);
    let scene = Scene::from_words(&other).unwrap();
    assert_eq!(
        Description::from_words(&desc, &scene, &other).map(|_| ()),
        Err(DescError::OtherScene)
    );
    // The same scene rebuilt (another BUILD_MS) still matches.
    let mut rebuilt = words.clone();
    rebuilt[kdray_core::format::header::BUILD_MS] = 123.5f32.to_bits();
    kdray_core::format::seal(&mut rebuilt);
    assert_ne!(rebuilt, words);
    let scene = Scene::from_words(&rebuilt).unwrap();
    assert!(Description::from_words(&desc, &scene, &rebuilt).is_ok());
}

#[test]
fn the_framing_description_looks_at_the_scene() {
    let (_, words, _) = room();
    let scene = Scene::from_words(&words).unwrap();
    let d = Description::framing(&scene);
    assert!(d.materials().is_empty() && d.lights().is_empty());
    let camera = d.camera::<Pinhole>().unwrap();
    let s = d.settings();
    // The centre pixel's ray hits the room.
    let ray = camera.ray(256.0, 256.0, s.width, s.height);
    assert!(scene.intersect(&ray).is_hit());
    assert_eq!(s.background, Vec3::ONE);
}

#[test]
fn bytes_view_as_words_only_when_aligned_and_whole() {
    static BYTES: Aligned<[u8; 12]> = Aligned([1, 0, 0, 0, 2, 0, 0, 0, 0xff, 0xff, 0xff, 0xff]);
    assert_eq!(words::from_bytes(&BYTES.0), Ok(&[1u32, 2, u32::MAX][..]));
    assert_eq!(words::from_bytes(&BYTES.0[..0]), Ok(&[][..]));
    assert_eq!(
        words::from_bytes(&BYTES.0[..7]),
        Err(WordsError::OddLength { bytes: 7 })
    );
    assert_eq!(
        words::from_bytes(&BYTES.0[1..9]),
        Err(WordsError::Misaligned)
    );
    assert_eq!(
        words::from_bytes(&BYTES.0[4..12]),
        Ok(&[2u32, u32::MAX][..])
    );
    let embedded = kdray_core::include_words!("../../host/scenes/default.toml");
    assert_eq!(embedded.as_ptr() as usize % 4, 0);
}

#[test]
fn srgb_transfer_hits_its_anchor_points() {
    assert_eq!(srgb8(0.0), 0);
    assert_eq!(srgb8(1.0), 255);
    assert_eq!(srgb8(2.0), 255);
    assert_eq!(srgb8(-1.0), 0);
    assert_eq!(srgb8(f32::NAN), 0);
    // Linear 0.5 is sRGB 0.7354 (188 of 255); 0.0031308 is the knee, 0.04045 in sRGB (10).
    assert_eq!(srgb8(0.5), 188);
    assert_eq!(srgb8(0.003_130_8), 10);
    assert_eq!(rgba8([2.0, 1.0, 0.0], 2.0), [255, 188, 0, 255]);
}

#[test]
fn the_kernel_a_target_names_renders_what_render_rows_does() {
    use kdray_core::traverse::{Mixed, Spheres, Triangles};
    // The room without its balls: triangles only.
    let mut file = room_file();
    file.spheres.clear();
    let words = scene_words(&file.geometry().unwrap(), 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let desc = kdray::description::encode(&file, &words, 3).unwrap();
    let d = Description::from_words(&desc, &scene, &words).unwrap();
    let camera = d.camera::<Pinhole>().unwrap();
    let mut s = d.settings();
    (s.width, s.height, s.spp, s.bounces) = (10, 10, 2, Bounces::SingleRays);
    let (m, l) = (d.materials(), d.lights());
    let mut images = [[[0.0f32; 3]; 100]; 4];
    render::render_rows(&scene, &camera, m, l, &s, 0, &mut images[0]).unwrap();
    render::render_rows_with::<Triangles, _, false>(&scene, &camera, m, l, &s, 0, &mut images[1])
        .unwrap();
    render::render_rows_with::<Mixed, _, true>(&scene, &camera, m, l, &s, 0, &mut images[2])
        .unwrap();
    // Single rays whatever the settings say.
    s.bounces = Bounces::Packets;
    render::render_rows_with::<Triangles, _, false>(&scene, &camera, m, l, &s, 0, &mut images[3])
        .unwrap();
    let bits = |px: &[[f32; 3]]| px.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
    for image in &images[1..] {
        assert_eq!(bits(&images[0]), bits(image));
    }
    assert!(render::kernel_fits::<Triangles>(&scene) && render::kernel_fits::<Mixed>(&scene));
    assert!(!render::kernel_fits::<Spheres>(&scene));
    let (_, room_words, _) = room();
    let room = Scene::from_words(&room_words).unwrap();
    assert!(!render::kernel_fits::<Triangles>(&room) && render::kernel_fits::<Mixed>(&room));
    assert!(images[0].iter().flatten().any(|&c| c > 0.0));
}
