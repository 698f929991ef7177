//! The `kdray` command line. Its contract (subcommands, flags, output line, exit codes) is in
//! docs/FORMATS.md: input errors print `FILE[:LINE]: message` and exit 1, usage errors exit 2.

mod commands;
#[cfg(test)]
mod help_tests;

use clap::{CommandFactory, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::LazyLock;

/// `kdray --version`: the version, the instruction set the build uses and the CPU's
/// (`kdray::cpu::describe`).
static VERSION: LazyLock<String> =
    LazyLock::new(|| format!("{} {}", env!("CARGO_PKG_VERSION"), kdray::cpu::describe()));

#[derive(Parser)]
#[command(
    name = "kdray",
    version = VERSION.as_str(),
    about = "Build, inspect and trace SAH kd-trees for the kdray core"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Path-trace a scene (.toml; without one, the built-in default scene) into a PNG or EXR
    Render(commands::RenderArgs),
    /// Measure error against run time: RMSE at doubling sample counts against an analytic (the
    /// built-in white furnace) or a long reference render; a CSV, a log-log plot and the slope.
    Converge(commands::ConvergeArgs),
    /// Assemble the row bands written by `render --tile K/N` into one image (.png or .exr).
    Merge {
        /// The bands (.exr), in any order; together they must cover every row exactly once.
        #[arg(required = true, value_name = "PART.exr")]
        parts: Vec<PathBuf>,
        /// The whole image to write: .png (8-bit sRGB) or .exr (linear f32 RGB).
        #[arg(short, long, value_name = "OUT")]
        out: PathBuf,
    },
    /// Build a kd-tree from a mesh (.ply, .ply.gz, .obj, .tri) or a scene (.toml) into a .kdt file.
    Build {
        /// The mesh (.ply, .ply.gz, .obj, .tri: one u32 count, then 9 f32 per triangle) or scene
        /// file (.toml, docs/SCENE.md) to build the tree of.
        input: PathBuf,
        /// The tree to write, in the flat format (.kdt; `kdray info` prints its statistics).
        #[arg(short, long, value_name = "OUT.kdt")]
        out: PathBuf,
        /// Also write the scene's render description (camera, settings, materials, lights) for
        /// firmware and WASM targets, e.g. SCENE.kdr (needs a .toml scene).
        #[arg(long, value_name = "OUT.kdr")]
        description: Option<PathBuf>,
        #[command(flatten)]
        build: commands::BuildArgs,
    },
    /// Print statistics of a .kdt file.
    Info {
        /// The tree file (.kdt) written by `kdray build`.
        #[arg(value_name = "FILE.kdt")]
        file: PathBuf,
    },
    /// Trace a rays file through a scene (a .kdt or anything `build` accepts) and write the hits.
    Trace(commands::TraceArgs),
    /// Write a benchmark ray set for `kdray trace`: the primary rays of a framing camera, one per
    /// pixel of a WxH image (default 1024x1024: 1,048,576 rays), or one diffuse bounce from each
    /// primary hit.
    ///
    /// The framing camera is a pinhole with a 45° vertical field of view, on the +z side of the
    /// scene's bounding box, looking along −z at its centre, far enough back that the box's
    /// bounding sphere fills the view; it does not use a scene file's [camera]. Rays are written
    /// in 2x4-pixel tiles (8 consecutive rays are one tile, for 4- and 8-wide packets).
    Rays {
        /// The scene: a .kdt, or anything `build` accepts (built first).
        input: PathBuf,
        /// The rays file to write: n × 8 little-endian f32 (origin xyz, direction xyz, tmin, tmax).
        #[arg(short, long, value_name = "RAYS.bin")]
        out: PathBuf,
        /// `primary`: the framing camera's rays, one per pixel; `diffuse`: from each primary
        /// ray's hit, one cosine-weighted bounce about the surface normal (misses give no ray, so
        /// there are fewer).
        #[arg(long, value_enum, default_value_t = commands::RayKind::Primary)]
        kind: commands::RayKind,
        /// Image size WxH of the primary rays (the number of primary rays is W·H).
        #[arg(long, default_value = "1024x1024", value_parser = commands::parse_size)]
        size: (u32, u32),
        /// Seed of the random bounce directions of `--kind diffuse` (the same seed gives the same
        /// rays; primary rays have no randomness).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Print a hits file (written by `kdray trace`) as text, one line per ray:
    /// `INDEX t=T prim=P u=U v=V`, or `INDEX miss` for a miss (stored as t = inf,
    /// prim = 0xFFFFFFFF).
    Hits(commands::HitsArgs),
    /// Measure every intersection kernel (Möller–Trumbore, sphere; scalar, 4- and 8-wide; f64
    /// references) on the same ray sets: ns per test against the error of t and false misses/hits.
    /// Prints a table, writes it as CSV and a scatter plot (PNG, next to the CSV).
    Accuracy(commands::AccuracyArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => commands::render(&args),
        Command::Converge(args) => commands::converge(&args),
        Command::Merge { parts, out } => commands::merge(&parts, &out),
        Command::Build {
            input,
            out,
            description,
            build,
        } => {
            let is_toml = input
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
            if description.is_some() && !is_toml {
                Cli::command()
                    .error(
                        clap::error::ErrorKind::ArgumentConflict,
                        "--description needs a scene file (.toml) as INPUT",
                    )
                    .exit();
            }
            commands::build(&input, &out, description.as_deref(), &build)
        }
        Command::Info { file } => commands::info(&file),
        Command::Hits(args) => commands::hits(&args),
        Command::Accuracy(args) => commands::accuracy(&args),
        Command::Trace(args) => {
            if args.stream && args.packet == 16 {
                Cli::command()
                    .error(
                        clap::error::ErrorKind::ArgumentConflict,
                        "--stream takes packets of 1, 4 or 8 rays (--packet 16 traces \
                         consecutive rays without the stream)",
                    )
                    .exit();
            }
            commands::trace(&args)
        }
        Command::Rays {
            input,
            out,
            kind,
            size,
            seed,
        } => commands::rays(&input, &out, kind, size, seed),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kdray: {e}");
            ExitCode::from(1)
        }
    }
}
