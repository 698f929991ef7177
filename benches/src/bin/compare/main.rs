//! `kdray-compare MESH [--repeat N] [--size WxH]`: the benchmark protocol's side-by-side tables.
//!
//! Builds kdray's kd-tree, the `bvh` crate's BVH and (with the `embree` feature) Embree 3's
//! high-quality BVH over the same mesh (traced by `rtcIntersect1`, `rtcIntersect8` and the stream
//! call `rtcIntersect1M` with the coherent and the incoherent hint), each single-threaded and
//! timed. For each camera framing (loose: the bounding sphere in a 45° field of view, the rays of
//! every earlier table; tight: the mesh's projected bounds fill the image) it makes the
//! protocol's primary rays (2×4 tiles) and one cosine-weighted diffuse bounce per primary hit,
//! traces every set with every tracer on one thread, `--repeat` times, and prints a table of the
//! median Mrays/s, plus how many rays disagree with kdray's scalar traversal (a different `t`;
//! ties at the same `t` do not count). Each framing says what share of its primary rays hit the
//! mesh, and each (framing, kind of ray) ends with a summary line: kdray's best row against
//! Embree's best row and the ratio.
//!
//! Exit codes: 0 done, 1 the mesh cannot be loaded or framed, 2 a usage error.

mod args;
mod report;

use args::{Command, USAGE};
use kdray_benches::median;
use kdray_benches::peer_bvh::BvhPeer;
use kdray_benches::setup::{Workload, to_input_ids, trace_packets, trace_scalar};
use kdray_core::simd::{f32x4, f32x8, f32x16};
use kdray_core::{Hit, Ray};
use report::{Family, Row};
use std::time::Instant;

/// Median Mrays/s of `trace` over `repeat` runs, and the hits of the last run.
fn time(rays: &[Ray], repeat: usize, mut trace: impl FnMut(&[Ray], &mut [Hit])) -> (f64, Vec<Hit>) {
    let mut hits = vec![Hit::MISS; rays.len()];
    let times = (0..repeat)
        .map(|_| {
            hits.fill(Hit::MISS);
            let start = Instant::now();
            trace(rays, &mut hits);
            rays.len() as f64 / start.elapsed().as_secs_f64() / 1e6
        })
        .collect();
    (median(times), hits)
}

fn mismatches(reference: &[Hit], hits: &[Hit]) -> usize {
    let close = |a: f32, b: f32| a == b || (a - b).abs() <= 1e-4 * a.abs().max(b.abs());
    reference
        .iter()
        .zip(hits)
        .filter(|(r, h)| !close(r.t, h.t))
        .count()
}

