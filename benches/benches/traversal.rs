//! Traversal throughput on the benchmark protocol's rays (docs/BENCHMARKS.md, "Protocol"): the dragon and the bunny
//! (`scripts/fetch-meshes.sh` puts them in `data/`), primary and diffuse rays of both framings
//! (loose and tight, `kdray_benches::framing`), one thread,
//! kdray scalar / 4-wide / 8-wide next to the `bvh` crate and, with `--features embree`,
//! Embree's `rtcIntersect1` and `rtcIntersect8` on the same rays in the same run.
//!
//! Meshes that are missing are skipped with a note. `KDRAY_BENCH_SIZE=WxH` shrinks the image
//! (default 1024x1024) for a quick run.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use kdray_benches::peer_bvh::BvhPeer;
use kdray_benches::setup::{Workload, trace_packets, trace_scalar};
use kdray_core::simd::{f32x4, f32x8};
use kdray_core::{Hit, Ray};
use std::path::Path;

/// `KDRAY_BENCH_SIZE`, or 1024×1024 when it is not set.
///
/// # Panics
/// On a value that is not `WxH` with both at least 1: a typo must not measure the default size.
fn size() -> (u32, u32) {
    let Ok(v) = std::env::var("KDRAY_BENCH_SIZE") else {
        return (1024, 1024);
    };
    let parsed = v.split_once('x').and_then(|(w, h)| {
        let (w, h): (u32, u32) = (w.parse().ok()?, h.parse().ok()?);
        (w > 0 && h > 0).then_some((w, h))
    });
    parsed.unwrap_or_else(|| panic!("KDRAY_BENCH_SIZE='{v}': expected WxH, e.g. 256x256"))
}

fn traversal(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data");
    let (w, h) = size();
    for mesh in ["dragon", "bunny"] {
        let path = root.join(format!("{mesh}.ply"));
        let work = match Workload::load(&path, w, h) {
            Ok(work) => work,
            Err(e) => {
                eprintln!("skipping {mesh}: {e} (run scripts/fetch-meshes.sh)");
                continue;
            }
        };
        let scene = work.scene();
        let bvh = BvhPeer::build(&work.triangles);
        #[cfg(feature = "embree")]
        let device = kdray_benches::peer_embree::EmbreeDevice::new().expect("embree device");
        #[cfg(feature = "embree")]
        let embree = device.build(&work.triangles).expect("embree build");
        let sets = work.framings.iter().flat_map(|f| {
            let name = f.framing.name();
            [(name, "primary", &f.primary), (name, "diffuse", &f.diffuse)]
        });
        for (framing, set, rays) in sets {
            let isa = kdray_core::isa::name();
            let mut group = c.benchmark_group(format!("{mesh}/{framing}/{set}/isa={isa}"));
            group
                .sample_size(10)
                .throughput(Throughput::Elements(rays.len() as u64));
            let mut hits = vec![Hit::MISS; rays.len()];
            let mut bench = |name: &str, f: &mut dyn FnMut(&[Ray], &mut [Hit])| {
                group.bench_function(name, |b| b.iter(|| f(rays, &mut hits)));
            };
            bench("kdray_scalar", &mut |r, h| trace_scalar(&scene, r, h));
            bench("kdray_packet4", &mut |r, h| {
                trace_packets::<f32x4>(&scene, r, h)
            });
            bench("kdray_packet8", &mut |r, h| {
                trace_packets::<f32x8>(&scene, r, h)
            });
            bench("bvh_crate", &mut |r, h| bvh.trace_into(r, h));
            #[cfg(feature = "embree")]
            {
                bench("embree_intersect1", &mut |r, h| embree.trace1_into(r, h));
                bench("embree_intersect8", &mut |r, h| embree.trace8_into(r, h));
            }
            group.finish();
        }
    }
}

criterion_group!(benches, traversal);
criterion_main!(benches);
