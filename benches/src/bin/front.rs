//! `front`: the builder's front — build cost against trace cost, with the tree's bytes — for the
//! settings of `kdray_benches::front` (docs/BUILD.md, "The front"). Four modes:
//!
//! ```sh
//! front MESH... [--size W] [--random N] [--repeat R] [--only NAME,...] [--tsv FILE]   # timed
//! front MESH... --count [--size W] [--random N] [--only NAME]   # for callgrind: scripts/front.sh
//! front --list [--only NAME,...]                                 # the settings' names
//! front --plot TABLE --png FILE                                  # plot scripts/front.sh's table
//! ```
//!
//! A mesh is a file `kdray` loads, or `torusknot` for the npm benchmarks' torus knot
//! ([`kdray_benches::knot`]).
//!
//! Timed, per mesh and setting: the build as the packages run it (build, serialize with the wide
//! section and groups or lists, open with `Scene::from_built_words`) on one thread and on all of
//! rayon's, the bytes a triangle, and the single-thread cost of three ray sets through
//! `Scene::intersect` (the wide walk the packages use for rays that do not form packets): the
//! framing camera's primary rays (`--size`², default 512), one cosine bounce from each of their
//! hits, and `--random` rays (default 200,000) with origins uniform in the mesh's box and
//! directions uniform on the sphere — the rays of a picking or analysis user. Times are the
//! median of `--repeat` runs (default 3), the settings taking turns in each round, each round
//! starting at another setting; with `FRONT_PHASES` set, each build's tree, serialization and
//! opening times go to standard error.
//! Every setting's hits are compared with the first's (same `t` bits; a triangle may differ only
//! in a tie): a tree that answers differently is reported, and the run exits 1.
//!
//! `scripts/front.sh` runs `--count` under callgrind for each setting and mesh (instructions do
//! not depend on the machine's load), writes docs/front.tsv and plots it with `--plot`.
//!
//! Exit codes: 0 done, 1 a mesh that cannot be read or a setting that answers differently,
//! 2 a usage error.

use glam::Vec3;
use kdray::build::{BuildParams, build};
use kdray::converge::median;
use kdray::flat::{Layout, serialize_as};
use kdray::geometry::Geometry;
use kdray::plot::{Panel, Point, scatter_log_y};
use kdray::rays::{diffuse_rays, framing_camera, primary_rays};
use kdray_benches::front::{Setting, settings};
use kdray_benches::knot;
use kdray_core::sampling::Pcg32;
use kdray_core::{Hit, Ray, Scene};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

const USAGE: &str = "usage: front MESH... [--count] [--size W] [--random N] [--repeat R] \
                     [--only NAME,...] [--tsv FILE] | front --list | front --plot TABLE --png FILE";

struct Args {
    meshes: Vec<PathBuf>,
    size: u32,
    random: usize,
    repeat: usize,
    only: Option<Vec<String>>,
    tsv: Option<PathBuf>,
    png: Option<PathBuf>,
    /// Print the chosen settings' names and stop.
    list: bool,
    /// Plot a table `scripts/front.sh` wrote into `png` and stop.
    plot: Option<PathBuf>,
    /// Build each setting once and trace each set once, untimed, for callgrind
    /// (`scripts/front.sh`).
    count: bool,
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut a = Args {
        meshes: Vec::new(),
        size: 512,
        random: 200_000,
        repeat: 3,
        only: None,
        tsv: None,
        png: None,
        count: false,
        list: false,
        plot: None,
    };
    let number = |name: &str, v: Option<String>| -> Result<usize, String> {
        let v = v.ok_or(format!("{name} needs a value"))?;
        v.parse()
            .ok()
            .filter(|&n| n >= 1)
            .ok_or(format!("{name}: expected an integer >= 1, got '{v}'"))
    };
    while let Some(s) = args.next() {
        match s.as_str() {
            "--size" => a.size = number("--size", args.next())?.min(8192) as u32,
            "--random" => a.random = number("--random", args.next())?,
            "--repeat" => a.repeat = number("--repeat", args.next())?,
            "--only" => {
                let v = args.next().ok_or("--only needs a value")?;
                a.only = Some(v.split(',').map(str::to_string).collect());
            }
            "--tsv" => a.tsv = Some(args.next().ok_or("--tsv needs a file")?.into()),
            "--png" => a.png = Some(args.next().ok_or("--png needs a file")?.into()),
            "--count" => a.count = true,
            "--list" => a.list = true,
            "--plot" => a.plot = Some(args.next().ok_or("--plot needs a file")?.into()),
            s if s.starts_with('-') => return Err(format!("unknown option '{s}'")),
            _ => a.meshes.push(PathBuf::from(s)),
        }
    }
    if a.png.is_some() != a.plot.is_some() {
        return Err("--plot and --png go together".into());
    }
    if a.meshes.is_empty() && !a.list && a.plot.is_none() {
        return Err("no mesh given".into());
    }
    Ok(a)
}

