//! Issue 42's targets for instances, measured: a ray through a scene of instances against the same
//! ray through the scene merged into one mesh (target ≤ 1.3×, goal 1.1×), one ray at a time, as
//! 4- and 8-wide packets and as a stream; and 10,000 instances moved (the top level rebuilt, and
//! refitted as `TopLevel::move_to` does, then opened as the builder's words,
//! `InstancedScene::from_built_words`) and rays traced again (target ≤ 5 ms).
//!
//! Two scenes: the bunny placed 100 times by translations on a 10 × 10 grid facing the camera, and three meshes
//! (the bunny, the dragon at resolutions 4 and 3) placed 8, 8 and 4 times, turned about y and
//! scaled. Each bottom mesh and the merged mesh are built as `kdray trace` builds (groups, wide
//! nodes, high quality). The rays: the protocol's primary rays of a framing camera (2×4 tiles)
//! over the merged scene, and one diffuse bounce from each of the merged mesh's primary hits;
//! the same rays go through both. Times are the median of `--repeat` runs, the instanced and the
//! merged scene alternating, one thread.
//!
//! Usage: `cargo run --release -p kdray-benches --bin instances -- [--size N] [--repeat N]`
//! (needs data/bunny.ply, data/dragon-4.ply and data/dragon-3.ply: scripts/fetch-meshes.sh).

use core::hint::black_box;
use glam::Vec3;
use kdray::Geometry;
use kdray::build::build;
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray::instances::{Moved, Placement, TopLevel, top_level};
use kdray::rays::{diffuse_rays, framing_camera, primary_rays};
use kdray_benches::median;
use kdray_core::instance::{self, Affine, InstanceHit, InstancedScene};
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};
use std::path::Path;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn core::error::Error>>;

/// `geom` built and serialized as `kdray trace` does by default; read from
/// `$KDRAY_BENCH_CACHE/key.kdt` instead when that variable names a folder holding it (and written
/// there otherwise), so that a run under callgrind need not build.
fn words(geom: &Geometry, key: &str) -> Res<Vec<u32>> {
    let cached =
        std::env::var_os("KDRAY_BENCH_CACHE").map(|d| Path::new(&d).join(format!("{key}.kdt")));
    if let Some(path) = cached.as_ref().filter(|p| p.exists()) {
        return Ok(kdray::flat::read_kdt(path)?);
    }
    let tree = build(geom, &Leaves::Groups.build_params(), None)?;
    let words = serialize_as(&tree, geom, 0.0, Layout::Wide, Leaves::Groups)?;
    if let Some(path) = cached {
        kdray::flat::write_kdt(&path, &words)?;
    }
    Ok(words)
}

fn load(name: &str) -> Res<Geometry> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../data")
        .join(name);
    Ok(kdray::load::load_mesh(&path)?)
}

/// A transform taking `geom`'s box to a box of largest side `size` whose centre is `at`, turned
/// by `angle` about y.
fn place(geom: &Geometry, size: f32, angle: f32, at: Vec3) -> Affine {
    place_box(bounds(geom), size, angle, at)
}

/// The box of `geom`'s vertices.
fn bounds(geom: &Geometry) -> (Vec3, Vec3) {
    geom.triangles.iter().flatten().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &v| (lo.min(v), hi.max(v)),
    )
}

/// [`place`] for a mesh of box `lo`..`hi`.
fn place_box((lo, hi): (Vec3, Vec3), size: f32, angle: f32, at: Vec3) -> Affine {
    let s = size / (hi - lo).max_element();
    let c = 0.5 * (lo + hi);
    let (sin, cos) = angle.sin_cos();
    // x' = R·s·(x − c) + at, R about y.
    let r = [[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]];
    let mut m = [0.0f32; 12];
    for i in 0..3 {
        for j in 0..3 {
            m[4 * i + j] = r[i][j] * s;
        }
        m[4 * i + 3] = at[i] - s * (r[i][0] * c.x + r[i][1] * c.y + r[i][2] * c.z);
    }
    Affine(m)
}

