//! `kdray trace` and `kdray rays`.

use super::build::{BuildArgs, load_scene_words};
use super::{parse_threads, pool};
use kdray::error::{Error, Result};
use kdray::{files, rays};
use kdray_core::simd::{f32x4, f32x8, f32x16};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Packets};
use kdray_core::{Hit, Ray, Scene};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `kdray trace`'s arguments.
#[derive(clap::Args, Debug)]
pub struct TraceArgs {
    /// A .kdt (read, not built: the line says `build_ms=0.000 prebuilt=1` and the build time
    /// stored in the file as `stored_build_ms=`), or anything `build` accepts (built first:
    /// `build_ms=` that build, `prebuilt=0`).
    pub input: PathBuf,
    /// The rays file (n × 8 little-endian f32: ox oy oz dx dy dz tmin tmax; `kdray rays` writes
    /// one). Directions must have length 1 (± 1e-3).
    #[arg(long, value_name = "RAYS.bin")]
    pub rays: PathBuf,
    /// The hits file to write: one per ray, in the rays' order, n × (f32 t, u32 prim, f32 u,
    /// f32 v) little-endian; prim is the primitive's index in the input (triangles first, then
    /// spheres), u, v the barycentrics (0 for a sphere). A miss is written as t = inf,
    /// prim = 0xFFFFFFFF, u = v = 0. `kdray hits FILE` prints it as text.
    #[arg(long, value_name = "HITS.bin")]
    pub out: PathBuf,
    /// Also write each hit's instance id: n × u32 little-endian, one per ray in the rays' order,
    /// 0xFFFFFFFF for a miss. For a scene file with [[instance]] entries the id is the copy's
    /// number (docs/SCENE.md, "Instances") and the hits file's prim the primitive's index in
    /// that copy's mesh; for a scene of one mesh every hit's id is 0. `kdray hits FILE
    /// --instances IDS.bin` prints them beside the hits.
    #[arg(long, value_name = "IDS.bin")]
    pub instances: Option<PathBuf>,
    /// Rays per packet: 1 (single rays), or 4, 8 or 16 consecutive rays traced together (16: one
    /// AVX-512 register a value, the fastest for camera rays where the build has AVX-512, see
    /// `kdray --version`; elsewhere two registers, slower than 8; not with `--stream`).
    #[arg(long, default_value_t = 1, value_parser = parse_packet)]
    pub packet: u32,
    /// Trace through the core's ray-stream API (`kdray_core::traverse::stream`): coherent runs as
    /// packets of `--packet` rays (1: no packets), the rest sorted by direction octant, origin and
    /// direction, its coherent runs as packets and the others as single rays (over the wide nodes
    /// when the tree has them). Hits are the same; the time includes the sorting.
    #[arg(long)]
    pub stream: bool,
    /// Retired in format 12 (the interleaved single-ray walks): a usage error that says so.
    #[arg(long, hide = true, value_parser = parse_in_flight)]
    pub in_flight: Option<u32>,
    /// Worker threads (default: all cores; at most 16 per core).
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Watertight mode: the watertight triangle test (Woop, Benthin & Wald 2013) and a
    /// conservative kd-tree walk, so no ray escapes a closed mesh through a seam
    /// (docs/ROBUSTNESS.md); slower than the default fast mode (README).
    #[arg(long)]
    pub watertight: bool,
    /// Trace this many times and report the fastest (1 to 1000: a bound on the run time).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// Also count, per ray, what the single-ray closest-hit walk does over the nodes in fast mode
    /// (interior steps, leaf visits, groups of four triangles and single primitives tested) and
    /// print it on a second line (one more untimed pass over the rays, on one thread).
    #[arg(long)]
    pub counts: bool,
    #[command(flatten)]
    pub build: BuildArgs,
}

/// Rays per parallel work item: large enough to amortize scheduling, small enough to balance.
pub(super) const CHUNK: usize = 4096;

/// How `kdray trace` traces: packets of consecutive rays, single rays, or the stream API.
#[derive(Clone, Copy, Debug)]
struct Tracer {
    packet: u32,
    stream: bool,
    mode: Mode,
}

