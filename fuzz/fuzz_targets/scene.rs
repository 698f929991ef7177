//! The scene-file loader (`SceneFile::from_toml_str`, docs/SCENE.md) on arbitrary text: it must
//! return, never panic or hang. A scene it accepts must give a camera or a located error, and,
//! when it names no mesh file (the fuzzer's files are not on disk), geometry that builds into a
//! scene that validates ([`kdray_fuzz::build_and_validate`]); the camera's corner and centre
//! rays are then traced through it.
//!
//! Run: `cargo +nightly fuzz run scene fuzz/corpus/scene` (from `fuzz/`); seeds:
//! `fuzz/corpus/scene` (the repository's scene files).
#![no_main]

use kdray::scene::SceneFile;
use kdray_core::Scene;
use kdray_core::camera::Camera;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = core::str::from_utf8(data) else {
        return;
    };
    let Ok(file) = SceneFile::from_toml_str(text, Path::new("/nonexistent/fuzz.toml")) else {
        return;
    };
    let camera = file.camera();
    if !file.meshes.is_empty() {
        return;
    }
    let Ok(geom) = file.geometry() else {
        return;
    };
    if geom.triangles.is_empty() && geom.spheres.is_empty() {
        return;
    }
    let words = kdray_fuzz::build_and_validate("scene", &geom);
    let scene = Scene::from_words(&words).unwrap();
    if let Ok(camera) = camera {
        let (w, h) = (
            file.render.width.clamp(1, 64),
            file.render.height.clamp(1, 64),
        );
        for (x, y) in [
            (0, 0),
            (w - 1, 0),
            (0, h - 1),
            (w - 1, h - 1),
            (w / 2, h / 2),
        ] {
            let ray = camera.pixel_ray(x, y, w, h);
            let _ = scene.intersect(&ray);
            let _ = scene.occluded(&ray);
        }
    }
});
