//! A pixel's paths traced eight at a time, side by side: each round of their bounce rays (and of
//! their shadow rays) as one 8-wide packet ([`Bounces::Packets`](super::Bounces::Packets)), or each
//! path by itself through the scalar walk ([`Bounces::SingleRays`](super::Bounces::SingleRays)).

use super::path::{Context, Path, add_path, camera_path, vertex};
use crate::camera::Camera;
use crate::format::Scene;
use crate::ray::Ray;
use crate::simd::lanes::set_lanes;
use crate::simd::{Lanes, RayPacket, f32x8};
use crate::traverse::Contents;
use core::ops::Range;
use glam::Vec3;

/// rays as 8-wide packets when `PACKETS`.
pub(super) fn render_pixel<K: Contents, C: Camera, const PACKETS: bool>(
    ctx: &Context<Scene>,
    camera: &C,
    x: u32,
    y: u32,
    samples: Range<u32>,
    sums: &mut super::SampleSums,
) {
    let mut first = samples.start;
    while first < samples.end {
        let n = (samples.end - first).min(8);
        let mut paths = [Path::IDLE; 8];
        // The samples the camera keeps, packed to the front.
        let mut kept = 0;
        for sample in first..first + n {
            if let Some(path) = camera_path(ctx.settings, camera, x, y, sample) {
                paths[kept] = path;
                kept += 1;
            }
        }
        let paths = &mut paths[..kept];
        if paths.is_empty() {
            // The camera dropped every sample of this round: nothing to trace.
        } else if PACKETS {
            trace_paths_packed::<K>(ctx, paths);
        } else {
            paths.iter_mut().for_each(|p| trace_path::<K>(ctx, p));
        }
        paths.iter().for_each(|path| add_path(sums, path));
        first += n;
    }
}

fn trace_path<K: Contents>(ctx: &Context<Scene>, path: &mut Path) {
    let mut hit = ctx.scene.intersect_with::<K>(&path.ray);
    for depth in 1..=ctx.settings.max_depth {
        let (goes_on, shadow) = vertex(ctx, path, &hit);
        if let Some(shadow) = shadow {
            path.resolve(&shadow, ctx.scene.occluded_with::<K>(&shadow.ray));
        }
        if !goes_on || depth == ctx.settings.max_depth {
            return;
        }
        hit = ctx.scene.intersect_with::<K>(&path.ray);
    }
}

/// Up to eight paths side by side: each round's camera or bounce rays are one 8-wide packet, and
/// so are its shadow rays, with the lanes of finished paths (or of paths without a shadow ray)
/// inactive. Every lane does exactly what [`trace_path`] does for it, in the same order, and the
/// packet traversal finds what the scalar walk finds, so the image is the same.
fn trace_paths_packed<K: Contents>(ctx: &Context<Scene>, paths: &mut [Path]) {
    let scene = ctx.scene;
    let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
    let mut live = 0u32;
    for (i, path) in paths.iter().enumerate() {
        rays[i] = path.ray;
        live |= 1 << i;
    }
    let mut hits = scene.intersect_packet_with::<K, f32x8>(&packet(&rays, live));
    for depth in 1..=ctx.settings.max_depth {
        let mut shadows = [None; 8];
        let (mut next, mut waiting) = (0u32, 0u32);
        for i in set_lanes(live) {
            let (goes_on, shadow) = vertex(ctx, &mut paths[i], &hits.hit(i));
            if let Some(shadow) = shadow {
                rays[i] = shadow.ray;
                waiting |= 1 << i;
            }
            shadows[i] = shadow;
            next |= u32::from(goes_on) << i;
        }
        if waiting != 0 {
            let occluded = scene
                .occluded_packet_with::<K, f32x8>(&packet(&rays, waiting))
                .bitmask();
            for i in set_lanes(waiting) {
                if let Some(shadow) = &shadows[i] {
                    paths[i].resolve(shadow, occluded >> i & 1 == 1);
                }
            }
        }
        live = next;
        if live == 0 || depth == ctx.settings.max_depth {
            return;
        }
        for i in set_lanes(live) {
            rays[i] = paths[i].ray;
        }
        hits = scene.intersect_packet_with::<K, f32x8>(&packet(&rays, live));
    }
}

/// The packet of `rays` with only the lanes in `mask` active.
fn packet(rays: &[Ray; 8], mask: u32) -> RayPacket<f32x8> {
    let mut packet = RayPacket::from_rays(rays);
    packet.active &= f32x8::mask_from_bits(mask);
    packet
}
