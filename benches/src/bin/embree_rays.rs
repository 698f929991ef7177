//! `embree-rays MESH RAYS [--repeat N] [--packet 1|8 | --stream]`: Embree 3 over a kdray rays
//! file, one thread, for the same-ray comparison with `kdray trace MESH --rays RAYS --threads 1`
//! and for profiling both under one tool (callgrind, with a build for `x86-64-v3`: valgrind
//! reports no AVX-512, so Embree takes its AVX2 kernels there as kdray does).
//!
//! The call is `rtcIntersect1` by default, `rtcIntersect8` over 8 consecutive rays a packet with
//! `--packet 8`, and the stream call `rtcIntersect1M` with the coherent hint with `--stream`: the
//! `compare` table's rows "Embree `rtcIntersect1`", "`rtcIntersect8`" and "`rtcIntersect1M`,
//! coherent" ([`EmbreeScene`](kdray_benches::peer_embree::EmbreeScene)'s `trace1_into`,
//! `trace8_into`, `trace1m_into`).
//!
//! Prints one line in `kdray trace`'s style: `build_ms`, the median `mrays_s` over `--repeat`
//! runs (default 5), `rays`, `hits`, the call, and Embree's version. Needs the `embree` feature
//! (`cargo run --release -p kdray-benches --features embree --bin embree-rays -- …`).
//!
//! Exit codes: 0 done, 1 a mesh or rays file that cannot be read, or an Embree error, 2 a usage
//! error.

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: embree-rays MESH RAYS [--repeat N] [--packet 1|8 | --stream]";

/// Which Embree call traces the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Call {
    /// `rtcIntersect1`, one ray a call.
    One,
    /// `rtcIntersect8`, 8 consecutive rays a packet.
    Eight,
    /// `rtcIntersect1M` with the coherent hint.
    StreamCoherent,
}

// Read only by the Embree run: without the `embree` feature the binary reports that and stops.
#[cfg_attr(not(feature = "embree"), allow(dead_code))]
impl Call {
    fn name(self) -> &'static str {
        match self {
            Call::One => "rtcIntersect1",
            Call::Eight => "rtcIntersect8",
            Call::StreamCoherent => "rtcIntersect1M_coherent",
        }
    }
}

#[cfg_attr(not(feature = "embree"), allow(dead_code))]
struct Args {
    mesh: PathBuf,
    rays: PathBuf,
    repeat: usize,
    call: Call,
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let (mut paths, mut repeat) = (Vec::new(), 5usize);
    let (mut packet, mut stream) = (None, false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--packet" => {
                let v = args.next().ok_or("--packet needs a value")?;
                packet = Some(match v.as_str() {
                    "1" => Call::One,
                    "8" => Call::Eight,
                    _ => return Err(format!("--packet: expected 1 or 8, got '{v}'")),
                });
            }
            "--stream" => stream = true,
            "--repeat" => {
                let v = args.next().ok_or("--repeat needs a value")?;
                repeat = v
                    .parse()
                    .ok()
                    .filter(|&n| n >= 1)
                    .ok_or(format!("--repeat: expected an integer >= 1, got '{v}'"))?;
            }
            s if s.starts_with('-') => return Err(format!("unknown option '{s}'")),
            _ => paths.push(PathBuf::from(a)),
        }
    }
    let call = match (packet, stream) {
        (Some(_), true) => return Err("--packet and --stream exclude each other".into()),
        (Some(call), false) => call,
        (None, true) => Call::StreamCoherent,
        (None, false) => Call::One,
    };
    match <[PathBuf; 2]>::try_from(paths) {
        Ok([mesh, rays]) => Ok(Args {
            mesh,
            rays,
            repeat,
            call,
        }),
        Err(_) => Err("expected a mesh and a rays file".into()),
    }
}

#[cfg(feature = "embree")]
fn run(args: &Args) -> Result<(), String> {
    use kdray_benches::peer_embree::{Coherence, EmbreeDevice};
    use kdray_core::Hit;
    use std::time::Instant;
    let geom = kdray::load::load_mesh(&args.mesh).map_err(|e| e.to_string())?;
    let rays = kdray::rays::read_rays(&args.rays).map_err(|e| e.to_string())?;
    let device = EmbreeDevice::new().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let scene = device.build(&geom.triangles).map_err(|e| e.to_string())?;
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut hits = vec![Hit::MISS; rays.len()];
    let mut rates: Vec<f64> = (0..args.repeat)
        .map(|_| {
            hits.fill(Hit::MISS);
            let start = Instant::now();
            match args.call {
                Call::One => scene.trace1_into(&rays, &mut hits),
                Call::Eight => scene.trace8_into(&rays, &mut hits),
                Call::StreamCoherent => scene.trace1m_into(&rays, &mut hits, Coherence::Coherent),
            }
            rays.len() as f64 / start.elapsed().as_secs_f64() / 1e6
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    let hit_count = hits.iter().filter(|h| h.t.is_finite()).count();
    println!(
        "build_ms={build_ms:.3} mrays_s={:.3} rays={} hits={hit_count} tracer={} threads=1 \
         embree={}",
        rates[rates.len() / 2],
        rays.len(),
        args.call.name(),
        device.version()
    );
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
            eprintln!("embree-rays: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("embree-rays: {e}");
            ExitCode::FAILURE
        }
    }
}