/// A scene both ways: bottom meshes with placements, and the placed triangles merged.
struct Both {
    name: &'static str,
    bottoms: Vec<Vec<u32>>,
    placements: Vec<Placement>,
    merged: Vec<u32>,
    triangles: usize,
}

fn both(name: &'static str, meshes: &[Geometry], placed: &[(usize, Affine)]) -> Res<Both> {
    let bottoms = meshes
        .iter()
        .enumerate()
        .map(|(b, m)| words(m, &format!("{name}-bottom{b}")))
        .collect::<Res<Vec<_>>>()?;
    let placements: Vec<Placement> = placed
        .iter()
        .enumerate()
        .map(|(k, &(b, transform))| Placement {
            bottom: b as u32,
            transform,
            user_id: k as u32,
        })
        .collect();
    let triangles: Vec<[Vec3; 3]> = placed
        .iter()
        .flat_map(|&(b, t)| {
            meshes[b]
                .triangles
                .iter()
                .map(move |tri| tri.map(|v| t.point(v)))
        })
        .collect();
    let n = triangles.len();
    let merged = words(
        &Geometry {
            triangles,
            ..Geometry::default()
        },
        &format!("{name}-merged"),
    )?;
    Ok(Both {
        name,
        bottoms,
        placements,
        merged,
        triangles: n,
    })
}

/// The median of `f`'s times in ms over `repeat` runs of `a` then `b`, alternating.
fn alternate(repeat: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64) {
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    for _ in 0..repeat {
        let start = Instant::now();
        a();
        ta.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        b();
        tb.push(start.elapsed().as_secs_f64() * 1e3);
    }
    (median(ta), median(tb))
}

/// Called after each pair of timed runs: a name for callgrind's `--dump-before`, so that with
/// `--repeat 1` each dump holds exactly one tracing call (scripts in docs/BENCHMARKS.md).
#[inline(never)]
fn mark() {
    black_box(());
}

/// The tracing functions below are never inlined, so that callgrind counts each by name
/// (`callgrind_annotate --inclusive=yes`).
#[inline(never)]
fn single_top(top: &InstancedScene, rays: &[Ray], hits: &mut [InstanceHit]) {
    hits.iter_mut()
        .zip(rays)
        .for_each(|(h, r)| *h = top.intersect(r));
}

#[inline(never)]
fn single_mesh(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    hits.iter_mut()
        .zip(rays)
        .for_each(|(h, r)| *h = scene.intersect(r));
}

#[inline(never)]
fn stream_top(top: &InstancedScene, rays: &[Ray], hits: &mut [InstanceHit], scratch: &mut [u64]) {
    instance::stream::intersect(top, &Config::default(), rays, hits, scratch).unwrap();
}

#[inline(never)]
fn stream_mesh(scene: &Scene, rays: &[Ray], hits: &mut [Hit], scratch: &mut [u64]) {
    stream::intersect(scene, &Config::default(), rays, hits, scratch).unwrap();
}

#[inline(never)]
fn packets_top<L: Lanes>(top: &InstancedScene, rays: &[Ray], hits: &mut [InstanceHit]) {
    for (r, h) in rays.chunks(L::WIDTH).zip(hits.chunks_mut(L::WIDTH)) {
        let p = RayPacket::<L>::from_rays(r);
        top.intersect_packet_in(Mode::Fast, &p).write_active(&p, h);
    }
}

#[inline(never)]
fn packets_mesh<L: Lanes>(scene: &Scene, rays: &[Ray], hits: &mut [Hit]) {
    for (r, h) in rays.chunks(L::WIDTH).zip(hits.chunks_mut(L::WIDTH)) {
        let p = RayPacket::<L>::from_rays(r);
        scene
            .intersect_packet_in(Mode::Fast, &p)
            .write_active(&p, h);
    }
}

