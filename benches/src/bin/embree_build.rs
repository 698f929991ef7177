//! `embree-build MESH [--quality medium|high] [--threads N] [--repeat N]`: Embree 3's build of a
//! mesh (one triangle geometry, `rtcCommitScene`), timed as `kdray build` times its own, for the
//! build-speed comparison of docs/BUILD.md:
//!
//! ```sh
//! kdray build data/dragon.tri --serial-build --quality fast -o fast.kdt   # build_ms, cpu_ms
//! embree-build data/dragon.tri --quality medium                            # the same fields
//! ```
//!
//! Each of `--repeat` runs (default 3) builds on a new device of `--threads` threads (default
//! 1, Embree's `threads=N`), and prints one line: `build_ms` (wall time of the vertex and index
//! buffers and the commit), `cpu_ms` (the process's CPU time over the same span, to the
//! kernel's 10 ms tick: on a busy machine a serial build's CPU time varies less than its wall
//! time), `triangles`, `quality`, `threads` and Embree's version. Needs the `embree` feature
//! (`cargo run --release -p kdray-benches --features embree --bin embree-build -- …`).
//!
//! Exit codes: 0 done, 1 a mesh that cannot be read or an Embree error, 2 a usage error.

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: embree-build MESH [--quality medium|high] [--threads N] [--repeat N]";

// Without the `embree` feature `run` only reports that Embree is missing, reading no field.
#[cfg_attr(not(feature = "embree"), allow(dead_code))]
struct Args {
    mesh: PathBuf,
    high: bool,
    threads: usize,
    repeat: usize,
}

fn count(name: &str, v: Option<String>) -> Result<usize, String> {
    let v = v.ok_or(format!("{name} needs a value"))?;
    v.parse()
        .ok()
        .filter(|&n| n >= 1)
        .ok_or(format!("{name}: expected an integer >= 1, got '{v}'"))
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let (mut meshes, mut high, mut threads, mut repeat) = (Vec::new(), true, 1, 3);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quality" => {
                high = match args.next().as_deref() {
                    Some("high") => true,
                    Some("medium") => false,
                    other => {
                        return Err(format!(
                            "--quality: expected medium or high, got '{}'",
                            other.unwrap_or("")
                        ));
                    }
                }
            }
            "--threads" => threads = count("--threads", args.next())?,
            "--repeat" => repeat = count("--repeat", args.next())?,
            s if s.starts_with('-') => return Err(format!("unknown option '{s}'")),
            _ => meshes.push(PathBuf::from(a)),
        }
    }
    match <[PathBuf; 1]>::try_from(meshes) {
        Ok([mesh]) => Ok(Args {
            mesh,
            high,
            threads,
            repeat,
        }),
        Err(_) => Err("expected one mesh".into()),
    }
}

#[cfg(feature = "embree")]
fn run(a: &Args) -> Result<(), String> {
    use kdray_benches::peer_embree::{EmbreeDevice, Quality};
    use std::time::Instant;
    let geom = kdray::load::load_mesh(&a.mesh).map_err(|e| e.to_string())?;
    let (quality, name) = if a.high {
        (Quality::High, "high")
    } else {
        (Quality::Medium, "medium")
    };
    for _ in 0..a.repeat {
        let device = EmbreeDevice::with_config(&format!("threads={}", a.threads))
            .map_err(|e| e.to_string())?;
        let (start, cpu) = (Instant::now(), kdray::cpu::process_ms());
        let scene = device
            .build_at(&geom.triangles, quality)
            .map_err(|e| e.to_string())?;
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let cpu_ms = cpu.zip(kdray::cpu::process_ms()).map(|(a, b)| b - a);
        drop(scene);
        println!(
            "build_ms={build_ms:.1} cpu_ms={} triangles={} quality={name} threads={} embree={}",
            cpu_ms.map_or("-".into(), |c| format!("{c:.0}")),
            geom.triangles.len(),
            a.threads,
            device.version()
        );
    }
    Ok(())
}

#[cfg(not(feature = "embree"))]
fn run(_: &Args) -> Result<(), String> {
    Err("built without the `embree` feature (scripts/bench-setup.sh installs Embree 3)".into())
}

fn main() -> ExitCode {
    let args = match parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("embree-build: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("embree-build: {e}");
            ExitCode::FAILURE
        }
    }
}
