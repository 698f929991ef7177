//! Triangle groups (format v9's groups section): one ray against four triangles matches the
//! scalar kernels lane by lane, bit for bit, in both modes; a tree stored with groups returns
//! exactly the hits of the same tree stored with an index list, for every walk (one ray over
//! nodes or wide nodes, stream, packets), closest and any hit, fast and watertight; validation rebuilds
//! each group and refuses any other; the serializer refuses groups for a scene with spheres; a
//! listed leaf's triangles, gathered four at a time for the same kernels, make the same groups;
//! two groups tested at once in eight lanes pick what testing their triangles in order keeps.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::format::{FormatError, contents, header, seal};
use kdray_core::group::{self, GROUP_WORDS, PAD_ID, slot};
use kdray_core::simd::group::{
    GroupLanes, Pair, closest_in_group, intersect_group, intersect_group_watertight,
};
use kdray_core::simd::{HitPacket, Lanes, RayPacket, f32x8};
use kdray_core::traverse::Mode;
use kdray_core::traverse::stream::{self, Config, Packets};
use kdray_core::watertight::{Shear, intersect_sheared};
use kdray_core::{Hit, Scene, Triangle};
use kdray_tests::strategies::{
    any_vec3, grid_geometry, grid_point, scattered_triangles, traversal_ray, vec3,
};
use proptest::prelude::*;

fn bits(h: &Hit) -> [u32; 4] {
    [h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()]
}

/// One tree over `geom` (priced per triangle or in groups), stored with an index list and with
/// groups, in `layout`.
fn both_leaves(
    geom: &Geometry,
    intersect_cost: f64,
    group: usize,
    layout: Layout,
) -> [Vec<u32>; 2] {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        group,
        ..BuildParams::default()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    [Leaves::List, Leaves::Groups]
        .map(|leaves| serialize_as(&tree, geom, 0.0, layout, leaves).expect("fits the format"))
}

/// A triangle of the kernel tests: anywhere, on the grid, or degenerate.
fn lane_triangle() -> impl Strategy<Value = [Vec3; 3]> {
    prop_oneof![
        3 => [vec3(-4.0, 4.0), vec3(-4.0, 4.0), vec3(-4.0, 4.0)],
        2 => [grid_point(), grid_point(), grid_point()],
        1 => (grid_point(), grid_point()).prop_map(|(a, b)| [a, b, a + (b - a) * 0.5]),
        1 => [any_vec3(), any_vec3(), any_vec3()],
    ]
    .prop_filter("finite edges", |v| {
        let t = Triangle::from_vertices(v[0], v[1], v[2]);
        t.e1.is_finite() && t.e2.is_finite()
    })
}

