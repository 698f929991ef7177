//! The two-level walk for packets (4, 8 and 16 lanes) and streams (`kdray_core::instance::packet`,
//! `kdray_core::instance::stream`) against the single-ray two-level walk, ray by ray, in both
//! modes, with random transforms (mirrors, shears, scales from 10⁻⁶ to 10⁶): the same `t` bits,
//! the same instance, user id and primitive, or, where two tie at exactly that `t`, one that the
//! ray hits at that `t` too; occlusion the same per lane; inactive lanes never written. Then
//! translations exact in f32 against the merged mesh's single-ray walk, bit for bit.

use glam::Vec3;
use kdray::instances::{Placement, top_level};
use kdray_core::instance::walk::into_instance;
use kdray_core::instance::{Affine, InstanceHit, InstancedScene, stream};
use kdray_core::simd::{Lanes, RayPacket, f32x4, f32x8, f32x16};
use kdray_core::traverse::stream::{Config, Packets, scratch_words};
use kdray_core::traverse::{Mode, Triangles, Watertight};
use kdray_core::{Ray, Scene};
use kdray_tests::strategies::{grid_point, grid_triangles, unit_vec3};
use kdray_tests::walks::{node_words, wide_words};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// A transform: a random linear part (rotations, shears, mirrors) times a scale of either sign
/// from 10⁻⁶ to 10⁶, and a translation of the scale's order; refused only if not invertible.
fn transform() -> impl Strategy<Value = Affine> {
    let scale = prop_oneof![
        Just(1.0f32),
        Just(-1.0),
        Just(1.0e-6),
        Just(-3.0e-3),
        Just(250.0),
        Just(-1.0e6),
        0.5f32..2.0
    ];
    let linear = prop_oneof![
        // Shears, mirrors, anything.
        prop::array::uniform9(-1.0f32..1.0),
        // The identity mirrored in some axes.
        (any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(a, b, c)| {
            let s = |m: bool| if m { -1.0 } else { 1.0 };
            [s(a), 0.0, 0.0, 0.0, s(b), 0.0, 0.0, 0.0, s(c)]
        }),
    ];
    (linear, scale, prop::array::uniform3(-4.0f32..4.0)).prop_filter_map(
        "not invertible",
        |(m, s, t)| {
            let a = Affine([
                m[0] * s,
                m[1] * s,
                m[2] * s,
                t[0] * s,
                m[3] * s,
                m[4] * s,
                m[5] * s,
                t[1] * s,
                m[6] * s,
                m[7] * s,
                m[8] * s,
                t[2] * s,
            ]);
            a.inverse().map(|_| a)
        },
    )
}

/// Whether `got` is an answer as good as the single-ray walk's `want` for `ray`: the same `t`
/// bits, and the same instance and primitive or another that `ray`, moved into its instance,
/// hits at exactly that `t` (a tie); the user id the record's.
fn same_answer(
    top: &InstancedScene,
    ray: &Ray,
    mode: Mode,
    got: &InstanceHit,
    want: &InstanceHit,
) -> Result<(), TestCaseError> {
    prop_assert_eq!(
        got.t.to_bits(),
        want.t.to_bits(),
        "{:?} {:?}: {:?} against {:?}",
        mode,
        ray,
        got,
        want
    );
    if !want.is_hit() {
        prop_assert_eq!(got, want);
        return Ok(());
    }
    prop_assert_eq!(got.user_id, top.instance(got.instance).user_id);
    if (got.instance, got.prim) != (want.instance, want.prim) {
        let (local, back) = into_instance(&top.instance(got.instance).inverse, ray).unwrap();
        let bottom = top.bottom_of(got.instance);
        let own = match mode {
            Mode::Fast => bottom.intersect_prim::<Triangles>(got.prim, &local),
            Mode::Watertight => bottom.intersect_prim::<Watertight<Triangles>>(got.prim, &local),
        };
        prop_assert_eq!(
            own.map(|h| (h.0 * back).to_bits()),
            Some(want.t.to_bits()),
            "{:?} {:?}: {:?} is not a tie with {:?}",
            mode,
            ray,
            got,
            want
        );
    }
    Ok(())
}

