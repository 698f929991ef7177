//! `kdray render`: builds a scene's tree, path-traces it with the core's render kernel on all
//! cores, and writes an 8-bit sRGB PNG.

use super::build::build_words;
use super::trace::{parse_size, pool};
use super::with_progress;
use core::sync::atomic::{AtomicU64, Ordering};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use kdray::build::BuildParams;
use kdray::error::{Error, Result};
use kdray::scene::{SceneFile, load_scene};
use kdray_core::Scene;
use kdray_core::color::srgb8;
use kdray_core::render::{self, Bounces, Material, Settings};
use kdray_core::words::Fnv1a;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The most pixels an image may have (as for `kdray rays`).
const MAX_PIXELS: u64 = 1 << 26;
/// The most samples per pixel and surface hits per path a render accepts.
const MAX_SPP: u32 = 1 << 20;
const MAX_DEPTH: u32 = 1024;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A scene file (.toml, see docs/SCENE.md); without one, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// The image to write (PNG, 8-bit sRGB).
    #[arg(short, long, default_value = "render.png")]
    pub out: PathBuf,
    /// Samples per pixel (default: the scene's `[render] spp`).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SPP)))]
    pub spp: Option<u32>,
    /// Image size WxH (default: the scene's `[render] width, height`).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the samples' random numbers: the same seed gives the same image, whatever the
    /// thread count.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How bounce and shadow rays are traced: `packets` (a pixel's samples advance together as
    /// 8-wide packets) or `single` (each ray through the scalar walk). Same image either way.
    #[arg(long, value_enum, default_value_t = BouncesArg::Packets)]
    pub bounces: BouncesArg,
    /// Also print `checksum=` of the image's linear pixels (FNV-1a of their f32 bits, the
    /// checksum the firmware in targets/cortex-m4f prints) (extension of the contract).
    #[arg(long)]
    pub checksum: bool,
}

/// `--bounces`: the CLI's names for [`Bounces`].
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum BouncesArg {
    Packets,
    Single,
}

pub fn render(args: &RenderArgs) -> Result<()> {
    let is_png = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png {
        return Err(Error::new(
            &args.out,
            "the output image must be a .png file",
        ));
    }
    let file = match &args.scene {
        Some(path) => load_scene(path)?,
        None => SceneFile::default_scene(),
    };
    let settings = settings(&file, args)?;
    let camera = file.camera()?;
    let geom = file.geometry()?;
    let (words, build_ms) = build_words(&file.path, &geom, &BuildParams::default())?;
    let scene = Scene::from_words(&words).map_err(|e| Error::new(&file.path, e.to_string()))?;
    let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
    let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
    render::emitters(&scene, &materials, &mut lights);

    let pool = pool(&file.path, args.threads)?;
    let (w, h) = (settings.width as usize, settings.height as usize);
    let mut pixels = vec![[0.0f32; 3]; w * h];
    let rows_done = AtomicU64::new(0);
    let bar = ProgressBar::new(h as u64).with_message(format!("rendering {}", file.path.display()));
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} rows {elapsed} (eta {eta})")
            .expect("valid template"),
    );
    let start = Instant::now();
    let result = with_progress(
        &bar,
        || rows_done.load(Ordering::Relaxed),
        || {
            pool.install(|| {
                pixels
                    .par_chunks_mut(w)
                    .enumerate()
                    .try_for_each(|(row, out)| {
                        let r = render::render_rows(
                            &scene, &camera, &materials, &lights, &settings, row as u32, out,
                        );
                        rows_done.fetch_add(1, Ordering::Relaxed);
                        r
                    })
            })
        },
    );
    result.map_err(|e| Error::new(&file.path, e.to_string()))?;
    let render_ms = start.elapsed().as_secs_f64() * 1e3;

    write_png(&args.out, &pixels, settings.width, settings.height)?;
    let checksum = match args.checksum {
        true => {
            let mut h = Fnv1a::default();
            h.pixels(&pixels);
            format!(" checksum={:08x}", h.0)
        }
        false => String::new(),
    };
    println!(
        "wrote {}: {}x{}, {} spp, max_depth {}, {} triangles, {} spheres, build_ms={build_ms:.1} \
         render_ms={render_ms:.1} threads={}{checksum}",
        args.out.display(),
        settings.width,
        settings.height,
        settings.spp,
        settings.max_depth,
        scene.tri_count(),
        scene.sphere_count(),
        pool.current_num_threads()
    );
    Ok(())
}

/// The scene's `[render]` table with the command line's overrides, checked against the limits.
fn settings(file: &SceneFile, args: &RenderArgs) -> Result<Settings> {
    let r = &file.render;
    let (width, height) = args.size.unwrap_or((r.width, r.height));
    let spp = args.spp.unwrap_or(r.spp);
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        let msg = format!("[render]: {width}x{height} is more than {MAX_PIXELS} pixels");
        return Err(Error::new(&file.path, msg));
    }
    if spp > MAX_SPP {
        let msg = format!("[render]: spp = {spp} is more than {MAX_SPP}");
        return Err(Error::new(&file.path, msg));
    }
    if r.max_depth > MAX_DEPTH {
        let msg = format!(
            "[render]: max_depth = {} is more than {MAX_DEPTH}",
            r.max_depth
        );
        return Err(Error::new(&file.path, msg));
    }
    Ok(Settings {
        width,
        height,
        spp,
        max_depth: r.max_depth,
        background: Vec3::from(r.background),
        seed: args.seed,
        bounces: match args.bounces {
            BouncesArg::Packets => Bounces::Packets,
            BouncesArg::Single => Bounces::SingleRays,
        },
    })
}

/// Writes linear RGB pixels as an 8-bit sRGB PNG.
fn write_png(path: &Path, pixels: &[[f32; 3]], width: u32, height: u32) -> Result<()> {
    let bytes: Vec<u8> = pixels.iter().flatten().map(|&c| srgb8(c)).collect();
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let png_error = |e: png::EncodingError| Error::new(path, format!("cannot write PNG: {e}"));
    let mut writer = encoder.write_header().map_err(png_error)?;
    writer.write_image_data(&bytes).map_err(png_error)?;
    writer.finish().map_err(png_error)
}
