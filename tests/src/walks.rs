//! Every walk of a scene over the same rays, for tests that compare them ray by ray: the wide
//! walk (single rays over wide nodes, what `Scene::intersect` takes when the section is there),
//! the binary-node walk (the same scene without its wide section), 4- and 8-wide packets of
//! consecutive rays, and the ray stream (sorted runs as packets, the rest single rays).

use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize, serialize_as};
use kdray_core::simd::{HitPacket, Lanes, RayPacket, f32x4, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config};
use kdray_core::{Hit, Ray, Scene};

/// The walks [`trace_all`] runs, in its order.
pub const WALKS: [&str; 5] = ["wide", "nodes", "packet 4", "packet 8", "stream"];

/// `triangles` built (default SAH parameters, one thread) into words with index lists in binary
/// nodes only ([`serialize`]'s tree: the packet walks' own, and the single-ray walk's too).
///
/// # Panics
/// If the builder or the serializer refuses the triangles.
pub fn node_words(triangles: Vec<[glam::Vec3; 3]>) -> Vec<u32> {
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    let params = BuildParams {
        parallel: false,
        ..BuildParams::default()
    };
    let tree = build(&geom, &params, None).expect("the triangles build");
    serialize(&tree, &geom, 0.0).expect("and serialize")
}

/// `triangles` built (default SAH parameters, one thread) into words with the wide section, with
/// index lists (`groups` false) or triangle groups.
///
/// # Panics
/// If the builder or the serializer refuses the triangles.
pub fn wide_words(triangles: Vec<[glam::Vec3; 3]>, groups: bool) -> Vec<u32> {
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    let leaves = if groups { Leaves::Groups } else { Leaves::List };
    let params = BuildParams {
        parallel: false,
        ..leaves.build_params()
    };
    let tree = build(&geom, &params, None).expect("the triangles build");
    serialize_as(&tree, &geom, 0.0, Layout::Wide, leaves).expect("and serialize")
}

/// The closest hits of `rays` in `mode` by every walk of [`WALKS`], in that order. `scene` should
/// hold a wide section (else "wide" is the node walk again).
pub fn trace_all(scene: &Scene, rays: &[Ray], mode: Mode) -> [Vec<Hit>; 5] {
    let nodes = scene.without_wide();
    let stream_hits = {
        let mut hits = vec![Hit::MISS; rays.len()];
        let mut scratch = vec![0u64; stream::scratch_words(rays.len())];
        let config = Config {
            mode,
            ..Config::default()
        };
        stream::intersect(scene, &config, rays, &mut hits, &mut scratch).expect("sizes match");
        hits
    };
    [
        rays.iter().map(|r| scene.intersect_in(mode, r)).collect(),
        rays.iter().map(|r| nodes.intersect_in(mode, r)).collect(),
        packets::<f32x4>(scene, rays, mode),
        packets::<f32x8>(scene, rays, mode),
        stream_hits,
    ]
}

/// The closest hits of `rays` as packets of `L::WIDTH` consecutive rays.
pub fn packets<L: Lanes>(scene: &Scene, rays: &[Ray], mode: Mode) -> Vec<Hit> {
    let mut out = vec![Hit::MISS; rays.len()];
    for (chunk, out) in rays.chunks(L::WIDTH).zip(out.chunks_mut(L::WIDTH)) {
        let packet = RayPacket::<L>::from_rays(chunk);
        let hits: HitPacket<L> = scene.intersect_packet_in(mode, &packet);
        hits.write_active(&packet, out);
    }
    out
}