/// One table row per way of tracing `rays`: instanced ms, merged ms, their ratio; and how many
/// rays the two answer with different `t` (beyond 10⁻⁴ relative: the merged mesh's triangles
/// are the instances' rounded into world space).
fn compare(top: &InstancedScene, merged: &Scene, rays: &[Ray], what: &str, repeat: usize) {
    let n = rays.len();
    let mut ih = vec![InstanceHit::MISS; n];
    let mut mh = vec![Hit::MISS; n];
    let mut scratch = vec![0u64; stream::scratch_words(n)];
    let mut scratch2 = scratch.clone();
    let ways: [&str; 4] = ["single", "packet4", "packet8", "stream"];
    for way in ways {
        let (ti, tm) = alternate(
            repeat,
            || match way {
                "single" => single_top(top, rays, &mut ih),
                "packet4" => packets_top::<f32x4>(top, rays, &mut ih),
                "packet8" => packets_top::<f32x8>(top, rays, &mut ih),
                _ => stream_top(top, rays, &mut ih, &mut scratch),
            },
            || match way {
                "single" => single_mesh(merged, rays, &mut mh),
                "packet4" => packets_mesh::<f32x4>(merged, rays, &mut mh),
                "packet8" => packets_mesh::<f32x8>(merged, rays, &mut mh),
                _ => stream_mesh(merged, rays, &mut mh, &mut scratch2),
            },
        );
        mark();
        black_box((&ih, &mh));
        let differ = ih
            .iter()
            .zip(&mh)
            .filter(|(a, b)| {
                a.is_hit() != b.is_hit() || (a.t - b.t).abs() > 1e-4 * a.t.abs().max(b.t.abs())
            })
            .count();
        println!(
            "| {what} | {way} | {:.1} | {:.1} | {:.2}× | {:.2} | {differ} |",
            ti,
            tm,
            ti / tm,
            n as f64 / ti / 1e3,
        );
    }
}

fn scene_rows(s: &Both, size: u32, repeat: usize) -> Res<()> {
    let bottoms: Vec<Scene> = s
        .bottoms
        .iter()
        .map(|w| Scene::from_words(w))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    let top_words = top_level(&bottoms, &s.placements)?;
    let top = InstancedScene::from_words(&top_words, &bottoms).map_err(|e| e.to_string())?;
    let merged = Scene::from_words(&s.merged).map_err(|e| e.to_string())?;
    let camera = framing_camera(merged.bounds()).ok_or("no camera")?;
    let primary = primary_rays(&camera, size, size);
    let hits: Vec<Hit> = primary.iter().map(|r| merged.intersect(r)).collect();
    let diffuse = diffuse_rays(&merged, &primary, &hits, 7);
    println!(
        "\n{}: {} instances of {} meshes ({} triangles placed), top level {} nodes, depth {}; \
         {} primary rays ({} hit), {} diffuse",
        s.name,
        s.placements.len(),
        s.bottoms.len(),
        s.triangles,
        top.node_count(),
        top.depth(),
        primary.len(),
        hits.iter().filter(|h| h.is_hit()).count(),
        diffuse.len()
    );
    println!(
        "| scene, rays | way | instanced ms | merged ms | ratio | instanced Mrays/s | t differs |"
    );
    println!("|---|---|--:|--:|--:|--:|--:|");
    compare(
        &top,
        &merged,
        &primary,
        &format!("{}, primary", s.name),
        repeat,
    );
    compare(
        &top,
        &merged,
        &diffuse,
        &format!("{}, diffuse", s.name),
        repeat,
    );
    Ok(())
}