fn lanes_of(tris: &[[Vec3; 3]]) -> Vec<group::Lane> {
    tris.iter()
        .enumerate()
        .map(|(i, v)| {
            let t = Triangle::from_vertices(v[0], v[1], v[2]);
            (10 + i as u32, *v, t.min_det2())
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(2000)))]

    /// Lane `j` of the group kernels is the scalar kernel on triangle `j`: the same hit or miss,
    /// and `t`, `u`, `v` bit for bit; padding lanes never hit; the pick is what testing the lanes
    /// in order keeps.
    #[test]
    fn group_lanes_match_the_scalar_kernels(
        tris in prop::collection::vec(lane_triangle(), 1..=4),
        ray in traversal_ray(),
    ) {
        let lanes = lanes_of(&tris);
        let g = group::pack(&lanes);
        let shear = Shear::new(ray.dir);
        let fast = intersect_group(&g, &ray);
        let tight = intersect_group_watertight(&g, &ray, &shear);
        let (mut want_fast, mut want_tight) = (None, None);
        let mut seq = [ray; 2];
        for j in 0..group::WIDTH {
            let got = |h: &kdray_core::simd::PrimHits<kdray_core::simd::f32x4>| {
                (h.mask.to_bitmask() >> j & 1 == 1).then(|| {
                    let lane = |x: kdray_core::simd::f32x4| x.to_array()[j].to_bits();
                    [lane(h.t), lane(h.u), lane(h.v)]
                })
            };
            let Some(&(id, v, min_det2)) = lanes.get(j) else {
                prop_assert_eq!(got(&fast), None, "padding lane {} hit (fast)", j);
                prop_assert_eq!(got(&tight), None, "padding lane {} hit (watertight)", j);
                continue;
            };
            let tri = Triangle::from_vertices(v[0], v[1], v[2]);
            let scalar = |r: Option<(f32, f32, f32)>| r.map(|(t, u, w)| [t.to_bits(), u.to_bits(), w.to_bits()]);
            prop_assert_eq!(got(&fast), scalar(tri.intersect_prepared(&ray, min_det2)), "fast lane {}", j);
            prop_assert_eq!(got(&tight), scalar(intersect_sheared(&v, min_det2, &ray, &shear)), "watertight lane {}", j);
            // The lanes one after another, tmax shrinking: what the list layout's leaf keeps.
            if let Some((t, u, w)) = tri.intersect_prepared(&seq[0], min_det2) {
                seq[0].tmax = t;
                want_fast = Some((t, u, w, id));
            }
            if let Some((t, u, w)) = intersect_sheared(&v, min_det2, &seq[1], &shear) {
                seq[1].tmax = t;
                want_tight = Some((t, u, w, id));
            }
        }
        let key = |h: Option<(f32, f32, f32, u32)>| h.map(|(t, u, v, id)| (t.to_bits(), u.to_bits(), v.to_bits(), id));
        prop_assert_eq!(key(closest_in_group(&g, &fast)), key(want_fast));
        prop_assert_eq!(key(closest_in_group(&g, &tight)), key(want_tight));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(2000)))]

    /// Two groups in the eight lanes ([`Pair`]) keep the hit that testing their triangles one
    /// after another keeps (the second group's lanes only where strictly nearer), both modes, bit
    /// for bit, including ties between the groups (a triangle repeated in both).
    #[test]
    fn a_pair_of_groups_keeps_the_sequential_hit(
        tris in prop::collection::vec(lane_triangle(), 5..=8),
        repeat in any::<bool>(),
        ray in traversal_ray(),
    ) {
        let mut tris = tris;
        if repeat {
            tris[4] = tris[0];
        }
        let lanes = lanes_of(&tris);
        let (g0, g1) = (group::pack(&lanes[..4]), group::pack(&lanes[4..]));
        let shear = Shear::new(ray.dir);
        let (mut want_fast, mut want_tight) = (None, None);
        let mut seq = [ray; 2];
        for &(id, v, min_det2) in &lanes {
            let tri = Triangle::from_vertices(v[0], v[1], v[2]);
            if let Some((t, u, w)) = tri.intersect_prepared(&seq[0], min_det2) {
                seq[0].tmax = t;
                want_fast = Some((t, u, w, id));
            }
            if let Some((t, u, w)) = intersect_sheared(&v, min_det2, &seq[1], &shear) {
                seq[1].tmax = t;
                want_tight = Some((t, u, w, id));
            }
        }
        let pair = Pair(&g0, &g1);
        let fast = intersect_group(pair, &ray);
        let tight = intersect_group_watertight(pair, &ray, &shear);
        let key = |h: Option<(f32, f32, f32, u32)>| h.map(|(t, u, v, id)| (t.to_bits(), u.to_bits(), v.to_bits(), id));
        prop_assert_eq!(key(closest_in_group(pair, &fast)), key(want_fast));
        prop_assert_eq!(key(closest_in_group(pair, &tight)), key(want_tight));
        // The any-hit query's answer: some triangle hits the ray as given.
        let hits = |f: &dyn Fn(&[Vec3; 3], f32) -> bool| lanes.iter().any(|(_, v, m)| f(v, *m));
        let tri = |v: &[Vec3; 3]| Triangle::from_vertices(v[0], v[1], v[2]);
        prop_assert_eq!(fast.mask.any(), hits(&|v, m| tri(v).intersect_prepared(&ray, m).is_some()));
        prop_assert_eq!(tight.mask.any(), hits(&|v, m| intersect_sheared(v, m, &ray, &shear).is_some()));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(64)))]

    /// Groups change how a leaf is stored, not what any walk finds.
    #[test]
    fn grouped_leaves_return_the_index_lists_hits(
        geom in grid_geometry(1),
        isect in prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
        group in prop_oneof![Just(1usize), Just(4)],
        wide in any::<bool>(),
        rays in prop::collection::vec(traversal_ray(), 1..40),
    ) {
        let layout = if wide { Layout::Wide } else { Layout::Nodes };
        let [list, grouped] = both_leaves(&geom, isect, group, layout);
        let list = Scene::from_words(&list).unwrap();
        let grouped = Scene::from_words(&grouped).unwrap();
        prop_assert!(!list.has_groups());
        prop_assert_eq!(grouped.has_groups(), grouped.contents() & contents::GROUPS != 0);
        let n = rays.len();
        for mode in [Mode::Fast, Mode::Watertight] {
            let want: Vec<[u32; 4]> = rays.iter().map(|r| bits(&list.intersect_in(mode, r))).collect();
            let want_occ: Vec<bool> = rays.iter().map(|r| list.occluded_in(mode, r)).collect();
            let got: Vec<[u32; 4]> = rays.iter().map(|r| bits(&grouped.intersect_in(mode, r))).collect();
            prop_assert_eq!(&got, &want, "{:?}", mode);
            let occ: Vec<bool> = rays.iter().map(|r| grouped.occluded_in(mode, r)).collect();
            prop_assert_eq!(&occ, &want_occ, "{:?}", mode);
            let config = Config { mode, packets: Packets::Off, ..Config::default() };
            let mut hits = vec![Hit::MISS; n];
            let mut scratch = vec![0u64; stream::scratch_words(n)];
            stream::intersect(&grouped, &config, &rays, &mut hits, &mut scratch).unwrap();
            prop_assert_eq!(&hits.iter().map(bits).collect::<Vec<_>>(), &want, "stream {:?}", mode);
            let mut occ = vec![false; n];
            stream::occluded(&grouped, &config, &rays, &mut occ, &mut scratch).unwrap();
            prop_assert_eq!(&occ, &want_occ, "stream occlusion {:?}", mode);
            for chunk in rays.chunks(8) {
                let packet = RayPacket::<f32x8>::from_rays(chunk);
                let (a, b) = (list.intersect_packet_in(mode, &packet), grouped.intersect_packet_in(mode, &packet));
                let (mut ha, mut hb) = (vec![Hit::MISS; chunk.len()], vec![Hit::MISS; chunk.len()]);
                HitPacket::write_active(&a, &packet, &mut ha);
                HitPacket::write_active(&b, &packet, &mut hb);
                prop_assert_eq!(ha.iter().map(bits).collect::<Vec<_>>(), hb.iter().map(bits).collect::<Vec<_>>());
                let (oa, ob) = (list.occluded_packet_in(mode, &packet), grouped.occluded_packet_in(mode, &packet));
                prop_assert_eq!(oa.to_bitmask(), ob.to_bitmask());
            }
        }
    }
}

