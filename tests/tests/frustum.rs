//! The frustum walk (`kdray_core::traverse::frustum`) against the packet walk and the single-ray
//! walk, lane by lane: tiles of up to eight packets from one region towards one direction, with
//! spreads from none to wide (tiles of several octants fall back to their packets), zero
//! direction components of either sign, NaN rays and ranges that start before 0. The hits must be
//! the packet walk's bit for bit (the same walk from the entry node on), and so the single-ray
//! walk's `t`, with either primitive of a tie; occlusion the same. On closed meshes in watertight
//! mode, no ray from inside may escape.

use glam::Vec3;
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8};
use kdray_core::traverse::frustum::Entry;
use kdray_core::traverse::stream::order::{key, origin_scale};
use kdray_core::traverse::{Contents, Mixed, Mode, Triangles, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::closed::{Aim, icosphere, skinny_box};
use kdray_tests::strategies::{grid, grid_geometry, grid_point, scattered_triangles, scene_words};
use proptest::prelude::*;

/// A direction component, often a zero of either sign.
fn component() -> impl Strategy<Value = f32> {
    prop_oneof![4 => -1.0f32..1.0, 1 => Just(0.0f32), 1 => Just(-0.0f32)]
}

/// A tile of `8 * packets` rays: from one point (a pinhole) or points spread around it, towards
/// directions spread around one by a small to wide amount (a spread of 0 keeps zero components),
/// with the whole range or one that starts before 0, and now and then a NaN ray.
fn tile_rays() -> impl Strategy<Value = Vec<Ray>> {
    (
        (grid_point(), (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0)),
        (component(), component(), component()),
        prop_oneof![Just(0.0f32), Just(1e-3), Just(0.02), Just(0.2)],
        prop_oneof![3 => Just(0.0f32), 1 => Just(0.05)],
        prop_oneof![3 => Just((0.0f32, f32::INFINITY)), 1 => grid().prop_map(|a| (a, a + 3.0))],
        1usize..=8,
        prop::option::weighted(0.2, 0usize..64),
        any::<bool>(),
    )
        .prop_filter_map(
            "zero direction",
            |((g, o), (x, y, z), spread, jitter, (t0, t1), packets, nan, on_grid)| {
                let d = Vec3::new(x, y, z).try_normalize()?;
                let origin = if on_grid { g } else { Vec3::from(o) };
                let (u, v) = d.any_orthonormal_pair();
                let n = 8 * packets;
                let rays = (0..n).map(|i| {
                    // 2×4 pixels a packet, packets side by side: a camera's tile.
                    let (px, py) = ((i / 8 * 2 + i % 2) as f32, (i % 8 / 2) as f32);
                    let dir = (d + spread * (px * u + py * v)).normalize_or(d);
                    let o = origin + jitter * (px * u - py * v);
                    let ray = Ray::new(o, dir).with_range(t0, t1);
                    if nan == Some(i) {
                        Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), dir)
                    } else {
                        ray
                    }
                });
                Some(rays.collect())
            },
        )
}

/// Traces `rays` as tiles of `L` packets in `C`'s mode and checks every lane against the packet
/// walk (bit for bit) and the single-ray walk (the same `t`, a tie's primitive); the number of
/// tiles that started below the root.
fn check_tiles<C: Contents, L: Lanes>(scene: &Scene, mode: Mode, rays: &[Ray]) -> usize {
    let mut deeper = 0;
    for tile_rays in rays.chunks(8 * L::WIDTH) {
        let packets: Vec<RayPacket<L>> = tile_rays
            .chunks(L::WIDTH)
            .map(RayPacket::from_rays)
            .collect();
        if let Some(Entry::Node { depth, .. }) = scene.tile_entry::<C, L>(&packets) {
            deeper += usize::from(depth > 0);
        }
        let mut hits = vec![kdray_core::simd::HitPacket::<L>::miss(); packets.len()];
        scene.intersect_tile_with::<C, L>(&packets, &mut hits);
        let mut occluded = vec![L::splat(0.0); packets.len()];
        scene.occluded_tile_with::<C, L>(&packets, &mut occluded);
        for (p, packet) in packets.iter().enumerate() {
            let want_packet = scene.intersect_packet_with::<C, L>(packet);
            let want_occluded = scene.occluded_packet_with::<C, L>(packet).bitmask();
            assert_eq!(
                occluded[p].bitmask(),
                want_occluded,
                "occlusion of packet {p}"
            );
            let active = packet.active.bitmask();
            for lane in 0..L::WIDTH {
                let Some(ray) = tile_rays.get(p * L::WIDTH + lane) else {
                    continue;
                };
                let (got, packet_hit) = (hits[p].hit(lane), want_packet.hit(lane));
                if active >> lane & 1 == 0 {
                    assert!(!ray.is_finite(), "finite ray {ray:?} inactive");
                    continue;
                }
                assert_eq!(
                    (got.t.to_bits(), got.prim, got.u.to_bits(), got.v.to_bits()),
                    (
                        packet_hit.t.to_bits(),
                        packet_hit.prim,
                        packet_hit.u.to_bits(),
                        packet_hit.v.to_bits()
                    ),
                    "packet {p} lane {lane} ray {ray:?}: tile {got:?}, packet walk {packet_hit:?}"
                );
                let want = scene.intersect_in(mode, ray);
                assert_eq!(
                    got.t.to_bits(),
                    want.t.to_bits(),
                    "lane {lane} ray {ray:?}: tile {got:?}, single ray {want:?}"
                );
                if got.prim != want.prim {
                    let own = scene.intersect_prim::<C>(got.prim, ray).map(|h| h.0);
                    assert_eq!(own, Some(want.t), "prim {} is not a tie", got.prim);
                }
                assert_eq!(want_occluded >> lane & 1 == 1, scene.occluded_in(mode, ray));
            }
        }
    }
    deeper
}