/// Traces `rays` into `hits` (same length, pre-filled with misses).
fn trace_all(scene: &Scene, rays: &[Ray], hits: &mut [Hit], how: Tracer) {
    if how.stream {
        let (chunk, config) = stream_setup(rays.len(), how.mode, how.packet);
        hits.par_chunks_mut(chunk)
            .zip(rays.par_chunks(chunk))
            .for_each(|(h, r)| {
                let mut scratch = vec![0u64; stream::scratch_words(r.len())];
                // The lengths match by construction, so this cannot fail.
                let _ = stream::intersect(scene, &config, r, h, &mut scratch);
            });
        return;
    }
    let mode = how.mode;
    hits.par_chunks_mut(CHUNK)
        .zip(rays.par_chunks(CHUNK))
        .for_each(|(h, r)| match how.packet {
            4 => rays::trace_packets_in::<f32x4>(scene, mode, r, h),
            8 => rays::trace_packets_in::<f32x8>(scene, mode, r, h),
            16 => rays::trace_packets_in::<f32x16>(scene, mode, r, h),
            _ => rays::trace_scalar_in(scene, mode, r, h),
        });
}

/// `--stream`'s piece length and configuration for `n` rays: one stream per thread's share, in a
/// few pieces to balance (the longer the stream, the more coherent runs its sort finds), its
/// coherent runs as packets of `packet` rays (4 or 8; otherwise none).
pub(super) fn stream_setup(n: usize, mode: Mode, packet: u32) -> (usize, stream::Config) {
    let threads = rayon::current_num_threads().max(1);
    let chunk = n.div_ceil(4 * threads).max(CHUNK);
    let config = stream::Config {
        mode,
        packets: match packet {
            4 => Packets::Four,
            8 => Packets::Eight,
            _ => Packets::Off,
        },
        ..stream::Config::default()
    };
    (chunk, config)
}

/// Writes `ids` (one per ray) as n × u32 little-endian: the `--instances` file.
pub(super) fn write_instance_ids(path: &Path, ids: &[u32]) -> Result<()> {
    files::write_atomic_with(path, |w| {
        ids.iter()
            .try_for_each(|id| std::io::Write::write_all(w, &id.to_le_bytes()))
    })
}

pub fn trace(args: &TraceArgs) -> Result<()> {
    let outputs: Vec<&Path> = core::iter::once(args.out.as_path())
        .chain(args.instances.as_deref())
        .collect();
    files::check_outputs(&[&args.input, &args.rays], &outputs)?;
    let rays = rays::read_rays(&args.rays)?;
    if kdray::input::is_scene_file(&args.input) {
        let file = kdray::scene::load_scene(&args.input)?;
        if file.has_instances() {
            return super::trace_instanced::trace(args, &file, &rays);
        }
    }
    // The hits' memory (16 bytes a ray) is asked for before the scene is loaded or built.
    let mut hits = Vec::new();
    if hits.try_reserve_exact(rays.len()).is_err() {
        let msg = format!(
            "the hits of {} rays take {} of memory, which cannot be allocated here (out of \
             memory, or an address-space limit)",
            rays.len(),
            kdray::memory::mib((rays.len() * rays::HIT_BYTES) as u64)
        );
        return Err(Error::new(&args.rays, msg));
    }
    hits.resize(rays.len(), Hit::MISS);
    let (words, build_ms) = load_scene_words(&args.input, &args.build, &outputs)?;
    // Wide nodes on cache lines (see `flat::Aligned`).
    let words = kdray::flat::Aligned::new(&words);
    let scene = Scene::from_words(&words).map_err(|e| Error::new(&args.input, e.to_string()))?;
    kdray::reach::check_rays(&args.rays, &scene, &rays)?;
    let pool = pool(&args.input, args.threads)?;
    let mode = if args.watertight {
        Mode::Watertight
    } else {
        Mode::Fast
    };
    let how = Tracer {
        packet: args.packet,
        stream: args.stream,
        mode,
    };
    let mut best = f64::INFINITY;
    for _ in 0..args.repeat {
        let start = Instant::now();
        pool.install(|| {
            trace_all(&scene, &rays, &mut hits, how);
            hits.par_chunks_mut(CHUNK)
                .for_each(|h| rays::to_input_ids(&scene, h));
        });
        best = best.min(start.elapsed().as_secs_f64());
    }
    files::write_atomic_with(&args.out, |w| rays::write_hits(w, &hits))?;
    if let Some(path) = &args.instances {
        let ids: Vec<u32> = hits
            .iter()
            .map(|h| if h.is_hit() { 0 } else { Hit::MISS_PRIM })
            .collect();
        write_instance_ids(path, &ids)?;
    }
    let n_hits = hits.iter().filter(|h| h.is_hit()).count();
    let mrays = if best > 0.0 {
        rays.len() as f64 / best / 1e6
    } else {
        0.0
    };
    println!(
        "{} trace_ms={:.3} mrays_s={mrays:.3} rays={} hits={n_hits} packet={} isa={} threads={} mode={} stream={} layout={} leaves={}",
        build_keys(build_ms, &scene),
        best * 1e3,
        rays.len(),
        args.packet,
        kdray_core::isa::name(),
        pool.current_num_threads(),
        if args.watertight {
            "watertight"
        } else {
            "fast"
        },
        u8::from(args.stream),
        if scene.wide_nodes().is_empty() {
            "nodes"
        } else {
            "wide"
        },
        if scene.has_groups() { "groups" } else { "list" },
    );
    if args.counts {
        println!("{}", kdray::counts::count(&scene, &rays).per_ray());
    }
    Ok(())
}

