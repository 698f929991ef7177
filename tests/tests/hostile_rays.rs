//! Rays and triangles at the edges of f32 (issue 29): a ray starting on the scene box with a
//! subnormal direction component, whose `1/d` overflows, is traced by every walk (one ray over
//! nodes or wide nodes, groups, stream, packets), fast and watertight.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::build;
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::simd::{RayPacket, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config, Packets};
use kdray_core::{Hit, Ray, Scene};

/// The closed cube `[−1, 1]³`, two triangles a face.
fn cube() -> Geometry {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        )
    };
    let quads = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| {
            [
                [corner(q[0]), corner(q[1]), corner(q[2])],
                [corner(q[0]), corner(q[2]), corner(q[3])],
            ]
        })
        .collect();
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

/// Every way of storing the cube's tree: nodes or wide nodes, index lists or groups.
fn cube_scenes() -> Vec<(String, Vec<u32>)> {
    let geom = cube();
    let mut out = Vec::new();
    for leaves in [Leaves::List, Leaves::Groups] {
        let params = kdray::build::BuildParams {
            parallel: false,
            // Small leaves, so the walk takes several steps.
            intersect_cost: 80.0,
            ..leaves.build_params()
        };
        let tree = build(&geom, &params, None).expect("the cube builds");
        for layout in [Layout::Nodes, Layout::Wide] {
            let words = serialize_as(&tree, &geom, 0.0, layout, leaves).expect("fits");
            out.push((format!("{leaves:?} {layout:?}"), words));
        }
    }
    out
}

/// `rays` by every walk in `mode`: one ray at a time, the stream without packets,
/// 8-wide packets; the name of each walk with its hits.
fn every_walk(scene: &Scene, rays: &[Ray], mode: Mode) -> Vec<(&'static str, Vec<Hit>)> {
    let n = rays.len();
    let single = rays.iter().map(|r| scene.intersect_in(mode, r)).collect();
    let config = Config {
        mode,
        packets: Packets::Off,
        ..Config::default()
    };
    let mut streamed = vec![Hit::MISS; n];
    let mut scratch = vec![0u64; stream::scratch_words(n)];
    stream::intersect(scene, &config, rays, &mut streamed, &mut scratch).unwrap();
    let mut packets = vec![Hit::MISS; n];
    for (r, h) in rays.chunks(8).zip(packets.chunks_mut(8)) {
        let packet = RayPacket::<f32x8>::from_rays(r);
        scene
            .intersect_packet_in(mode, &packet)
            .write_active(&packet, h);
    }
    vec![
        ("single", single),
        ("stream", streamed),
        ("packets", packets),
    ]
}

/// The ray — from (0.3, 1, 0.2) on the cube's top face, direction (0, −1e−39, −1) — and
/// the same on every face, with subnormals down to the smallest, into the cube: each walk hits
/// the face ahead at `t = 1.2` (was: lost by every single-ray walk, `0·∞ = NaN` in the box
/// entry).
#[test]
fn rays_on_the_box_with_subnormal_direction_components_hit() {
    let mut rays = Vec::new();
    let mut want_t = Vec::new();
    for tiny in [1e-39f32, f32::from_bits(1), 1e-42] {
        for axis in 0..3 {
            for face in [-1.0f32, 1.0] {
                // Origin on the face `axis = face`, moving along the next axis towards −1,
                // with a subnormal component along `axis`, into the cube.
                let along = (axis + 1) % 3;
                let mut o = [0.3f32, 0.3, 0.3];
                o[axis] = face;
                o[along] = 0.2;
                let mut d = [0.0f32; 3];
                d[axis] = -face * tiny;
                d[along] = -1.0;
                rays.push(Ray::new(Vec3::from(o), Vec3::from(d)));
                want_t.push(1.2f32);
            }
        }
    }
    for (name, words) in cube_scenes() {
        let scene = Scene::from_words(&words).unwrap();
        for mode in [Mode::Fast, Mode::Watertight] {
            for (walk, hits) in every_walk(&scene, &rays, mode) {
                for ((ray, hit), want) in rays.iter().zip(&hits).zip(&want_t) {
                    assert!(
                        (hit.t - want).abs() < 1e-6,
                        "{name}, {mode:?}, {walk}: {hit:?} for {ray:?}, want t = {want}"
                    );
                }
            }
        }
    }
}
