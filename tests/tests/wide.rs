//! The wide layout (format v10's wide section): the walk over wide nodes returns the closest hit
//! of brute force and of the node walk (the same `t` bits; where two primitives tie at that `t`,
//! either), closest and any hit, fast and watertight, on the random grid scenes of the
//! brute-force tests, with lists and with groups; its slab test matches the scalar reference
//! lane by lane; closed meshes let no watertight ray escape; and validation refuses damaged
//! wide sections.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::format::{FormatError, contents, header, seal};
use kdray_core::traverse::wide::walk::{RaySetup, in_order, slab, slab_scalar};
use kdray_core::traverse::wide::{
    BOXES, EMPTY_BOX, LEAF_REF, NODE_WORDS, ORDERS, PART_REF, REFS, WIDTH, WideNode, set_slot_box,
    slot_box,
};
use kdray_core::traverse::{Contents, Mixed, Mode, Triangles, Watertight};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::brute_force;
use kdray_tests::strategies::{grid_geometry, scattered_triangles, traversal_ray, vec3};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// `geom`'s tree with the node layout and with wide nodes, with `leaves`.
fn layouts(geom: &Geometry, intersect_cost: f64, leaves: Leaves) -> (Vec<u32>, Vec<u32>) {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        ..leaves.build_params()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    let words = |layout| serialize_as(&tree, geom, 0.0, layout, leaves).expect("fits the format");
    (words(Layout::Nodes), words(Layout::Wide))
}

/// `got` is `want`'s closest hit: the same `t`, and a primitive that `ray` hits at that `t`.
fn same_closest<C: Contents>(
    scene: &Scene,
    ray: &Ray,
    got: Hit,
    want: Hit,
) -> Result<(), TestCaseError> {
    prop_assert!(
        got.t == want.t,
        "ray {:?}: got {:?}, want {:?}",
        ray,
        got,
        want
    );
    if got.prim != want.prim {
        let own = scene.intersect_prim::<C>(got.prim, ray).map(|h| h.0);
        prop_assert_eq!(
            own,
            Some(want.t),
            "ray {:?}: prim {} is not a tie",
            ray,
            got.prim
        );
    }
    Ok(())
}

/// The wide walk against brute force and the node walk, in `mode` with contents `C`.
fn check<C: Contents>(
    wide: &Scene,
    nodes: &Scene,
    ray: &Ray,
    mode: Mode,
) -> Result<(), TestCaseError> {
    let got = wide.intersect_in(mode, ray);
    same_closest::<C>(wide, ray, got, brute_force::<C>(wide, ray))?;
    same_closest::<C>(wide, ray, got, nodes.intersect_in(mode, ray))?;
    prop_assert_eq!(
        wide.occluded_in(mode, ray),
        got.is_hit(),
        "any hit, {:?} {:?}",
        mode,
        ray
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(128)))]

    #[test]
    fn wide_walk_returns_the_closest_hit(
        geom in grid_geometry(3),
        isect in prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
        rays in prop::collection::vec(traversal_ray(), 40),
    ) {
        let (nodes, wide) = layouts(&geom, isect, Leaves::List);
        let (nodes, wide) = (Scene::from_words(&nodes).unwrap(), Scene::from_words(&wide).unwrap());
        prop_assert!(nodes.wide_nodes().is_empty() && !wide.wide_nodes().is_empty());
        for ray in &rays {
            check::<Mixed>(&wide, &nodes, ray, Mode::Fast)?;
            check::<Watertight<Mixed>>(&wide, &nodes, ray, Mode::Watertight)?;
        }
    }

    #[test]
    fn wide_walk_over_groups_returns_the_closest_hit(
        geom in grid_geometry(1),
        isect in prop_oneof![Just(80.0), Just(2.0)],
        rays in prop::collection::vec(traversal_ray(), 40),
    ) {
        prop_assume!(!geom.triangles.is_empty());
        let (nodes, wide) = layouts(&geom, isect, Leaves::Groups);
        let (nodes, wide) = (Scene::from_words(&nodes).unwrap(), Scene::from_words(&wide).unwrap());
        for ray in &rays {
            check::<Triangles>(&wide, &nodes, ray, Mode::Fast)?;
            check::<Watertight<Triangles>>(&wide, &nodes, ray, Mode::Watertight)?;
        }
    }

    /// Each lane of the 8-wide slab test is the scalar slab test of its box, in both modes.
    #[test]
    fn slab_lanes_match_the_scalar_reference(
        boxes in prop::collection::vec((vec3(-4.0, 4.0), vec3(0.0, 3.0), 0..6u8), WIDTH),
        ray in traversal_ray(),
        limit in prop_oneof![Just(f32::INFINITY), 0.0f32..10.0],
    ) {
        prop_assume!(ray.is_finite());
        let mut node: WideNode = [0; NODE_WORDS];
        let mut list = [EMPTY_BOX; WIDTH];
        for (slot, &(lo, size, kind)) in boxes.iter().enumerate() {
            // Some boxes flat, some unused, some degenerate to a point.
            let b = match kind {
                0 => EMPTY_BOX,
                1 => [lo, lo],
                2 => [lo, lo + Vec3::new(size.x, 0.0, size.z)],
                _ => [lo, lo + size],
            };
            list[slot] = b;
            set_slot_box(&mut node, slot, b);
        }
        let setup = RaySetup::new(&ray);
        for (mask, entry, conservative) in [
            (slab::<Mixed>(&node, &setup, limit).0, slab::<Mixed>(&node, &setup, limit).1, false),
            (slab::<Watertight<Mixed>>(&node, &setup, limit).0, slab::<Watertight<Mixed>>(&node, &setup, limit).1, true),
        ] {
            for (slot, b) in list.iter().enumerate() {
                let (hit, t) = if conservative {
                    slab_scalar::<Watertight<Mixed>>(*b, &ray, limit)
                } else {
                    slab_scalar::<Mixed>(*b, &ray, limit)
                };
                prop_assert_eq!(mask >> slot & 1 == 1, hit, "slot {} box {:?} ray {:?}", slot, b, ray);
                prop_assert!(t == entry[slot] || (t.is_nan() && entry[slot].is_nan()), "slot {} entry {} vs {}", slot, t, entry[slot]);
            }
        }
    }
}

