//! The `kdray` command line. The contract (subcommands, flags, output line, exit codes) is fixed by
//! DESIGN.md: input errors print `FILE[:LINE]: message` and exit 1, usage errors exit 2.

mod commands;

use clap::{CommandFactory, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "kdray",
    version,
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
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Build a kd-tree from a mesh (.ply, .ply.gz, .obj, .tri) or a scene (.toml) into a .kdt file.
    Build {
        input: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        /// Also write the scene's render description (camera, settings, materials, lights) for
        /// firmware and WASM targets, e.g. SCENE.kdr (needs a .toml scene; extension of the
        /// contract).
        #[arg(long)]
        description: Option<PathBuf>,
        #[command(flatten)]
        build: commands::BuildArgs,
    },
    /// Print statistics of a .kdt file.
    Info { file: PathBuf },
    /// Trace a rays file through a scene (a .kdt or anything `build` accepts) and write the hits.
    Trace(commands::TraceArgs),
    /// Write a benchmark ray set (extension of the contract): primary rays of the framing camera
    /// in 2x4 tiles, or one cosine-weighted diffuse bounce from each primary hit.
    Rays {
        input: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        #[arg(long, value_enum, default_value_t = commands::RayKind::Primary)]
        kind: commands::RayKind,
        /// Image size WxH of the primary rays.
        #[arg(long, default_value = "1024x1024", value_parser = commands::parse_size)]
        size: (u32, u32),
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
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
        Command::Accuracy(args) => commands::accuracy(&args),
        Command::Trace(args) => commands::trace(&args),
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