/// One setting's figures on one mesh (times in ms, medians).
struct Row {
    setting: &'static str,
    build_one: f64,
    build_all: f64,
    bytes: usize,
    /// ns a ray: primary, diffuse, random.
    ns: [f64; 3],
}

/// Builds `geom` as the packages do: tree, words (wide section), opened as just built.
fn build_words(geom: &Geometry, s: &Setting, parallel: bool) -> Result<(Vec<u32>, f64), String> {
    let start = Instant::now();
    let params = BuildParams {
        parallel,
        ..s.params
    };
    let tree = build(geom, &params, None)?;
    let built = start.elapsed().as_secs_f64() * 1e3;
    let words = serialize_as(&tree, geom, 0.0, Layout::Wide, s.leaves)?;
    let serialized = start.elapsed().as_secs_f64() * 1e3;
    Scene::from_built_words(&words).map_err(|e| e.to_string())?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    if std::env::var_os("FRONT_PHASES").is_some() {
        eprintln!(
            "front: {} parallel={parallel}: tree {built:.0} ms, words {:.0} ms, open {:.0} ms",
            s.name,
            serialized - built,
            ms - serialized
        );
    }
    Ok((words, ms))
}

/// The mesh at `path`, or the npm benchmarks' torus knot for `torusknot`.
fn load(path: &Path) -> Result<Geometry, String> {
    if path.as_os_str() == knot::NAME {
        return Ok(knot::benchmark_knot());
    }
    kdray::load::load_mesh(path).map_err(|e| e.to_string())
}