proptest! {
    /// The entered slots put in an octant's front-to-back order in lanes ([`in_order`]) are the
    /// loop over the order word's positions: bit `k` is the slot at position `k` entered, for
    /// the positions below the node's count and none past it (which read slot 0).
    #[test]
    fn entered_slots_in_order_match_the_loop_over_positions(
        slots in Just((0..WIDTH as u32).collect::<Vec<_>>()).prop_shuffle(),
        count in 1..=WIDTH,
        mask in 0u32..256,
    ) {
        let order = slots[..count]
            .iter()
            .enumerate()
            .fold((count as u32) << 24, |o, (k, &s)| o | s << (3 * k));
        let expected = (0..count).fold(0, |bits, k| bits | (mask >> slots[k] & 1) << k);
        prop_assert_eq!(in_order(order, mask), expected, "order {:#x} mask {:#b}", order, mask);
    }
}

/// A ray along a box's face, and rays with zero and subnormal direction components from a
/// box's corner, enter it (the NaN-safe branch of the slab test).
#[test]
fn rays_in_a_face_or_with_subnormal_components_enter_the_box() {
    let b = [Vec3::ZERO, Vec3::ONE];
    let mut node: WideNode = [0; NODE_WORDS];
    for slot in 0..WIDTH {
        set_slot_box(&mut node, slot, if slot == 3 { b } else { EMPTY_BOX });
    }
    let tiny = f32::from_bits(1);
    for (o, d) in [
        (Vec3::new(0.0, 0.5, -1.0), Vec3::Z),
        (Vec3::new(1.0, 1.0, 2.0), -Vec3::Z),
        (
            Vec3::new(0.3, 1.0, 0.2),
            Vec3::new(0.0, -tiny, -1.0).normalize(),
        ),
        (Vec3::new(0.3, 1.0, 0.2), Vec3::new(-0.0, -1e-39, -1.0)),
    ] {
        let ray = Ray::new(o, d);
        for mask in [
            slab::<Mixed>(&node, &RaySetup::new(&ray), f32::INFINITY).0,
            slab::<Watertight<Mixed>>(&node, &RaySetup::new(&ray), f32::INFINITY).0,
        ] {
            assert_eq!(mask, 1 << 3, "ray {o:?} {d:?}");
        }
    }
}

