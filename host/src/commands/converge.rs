//! `kdray converge`: error against run time. Renders a scene at doubling sample counts, several
//! times each, and reports the median wall time and RMSE against a reference: the white
//! furnace's analytic radiance by default, otherwise a long render of the same scene with another
//! seed. Writes the CSV and a log-log plot next to it, and prints the fitted slopes.
//!
//! The machine may be shared, so one measurement is not trusted: the sample counts are measured
//! in rounds (each round renders every count once, adaptive right after uniform at each count,
//! so both see the same load), each round with its own seed, and the medians over the rounds are
//! reported and fitted. The reference render's own noise is taken out of each measured error:
//! `RMSE² = MSE(image, reference) − (the reference's estimated RMSE)²`, since the two renders'
//! errors are independent.

use super::render::{MAX_SPP, Prepared};
use super::{parse_size, pool};
use glam::Vec3;
use kdray::converge::{self, Point};
use kdray::error::{Error, Result};
use kdray::plot::{self, LogLog, Series};
use kdray::progressive::{Plan, Stats, Stop};
use kdray_core::render::{Bounces, Settings};
use kdray_core::traverse::Mode;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ConvergeArgs {
    /// A scene file (.toml); without one, the built-in white furnace (analytic reference).
    pub scene: Option<PathBuf>,
    /// The report to write (.csv); the plot goes next to it as .png.
    #[arg(short, long, value_name = "REPORT.csv")]
    pub out: PathBuf,
    /// The sample counts double from 2 until a render takes this many seconds.
    #[arg(long, default_value_t = 4.0, value_parser = parse_seconds)]
    pub seconds: f64,
    /// Renders per sample count; the medians are reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=99))]
    pub repeats: u32,
    /// Also measure adaptive sampling (`render --adaptive`) at the same sample counts.
    #[arg(long)]
    pub adaptive: bool,
    /// Image size WxH (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Worker threads (default: all cores; at most 16 per core).
    #[arg(long, value_parser = super::parse_threads)]
    pub threads: Option<usize>,
    /// The first round's seed; round r uses seed + r, the reference seed + 1000.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Parses `--seconds`: more than 0, at most an hour.
fn parse_seconds(s: &str) -> core::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 3600.0 => Ok(v),
        _ => Err(format!("expected seconds in (0, 3600], got '{s}'")),
    }
}

/// One measured render.
struct Run {
    mode: &'static str,
    spp: u32,
    image: Vec<[f32; 3]>,
    seconds: f64,
    mean_spp: f64,
}

impl Run {
    fn new(mode: &'static str, spp: u32, image: Vec<[f32; 3]>, stats: &Stats) -> Self {
        Self {
            mode,
            spp,
            image,
            seconds: stats.seconds,
            mean_spp: stats.mean_spp,
        }
    }
}

/// How many times the top sample count the reference render takes.
const REFERENCE_FACTOR: u32 = 16;