fn grouped_words() -> (Vec<u32>, usize) {
    let [_, words] = both_leaves(&scattered_triangles(300), 20.0, 4, Layout::Nodes);
    assert_ne!(words[header::CONTENTS] & contents::GROUPS, 0);
    assert_eq!(
        words[header::INDEX_COUNT],
        0,
        "groups replace the index list"
    );
    (words.clone(), words[header::GROUPS_OFFSET] as usize)
}

fn corrupt(edit: impl Fn(&mut Vec<u32>, usize, usize)) -> Result<(), FormatError> {
    let (mut w, base) = grouped_words();
    let n = w[header::GROUP_COUNT] as usize;
    // A group with a padding lane, to damage that too.
    let padded = (0..n)
        .find(|g| w[base + g * GROUP_WORDS + slot::IDS + 3] == PAD_ID)
        .expect("a group with padding");
    edit(&mut w, base, padded);
    seal(&mut w);
    Scene::from_words(&w).map(|_| ())
}

#[test]
fn validation_rebuilds_every_group() {
    let (w, _) = grouped_words();
    Scene::from_words(&w).expect("the serializer's groups validate");
    let bad_group = |r: Result<(), FormatError>| matches!(r, Err(FormatError::BadGroup { .. }));
    // A vertex bit, a threshold, an id, a padding lane's id, vertex or threshold.
    assert!(bad_group(corrupt(|w, b, _| w[b + slot::VERTICES + 5] ^= 1)));
    assert!(bad_group(corrupt(
        |w, b, _| w[b + slot::MIN_DET2] = f32::INFINITY.to_bits()
    )));
    assert!(bad_group(corrupt(|w, b, _| w[b + slot::IDS + 1] ^= 1)));
    assert!(bad_group(corrupt(|w, b, g| w
        [b + g * GROUP_WORDS + slot::IDS + 3] =
        0)));
    assert!(bad_group(corrupt(
        |w, b, g| w[b + g * GROUP_WORDS + 3] = 1.0f32.to_bits()
    )));
    assert!(bad_group(corrupt(|w, b, g| w
        [b + g * GROUP_WORDS + slot::MIN_DET2 + 3] =
        0)));
    // An id past the triangles is a bad primitive, not a read out of range.
    assert!(matches!(
        corrupt(|w, b, _| w[b + slot::IDS] = 300),
        Err(FormatError::BadPrimitive { .. })
    ));
    // The bit without the section, the section without the bit, groups beside an index list.
    assert_eq!(
        corrupt(|w, _, _| w[header::CONTENTS] &= !contents::GROUPS),
        Err(FormatError::BadContents)
    );
    assert_eq!(
        corrupt(|w, _, _| w[header::INDEX_COUNT] = 1),
        Err(FormatError::BadContents)
    );
}

