//! `kdray trace` on a scene file with `[[instance]]` entries: one tree per mesh (built as
//! `--leaves`, `--layout` and the build options say), the top level over the copies
//! ([`kdray::instances::top_level`]), the rays through the two-level walk: one at a time
//! ([`InstancedScene::intersect_in`]), in packets of `--packet 4`/`8`/`16` of consecutive rays
//! ([`InstancedScene::intersect_packet_in`]), or as a stream (`--stream`,
//! [`kdray_core::instance::stream`]), the same hits each way. The hits file is the single-mesh one, `prim` the
//! primitive's index in its mesh's input order; `--instances` writes each hit's instance id (the
//! copy's number, `docs/SCENE.md`, "Instances").

use super::build::build_words;
use super::pool;
use super::trace::{CHUNK, TraceArgs, stream_setup, write_instance_ids};
use kdray::error::{Error, Result};
use kdray::scene::SceneFile;
use kdray::{files, rays};
use kdray_core::instance::{InstanceHit, InstancedScene, stream};
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8, f32x16};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::scratch_words;
use kdray_core::{Hit, Ray, Scene};
use rayon::prelude::*;
use std::time::Instant;

/// Traces `rays` through the instanced scene `file` (see the module doc) and prints the line.
///
/// # Errors
/// `--counts` (the single-mesh walk's steps); what loading, building or writing refuses.
pub(super) fn trace(args: &TraceArgs, file: &SceneFile, rays: &[Ray]) -> Result<()> {
    if args.counts {
        let msg = "has [[instance]] entries: --counts counts the steps of a single-mesh walk, \
                   not of the two-level one (drop it)";
        return Err(Error::new(&args.input, msg));
    }
    let outputs: Vec<&std::path::Path> = core::iter::once(args.out.as_path())
        .chain(args.instances.as_deref())
        .collect();
    files::check_not_inputs(&file.mesh_files(), &outputs)?;
    let geom = file.instanced_geometry()?;
    let start = Instant::now();
    let bottoms = geom
        .bottoms
        .iter()
        .map(|g| {
            let leaves = args.build.leaves_for(g);
            let params = args.build.params(leaves);
            build_words(&file.path, g, &params, args.build.layout, leaves).map(|(w, _, _)| w)
        })
        .collect::<Result<Vec<_>>>()?;
    let scenes = bottoms
        .iter()
        .map(|w| Scene::from_words(w).map_err(|e| Error::new(&file.path, e.to_string())))
        .collect::<Result<Vec<_>>>()?;
    let top = kdray::instances::top_level(&scenes, &geom.placements)
        .map_err(|msg| Error::new(&file.path, format!("[[instance]]: {msg}")))?;
    let scene = InstancedScene::from_words(&top, &scenes)
        .map_err(|e| Error::new(&file.path, e.to_string()))?;
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let pool = pool(&args.input, args.threads)?;
    let mode = if args.watertight {
        Mode::Watertight
    } else {
        Mode::Fast
    };
    let mut found = vec![InstanceHit::MISS; rays.len()];
    let mut best = f64::INFINITY;
    for _ in 0..args.repeat {
        let start = Instant::now();
        pool.install(|| trace_all(&scene, rays, &mut found, mode, args));
        best = best.min(start.elapsed().as_secs_f64());
    }
    let hits: Vec<Hit> = found.iter().map(|h| input_hit(&scene, h)).collect();
    let ids: Vec<u32> = found.iter().map(|h| h.user_id).collect();
    files::write_atomic_with(&args.out, |w| rays::write_hits(w, &hits))?;
    if let Some(path) = &args.instances {
        write_instance_ids(path, &ids)?;
    }
    let n_hits = hits.iter().filter(|h| h.is_hit()).count();
    let mrays = if best > 0.0 {
        rays.len() as f64 / best / 1e6
    } else {
        0.0
    };
    let first = &scenes[0];
    println!(
        "build_ms={build_ms:.3} prebuilt=0 trace_ms={:.3} mrays_s={mrays:.3} rays={} hits={n_hits} packet={} isa={} threads={} mode={} stream={} layout={} leaves={} instances={} meshes={}",
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
        if first.wide_nodes().is_empty() {
            "nodes"
        } else {
            "wide"
        },
        if first.has_groups() { "groups" } else { "list" },
        scene.instance_count(),
        scenes.len(),
    );
    Ok(())
}

/// Traces `rays` into `hits` (same length) as `args` say: the stream, packets or single rays.
fn trace_all(
    scene: &InstancedScene,
    rays: &[Ray],
    hits: &mut [InstanceHit],
    mode: Mode,
    args: &TraceArgs,
) {
    if args.stream {
        let (chunk, config) = stream_setup(rays.len(), mode, args.packet);
        hits.par_chunks_mut(chunk)
            .zip(rays.par_chunks(chunk))
            .for_each(|(h, r)| {
                let mut scratch = vec![0u64; scratch_words(r.len())];
                // The lengths match by construction, so this cannot fail.
                let _ = stream::intersect(scene, &config, r, h, &mut scratch);
            });
        return;
    }
    hits.par_chunks_mut(CHUNK)
        .zip(rays.par_chunks(CHUNK))
        .for_each(|(h, r)| match args.packet {
            4 => packets::<f32x4>(scene, mode, r, h),
            8 => packets::<f32x8>(scene, mode, r, h),
            16 => packets::<f32x16>(scene, mode, r, h),
            _ => kdray::instances::trace_rays(scene, mode, r, h),
        });
}

/// `rays` in packets of `L::WIDTH` consecutive rays (the last one partial). Never inlined, so
/// that scripts/icount.sh can count its instructions by name.
#[inline(never)]
fn packets<L: Lanes>(scene: &InstancedScene, mode: Mode, rays: &[Ray], hits: &mut [InstanceHit]) {
    for (r, h) in rays.chunks(L::WIDTH).zip(hits.chunks_mut(L::WIDTH)) {
        let packet = RayPacket::<L>::from_rays(r);
        scene
            .intersect_packet_in(mode, &packet)
            .write_active(&packet, h);
    }
}

/// A two-level hit as the hits file writes it: `prim` in its mesh's input order.
fn input_hit(scene: &InstancedScene, h: &InstanceHit) -> Hit {
    if !h.is_hit() {
        return Hit::MISS;
    }
    let bottom = scene.bottom_of(h.instance);
    let prim = if bottom.reorders_triangles() {
        bottom.input_id(h.prim)
    } else {
        h.prim
    };
    Hit {
        t: h.t,
        prim,
        u: h.u,
        v: h.v,
    }
}