/// Every way of tracing `rays` against the single-ray walk: packets of 4 and 8 (closest and any
/// hit), and the stream with each kind of packets.
fn check_all(top: &InstancedScene, rays: &[Ray]) -> Result<(), TestCaseError> {
    for mode in [Mode::Fast, Mode::Watertight] {
        let want: Vec<InstanceHit> = rays.iter().map(|r| top.intersect_in(mode, r)).collect();
        let any: Vec<bool> = rays.iter().map(|r| top.occluded_in(mode, r)).collect();
        check_packets::<f32x4>(top, rays, mode, &want, &any)?;
        check_packets::<f32x8>(top, rays, mode, &want, &any)?;
        check_packets::<f32x16>(top, rays, mode, &want, &any)?;
        for packets in [Packets::Off, Packets::Four, Packets::Eight] {
            let config = Config {
                mode,
                packets,
                ..Config::default()
            };
            let mut hits = vec![InstanceHit::MISS; rays.len()];
            let mut occluded = vec![false; rays.len()];
            let mut scratch = vec![0u64; scratch_words(rays.len())];
            stream::intersect(top, &config, rays, &mut hits, &mut scratch).unwrap();
            stream::occluded(top, &config, rays, &mut occluded, &mut scratch).unwrap();
            for (i, ray) in rays.iter().enumerate() {
                if packets == Packets::Off {
                    prop_assert_eq!(hits[i], want[i], "stream without packets, ray {}", i);
                }
                same_answer(top, ray, mode, &hits[i], &want[i])?;
                prop_assert_eq!(occluded[i], any[i], "stream occlusion, ray {} {:?}", i, ray);
            }
        }
    }
    Ok(())
}

fn check_packets<L: Lanes>(
    top: &InstancedScene,
    rays: &[Ray],
    mode: Mode,
    want: &[InstanceHit],
    any: &[bool],
) -> Result<(), TestCaseError> {
    let sentinel = InstanceHit {
        t: -7.0,
        prim: 77,
        u: 7.0,
        v: 7.0,
        instance: 77,
        user_id: 77,
    };
    for (c, chunk) in rays.chunks(L::WIDTH).enumerate() {
        let packet = RayPacket::<L>::from_rays(chunk);
        let mut out = [sentinel; 16];
        top.intersect_packet_in(mode, &packet)
            .write_active(&packet, &mut out[..L::WIDTH]);
        let occluded = top.occluded_packet_in(mode, &packet).bitmask();
        for (i, ray) in chunk.iter().enumerate() {
            let k = c * L::WIDTH + i;
            if !ray.is_finite() {
                prop_assert_eq!(out[i], sentinel, "inactive lane {} written", i);
                prop_assert_eq!(occluded >> i & 1, 0);
                continue;
            }
            same_answer(top, ray, mode, &out[i], &want[k])?;
            prop_assert_eq!(
                occluded >> i & 1 == 1,
                any[k],
                "{}-lane occlusion, lane {} {:?}",
                L::WIDTH,
                i,
                ray
            );
        }
        for (i, slot) in out.iter().enumerate().skip(chunk.len()) {
            prop_assert_eq!(*slot, sentinel, "lane {} past the rays written", i);
        }
    }
    Ok(())
}

