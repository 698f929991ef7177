//! `kdray render`: builds a scene's tree, path-traces it with the core's render kernel on all
//! cores in passes (kdray::progressive) until a sample count, a time or a noise level is reached,
//! and writes an 8-bit sRGB PNG or a linear EXR (the whole image, or one band of rows with
//! `--tile K/N`), then prints one summary line.

use super::build::build_words;
use super::with_progress;
use super::{MAX_PIXELS, parse_size, parse_threads, pool};
use core::ops::Range;
use core::sync::atomic::{AtomicU64, Ordering};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use kdray::error::{Error, Result};
use kdray::image::{self, Band, Format};
use kdray::progressive::{self, Plan, Stats, Stop};
use kdray::scene::{SceneCamera, SceneFile, load_scene};
use kdray_core::Scene;
use kdray_core::instance::InstancedScene;
use kdray_core::render::{self, Bounces, Frame, InstanceLight, InstancedFrame, Material, Settings};
use kdray_core::traverse::Mode;
use kdray_core::words::Fnv1a;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a render holds per pixel at its peak, with a margin: the film's sums (32 bytes) and
/// sample count (4), the pass plan's counts (4) and, adaptive, the per-pixel deviations and
/// weights (16), then the mean image (12) and its encoding (at most 12): 80, rounded up.
pub(crate) const RENDER_BYTES_PER_PIXEL: u64 = 96;

/// The most samples per pixel and surface hits per path a render accepts.
pub(crate) const MAX_SPP: u32 = 1 << 20;
const MAX_DEPTH: u32 = 1024;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A scene file (.toml, see docs/SCENE.md); without one, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// The image to write: .png (8-bit sRGB) or .exr (linear f32 RGB). Default: named after the
    /// scene file, in the current directory (`host/scenes/thick_lens.toml` → `thick_lens.png`;
    /// with --tile K/N, `thick_lens-K.exr`); without a scene, `render.png`.
    #[arg(short, long, value_name = "OUT")]
    pub out: Option<PathBuf>,
    /// Samples per pixel (default: the scene's `[render] spp`, unless --seconds or --noise is
    /// given; with them, a cap).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SPP)))]
    pub spp: Option<u32>,
    /// Render passes of 8 samples per pixel until this many seconds are spent.
    #[arg(long, value_parser = parse_positive)]
    pub seconds: Option<f64>,
    /// Render passes until the estimated relative RMSE of the image (from the per-pixel sample
    /// variance) is below this, e.g. 0.01.
    #[arg(long, value_parser = parse_positive)]
    pub noise: Option<f64>,
    /// After two even passes, spend every other pass's samples where the per-pixel variance is
    /// (n ∝ σ) instead of evenly (README, "Error against run time": about 13 % lower RMSE at equal
    /// time on the glass scene, 3–4 % on evenly noisy ones). Not with --tile: each band would
    /// place its samples by its own variance, so the merged bands would not be the whole render's
    /// image.
    #[arg(long, conflicts_with = "tile")]
    pub adaptive: bool,
    /// Image size WxH (default: the scene's `[render] width, height`).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Worker threads (default: all cores; at most 16 per core).
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Seed of the samples' random numbers: the same seed gives the same image, whatever the
    /// thread count.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How bounce and shadow rays are traced: `stream` (a row's paths advance as one wavefront,
    /// each round's rays one ray stream; the fastest measured, docs/BENCHMARKS.md), `packets` (a
    /// pixel's samples advance together as 8-wide packets) or `single` (each ray through the
    /// scalar walk). Same image every way.
    #[arg(long, value_enum, default_value_t = BouncesArg::Stream)]
    pub bounces: BouncesArg,
    /// Render only the K-th of N bands of rows (K from 1), written as .exr; `kdray merge`
    /// assembles the bands. With --spp, its pixels are those of the whole render.
    #[arg(long, value_name = "K/N", value_parser = parse_tile)]
    pub tile: Option<(u32, u32)>,
    /// Also print `checksum=` of the image's linear pixels (FNV-1a of their f32 bits, the
    /// checksum the firmware in targets/cortex-m4f prints).
    #[arg(long)]
    pub checksum: bool,
}

/// `--bounces`: the CLI's names for [`Bounces`].
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum BouncesArg {
    Packets,
    Single,
    Stream,
}

/// Parses a finite number greater than 0.
fn parse_positive(s: &str) -> core::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a number greater than 0, got '{s}'")),
    }
}