/// 10,000 bunnies on a 100 × 100 grid, moved each frame: the top level rebuilt (timed alone) and
/// refitted, the refitted words opened (as the packages open what they just built:
/// `from_built_words`), then `rays` primary rays traced again (8-wide packets, and one at a time).
fn moving(bunny: &Geometry, repeat: usize) -> Res<()> {
    let mesh = words(bunny, "bunny")?;
    let bottoms = [Scene::from_words(&mesh).map_err(|e| e.to_string())?];
    let box_ = bounds(bunny);
    let field = |frame: f32| -> Vec<Placement> {
        (0..10_000u32)
            .map(|k| {
                let at = Vec3::new(
                    (k % 100) as f32 * 1.25 + frame,
                    (k / 100) as f32 * 1.25,
                    0.0,
                );
                Placement {
                    bottom: 0,
                    transform: place_box(box_, 1.0, 0.3 * k as f32 + frame, at),
                    user_id: k,
                }
            })
            .collect()
    };
    let mut kept = TopLevel::build(&bottoms, &field(0.0))?;
    let top =
        InstancedScene::from_words(kept.sealed_words(), &bottoms).map_err(|e| e.to_string())?;
    let camera = framing_camera(top.bounds()).ok_or("no camera")?;
    let rays = primary_rays(&camera, 128, 128);
    let mut hits = vec![InstanceHit::MISS; rays.len()];
    let (mut build_ms, mut refit_ms, mut open_ms, mut packet_ms, mut single_ms) =
        (vec![], vec![], vec![], vec![], vec![]);
    for frame in 0..repeat.max(5) {
        let moved = field(0.01 * (frame + 1) as f32);
        let start = Instant::now();
        black_box(top_level(&bottoms, &moved)?);
        build_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        let how = kept.move_to(&bottoms, &moved)?;
        refit_ms.push(start.elapsed().as_secs_f64() * 1e3);
        if how != Moved::Refitted {
            return Err("the moving field was rebuilt, not refitted".into());
        }
        let start = Instant::now();
        let top = InstancedScene::from_built_words(kept.built_words(), &bottoms)
            .map_err(|e| e.to_string())?;
        open_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        packets_top::<f32x8>(&top, &rays, &mut hits);
        packet_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        hits.iter_mut()
            .zip(&rays)
            .for_each(|(h, r)| *h = top.intersect(r));
        single_ms.push(start.elapsed().as_secs_f64() * 1e3);
        black_box(&hits);
    }
    let (b, f, v, p, s) = (
        median(build_ms),
        median(refit_ms),
        median(open_ms),
        median(packet_ms),
        median(single_ms),
    );
    println!(
        "\n10,000 bunnies moved: top level rebuilt {b:.2} ms or refitted {f:.2} ms (placements \
         included), opened {v:.2} ms; {} primary rays ({} hit) traced again: 8-wide packets \
         {p:.2} ms, single rays {s:.2} ms; move (refit) and trace (packets) {:.2} ms",
        rays.len(),
        hits.iter().filter(|h| h.is_hit()).count(),
        f + v + p
    );
    Ok(())
}

fn main() -> Res<()> {
    let mut size = 512u32;
    let mut repeat = 5usize;
    let args: Vec<String> = std::env::args().skip(1).collect();
    for pair in args.chunks(2) {
        let value = pair.get(1).ok_or("a flag without its value")?;
        match pair[0].as_str() {
            "--size" => size = value.parse()?,
            "--repeat" => repeat = value.parse()?,
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    println!(
        "isa {}, one thread, default stream config ({:?})",
        kdray_core::isa::name(),
        Config::default().packets
    );
    let bunny = load("bunny.ply")?;
    let grid: Vec<(usize, Affine)> = (0..100)
        .map(|k| {
            let at = Vec3::new((k % 10) as f32 * 1.25, (k / 10) as f32 * 1.25, 0.0);
            (0, place(&bunny, 1.0, 0.0, at))
        })
        .collect();
    scene_rows(
        &both("bunny x100", core::slice::from_ref(&bunny), &grid)?,
        size,
        repeat,
    )?;
    let meshes = [bunny.clone(), load("dragon-4.ply")?, load("dragon-3.ply")?];
    let counts = [8, 8, 4];
    let mut placed = Vec::new();
    let mut k = 0;
    for (b, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let at = Vec3::new(
                (k % 5) as f32 * 1.5,
                (k % 3) as f32 * 0.3,
                (k / 5) as f32 * 1.5,
            );
            placed.push((
                b,
                place(&meshes[b], 0.8 + 0.1 * (k % 4) as f32, 0.7 * k as f32, at),
            ));
            k += 1;
        }
    }
    scene_rows(&both("three meshes x20", &meshes, &placed)?, size, repeat)?;
    moving(&bunny, repeat)
}