macro_rules! tiles_match {
    ($name:ident, $lanes:ty, $mode:expr, $contents:ty) => {
        proptest! {
            #![proptest_config(ProptestConfig { cases: kdray_tests::cases(200), max_local_rejects: 1 << 24, ..ProptestConfig::default() })]
            #[test]
            fn $name(geom in grid_geometry(4), isect in prop_oneof![Just(80.0), Just(4.0)], tiles in prop::collection::vec(tile_rays(), 1..6)) {
                let words = scene_words(&geom, isect);
                let scene = Scene::from_words(&words).unwrap();
                for rays in &tiles {
                    check_tiles::<$contents, $lanes>(&scene, $mode, rays);
                }
            }
        }
    };
}

tiles_match!(tiles4_match_packets, f32x4, Mode::Fast, Mixed);
tiles_match!(tiles8_match_packets, f32x8, Mode::Fast, Mixed);
tiles_match!(
    watertight_tiles4_match_packets,
    f32x4,
    Mode::Watertight,
    Watertight<Mixed>
);
tiles_match!(
    watertight_tiles8_match_packets,
    f32x8,
    Mode::Watertight,
    Watertight<Mixed>
);

/// A camera's tiles over a deeper tree: most tiles start below the root, and every lane matches.
#[test]
fn camera_tiles_start_deep_and_match() {
    let geom = scattered_triangles(300);
    let words = scene_words(&geom, 80.0);
    let scene = Scene::from_words(&words).unwrap();
    let eye = Vec3::new(4.0, 3.0, 25.0);
    let (w, h) = (64u32, 64u32);
    // 16×4-pixel tiles of 2×4-pixel packets, as consecutive rays of the benchmark's order.
    let mut rays = Vec::new();
    for ty in (0..h).step_by(4) {
        for tx in (0..w).step_by(16) {
            for px in (tx..tx + 16).step_by(2) {
                for y in ty..ty + 4 {
                    for x in px..px + 2 {
                        let target = Vec3::new(x as f32 / 6.0 - 1.0, y as f32 / 6.0 - 1.0, 5.0);
                        rays.push(Ray::new(eye, (target - eye).normalize()));
                    }
                }
            }
        }
    }
    for mode in [Mode::Fast, Mode::Watertight] {
        let deeper = match mode {
            Mode::Fast => check_tiles::<Triangles, f32x8>(&scene, mode, &rays),
            Mode::Watertight => check_tiles::<Watertight<Triangles>, f32x8>(&scene, mode, &rays),
        };
        let tiles = rays.len() / 64;
        // (Most tiles cross a split plane across the view near the top: both children live.)
        assert!(
            deeper > tiles / 8,
            "{mode:?}: {deeper} of {tiles} tiles below the root"
        );
        check_tiles::<Triangles, f32x4>(&scene, Mode::Fast, &rays);
    }
}

/// Closed meshes in watertight mode: rays from inside to every vertex and edge point, sorted into
/// narrow tiles, all hit; and every lane matches.
#[test]
fn closed_meshes_let_no_tile_ray_escape() {
    let mut deeper = 0;
    for (name, mesh) in [("icosphere", icosphere(3)), ("skinny box", skinny_box(8))] {
        let words = kdray_tests::closed::Mesh::scene_words(&mesh);
        let scene = Scene::from_words(&words).unwrap();
        // From the centre, which lies on split planes (every tile needs both sides there), and
        // off the centre by about a third of the radius.
        let off = mesh.centre + Vec3::new(0.21, -0.33, 0.17);
        for (origin, aim) in [
            (mesh.centre, Aim::Exact),
            (mesh.centre, Aim::Normalized),
            (off, Aim::Normalized),
        ] {
            let mut rays = mesh.seam_rays(origin, aim);
            let [lo, hi] = scene.bounds();
            let scale = origin_scale(lo, hi);
            rays.sort_by_key(|r| key(r, lo, scale));
            type C = Watertight<Triangles>;
            deeper += check_tiles::<C, f32x8>(&scene, Mode::Watertight, &rays);
            for tile in rays.chunks(64) {
                let packets: Vec<_> = tile.chunks(8).map(RayPacket::<f32x8>::from_rays).collect();
                let mut hits = vec![kdray_core::simd::HitPacket::miss(); packets.len()];
                scene.intersect_tile_with::<C, f32x8>(&packets, &mut hits);
                for (p, h) in hits.iter().enumerate() {
                    for lane in 0..tile[p * 8..].len().min(8) {
                        let hit: Hit = h.hit(lane);
                        assert!(
                            hit.is_hit(),
                            "{name} {aim:?}: ray {:?} escaped",
                            tile[p * 8 + lane]
                        );
                    }
                }
            }
        }
    }
    // (The skinny box's tree is a few planes deep, crossed by every tile.)
    assert!(deeper > 0, "no tile below the root");
}