#[test]
fn a_leaf_naming_another_leafs_groups_is_refused() {
    let (w, _) = grouped_words();
    let scene = Scene::from_words(&w).unwrap();
    let nodes = w[header::NODES_OFFSET] as usize;
    let leaves: Vec<usize> = (0..scene.node_count() as usize)
        .filter(|&i| {
            let n = scene.node(i as u32);
            n.is_leaf() && n.prim_count() > 1
        })
        .collect();
    assert!(leaves.len() >= 2);
    let (a, b) = (leaves[0], leaves[1]);
    let mut bad = w.clone();
    bad[nodes + 2 * b] = w[nodes + 2 * a]; // b's payload: a's first group
    seal(&mut bad);
    assert!(matches!(
        Scene::from_words(&bad),
        Err(FormatError::IndexOrder { .. })
    ));
}

#[test]
fn groups_need_a_scene_of_triangles_only() {
    let mut geom = scattered_triangles(300);
    geom.spheres.push((Vec3::splat(3.0), 1.0));
    let tree = build(&geom, &BuildParams::default(), None).unwrap();
    let err = serialize_as(&tree, &geom, 0.0, Layout::Nodes, Leaves::Groups).unwrap_err();
    assert!(err.contains("spheres"), "{err}");
}

#[test]
fn a_group_holds_its_lanes_as_the_triangles_section_does() {
    let v = [
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(4.0, 5.0, 6.0),
        Vec3::new(7.0, 8.0, 10.0),
    ];
    let g = group::pack(&[(5, v, 0.25)]);
    assert_eq!(g[slot::VERTICES], 1.0f32.to_bits()); // v0.x lane 0
    assert_eq!(g[slot::VERTICES + 4], 2.0f32.to_bits()); // v0.y lane 0
    assert_eq!(g[slot::VERTICES + 12 + 8], 6.0f32.to_bits()); // v1.z lane 0
    assert_eq!(g[slot::VERTICES + 24 + 8], 10.0f32.to_bits()); // v2.z lane 0
    assert_eq!(group::ids(&g), [5, PAD_ID, PAD_ID, PAD_ID]);
    assert_eq!(g[slot::MIN_DET2 + 1], f32::INFINITY.to_bits());
    assert_eq!(g[slot::VERTICES + 1], 0);
    assert_eq!(group::groups_for(1), 0);
    assert_eq!(group::groups_for(2), 1);
    assert_eq!(group::groups_for(5), 2);
}