/// Packets of rays from one region towards points of the instances (coherent, as a camera's),
/// rays in every direction, and a few odd ones (a band of `t`, a zero component, non-finite).
fn rays_at(placements: &[Placement], aims: &[(usize, Vec3, Vec3, f32, u8)]) -> Vec<Ray> {
    aims.iter()
        .map(|&(k, p, dir, back, kind)| {
            let pl = &placements[k % placements.len()];
            let target = pl.transform.point(p);
            let m = &pl.transform.0;
            let size = (m[0].abs() + m[5].abs() + m[10].abs()).max(1e-6);
            let ray = Ray::new(target - dir * back * size, dir);
            match kind % 8 {
                0 => ray.with_range(0.5 * back * size, 1.5 * back * size),
                1 => Ray::new(
                    ray.origin,
                    Vec3::new(dir.x, 0.0, dir.z).normalize_or(Vec3::X),
                ),
                2 if k % 5 == 0 => Ray::new(Vec3::NAN, dir),
                _ => ray,
            }
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: kdray_tests::cases(120), max_local_rejects: 1 << 20, ..ProptestConfig::default() })]

    #[test]
    fn packets_and_streams_give_the_single_ray_walks_answers(
        meshes in prop::collection::vec(grid_triangles(), 1..3),
        placed in prop::collection::vec((0usize..2, transform()), 1..14),
        // One aim shared by a packet's lanes, jittered, or each lane its own.
        aims in prop::collection::vec((0usize..14, grid_point(), unit_vec3(), 0.5f32..20.0, any::<u8>()), 1..40),
        coherent in any::<bool>(),
    ) {
        // The first bottom with wide nodes, the second without (the stream's two paths).
        let words: Vec<Vec<u32>> = meshes
            .iter()
            .enumerate()
            .map(|(b, m)| if b == 0 { wide_words(m.clone(), false) } else { node_words(m.clone()) })
            .collect();
        let bottoms: Vec<Scene> = words.iter().map(|w| Scene::from_words(w).unwrap()).collect();
        let placements: Vec<Placement> = placed
            .iter()
            .enumerate()
            .map(|(k, &(b, transform))| Placement {
                bottom: (b % bottoms.len()) as u32,
                transform,
                user_id: 1000 + k as u32,
            })
            .collect();
        let top_words = top_level(&bottoms, &placements).unwrap();
        let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
        let aims: Vec<_> = if coherent {
            // Eight lanes towards one instance from one side, each at its own grid point.
            aims.iter()
                .map(|&(_, p, _, back, kind)| (aims[0].0, p, aims[0].2, back.max(aims[0].3), kind))
                .collect()
        } else {
            aims
        };
        check_all(&top, &rays_at(&placements, &aims))?;
    }

    #[test]
    fn translated_packets_give_the_merged_meshs_answers_bit_for_bit(
        mesh in grid_triangles(),
        offsets in prop::collection::vec(prop::array::uniform3(-6i32..=6), 1..10),
        rays in prop::collection::vec((grid_point(), unit_vec3(), -3i32..=3), 1..40),
    ) {
        let words = wide_words(mesh.clone(), true);
        let bottoms = [Scene::from_words(&words).unwrap()];
        let offset = |k: usize| Vec3::from_array(offsets[k].map(|x| x as f32));
        let placements: Vec<Placement> = (0..offsets.len())
            .map(|k| {
                let t = offset(k);
                Placement {
                    bottom: 0,
                    transform: Affine([1.0, 0.0, 0.0, t.x, 0.0, 1.0, 0.0, t.y, 0.0, 0.0, 1.0, t.z]),
                    user_id: k as u32,
                }
            })
            .collect();
        let top_words = top_level(&bottoms, &placements).unwrap();
        let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
        let merged: Vec<[Vec3; 3]> = (0..offsets.len())
            .flat_map(|k| mesh.iter().map(move |tri| tri.map(|v| v + offset(k))))
            .collect();
        let merged_words = wide_words(merged, true);
        let merged = Scene::from_words(&merged_words).unwrap();
        // Origins on the grid, moved by whole units: every coordinate exact in f32.
        let rays: Vec<Ray> = rays
            .iter()
            .map(|&(p, dir, shift)| Ray::new(p + Vec3::splat(shift as f32), dir))
            .collect();
        for mode in [Mode::Fast, Mode::Watertight] {
            for chunk in rays.chunks(8) {
                let p4: Vec<InstanceHit> = chunk
                    .chunks(4)
                    .flat_map(|c| {
                        let packet = RayPacket::<f32x4>::from_rays(c);
                        let hits = top.intersect_packet_in(mode, &packet);
                        (0..c.len()).map(move |i| hits.hit(i))
                    })
                    .collect();
                let packet = RayPacket::<f32x8>::from_rays(chunk);
                let p8 = top.intersect_packet_in(mode, &packet);
                let any8 = top.occluded_packet_in(mode, &packet).bitmask();
                for (i, ray) in chunk.iter().enumerate() {
                    let want = merged.intersect_in(mode, ray);
                    for got in [p4[i], p8.hit(i)] {
                        prop_assert_eq!(got.t.to_bits(), want.t.to_bits(), "{:?} {:?}: {:?} vs {:?}", mode, ray, got, want);
                    }
                    prop_assert_eq!(any8 >> i & 1 == 1, merged.occluded_in(mode, ray));
                }
            }
        }
    }
}

/// Wrong lengths and short scratch are errors, not panics; an empty stream is fine.
#[test]
fn stream_arguments_are_checked() {
    let words = node_words(vec![[Vec3::ZERO, Vec3::X, Vec3::Y]]);
    let bottoms = [Scene::from_words(&words).unwrap()];
    let placements = [Placement {
        bottom: 0,
        transform: Affine::IDENTITY,
        user_id: 3,
    }];
    let top_words = top_level(&bottoms, &placements).unwrap();
    let top = InstancedScene::from_words(&top_words, &bottoms).unwrap();
    let rays = [Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z); 3];
    let config = Config::default();
    let mut hits = [InstanceHit::MISS; 2];
    let mut scratch = [0u64; 6];
    assert!(stream::intersect(&top, &config, &rays, &mut hits, &mut scratch).is_err());
    let mut hits = [InstanceHit::MISS; 3];
    assert!(stream::intersect(&top, &config, &rays, &mut hits, &mut scratch[..5]).is_err());
    stream::intersect(&top, &config, &rays, &mut hits, &mut scratch).unwrap();
    assert!(hits.iter().all(|h| h.user_id == 3 && h.t == 1.0));
    stream::intersect(&top, &config, &[], &mut [], &mut []).unwrap();
}
