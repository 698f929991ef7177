//! `embree-rays MESH RAYS [--repeat N]`: Embree 3's `rtcIntersect1` over a kdray rays file, one
//! thread, for the same-ray comparison with `kdray trace MESH --rays RAYS --threads 1` and for
//! profiling both under one tool (callgrind, with a build for `x86-64-v3`: valgrind reports no
//! AVX-512, so Embree takes its AVX2 kernels there as kdray does).
//!
//! Prints one line in `kdray trace`'s style: `build_ms`, the median `mrays_s` over `--repeat`
//! runs (default 5), `rays`, `hits`, and Embree's version. Needs the `embree` feature
//! (`cargo run --release -p kdray-benches --features embree --bin embree-rays -- …`).
//!
//! Exit codes: 0 done, 1 a mesh or rays file that cannot be read, or an Embree error, 2 a usage
//! error.

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: embree-rays MESH RAYS [--repeat N]";

fn parse(mut args: impl Iterator<Item = String>) -> Result<(PathBuf, PathBuf, usize), String> {
    let (mut paths, mut repeat) = (Vec::new(), 5usize);
    while let Some(a) = args.next() {
        match a.as_str() {
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
    match <[PathBuf; 2]>::try_from(paths) {
        Ok([mesh, rays]) => Ok((mesh, rays, repeat)),
        Err(_) => Err("expected a mesh and a rays file".into()),
    }
}

#[cfg(feature = "embree")]
fn run(mesh: &std::path::Path, rays: &std::path::Path, repeat: usize) -> Result<(), String> {
    use kdray_benches::peer_embree::EmbreeDevice;
    use kdray_core::Hit;
    use std::time::Instant;
    let geom = kdray::load::load_mesh(mesh).map_err(|e| e.to_string())?;
    let rays = kdray::rays::read_rays(rays).map_err(|e| e.to_string())?;
    let device = EmbreeDevice::new().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let scene = device.build(&geom.triangles).map_err(|e| e.to_string())?;
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut hits = vec![Hit::MISS; rays.len()];
    let mut rates: Vec<f64> = (0..repeat)
        .map(|_| {
            hits.fill(Hit::MISS);
            let start = Instant::now();
            scene.trace1_into(&rays, &mut hits);
            rays.len() as f64 / start.elapsed().as_secs_f64() / 1e6
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    let hit_count = hits.iter().filter(|h| h.t.is_finite()).count();
    println!(
        "build_ms={build_ms:.3} mrays_s={:.3} rays={} hits={hit_count} tracer=rtcIntersect1 \
         threads=1 embree={}",
        rates[rates.len() / 2],
        rays.len(),
        device.version()
    );
    Ok(())
}

#[cfg(not(feature = "embree"))]
fn run(_: &std::path::Path, _: &std::path::Path, _: usize) -> Result<(), String> {
    Err("built without the `embree` feature (scripts/bench-setup.sh installs Embree 3)".into())
}

fn main() -> ExitCode {
    let (mesh, rays, repeat) = match parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("embree-rays: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&mesh, &rays, repeat) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("embree-rays: {e}");
            ExitCode::FAILURE
        }
    }
}
