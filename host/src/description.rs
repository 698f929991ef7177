//! The render description a target reads next to a scene's words (the layout is documented in
//! `kdray_core::description`): written by `kdray build SCENE.toml -o SCENE.kdt --description
//! SCENE.kdr` from the scene file's camera, `[render]` table and materials, and the light list the
//! core's [`render::emitters`] finds in the built scene.

use crate::error::{Error, Result};
use crate::scene::{CameraDesc, SceneFile};
use kdray_core::Scene;
use kdray_core::description::{
    self as desc, AnyCamera, Description, HEADER_WORDS, MAX_MATERIALS, camera_kind, header,
    material_words,
};
use kdray_core::render::{self, Material};

/// The render description of `file`, built into `scene_words`, with the samples' `seed`; checked
/// by the core's own parser before it is returned.
///
/// # Errors
/// More materials than a description holds ([`MAX_MATERIALS`]), or settings the core refuses.
pub fn encode(file: &SceneFile, scene_words: &[u32], seed: u64) -> Result<Vec<u32>> {
    let scene =
        Scene::from_words(scene_words).map_err(|e| Error::new(&file.path, e.to_string()))?;
    if file.materials.len() > MAX_MATERIALS {
        let msg = format!(
            "{} materials: a render description holds at most {MAX_MATERIALS}",
            file.materials.len()
        );
        return Err(Error::new(&file.path, msg));
    }
    let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);

    let r = &file.render;
    let camera = camera_words(&file.camera);
    let mut words = vec![0u32; HEADER_WORDS];
    words[header::MAGIC] = desc::MAGIC;
    words[header::VERSION] = desc::VERSION;
    words[header::SCENE_WORDS] = scene_words.len() as u32;
    words[header::SCENE_HASH] = desc::scene_hash(scene_words);
    words[header::WIDTH] = r.width;
    words[header::HEIGHT] = r.height;
    words[header::SPP] = r.spp;
    words[header::MAX_DEPTH] = r.max_depth;
    for (k, c) in r.background.iter().enumerate() {
        words[header::BACKGROUND + k] = c.to_bits();
    }
    words[header::SEED_LO] = seed as u32;
    words[header::SEED_HI] = (seed >> 32) as u32;
    words[header::CAMERA_KIND] = camera.0;
    words[header::CAMERA_WORDS] = camera.1.len() as u32;
    words.extend(&camera.1);
    words.push(materials.len() as u32);
    words.extend(materials.iter().flat_map(material_words));
    words.push(lights.len() as u32);
    words.extend(&lights);
    words[header::TOTAL_WORDS] = words.len() as u32;
    Description::from_words(&words, &scene, scene_words)
        .map_err(|e| Error::new(&file.path, format!("render description: {e}")))?;
    Ok(words)
}

/// CAMERA_KIND and the parameter words of a scene file's camera.
fn camera_words(camera: &CameraDesc) -> (u32, Vec<u32>) {
    let (kind, floats): (u32, Vec<f32>) = match camera {
        CameraDesc::Pinhole {
            eye,
            target,
            up,
            vfov,
        } => (
            camera_kind::PINHOLE,
            [*eye, *target, *up, [*vfov, 0.0, 0.0]].concat()[..10].to_vec(),
        ),
        CameraDesc::Fisheye { origin, phi, theta } => {
            (camera_kind::FISHEYE, [*origin, *phi, *theta].concat())
        }
        CameraDesc::Parallel {
            origin,
            phi,
            theta,
            horizontal,
            vertical,
        } => (
            camera_kind::PARALLEL,
            [&origin[..], &[*phi, *theta], horizontal, vertical].concat(),
        ),
        CameraDesc::ThickLens {
            eye,
            target,
            up,
            vfov,
            lens,
            ..
        } => {
            // The focus resolved into the sensor distance (NaN, which the core's check refuses,
            // for a camera that does not build: load_scene has refused it already).
            let sensor = match camera.build() {
                Ok(AnyCamera::ThickLens(c)) => c.sensor_distance(),
                _ => f32::NAN,
            };
            let tail = [
                *vfov, lens[0], lens[1], lens[2], lens[3], lens[4], lens[5], sensor,
            ];
            (
                camera_kind::THICK_LENS,
                [&eye[..], target, up, &tail].concat(),
            )
        }
        CameraDesc::LensArray {
            eye,
            target,
            up,
            size,
            pitch,
            gap,
        } => (
            camera_kind::LENS_ARRAY,
            [&eye[..], target, up, size, pitch, &[*gap]].concat(),
        ),
    };
    (kind, floats.iter().map(|f| f.to_bits()).collect())
}