pub fn converge(args: &ConvergeArgs) -> Result<()> {
    let is_csv = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if !is_csv {
        return Err(Error::new(&args.out, "the report must be a .csv file"));
    }
    let png = args.out.with_extension("png");
    let inputs: Vec<&std::path::Path> = args.scene.iter().map(PathBuf::as_path).collect();
    kdray::files::check_outputs(&inputs, &[&args.out, &png])?;
    let file = match &args.scene {
        Some(path) => kdray::scene::load_scene(path)?,
        None => converge::furnace_scene(),
    };
    let prepared = Prepared::from_file(file)?;
    let file = &prepared.file;
    let (width, height) = args.size.unwrap_or((file.render.width, file.render.height));
    if u64::from(width) * u64::from(height) > super::MAX_PIXELS {
        return Err(Error::new(&file.path, "the image is too large"));
    }
    let pool = pool(&file.path, args.threads)?;
    // A render and the reference image kept beside it.
    kdray::memory::ensure(
        &file.path,
        u64::from(width) * u64::from(height) * 2 * super::render::RENDER_BYTES_PER_PIXEL,
        &format!("a {width}x{height} convergence run"),
        &format!(
            "images up to {} pixels are accepted, memory permitting",
            super::MAX_PIXELS
        ),
    )?;
    let settings = |seed: u64| Settings {
        width,
        height,
        spp: 1,
        max_depth: file.render.max_depth.min(1024),
        background: Vec3::from(file.render.background),
        seed,
        // The fastest way (docs/BENCHMARKS.md), the same image as every other.
        bounces: Bounces::Stream,
        mode: Mode::Fast,
    };
    let modes: &[&'static str] = if args.adaptive {
        &["uniform", "adaptive"]
    } else {
        &["uniform"]
    };
    let render_with = |spp: u32, seed: u64, adaptive: bool, show_bar: bool| {
        let plan = Plan {
            rows: 0..height,
            stop: Stop {
                spp,
                seconds: None,
                noise: None,
            },
            adaptive,
        };
        prepared.render_with(&settings(seed), &plan, &pool, show_bar)
    };
    let render = |spp: u32, seed: u64, adaptive: bool| render_with(spp, seed, adaptive, true);

    // Round 0 finds the sample counts: doubling until a render takes --seconds.
    let mut images: Vec<Run> = Vec::new();
    let mut counts = Vec::new();
    let mut spp = 2;
    loop {
        for &mode in modes {
            let (film, stats) = render(spp, args.seed, mode == "adaptive")?;
            images.push(Run::new(mode, spp, film.mean(), &stats));
        }
        counts.push(spp);
        let uniform_time = images
            .iter()
            .rev()
            .find(|i| i.mode == "uniform")
            .map_or(0.0, |i| i.seconds);
        eprintln!(
            "converge: round 1/{}: {spp} spp took {uniform_time:.3} s",
            args.repeats
        );
        if uniform_time >= args.seconds || spp * 2 * REFERENCE_FACTOR > MAX_SPP {
            break;
        }
        spp *= 2;
    }
    // The other rounds: one progress bar for all their renders, in samples (a render's time is
    // about proportional to them), so that its estimate of the time left holds.
    let per_round: u64 = counts.iter().map(|&c| u64::from(c)).sum::<u64>() * modes.len() as u64;
    let bar = indicatif::ProgressBar::new(per_round * u64::from(args.repeats - 1));
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {percent}% {elapsed} (eta {eta})",
        )
        .expect("valid template"),
    );
    for round in 1..args.repeats {
        bar.set_message(format!("converge: round {}/{}", round + 1, args.repeats));
        for &spp in &counts {
            for &mode in modes {
                let seed = args.seed + u64::from(round);
                let (film, stats) = render_with(spp, seed, mode == "adaptive", false)?;
                images.push(Run::new(mode, spp, film.mean(), &stats));
                bar.inc(u64::from(spp));
            }
        }
    }
    bar.finish_and_clear();

    // The reference and the error of each image against it.
    let max_spp = *counts.last().unwrap_or(&2);
    let (reference, ref_mse, reference_text) = if args.scene.is_none() {
        let m = &file.materials[0];
        let l = converge::furnace_radiance(
            f64::from(m.albedo[0]),
            f64::from(m.emission[0]),
            settings(0).max_depth,
        );
        let text = format!("analytic: the furnace's radiance {l:.6} in every pixel");
        (vec![[l as f32; 3]; (width * height) as usize], 0.0, text)
    } else {
        let spp = max_spp * REFERENCE_FACTOR;
        eprintln!("converge: reference render, {spp} spp");
        let (film, stats) = render(spp, args.seed + 1000, false)?;
        let text = format!(
            "a {spp} spp render with seed {} ({:.1} s, its estimated RMSE {:.3e} taken out)",
            args.seed + 1000,
            stats.seconds,
            stats.rmse
        );
        (film.mean(), stats.rmse * stats.rmse, text)
    };
    let mut points: Vec<Point> = Vec::new();
    for &spp in &counts {
        for &mode in modes {
            let runs: Vec<_> = images
                .iter()
                .filter(|i| i.mode == mode && i.spp == spp)
                .collect();
            points.push(Point {
                mode,
                spp: converge::median(&runs.iter().map(|i| i.mean_spp).collect::<Vec<_>>()),
                seconds: runs.iter().map(|i| i.seconds).collect(),
                rmse: runs
                    .iter()
                    .map(|i| {
                        (converge::mse(&i.image, &reference) - ref_mse)
                            .max(0.0)
                            .sqrt()
                    })
                    .collect(),
            });
        }
    }
    converge::write_csv(&args.out, &points)?;
    let series: Vec<Series> = modes
        .iter()
        .map(|&mode| Series {
            name: format!("{mode} (slope {})", figure(converge::slope(&points, mode))),
            points: points
                .iter()
                .filter(|p| p.mode == mode)
                .map(Point::medians)
                .collect(),
        })
        .collect();
    let title = format!(
        "{}: RMSE against render time, {width}x{height}",
        match &args.scene {
            Some(p) => p
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into()),
            None => "white furnace".into(),
        }
    );
    let plot = LogLog {
        title: &title,
        x_label: "seconds (median)",
        y_label: "RMSE (median)",
        series: &series,
        guide_slope: Some(-0.5),
    };
    if let Err(e) = plot::log_log(&png, &plot, (800, 560)) {
        eprintln!("kdray: warning: no plot: {e}");
    }

    println!("reference: {reference_text}");
    println!("mode      spp      seconds   RMSE");
    for p in &points {
        let (t, e) = p.medians();
        println!("{:<8} {:>6.1} {:>10.3} {:>10.4e}", p.mode, p.spp, t, e);
    }
    for &mode in modes {
        println!(
            "slope={} mode={mode} points={} repeats={} threads={} (an unbiased estimator gives -0.5)",
            figure(converge::slope(&points, mode)),
            counts.len(),
            args.repeats,
            pool.current_num_threads()
        );
    }
    println!("wrote {} and {}", args.out.display(), png.display());
    Ok(())
}

/// A fitted slope to 3 decimals, or `none` where there is none to fit (an RMSE of 0: a noiseless
/// image); never `NaN`.
fn figure(slope: f64) -> String {
    if slope.is_finite() {
        format!("{slope:.3}")
    } else {
        "none (an RMSE of 0 leaves no line to fit)".into()
    }
}