/// `n` rays from points uniform in `bounds` in directions uniform on the sphere.
fn random_rays(bounds: [Vec3; 2], n: usize) -> Vec<Ray> {
    let mut rng = Pcg32::new(7, 0);
    (0..n)
        .map(|_| {
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let o = bounds[0] + u * (bounds[1] - bounds[0]);
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = core::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

#[inline(always)]
fn trace(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) -> f64 {
    let start = Instant::now();
    for (h, r) in hits.iter_mut().zip(rays) {
        *h = scene.intersect(r);
    }
    start.elapsed().as_secs_f64() * 1e9 / rays.len().max(1) as f64
}

/// The three ray sets (primary, diffuse, random) for `scene`, the first setting's tree.
fn ray_sets(mesh: &Path, scene: &Scene, a: &Args) -> Result<[Vec<Ray>; 3], String> {
    let bounds = scene.bounds();
    let camera =
        framing_camera(bounds).ok_or(format!("{}: no camera frames it", mesh.display()))?;
    let primary = primary_rays(&camera, a.size, a.size);
    let mut hits = vec![Hit::MISS; primary.len()];
    trace(scene, &primary, &mut hits);
    let diffuse = diffuse_rays(scene, &primary, &hits, 1);
    Ok([primary, diffuse, random_rays(bounds, a.random)])
}

/// `--count`: each setting built once on one thread, each set traced once, in functions
/// callgrind counts by name (`count_build`, `count_primary`, `count_diffuse`, `count_random`);
/// prints `mesh setting bytes_per_tri triangles rays_primary rays_diffuse rays_random`.
fn count(mesh: &Path, a: &Args, chosen: &[Setting]) -> Result<(), String> {
    let geom = load(mesh)?;
    let name = mesh.file_stem().map_or("?".into(), |s| s.to_string_lossy());
    for s in chosen {
        let words = count_build(&geom, s)?;
        let scene = Scene::from_built_words(&words).map_err(|e| e.to_string())?;
        let sets = ray_sets(mesh, &scene, a)?;
        let mut hits = vec![Hit::MISS; sets[0].len().max(sets[1].len()).max(sets[2].len())];
        count_primary(&scene, &sets[0], &mut hits);
        count_diffuse(&scene, &sets[1], &mut hits);
        count_random(&scene, &sets[2], &mut hits);
        let tris = geom.triangles.len().max(1);
        println!(
            "{name}\t{}\t{}\t{tris}\t{}\t{}\t{}",
            s.name,
            words.len() * 4 / tris,
            sets[0].len(),
            sets[1].len(),
            sets[2].len()
        );
    }
    Ok(())
}

#[inline(never)]
fn count_build(geom: &Geometry, s: &Setting) -> Result<Vec<u32>, String> {
    build_words(geom, s, false).map(|(w, _)| w)
}

#[inline(never)]
fn count_primary(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    // A distinct body, so that the linker does not fold the three functions into one.
    core::hint::black_box(0);
    trace(scene, rays, hits);
}

#[inline(never)]
fn count_diffuse(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    // A distinct body, so that the linker does not fold the three functions into one.
    core::hint::black_box(1);
    trace(scene, rays, hits);
}

#[inline(never)]
fn count_random(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    // A distinct body, so that the linker does not fold the three functions into one.
    core::hint::black_box(2);
    trace(scene, rays, hits);
}

fn measure(mesh: &Path, a: &Args, chosen: &[Setting]) -> Result<Vec<Row>, String> {
    let geom = load(mesh)?;
    let tris = geom.triangles.len();
    let (words, _) = build_words(&geom, &chosen[0], true)?;
    let scene = Scene::from_built_words(&words).map_err(|e| e.to_string())?;
    let sets = ray_sets(mesh, &scene, a)?;
    let reference: Vec<Vec<u32>> = sets
        .iter()
        .map(|rays| {
            let mut h = vec![Hit::MISS; rays.len()];
            trace(&scene, rays, &mut h);
            h.iter().map(|h| h.t.to_bits()).collect()
        })
        .collect();
    let mut times: Vec<[Vec<f64>; 5]> = chosen.iter().map(|_| Default::default()).collect();
    let mut bytes = vec![0; chosen.len()];
    for round in 0..a.repeat {
        // Each round starts at another setting: the setting built first in a round traced up
        // to a fifth faster than in later places (the knot's diffuse rays, 2026-11-29; the
        // cause not isolated), so a fixed order would favour the first.
        let first = round * chosen.len() / a.repeat;
        for k in (0..chosen.len()).map(|i| (i + first) % chosen.len()) {
            let s = &chosen[k];
            let (_, one) = build_words(&geom, s, false)?;
            let (words, all) = build_words(&geom, s, true)?;
            bytes[k] = words.len() * 4;
            let scene = Scene::from_built_words(&words).map_err(|e| e.to_string())?;
            times[k][0].push(one);
            times[k][1].push(all);
            for (j, rays) in sets.iter().enumerate() {
                let mut h = vec![Hit::MISS; rays.len()];
                times[k][2 + j].push(trace(&scene, rays, &mut h));
                if round == 0 {
                    let wrong = h
                        .iter()
                        .zip(&reference[j])
                        .filter(|(h, t)| h.t.to_bits() != **t)
                        .count();
                    if wrong > 0 {
                        return Err(format!(
                            "{}: setting '{}' answers {wrong} of {} rays of set {j} differently",
                            mesh.display(),
                            s.name,
                            rays.len()
                        ));
                    }
                }
            }
            eprintln!(
                "front: {} round {} {}: {:.0} / {:.0} ms",
                mesh.display(),
                round + 1,
                s.name,
                one,
                all
            );
        }
    }
    Ok(chosen
        .iter()
        .zip(times)
        .zip(bytes)
        .map(|((s, t), bytes)| {
            let [b1, b2, p, d, r] = t.map(|v| median(&v));
            Row {
                setting: s.name,
                build_one: b1,
                build_all: b2,
                bytes: bytes / tris.max(1),
                ns: [p, d, r],
            }
        })
        .collect())
}

fn run(a: &Args) -> Result<(), String> {
    let all = settings();
    let chosen: Vec<Setting> = match &a.only {
        None => all,
        Some(names) => names
            .iter()
            .map(|n| {
                all.iter()
                    .find(|s| s.name == n)
                    .copied()
                    .ok_or(format!("no setting named '{n}'"))
            })
            .collect::<Result<_, _>>()?,
    };
    let mut tsv = String::from(
        "mesh\tsetting\tbuild_ms_1\tbuild_ms_all\tbytes_per_tri\tns_primary\tns_diffuse\tns_random\n",
    );
    if a.list {
        for s in &chosen {
            println!("{}", s.name);
        }
        return Ok(());
    }
    if let Some(table) = &a.plot {
        let png = a.png.as_ref().ok_or("--plot needs --png")?;
        return plot_table(table, png);
    }
    if a.count {
        for mesh in &a.meshes {
            count(mesh, a, &chosen)?;
        }
        return Ok(());
    }
    for mesh in &a.meshes {
        let rows = measure(mesh, a, &chosen)?;
        let name = mesh.file_stem().map_or("?".into(), |s| s.to_string_lossy());
        for r in &rows {
            let line = format!(
                "{name}\t{}\t{:.1}\t{:.1}\t{}\t{:.1}\t{:.1}\t{:.1}",
                r.setting, r.build_one, r.build_all, r.bytes, r.ns[0], r.ns[1], r.ns[2]
            );
            println!("{line}");
            tsv.push_str(&line);
            tsv.push('\n');
        }
    }
    if let Some(p) = &a.tsv {
        std::fs::write(p, tsv).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok(())
}

/// Draws `scripts/front.sh`'s table: per mesh, build instructions a triangle against
/// instructions a random ray, each point labelled with its setting and bytes a triangle.
fn plot_table(table: &Path, png: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(table).map_err(|e| format!("{}: {e}", table.display()))?;
    let mut panels: Vec<Panel> = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        let num = |i: usize| -> Result<f64, String> {
            f.get(i).and_then(|v| v.parse().ok()).ok_or(format!(
                "{}:{}: expected 7 fields",
                table.display(),
                k + 1
            ))
        };
        let point = Point {
            x: num(3)?,
            y: num(6)?,
            label: format!("{} ({} B)", f[1], f[2]),
        };
        match panels.iter_mut().find(|p| p.title == f[0]) {
            Some(p) => p.series[0].1.push(point),
            None => panels.push(Panel {
                title: f[0].to_string(),
                series: vec![("setting (bytes a triangle)".into(), vec![point])],
            }),
        }
    }
    if panels.is_empty() {
        return Err(format!("{}: no rows", table.display()));
    }
    scatter_log_y(
        png,
        "The builder's front: build against trace cost (callgrind, x86-64-v3)",
        (
            "build instructions a triangle (one thread)",
            "instructions a random ray",
        ),
        &panels,
        100.0,
        (620 * panels.len() as u32, 560),
    )
    .map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let args = match parse(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("front: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("front: {e}");
            ExitCode::FAILURE
        }
    }
}