/// Which ray set `kdray rays` writes.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// The framing pinhole camera's rays, in 2x4 pixel tiles.
    Primary,
    /// One cosine-weighted bounce from each primary hit.
    Diffuse,
}

/// Parses `--packet`: the packet widths this build traces.
pub fn parse_packet(s: &str) -> core::result::Result<u32, String> {
    match s {
        "1" => Ok(1),
        "4" => Ok(4),
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("packet width must be 1, 4, 8 or 16, got '{s}'")),
    }
}

/// Parses the retired `--in-flight`: always a usage error that says what replaces it.
pub fn parse_in_flight(_: &str) -> core::result::Result<u32, String> {
    Err(
        "--in-flight was retired in format 12 with the interleaved single-ray walks: \
         single rays (`--packet 1`, and the rays `--stream` leaves out of packets) walk the \
         wide nodes one after another (`kdray build --layout wide`, the default); drop the \
         option (docs/BENCHMARKS.md, \"Retired: blocks and interleaved walks\")"
            .to_string(),
    )
}

/// The line's first keys: what the build took now — `build_ms=` and `prebuilt=0` for a tree built
/// from the input, `build_ms=0.000 prebuilt=1` and the time stored in the file for a `.kdt`.
fn build_keys(built_ms: Option<f64>, scene: &Scene) -> String {
    match built_ms {
        Some(ms) => format!("build_ms={ms:.3} prebuilt=0"),
        None => format!(
            "build_ms=0.000 prebuilt=1 stored_build_ms={:.3}",
            scene.build_ms()
        ),
    }
}

pub fn rays(input: &Path, out: &Path, kind: RayKind, size: (u32, u32), seed: u64) -> Result<()> {
    files::check_outputs(&[input], &[out])?;
    let (words, _) = load_scene_words(input, &BuildArgs::default(), &[out])?;
    let scene = Scene::from_words(&words).map_err(|e| Error::new(input, e.to_string()))?;
    let [lo, hi] = scene.bounds();
    let camera = rays::framing_camera(scene.bounds()).ok_or_else(|| {
        let msg = format!(
            "the scene's box [{lo}] .. [{hi}] is too large to frame with an f32 camera \
             (coordinates up to about 1e18 can be framed)"
        );
        Error::new(input, msg)
    })?;
    // The rays (32 bytes each); for diffuse, their hits (16) and the bounced rays (32) too.
    let per_ray: u64 = match kind {
        RayKind::Primary => 32,
        RayKind::Diffuse => 80,
    };
    kdray::memory::ensure(
        out,
        u64::from(size.0) * u64::from(size.1) * per_ray,
        &format!("a {}x{} ray set", size.0, size.1),
        &format!(
            "sets up to {} rays are accepted, memory permitting",
            super::MAX_PIXELS
        ),
    )?;
    let primary = rays::primary_rays(&camera, size.0, size.1);
    let set = match kind {
        RayKind::Primary => primary,
        RayKind::Diffuse => {
            let mut hits = vec![Hit::MISS; primary.len()];
            let how = Tracer {
                packet: 8,
                stream: false,
                mode: Mode::Fast,
            };
            trace_all(&scene, &primary, &mut hits, how);
            rays::diffuse_rays(&scene, &primary, &hits, seed)
        }
    };
    files::write_atomic_with(out, |w| rays::write_rays(w, &set))?;
    println!("wrote {}: {} rays", out.display(), set.len());
    Ok(())
}
