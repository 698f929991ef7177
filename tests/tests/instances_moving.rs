//! Moving instances: `kdray::instances::TopLevel::move_to` refits the top level when the same
//! placements move. A refitted top level must validate as a file would (`from_words`, every
//! check), hold for each placement exactly the record a new build writes for it, bound the same
//! world box, and answer every ray as the rebuilt top level does; a refused placement changes
//! nothing; a changed count, changed bottom boxes or a tree loosened past `REBUILD_GROWTH` build
//! anew, and then the words are the new build's, bit for bit.

use glam::Vec3;
use kdray::instances::{Moved, Placement, REBUILD_GROWTH, TopLevel, top_level};
use kdray_core::instance::{
    Affine, HEADER_WORDS, InstancedScene, NODE_WORDS, RECORD_WORDS, header,
};
use kdray_core::traverse::Mode;
use kdray_core::{Ray, Scene};
use kdray_tests::strategies::{grid_triangles, unit_vec3};
use kdray_tests::walks::node_words;
use proptest::prelude::*;

/// A rotation about z by `angle`, scaled by `scale`, moved to `at`.
fn placed(angle: f32, scale: f32, at: [f32; 3]) -> Affine {
    let (s, c) = angle.sin_cos();
    Affine([
        c * scale,
        -s * scale,
        0.0,
        at[0],
        s * scale,
        c * scale,
        0.0,
        at[1],
        0.0,
        0.0,
        scale,
        at[2],
    ])
}

/// The records of `words` (a top level), each with the index of the placement it holds.
fn records<'w>(words: &'w [u32], order: &[u32]) -> Vec<(u32, &'w [u32])> {
    let first = HEADER_WORDS + NODE_WORDS * words[header::NODE_COUNT] as usize;
    order
        .iter()
        .enumerate()
        .map(|(r, &p)| {
            let at = first + RECORD_WORDS * r;
            (p, &words[at..at + RECORD_WORDS])
        })
        .collect()
}

/// `moved`'s words against a top level built anew for `placements`: valid as words from outside,
/// every placement's record bit for bit the new build's, the same world bounds, and every ray of
/// `rays` the same closest `t` and occlusion in both modes.
fn check_refit(
    moved: &mut TopLevel,
    bottoms: &[Scene],
    placements: &[Placement],
    rays: &[Ray],
) -> Result<(), TestCaseError> {
    let order = moved.order().to_vec();
    let words = moved.sealed_words().to_vec();
    let top = InstancedScene::from_words(&words, bottoms);
    prop_assert!(
        top.is_ok(),
        "the refitted words do not validate: {:?}",
        top.err()
    );
    let top = top.unwrap();
    let fresh = TopLevel::build(bottoms, placements).unwrap();
    let mut want: Vec<(u32, &[u32])> = records(fresh.built_words(), fresh.order());
    want.sort_by_key(|&(p, _)| p);
    let mut got = records(&words, &order);
    got.sort_by_key(|&(p, _)| p);
    prop_assert_eq!(got, want, "records");
    let bounds = header::BOUNDS..header::BOUNDS + 6;
    prop_assert_eq!(&words[bounds.clone()], &fresh.built_words()[bounds]);
    let rebuilt = InstancedScene::from_built_words(fresh.built_words(), bottoms).unwrap();
    for ray in rays {
        for mode in [Mode::Fast, Mode::Watertight] {
            let (a, b) = (top.intersect_in(mode, ray), rebuilt.intersect_in(mode, ray));
            prop_assert_eq!(a.t.to_bits(), b.t.to_bits(), "{:?} {:?}", mode, ray);
            prop_assert_eq!(top.occluded_in(mode, ray), rebuilt.occluded_in(mode, ray));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: kdray_tests::cases(100), ..ProptestConfig::default() })]

    /// Placements moved by small random steps (a few not at all, a few given the other mesh or
    /// another id), frame after frame: each refit is what a new build would place.
    #[test]
    fn refits_place_what_a_new_build_places(
        meshes in prop::collection::vec(grid_triangles(), 2..3),
        start in prop::collection::vec((0u32..2, -3.0f32..3.0, 0.5f32..2.0, prop::array::uniform3(-20.0f32..20.0)), 1..40),
        steps in prop::collection::vec(prop::collection::vec((0u32..4, -0.2f32..0.2, prop::array::uniform3(-0.5f32..0.5)), 40), 1..4),
        rays in prop::collection::vec((prop::array::uniform3(-25.0f32..25.0), unit_vec3()), 1..30),
    ) {
        let words: Vec<Vec<u32>> = meshes.into_iter().map(node_words).collect();
        let bottoms: Vec<Scene> = words.iter().map(|w| Scene::from_words(w).unwrap()).collect();
        let mut now: Vec<(u32, f32, f32, [f32; 3], u32)> =
            start.iter().enumerate().map(|(k, &(b, a, s, at))| (b, a, s, at, k as u32)).collect();
        let placements = |now: &[(u32, f32, f32, [f32; 3], u32)]| -> Vec<Placement> {
            now.iter()
                .map(|&(bottom, a, s, at, user_id)| Placement { bottom, transform: placed(a, s, at), user_id })
                .collect()
        };
        let rays: Vec<Ray> = rays.iter().map(|&(o, d)| Ray::new(Vec3::from_array(o), d)).collect();
        let mut top = TopLevel::build(&bottoms, &placements(&now)).unwrap();
        for step in &steps {
            for (p, &(what, da, dx)) in now.iter_mut().zip(step) {
                match what {
                    0 => {}
                    1 => p.0 = 1 - p.0,
                    2 => p.4 += 1000,
                    _ => {
                        p.1 += da;
                        p.3 = [p.3[0] + dx[0], p.3[1] + dx[1], p.3[2] + dx[2]];
                    }
                }
            }
            let moved = placements(&now);
            match top.move_to(&bottoms, &moved).unwrap() {
                Moved::Refitted => check_refit(&mut top, &bottoms, &moved, &rays)?,
                Moved::Rebuilt => {
                    prop_assert_eq!(top.clone().into_words(), top_level(&bottoms, &moved).unwrap());
                }
            }
        }
    }
}