/// A listed leaf's triangles are tested in lanes gathered from the triangles section
/// (`Scene::gather4`, `Scene::gather8`): they must be the lanes of the group `pack` makes of the
/// same triangles (four or fewer), or of the pair of groups (five to eight), padding included,
/// bit for bit: every vertex, threshold, id and lane's vertices.
#[test]
fn gathered_lanes_are_the_packed_groups_of_their_triangles() {
    let geom = scattered_triangles(40);
    let [list, _] = both_leaves(&geom, 80.0, 1, Layout::Nodes);
    let scene = Scene::from_words(&list).unwrap();
    let all: Vec<u32> = (0..scene.tri_count()).rev().collect();
    let pack = |ids: &[u32]| {
        let lanes: Vec<group::Lane> = ids
            .iter()
            .map(|&i| (i, scene.vertices(i), scene.prepared_triangle(i).1))
            .collect();
        group::pack(&lanes)
    };
    for width in 1..=8 {
        for ids in all.chunks(width) {
            if ids.len() <= 4 {
                same_lanes(scene.gather4(ids), &pack(ids), ids);
            } else {
                let (a, b) = ids.split_at(4);
                same_lanes(scene.gather8(ids), Pair(&pack(a), &pack(b)), ids);
            }
        }
    }
}

/// Asserts that two sets of group lanes hold the same bits in every lane.
fn same_lanes<G: GroupLanes, H: GroupLanes<L = G::L>>(g: G, h: H, ids: &[u32]) {
    let bits = |x: G::L| {
        x.to_array()
            .as_ref()
            .iter()
            .map(|f| f.to_bits())
            .collect::<Vec<_>>()
    };
    for k in 0..3 {
        let (a, b) = (g.vertex(k), h.vertex(k));
        for (x, y) in [(a.x, b.x), (a.y, b.y), (a.z, b.z)] {
            assert_eq!(bits(x), bits(y), "ids {ids:?}, vertex {k}");
        }
    }
    assert_eq!(bits(g.thresholds()), bits(h.thresholds()), "ids {ids:?}");
    for j in 0..G::L::WIDTH {
        assert_eq!(g.id(j), h.id(j), "ids {ids:?}, lane {j}");
        let (a, b) = (g.lane_vertices(j), h.lane_vertices(j));
        let words = |v: [Vec3; 3]| v.map(|p| p.to_array().map(f32::to_bits));
        assert_eq!(words(a), words(b), "ids {ids:?}, lane {j}");
    }
}

/// Only kernels for triangles-only contents read groups (`Contents::GROUPS`): a target that names
/// triangles and spheres links no group code, and `kernel_fits` refuses it a grouped scene, which
/// its walk would see as empty leaves — misses, never a read out of bounds.
#[test]
fn only_triangles_only_kernels_read_groups() {
    use kdray_core::render::kernel_fits;
    use kdray_core::traverse::{Contents, Mixed, Spheres, Triangles, Watertight};
    const { assert!(Triangles::GROUPS && Watertight::<Triangles>::GROUPS) };
    const { assert!(!Mixed::GROUPS && !Spheres::GROUPS && !Watertight::<Mixed>::GROUPS) };
    let geom = scattered_triangles(200);
    let [list, grouped] = both_leaves(&geom, 80.0, 4, Layout::Nodes);
    let (list, grouped) = (
        Scene::from_words(&list).unwrap(),
        Scene::from_words(&grouped).unwrap(),
    );
    assert!(kernel_fits::<Triangles>(&grouped) && kernel_fits::<Mixed>(&list));
    assert!(!kernel_fits::<Mixed>(&grouped) && !kernel_fits::<Watertight<Mixed>>(&grouped));
    // Mixed kernels on the grouped scene: the hits of one-triangle leaves, never one that the
    // triangles' kernels would not find, no panic.
    let mut rng = kdray_tests::Lcg::new(4);
    let mut hits = [0; 2];
    for _ in 0..2000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 14.0 - 2.0;
        let d = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize();
        let ray = kdray_core::Ray::new(o, d);
        hits[0] += usize::from(list.intersect_with::<Mixed>(&ray).is_hit());
        let h = grouped.intersect_with::<Mixed>(&ray);
        hits[1] += usize::from(h.is_hit() && h != grouped.intersect_with::<Triangles>(&ray));
    }
    assert!(
        hits[0] > 100,
        "the rays hit the list scene {} times",
        hits[0]
    );
    assert_eq!(
        hits[1], 0,
        "a Mixed kernel on groups found a hit Triangles did not"
    );
}