/// The wide tree of a closed mesh lets no watertight ray escape (the seam rays of
/// `stiff_closed`), and its watertight walk answers what the node walk's does.
#[test]
fn closed_meshes_let_no_watertight_ray_escape_the_wide_walk() {
    use kdray::closed::{Aim, icosphere, skinny_box};
    for (name, mesh) in [("icosphere", icosphere(4)), ("skinny box", skinny_box(64))] {
        let geom = Geometry {
            triangles: mesh.triangles(),
            ..Geometry::default()
        };
        let (nodes, wide) = layouts(&geom, 80.0, Leaves::List);
        let (nodes, wide) = (
            Scene::from_words(&nodes).unwrap(),
            Scene::from_words(&wide).unwrap(),
        );
        let rays = mesh.seam_rays(mesh.centre, Aim::Exact);
        let escapes = rays
            .iter()
            .filter(|r| !wide.intersect_in(Mode::Watertight, r).is_hit())
            .count();
        assert_eq!(
            escapes,
            0,
            "{name}: {escapes} of {} rays escaped",
            rays.len()
        );
        for r in rays.iter().step_by(7) {
            let (a, b) = (
                wide.intersect_in(Mode::Watertight, r),
                nodes.intersect_in(Mode::Watertight, r),
            );
            assert!(a.t == b.t, "{name}: {a:?} vs {b:?}");
        }
    }
}

/// The wide section of `words`: its offset and node count.
fn section(words: &[u32]) -> (usize, usize) {
    (
        words[header::WIDE_OFFSET] as usize,
        words[header::WIDE_COUNT] as usize,
    )
}

/// `words` with `f` applied to its wide section, resealed; what validation says.
fn damaged(words: &[u32], f: impl Fn(&mut [u32])) -> Result<(), FormatError> {
    let mut w = words.to_vec();
    let (at, n) = section(&w);
    f(&mut w[at..at + n * NODE_WORDS]);
    seal(&mut w);
    Scene::from_words(&w).map(|_| ())
}