fn main() {
    let args = match args::parse(std::env::args().skip(1)) {
        Ok(Command::Run(args)) => args,
        Ok(Command::Help) => {
            println!("{USAGE}");
            return;
        }
        Err(e) => {
            eprintln!("kdray-compare: {e}\n{USAGE}");
            std::process::exit(2);
        }
    };
    let repeat = args.repeat;
    let work = match Workload::load(&args.mesh, args.size.0, args.size.1) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("kdray-compare: {e}");
            std::process::exit(1);
        }
    };
    let (scene, tris, kd_build) = (work.scene(), &work.triangles[..], work.build_ms);
    // Every framing's sets in `report::set_index` order: loose primary, loose diffuse, tight
    // primary, tight diffuse.
    let sets: Vec<&[Ray]> = work
        .framings
        .iter()
        .flat_map(|f| [&f.primary[..], &f.diffuse[..]])
        .collect();

    let mut rows = Vec::new();
    let mut reference: Vec<Vec<Hit>> = Vec::new();
    let mut run = |name: &str,
                   family: Family,
                   build_ms: Option<f64>,
                   trace: &mut dyn FnMut(&[Ray], &mut [Hit])| {
        let mut row = Row {
            name: name.to_string(),
            family,
            build_ms,
            mrays: vec![0.0; sets.len()],
            mismatches: vec![0; sets.len()],
        };
        for (k, rays) in sets.iter().enumerate() {
            let (mrays, hits) = time(rays, repeat, &mut *trace);
            row.mrays[k] = mrays;
            if reference.len() <= k {
                reference.push(hits);
            } else {
                row.mismatches[k] = mismatches(&reference[k], &hits);
            }
        }
        rows.push(row);
    };
    run(
        "kdray scalar",
        Family::Kdray,
        Some(kd_build),
        &mut |r, h| {
            trace_scalar(&scene, r, h);
            to_input_ids(&scene, h);
        },
    );
    run("kdray packet 4", Family::Kdray, None, &mut |r, h| {
        trace_packets::<f32x4>(&scene, r, h);
        to_input_ids(&scene, h);
    });
    run("kdray packet 8", Family::Kdray, None, &mut |r, h| {
        trace_packets::<f32x8>(&scene, r, h);
        to_input_ids(&scene, h);
    });
    run("kdray packet 16", Family::Kdray, None, &mut |r, h| {
        trace_packets::<f32x16>(&scene, r, h);
        to_input_ids(&scene, h);
    });
    // The ray-stream API with its defaults (same-octant 8-wide packets, 16 single-ray walks in
    // flight); the scratch is the caller's and made once, the sorting is timed.
    let config = kdray_core::traverse::stream::Config::default();
    let most = sets.iter().map(|s| s.len()).max().unwrap_or(0);
    let mut scratch = vec![0u64; kdray_core::traverse::stream::scratch_words(most)];
    run("kdray stream", Family::Kdray, None, &mut |r, h| {
        let words = kdray_core::traverse::stream::scratch_words(r.len());
        kdray_core::traverse::stream::intersect(&scene, &config, r, h, &mut scratch[..words])
            .expect("stream buffers sized by scratch_words");
        to_input_ids(&scene, h);
    });
    // The same modes over the tree with triangle groups (`kdray build --leaves groups`).
    let grouped = work.grouped_scene();
    run(
        "kdray groups scalar",
        Family::Kdray,
        Some(work.grouped_build_ms),
        &mut |r, h| {
            trace_scalar(&grouped, r, h);
            to_input_ids(&grouped, h);
        },
    );
    run("kdray groups packet 8", Family::Kdray, None, &mut |r, h| {
        trace_packets::<f32x8>(&grouped, r, h);
        to_input_ids(&grouped, h);
    });
    run("kdray groups stream", Family::Kdray, None, &mut |r, h| {
        let words = kdray_core::traverse::stream::scratch_words(r.len());
        kdray_core::traverse::stream::intersect(&grouped, &config, r, h, &mut scratch[..words])
            .expect("stream buffers sized by scratch_words");
        to_input_ids(&grouped, h);
    });
    // Wide nodes over the grouped tree (`--layout wide`): single rays walk eight cells a step.
    let wide = work.wide_scene();
    run("kdray wide scalar", Family::Kdray, None, &mut |r, h| {
        trace_scalar(&wide, r, h);
        to_input_ids(&wide, h);
    });
    // The stream over it: coherent runs as packets over the nodes, the rest as single rays over
    // the wide nodes.
    run("kdray wide stream", Family::Kdray, None, &mut |r, h| {
        let words = kdray_core::traverse::stream::scratch_words(r.len());
        kdray_core::traverse::stream::intersect(&wide, &config, r, h, &mut scratch[..words])
            .expect("stream buffers sized by scratch_words");
        to_input_ids(&wide, h);
    });

    let start = Instant::now();
    let bvh = BvhPeer::build(tris);
    let bvh_build = start.elapsed().as_secs_f64() * 1e3;
    run(
        "bvh crate 0.13",
        Family::Bvh,
        Some(bvh_build),
        &mut |r, h| bvh.trace_into(r, h),
    );

    #[cfg(feature = "embree")]
    {
        use kdray_benches::peer_embree::{Coherence, EmbreeDevice};
        let device = EmbreeDevice::new().expect("embree device");
        let start = Instant::now();
        let scene = device.build(tris).expect("embree build");
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let e = Family::Embree;
        run("embree rtcIntersect1", e, Some(ms), &mut |r, h| {
            scene.trace1_into(r, h)
        });
        run("embree rtcIntersect8", e, None, &mut |r, h| {
            scene.trace8_into(r, h)
        });
        // The stream call with either hint; the peer's best mode for a kind of ray is the best
        // of its rows.
        run("embree rtcIntersect1M coherent", e, None, &mut |r, h| {
            scene.trace1m_into(r, h, Coherence::Coherent)
        });
        run("embree rtcIntersect1M incoherent", e, None, &mut |r, h| {
            scene.trace1m_into(r, h, Coherence::Incoherent)
        });
    }

    let mesh = args.mesh.display().to_string();
    report::print(&mesh, tris.len(), repeat, &work.framings, &rows);
}
