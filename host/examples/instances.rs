//! Many instances of one small mesh: the top level over 10,000 of them built, validated, moved
//! (rebuilt: the mesh's tree is not touched) and traced. Prints the top level's build and
//! validation times (median of 21 runs), what issue 42 asks measured. Run with
//! `cargo run --release -p kdray --example instances`.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::instances::{Moved, Placement, TopLevel, top_level};
use kdray_core::instance::{Affine, InstancedScene};
use kdray_core::{Ray, Scene};
use std::time::Instant;

/// A bumpy 8×8 patch (128 triangles) in `[0, 1]² × [0, 0.2]`.
fn patch() -> Geometry {
    let n = 8;
    let p = |i: usize, j: usize| {
        let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
        Vec3::new(x, y, 0.1 + 0.1 * (7.0 * x).sin() * (5.0 * y).cos())
    };
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            triangles.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            triangles.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

/// Instance `k` of a 100 × 100 field, turned about z by `phase + k`, scaled 0.5 to 1.5,
/// mirrored every third one.
fn placement(k: u32, phase: f32) -> Placement {
    let (s, c) = (phase + k as f32).sin_cos();
    let scale = 0.5 + (k % 11) as f32 / 10.0;
    let mirror = if k.is_multiple_of(3) { -1.0 } else { 1.0 };
    let (x, y) = ((k % 100) as f32 * 2.0, (k / 100) as f32 * 2.0);
    Placement {
        bottom: 0,
        transform: Affine([
            c * scale * mirror,
            -s * scale,
            0.0,
            x + phase,
            s * scale * mirror,
            c * scale,
            0.0,
            y,
            0.0,
            0.0,
            scale,
            0.0,
        ]),
        user_id: k,
    }
}

fn median_ms(mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..21)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() -> Result<(), Box<dyn core::error::Error>> {
    let geom = patch();
    let tree = build(&geom, &BuildParams::default(), None)?;
    let mesh = kdray::flat::serialize(&tree, &geom, 0.0)?;
    let bottoms = [Scene::from_words(&mesh).map_err(|e| e.to_string())?];
    let n = 10_000;
    let placements: Vec<Placement> = (0..n).map(|k| placement(k, 0.0)).collect();
    let words = top_level(&bottoms, &placements)?;
    let top = InstancedScene::from_words(&words, &bottoms).map_err(|e| e.to_string())?;
    println!(
        "{} instances of {} triangles: top level {} words, {} nodes, depth {}",
        n,
        geom.triangles.len(),
        words.len(),
        top.node_count(),
        top.depth()
    );
    // Moving every instance: a new top level from new placements, the mesh untouched.
    let mut frame = 0.0;
    let build_ms = median_ms(|| {
        frame += 0.01;
        let moved: Vec<Placement> = (0..n).map(|k| placement(k, frame)).collect();
        core::hint::black_box(top_level(&bottoms, &moved).unwrap());
    });
    // The same instances moved again: the tree refitted, not rebuilt (`TopLevel::move_to`).
    let mut kept = TopLevel::build(&bottoms, &placements)?;
    let refit_ms = median_ms(|| {
        frame += 0.01;
        let moved: Vec<Placement> = (0..n).map(|k| placement(k, frame)).collect();
        assert_eq!(kept.move_to(&bottoms, &moved).unwrap(), Moved::Refitted);
    });
    let validate_ms = median_ms(|| {
        core::hint::black_box(InstancedScene::from_words(&words, &bottoms).unwrap());
    });
    // What a program that just built the words opens them with (the packages do).
    let open_ms = median_ms(|| {
        core::hint::black_box(InstancedScene::from_built_words(&words, &bottoms).unwrap());
    });
    println!(
        "top level: build {build_ms:.2} ms or refit {refit_ms:.2} ms (placements included), \
         validate {validate_ms:.2} ms (words from outside), open {open_ms:.2} ms (words just \
         built)"
    );
    // Rays down onto the field from above, slightly slanted.
    let dir = Vec3::new(0.1, 0.05, -1.0).normalize();
    let rays: Vec<Ray> = (0..200_000u32)
        .map(|i| {
            let (x, y) = ((i % 1000) as f32 * 0.2, (i / 1000) as f32);
            Ray::new(Vec3::new(x, y, 5.0), dir)
        })
        .collect();
    let start = Instant::now();
    let hits = rays.iter().filter(|r| top.intersect(r).is_hit()).count();
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{} rays, {} hits: {:.2} Mrays/s (one thread, closest hit)",
        rays.len(),
        hits,
        rays.len() as f64 / secs / 1e6
    );
    Ok(())
}