#[test]
fn damaged_wide_sections_are_refused() {
    let geom = scattered_triangles(300);
    let (_, words) = layouts(&geom, 80.0, Leaves::List);
    let scene = Scene::from_words(&words).unwrap();
    assert_ne!(scene.contents() & contents::WIDE, 0);
    let n = scene.wide_nodes().len();
    assert!(n > 3, "{n} wide nodes");
    let at = |node: usize, word: usize| node * NODE_WORDS + word;
    // Find a wide node with a leaf child and one with a wide child.
    let nodes = scene.wide_nodes();
    let leaf_slot =
        |w: &WideNode| (0..WIDTH).find(|&k| w[REFS + k] & LEAF_REF != 0 && w[REFS + k] != 0);
    let (lw, lk) = (0..n)
        .find_map(|i| leaf_slot(&nodes[i]).map(|k| (i, k)))
        .unwrap();
    let (ww, wk) = (0..WIDTH)
        .find(|&k| nodes[0][REFS + k] != 0 && nodes[0][REFS + k] & LEAF_REF == 0)
        .map(|k| (0, k))
        .unwrap();

    // A reference to another leaf (a later one leaves this one out), another wide node, back,
    // or out of range.
    assert!(matches!(
        damaged(&words, |s| s[at(lw, REFS + lk)] ^= 1),
        Err(FormatError::BadWideNode { .. } | FormatError::WideLeafLeftOut { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(ww, REFS + wk)] += 1),
        Err(FormatError::BadWideNode { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(ww, REFS + wk)] = 0),
        Err(FormatError::BadWideNode { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(ww, REFS + wk)] = 1 << 30),
        Err(FormatError::BadWideNode { .. })
    ));
    // An order word naming a slot twice (so leaving one out), a count changed, an unused slot's
    // box or reference filled, an order naming an unused slot. (Two slots swapped in an order
    // word is a different order, not a wrong one: `recut_sections_answer_as_the_writers`.)
    assert!(matches!(
        damaged(&words, |s| {
            let first = s[at(0, ORDERS + 3)] & 7;
            s[at(0, ORDERS + 3)] = s[at(0, ORDERS + 3)] & !(7 << 3) | first << 3;
        }),
        Err(FormatError::BadWideNode { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(0, ORDERS)] ^= 1 << 24),
        Err(FormatError::BadWideNode { .. })
    ));
    let (fw, fk) = (0..n)
        .find_map(|i| {
            (0..WIDTH)
                .find(|&k| nodes[i][ORDERS] >> 24 <= k as u32)
                .map(|k| (i, k))
        })
        .expect("some node with an unused slot");
    assert!(matches!(
        damaged(&words, |s| s[at(fw, ORDERS + 5)] |= 7),
        Err(FormatError::BadWideNode { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(fw, REFS + fk)] = 5),
        Err(FormatError::BadWideNode { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[at(fw, BOXES + fk)] = 0f32.to_bits()),
        Err(FormatError::BadWideNode { .. })
    ));
    // A leaf's box shrunk off its triangles, grown out of its parent's box, or made NaN.
    let lo_x = at(lw, BOXES + lk);
    let hi_x = at(lw, BOXES + 8 + lk);
    assert!(
        matches!(
            damaged(&words, |s| s[lo_x] = s[hi_x]),
            Err(FormatError::BadWideBox { .. })
        ),
        "a box shrunk to its high face"
    );
    assert!(matches!(
        damaged(&words, |s| s[hi_x] = 1e30f32.to_bits()),
        Err(FormatError::BadWideBox { .. })
    ));
    assert!(matches!(
        damaged(&words, |s| s[lo_x] = f32::NAN.to_bits()),
        Err(FormatError::BadWideBox { .. })
    ));
    // A wide child's box that no longer holds its children's.
    let wlo = at(ww, BOXES + 16 + wk); // low y
    let whi = at(ww, BOXES + 24 + wk); // high y
    assert!(matches!(
        damaged(&words, |s| s[wlo] = s[whi]),
        Err(FormatError::BadWideBox { .. })
    ));
    // A section shorter by a node, or with its bit cleared.
    let mut w = words.clone();
    w[header::WIDE_COUNT] -= 1;
    seal(&mut w);
    assert!(Scene::from_words(&w).is_err());
    let mut w = words.clone();
    w[header::CONTENTS] &= !contents::WIDE;
    seal(&mut w);
    assert_eq!(Scene::from_words(&w).err(), Some(FormatError::BadContents));
    // A leaf of the node tree that no wide node references (the slot turned unused).
    let (ow, ok) = (0..n)
        .find_map(|i| {
            let count = (nodes[i][ORDERS] >> 24) as usize;
            let last = count.checked_sub(1)?;
            let r = nodes[i][REFS + last];
            (r & LEAF_REF != 0 && r & PART_REF == 0 && last > 0).then_some((i, last))
        })
        .expect("some node whose last slot is a whole leaf");
    assert!(matches!(
        damaged(&words, |s| {
            s[at(ow, REFS + ok)] = 0;
            let mut node: WideNode = s[at(ow, 0)..at(ow + 1, 0)].try_into().unwrap();
            set_slot_box(&mut node, ok, EMPTY_BOX);
            for o in 0..WIDTH {
                let order = node[ORDERS + o];
                let rank = (0..ok + 1)
                    .find(|&r| order >> (3 * r) & 7 == ok as u32)
                    .unwrap();
                // Drop `ok` from the order: the later positions move up one, the count falls.
                let low = order & ((1 << (3 * rank)) - 1);
                let high = (order & 0xff_ffff) >> (3 * (rank + 1)) << (3 * rank);
                node[ORDERS + o] = (ok as u32) << 24 | high | low;
            }
            s[at(ow, 0)..at(ow + 1, 0)].copy_from_slice(&node);
        }),
        Err(FormatError::WideLeafLeftOut { .. })
    ));
    // The undamaged words validate.
    assert!(damaged(&words, |_| {}).is_ok());
}

/// `words` (a scene with a wide section, the last section) with a wide section the writer
/// would not make: a new root whose one child is the writer's root (a cut the greedy cut never
/// takes), every order word reversed (back to front), and, when `grow`, every box that is not
/// empty grown to the scene box. Validation checks what the walk needs for its answers, not
/// the writer's cut, orders or tight boxes (issue 38), so it accepts this; resealed.
fn recut(words: &[u32], grow: bool) -> Vec<u32> {
    let (at, n) = section(words);
    assert_eq!(
        at + n * NODE_WORDS,
        words.len(),
        "the wide section is the last"
    );
    let scene = Scene::from_words(words).unwrap();
    let bounds = scene.bounds();
    let mut root: WideNode = [0; NODE_WORDS];
    for slot in 0..WIDTH {
        set_slot_box(&mut root, slot, EMPTY_BOX);
    }
    set_slot_box(&mut root, 0, bounds);
    root[REFS] = 1;
    root[ORDERS..].fill(1 << 24);
    let mut section: Vec<WideNode> = vec![root];
    for node in scene.wide_nodes() {
        let mut node = *node;
        let count = (node[ORDERS] >> 24) as usize;
        for k in 0..count {
            if node[REFS + k] & LEAF_REF == 0 {
                node[REFS + k] += 1;
            }
            let b = kdray_core::format::wide::slot_box(&node, k);
            if grow && b[0].cmple(b[1]).all() {
                set_slot_box(&mut node, k, bounds);
            }
        }
        for o in 0..WIDTH {
            let order = node[ORDERS + o];
            let reversed = (0..count).fold(0, |w, r| {
                w | (order >> (3 * (count - 1 - r)) & 7) << (3 * r)
            });
            node[ORDERS + o] = (count as u32) << 24 | reversed;
        }
        section.push(node);
    }
    let mut w = words[..at].to_vec();
    w.extend(section.iter().flatten());
    w[header::TOTAL_WORDS] = w.len() as u32;
    w[header::WIDE_COUNT] = section.len() as u32;
    seal(&mut w);
    w
}

/// A chain of wide nodes of two children each, one the next wide node and the other a leaf,
/// every box the scene's, the leaves in order. It loads with the wide child in either slot, and
/// a walk enters each leaf once: with the wide child in slot 0, the order words' positions past
/// the count (which name slot 0) once made each level walk slot 0 again, multiplying the walk by
/// up to seven a level.
#[test]
fn a_chain_of_two_child_nodes_loads_and_walks_each_leaf_once() {
    use kdray_core::traverse::wide::walk::{WalkCounts, walk_counted};
    // A scene of a few triangles: a chain as deep as its leaves stays within the walk's stack.
    let leaves_of = |scene: &Scene| -> Vec<u32> {
        (0..scene.node_count())
            .filter(|&i| scene.node(i).is_leaf() && !scene.node(i).is_empty_leaf())
            .collect()
    };
    let words = (3..40)
        .map(|n| layouts(&scattered_triangles(n), 80.0, Leaves::List).1)
        .find(|w| {
            let k = leaves_of(&Scene::from_words(w).unwrap()).len();
            (8..60).contains(&k)
        })
        .expect("a scene of 8 to 59 leaves");
    let scene = Scene::from_words(&words).unwrap();
    let leaves = leaves_of(&scene);
    // `m` nodes for the `m + 1` leaves, in slot order whichever slot holds the wide child.
    let m = leaves.len() - 1;
    let chain = |wide_slot: usize| {
        let mut section = Vec::new();
        for i in 0..m {
            let mut node: WideNode = [0; NODE_WORDS];
            for slot in 0..WIDTH {
                let b = if slot < 2 { scene.bounds() } else { EMPTY_BOX };
                set_slot_box(&mut node, slot, b);
            }
            if i + 1 == m {
                node[REFS] = LEAF_REF | leaves[if wide_slot == 0 { 0 } else { m - 1 }];
                node[REFS + 1] = LEAF_REF | leaves[if wide_slot == 0 { 1 } else { m }];
            } else {
                // Slot 0 wide: the leaves come back up the chain; slot 1 wide: on the way down.
                let leaf = if wide_slot == 0 {
                    leaves[m - i]
                } else {
                    leaves[i]
                };
                node[REFS + wide_slot] = i as u32 + 1;
                node[REFS + 1 - wide_slot] = LEAF_REF | leaf;
            }
            node[ORDERS..].fill(2 << 24 | 1 << 3);
            section.push(node);
        }
        section
    };
    let (at, n) = section(&words);
    assert_eq!(
        at + n * NODE_WORDS,
        words.len(),
        "the wide section is the last"
    );
    let with = |section: Vec<WideNode>| {
        let mut w = words[..at].to_vec();
        w.extend(section.iter().flatten());
        w[header::TOTAL_WORDS] = w.len() as u32;
        w[header::WIDE_COUNT] = section.len() as u32;
        seal(&mut w);
        w
    };
    for slot in [0, 1] {
        let w = with(chain(slot));
        let chained = Scene::from_words(&w).expect("a chain loads");
        let ray = Ray::new(
            scene.bounds()[0] - 1.0,
            scene.bounds()[1] - scene.bounds()[0],
        );
        let mut counts = WalkCounts::default();
        walk_counted::<Triangles, _>(
            &chained,
            chained.wide_nodes(),
            &ray,
            &mut Nothing,
            &mut counts,
        );
        assert_eq!(
            counts.leaves,
            leaves.len() as u32,
            "wide child in slot {slot}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(64)))]

    /// A wide section with another cut, back-to-front orders and loose boxes loads, and its walk
    /// returns brute force's closest hits and the node walk's (the order and the boxes' tightness
    /// cost time, not answers).
    #[test]
    fn recut_sections_answer_as_the_writers(
        geom in grid_geometry(2),
        grow in any::<bool>(),
        rays in prop::collection::vec(traversal_ray(), 40),
    ) {
        let (nodes, wide) = layouts(&geom, 2.0, Leaves::List);
        let crafted = recut(&wide, grow);
        let (nodes, wide) = (Scene::from_words(&nodes).unwrap(), Scene::from_words(&wide).unwrap());
        let crafted = Scene::from_words(&crafted).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(crafted.wide_nodes().len(), wide.wide_nodes().len() + 1);
        for ray in &rays {
            check::<Mixed>(&crafted, &nodes, ray, Mode::Fast)?;
            check::<Watertight<Mixed>>(&crafted, &nodes, ray, Mode::Watertight)?;
        }
    }
}

/// A query that hits nothing: the walk then enters every slot whose box the ray crosses.
struct Nothing;

impl kdray_core::traverse::steps::Query for Nothing {
    fn leaf<C: Contents>(&mut self, _: &Scene, _: kdray_core::format::LeafPrims) -> (f32, bool) {
        (f32::INFINITY, false)
    }
}

/// The leaves a walk that finds nothing enters, counted over the wide nodes by recursion: a
/// slot whose box the ray crosses counts once if it is a leaf, and its subtree if not.
fn leaves_crossed(wide: &[WideNode], node: u32, ray: &Ray) -> u32 {
    let n = &wide[node as usize];
    let count = (n[ORDERS] >> 24) as usize;
    (0..count)
        .filter(|&s| slab_scalar::<Triangles>(slot_box(n, s), ray, f32::INFINITY).0)
        .map(|s| match n[REFS + s] {
            r if r & LEAF_REF != 0 => 1,
            r => leaves_crossed(wide, r, ray),
        })
        .sum()
}

/// Each entered child is walked once: a node of fewer than eight children stores slot 0 in its
/// order words' positions past the count, and the walk once counted those as hits of slot 0,
/// walking slot 0's subtree up to eight times (a 64-triangle scene: 5 leaves tested where 1 was
/// needed).
#[test]
fn the_wide_walk_enters_each_crossed_leaf_once() {
    use kdray_core::traverse::wide::walk::{WalkCounts, walk_counted};
    let geom = scattered_triangles(300);
    let (_, words) = layouts(&geom, 3.0, Leaves::Groups);
    let scene = Scene::from_words(&words).unwrap();
    let wide = scene.wide_nodes();
    let mut rng = kdray_tests::Lcg::new(11);
    let (mut walked, mut crossed) = (0, 0);
    for _ in 0..2000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 0.5;
        let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let ray = Ray::new(o, d);
        let mut counts = WalkCounts::default();
        walk_counted::<Triangles, _>(&scene, wide, &ray, &mut Nothing, &mut counts);
        let want = leaves_crossed(wide, 0, &ray);
        assert_eq!(counts.leaves, want, "{ray:?}");
        (walked, crossed) = (walked + counts.leaves, crossed + want);
    }
    assert!(crossed > 2000, "the rays cross leaves: {crossed}");
    assert_eq!(walked, crossed);
}
