//! A scene rendered into a buffer of your own: the built-in default scene (`kdray render`
//! without a scene file) at 64×48 pixels, 16 samples per pixel, through the core's render kernel
//! (`kdray_core::render::render_rows`, the same pixels `kdray render --bounces packets` computes),
//! printed as characters. Run with `cargo run --release -p kdray --example render_buffer`.

use kdray::build::{BuildParams, build};
use kdray::flat;
use kdray::scene::SceneFile;
use kdray_core::Scene;
use kdray_core::render::{self, Bounces, Material, Settings};
use kdray_core::traverse::Mode;

fn main() -> Result<(), Box<dyn core::error::Error>> {
    // The host loads the scene (camera, materials, geometry) and builds its tree ...
    let file = SceneFile::default_scene();
    let geom = file.geometry()?;
    let words = flat::serialize(&build(&geom, &BuildParams::default(), None)?, &geom, 0.0)?;
    let camera = file.camera()?;
    let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();

    // ... and from here on it is what a firmware or a web page does with the core alone: check
    // the words, list the lights, render rows into a caller's buffer.
    let scene = Scene::from_words(&words).map_err(|e| e.to_string())?;
    let mut lights = vec![0u32; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);
    let settings = Settings {
        width: 64,
        height: 48,
        spp: 16,
        max_depth: file.render.max_depth,
        background: file.render.background.into(),
        seed: 1,
        bounces: Bounces::Packets,
        mode: Mode::Fast,
    };
    // Linear RGB, row-major; any number of whole rows can be rendered at a time (here all).
    let mut pixels = vec![[0.0f32; 3]; (settings.width * settings.height) as usize];
    render::render_rows(
        &scene,
        &camera,
        &materials,
        &lights,
        &settings,
        0,
        &mut pixels,
    )
    .map_err(|e| e.to_string())?;

    // Two rows of pixels per character (terminal cells are about twice as tall as wide).
    let ramp = b" .:-=+*#%@";
    for y in (0..settings.height as usize).step_by(2) {
        let line: String = (0..settings.width as usize)
            .map(|x| {
                let [r, g, b] = pixels[y * settings.width as usize + x];
                let luminance = 0.2126 * r + 0.7152 * g + 0.0722 * b;
                // sRGB-like compression, so that the dim walls are not all blank.
                let level = luminance.clamp(0.0, 1.0).powf(1.0 / 2.2);
                ramp[(level * (ramp.len() - 1) as f32).round() as usize] as char
            })
            .collect();
        println!("{line}");
    }
    let mean: f32 = pixels
        .iter()
        .map(|p| p.iter().sum::<f32>() / 3.0)
        .sum::<f32>()
        / pixels.len() as f32;
    println!(
        "{}x{}, {} spp, mean radiance {mean:.3}, {} lights",
        settings.width,
        settings.height,
        settings.spp,
        lights.len()
    );
    Ok(())
}