/// Parses `K/N` with `1 ≤ K ≤ N`.
fn parse_tile(s: &str) -> core::result::Result<(u32, u32), String> {
    let parsed = s
        .split_once('/')
        .and_then(|(k, n)| Some((k.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((k, n)) if (1..=n).contains(&k) => Ok((k, n)),
        _ => Err(format!("expected K/N with 1 <= K <= N, got '{s}'")),
    }
}

/// Band `k` (from 1) of `n` of an image `height` rows tall: rows `⌊(k−1)h/n⌋..⌊kh/n⌋`.
pub fn tile_rows(k: u32, n: u32, height: u32) -> Range<u32> {
    let edge = |i: u32| (u64::from(i) * u64::from(height) / u64::from(n)) as u32;
    edge(k - 1)..edge(k)
}

/// A scene's trees: one, or (a scene with `[[instance]]` entries) one per mesh under a top level.
pub(crate) enum Built {
    Single {
        words: Vec<u32>,
        lights: Vec<u32>,
    },
    Instanced {
        /// One tree per mesh (`InstancedGeometry::bottoms`), then the top level's words.
        bottoms: Vec<Vec<u32>>,
        top: Vec<u32>,
        lights: Vec<InstanceLight>,
    },
}

/// What `kdray render`'s line counts ([`Prepared::counts`]).
pub(crate) struct Counts {
    pub triangles: u64,
    pub spheres: u64,
    /// Copies and meshes, for a scene with instances.
    pub instanced: Option<(u32, usize)>,
}

/// A scene loaded, built and ready to render: what `render` and `converge` share.
pub(crate) struct Prepared {
    pub file: SceneFile,
    pub built: Built,
    /// Reading the scene file and its meshes and assembling the geometry, in ms.
    pub load_ms: f64,
    /// Making the tree, in ms: the build, its serialization and validation, the lights.
    pub build_ms: f64,
    pub camera: SceneCamera,
    pub materials: Vec<Material>,
}

impl Prepared {
    /// Loads `scene` (or the default scene), builds its tree and finds its lights.
    pub fn load(scene: Option<&Path>) -> Result<Self> {
        let start = Instant::now();
        let file = match scene {
            Some(path) => load_scene(path)?,
            None => SceneFile::default_scene(),
        };
        let read_ms = ms_since(start);
        let mut prepared = Self::from_file(file)?;
        prepared.load_ms += read_ms;
        Ok(prepared)
    }

    /// Builds `file`'s tree (or trees) and finds its lights.
    pub fn from_file(file: SceneFile) -> Result<Self> {
        if file.has_instances() {
            return Self::instanced(file);
        }
        let start = Instant::now();
        let camera = file.camera()?;
        let geom = file.geometry()?;
        let load_ms = ms_since(start);
        let start = Instant::now();
        let words = build_tree(&file.path, &geom)?;
        let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
        let scene = Scene::from_words(&words).map_err(|e| Error::new(&file.path, e.to_string()))?;
        let mut lights = vec![0; render::emitters(&scene, &materials, &mut [])];
        render::emitters(&scene, &materials, &mut lights);
        Ok(Self {
            file,
            built: Built::Single { words, lights },
            load_ms,
            build_ms: ms_since(start),
            camera,
            materials,
        })
    }

    /// A scene with instances: one tree per mesh, the top level over the copies, their lights.
    fn instanced(file: SceneFile) -> Result<Self> {
        let start = Instant::now();
        let camera = file.camera()?;
        let geom = file.instanced_geometry()?;
        let load_ms = ms_since(start);
        let start = Instant::now();
        let bottoms = geom
            .bottoms
            .iter()
            .map(|g| build_tree(&file.path, g))
            .collect::<Result<Vec<_>>>()?;
        let scenes = bottom_scenes(&file.path, &bottoms)?;
        let top = kdray::instances::top_level(&scenes, &geom.placements)
            .map_err(|msg| Error::new(&file.path, format!("[[instance]]: {msg}")))?;
        let materials: Vec<Material> = file.materials.iter().map(|m| m.to_core()).collect();
        let top_scene = InstancedScene::from_words(&top, &scenes)
            .map_err(|e| Error::new(&file.path, e.to_string()))?;
        let mut lights = vec![
            InstanceLight {
                instance: 0,
                prim: 0
            };
            render::instanced_emitters(&top_scene, &materials, &mut [])
        ];
        render::instanced_emitters(&top_scene, &materials, &mut lights);
        Ok(Self {
            file,
            built: Built::Instanced {
                bottoms,
                top,
                lights,
            },
            load_ms,
            build_ms: ms_since(start),
            camera,
            materials,
        })
    }

    /// The triangles and spheres the image shows, every copy's counted (`triangles=`,
    /// `spheres=`), and for an instanced scene its copies and meshes (`instances=`, `meshes=`).
    pub fn counts(&self) -> Result<Counts> {
        let path = &self.file.path;
        match &self.built {
            Built::Single { words, .. } => {
                let s = Scene::from_words(words).map_err(|e| Error::new(path, e.to_string()))?;
                Ok(Counts {
                    triangles: s.tri_count().into(),
                    spheres: s.sphere_count().into(),
                    instanced: None,
                })
            }
            Built::Instanced { bottoms, top, .. } => {
                let scenes = bottom_scenes(path, bottoms)?;
                let top = InstancedScene::from_words(top, &scenes)
                    .map_err(|e| Error::new(path, e.to_string()))?;
                let (mut tris, mut spheres) = (0u64, 0u64);
                for i in 0..top.instance_count() {
                    let b = top.bottom_of(i);
                    (tris, spheres) = (
                        tris + u64::from(b.tri_count()),
                        spheres + u64::from(b.sphere_count()),
                    );
                }
                Ok(Counts {
                    triangles: tris,
                    spheres,
                    instanced: Some((top.instance_count(), bottoms.len())),
                })
            }
        }
    }

    /// Renders `plan` with `settings` on `pool`, with a progress bar.
    pub fn render(
        &self,
        settings: &Settings,
        plan: &Plan,
        pool: &rayon::ThreadPool,
    ) -> Result<(progressive::Film, Stats)> {
        self.render_with(settings, plan, pool, true)
    }

    /// [`Prepared::render`]; without its progress bar when `show_bar` is false (`converge` shows
    /// one bar for all its renders).
    pub fn render_with(
        &self,
        settings: &Settings,
        plan: &Plan,
        pool: &rayon::ThreadPool,
        show_bar: bool,
    ) -> Result<(progressive::Film, Stats)> {
        let done = AtomicU64::new(0);
        let pixels = u64::from(settings.width) * plan.rows.len() as u64;
        let bar = match (plan.stop.seconds, plan.stop.noise) {
            (None, None) => ProgressBar::new(pixels * u64::from(plan.stop.spp)),
            _ => ProgressBar::no_length(),
        };
        // Hidden before anything is set: a message or style set first would draw once.
        if !show_bar {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        bar.set_message(format!("rendering {}", self.file.path.display()));
        let template = if bar.length().is_some() {
            "{msg} [{bar:30}] {percent}% {elapsed} (eta {eta})"
        } else {
            "{msg} {spinner} {pos} samples {elapsed}"
        };
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        let path = &self.file.path;
        let result = match &self.built {
            Built::Single { words, lights } => {
                let scene =
                    Scene::from_words(words).map_err(|e| Error::new(path, e.to_string()))?;
                let frame = Frame {
                    scene: &scene,
                    camera: &self.camera,
                    materials: &self.materials,
                    lights,
                    settings,
                };
                run_frame(&frame, plan, &done, &bar, pool)
            }
            Built::Instanced {
                bottoms,
                top,
                lights,
            } => {
                let scenes = bottom_scenes(path, bottoms)?;
                let scene = InstancedScene::from_words(top, &scenes)
                    .map_err(|e| Error::new(path, e.to_string()))?;
                let frame = InstancedFrame {
                    scene: &scene,
                    camera: &self.camera,
                    materials: &self.materials,
                    lights,
                    settings,
                };
                run_frame(&frame, plan, &done, &bar, pool)
            }
        };
        let (film, stats) = result.map_err(|e| Error::new(&self.file.path, e.to_string()))?;
        match film.overflowed() {
            0 => Ok((film, stats)),
            n => Err(Error::new(
                &self.file.path,
                format!(
                    "the radiance of {n} pixels overflowed f32 (their sums of samples passed \
                     3.4e38): no image is written; lower the emission or background"
                ),
            )),
        }
    }
}

impl RenderArgs {
    /// The image `render` writes: `-o`, or a name after the scene (see `--out`'s help).
    pub fn out_path(&self) -> PathBuf {
        if let Some(out) = &self.out {
            return out.clone();
        }
        let stem = self
            .scene
            .as_deref()
            .and_then(Path::file_stem)
            .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
        match self.tile {
            Some((k, _)) => PathBuf::from(format!("{stem}-{k}.exr")),
            None => PathBuf::from(format!("{stem}.png")),
        }
    }
}

/// `geom`'s tree as `kdray render` builds it: wide nodes, and triangle groups where the scene
/// has no spheres (the bounce and shadow rays that the stream cannot trace as packets walk them
/// one by one, docs/BENCHMARKS.md, "Wide nodes").
fn build_tree(path: &Path, geom: &kdray::Geometry) -> Result<Vec<u32>> {
    let leaves = kdray::flat::Leaves::for_host(geom);
    let params = leaves.build_params();
    let (words, _, _) = build_words(path, geom, &params, kdray::flat::Layout::Wide, leaves)?;
    Ok(words)
}

/// [`progressive::render`] of `frame` on `pool`, `bar` showing the samples done.
fn run_frame<F: progressive::Pixels>(
    frame: &F,
    plan: &Plan,
    done: &AtomicU64,
    bar: &ProgressBar,
    pool: &rayon::ThreadPool,
) -> core::result::Result<(progressive::Film, Stats), render::RenderError> {
    with_progress(
        bar,
        || done.load(Ordering::Relaxed),
        || pool.install(|| progressive::render(frame, plan, done)),
    )
}

/// The bottom scenes of an instanced scene, validated.
fn bottom_scenes<'a>(path: &Path, bottoms: &'a [Vec<u32>]) -> Result<Vec<Scene<'a>>> {
    bottoms
        .iter()
        .map(|w| Scene::from_words(w).map_err(|e| Error::new(path, e.to_string())))
        .collect()
}

/// Milliseconds since `start`.
fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

pub fn render(args: &RenderArgs) -> Result<()> {
    let start = Instant::now();
    let out = args.out_path();
    let format = Format::of(&out)?;
    if args.tile.is_some() && format != Format::Exr {
        return Err(Error::new(
            &out,
            "--tile writes a band of rows, which needs an .exr output",
        ));
    }
    let inputs: Vec<&Path> = args.scene.iter().map(PathBuf::as_path).collect();
    kdray::files::check_outputs(&inputs, &[&out])?;
    let prepared = Prepared::load(args.scene.as_deref())?;
    let file = &prepared.file;
    let settings = settings(file, args)?;
    let pool = pool(&file.path, args.threads)?;
    let rows = match args.tile {
        Some((k, n)) if n > settings.height => {
            let msg = format!(
                "--tile {k}/{n}: the image has only {} rows",
                settings.height
            );
            return Err(Error::new(&file.path, msg));
        }
        Some((k, n)) => tile_rows(k, n, settings.height),
        None => 0..settings.height,
    };
    let pixels = u64::from(settings.width) * rows.len() as u64;
    kdray::memory::ensure(
        &out,
        pixels * RENDER_BYTES_PER_PIXEL,
        &format!("a {}x{} render", settings.width, rows.len()),
        &format!("images up to {MAX_PIXELS} pixels are accepted, memory permitting"),
    )?;
    let timed = args.seconds.is_some() || args.noise.is_some();
    let plan = Plan {
        rows,
        stop: Stop {
            spp: if timed {
                args.spp.unwrap_or(MAX_SPP)
            } else {
                settings.spp
            },
            seconds: args.seconds,
            noise: args.noise,
        },
        adaptive: args.adaptive,
    };
    let (film, stats) = prepared.render(&settings, &plan, &pool)?;
    let band = Band {
        width: settings.width,
        height: settings.height,
        first_row: plan.rows.start,
        pixels: film.mean(),
    };
    let written = Instant::now();
    image::write(&out, &band)?;
    let write_ms = ms_since(written);
    let Counts {
        triangles,
        spheres,
        instanced,
    } = prepared.counts()?;
    let checksum = match args.checksum {
        true => {
            let mut h = Fnv1a::default();
            h.pixels(&band.pixels);
            format!(" checksum={:08x}", h.0)
        }
        false => String::new(),
    };
    println!(
        "wrote {}: {}x{}{}, {} spp, {:.2} s, {:.2} Mrays/s, est. RMSE {:.4} (relative {:.4}), \
         passes={} max_depth={} triangles={triangles} spheres={spheres} threads={} load_ms={:.1} \
         build_ms={:.1} render_ms={:.1} write_ms={:.1} total_ms={:.1}{checksum}{}",
        out.display(),
        settings.width,
        settings.height,
        match args.tile {
            Some((k, n)) => format!(
                " rows {}..{} (tile {k}/{n})",
                plan.rows.start, plan.rows.end
            ),
            None => String::new(),
        },
        spp_text(stats.mean_spp),
        stats.seconds,
        stats.rays as f64 / stats.seconds.max(1e-9) / 1e6,
        stats.rmse,
        stats.rel_rmse,
        stats.passes,
        settings.max_depth,
        pool.current_num_threads(),
        prepared.load_ms,
        prepared.build_ms,
        stats.seconds * 1e3,
        write_ms,
        ms_since(start),
        match instanced {
            Some((copies, meshes)) => format!(" instances={copies} meshes={meshes}"),
            None => String::new(),
        },
    );
    Ok(())
}

/// Samples per pixel as a whole number when it is one (uniform sampling), else to one decimal.
fn spp_text(spp: f64) -> String {
    if spp.fract() == 0.0 {
        format!("{spp}")
    } else {
        format!("{spp:.1}")
    }
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
            BouncesArg::Stream => Bounces::Stream,
        },
        mode: if r.watertight {
            Mode::Watertight
        } else {
            Mode::Fast
        },
    })
}