/// Sixteen placements of one square, four to a row.
fn field(shift: f32) -> Vec<Placement> {
    (0..16u32)
        .map(|k| Placement {
            bottom: 0,
            transform: placed(
                0.1 * k as f32,
                1.0,
                [(k % 4) as f32 * 3.0 + shift, (k / 4) as f32 * 3.0, 0.0],
            ),
            user_id: k,
        })
        .collect()
}

fn square() -> Vec<u32> {
    let (a, b, c, d) = (
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    );
    node_words(vec![[a, b, c], [a, c, d]])
}

#[test]
fn a_built_top_level_seals_to_top_levels_words() {
    let mesh = square();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let mut top = TopLevel::build(&bottoms, &field(0.0)).unwrap();
    assert_eq!(
        top.sealed_words(),
        top_level(&bottoms, &field(0.0)).unwrap()
    );
    // Not moved: refitted, and the same words.
    assert_eq!(top.move_to(&bottoms, &field(0.0)), Ok(Moved::Refitted));
    assert_eq!(top.into_words(), top_level(&bottoms, &field(0.0)).unwrap());
}

#[test]
fn a_refused_placement_changes_nothing() {
    let mesh = square();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let mut top = TopLevel::build(&bottoms, &field(0.0)).unwrap();
    let before = top.clone().into_words();
    for bad in [
        Affine([0.0; 12]),
        Affine([f32::NAN; 12]),
        placed(0.0, 1.0, [f32::MAX, 0.0, 0.0]),
    ] {
        let mut moved = field(0.5);
        moved[7].transform = bad;
        let refused = top.move_to(&bottoms, &moved).unwrap_err();
        assert!(refused.starts_with("instance 7:"), "{refused}");
        assert_eq!(top.clone().into_words(), before);
    }
    let mut gone = field(0.5);
    gone[3].bottom = 1;
    assert!(
        top.move_to(&bottoms, &gone)
            .unwrap_err()
            .contains("out of range")
    );
    assert_eq!(top.clone().into_words(), before);
    // And it still moves.
    assert_eq!(top.move_to(&bottoms, &field(0.5)), Ok(Moved::Refitted));
    assert_eq!(top.into_words().len(), before.len());
}

#[test]
fn another_count_other_bottoms_or_a_loosened_tree_build_anew() {
    let (mesh, big) = (square(), {
        let s = Vec3::splat(2.0);
        node_words(vec![[-s, Vec3::new(2.0, -2.0, 0.0), s]])
    });
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let mut top = TopLevel::build(&bottoms, &field(0.0)).unwrap();
    let fewer = &field(0.0)[..9];
    assert_eq!(top.move_to(&bottoms, fewer), Ok(Moved::Rebuilt));
    assert_eq!(
        top.clone().into_words(),
        top_level(&bottoms, fewer).unwrap()
    );
    // The same placements over a scene of another box.
    let other = [Scene::from_words(&big).unwrap()];
    assert_eq!(top.move_to(&other, fewer), Ok(Moved::Rebuilt));
    assert_eq!(top.clone().into_words(), top_level(&other, fewer).unwrap());
    // Each instance on the checkerboard's dark cells swapped with its mirror image through the
    // field's centre (a dark cell too): every node of two neighbours (one dark, one light) now
    // stretches across the field, past REBUILD_GROWTH times the areas of the tree built for them.
    let mut top = TopLevel::build(&bottoms, &field(0.0)).unwrap();
    let mut swapped = field(0.0);
    for k in (0..16).filter(|k| (k % 4 + k / 4) % 2 == 0 && *k < 8) {
        let (a, b) = (swapped[k].transform, swapped[15 - k].transform);
        (swapped[k].transform, swapped[15 - k].transform) = (b, a);
    }
    // The swaps grow the nodes' areas about 2.8-fold.
    const { assert!(REBUILD_GROWTH <= 2.0) };
    assert_eq!(top.move_to(&bottoms, &swapped), Ok(Moved::Rebuilt));
    assert_eq!(top.into_words(), top_level(&bottoms, &swapped).unwrap());
}
