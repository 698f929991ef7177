//! [`Scene::from_built_words`], the opening of words this process's builder just wrote: the
//! trust it places in the builder is checked here, where every tree the builder makes on random
//! meshes must pass the full validation ([`Scene::from_words`]) — both layouts, index lists and
//! groups, triangles and spheres — and the trusted opening must give the same scene: the same
//! closest hit (bits of `t`, primitive, `u`, `v`) and the same any-hit answer ray by ray, fast and
//! watertight. It still refuses words whose header, sections or tree shape are wrong.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::format::{FormatError, HEADER_WORDS, header, seal};
use kdray_core::traverse::Mode;
use kdray_core::traverse::wide::REFS;
use kdray_core::{Ray, Scene};
use kdray_tests::strategies::{grid_geometry, traversal_ray, vec3};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Every layout and leaf kind `geom` can be stored with (groups hold triangles only).
fn built(geom: &Geometry, intersect_cost: f64) -> Vec<Vec<u32>> {
    let mut all = Vec::new();
    for leaves in [Leaves::List, Leaves::Groups] {
        if leaves == Leaves::Groups && (!geom.spheres.is_empty() || geom.triangles.is_empty()) {
            continue;
        }
        let params = BuildParams {
            intersect_cost,
            parallel: false,
            ..leaves.build_params()
        };
        let tree = build(geom, &params, None).expect("finite geometry builds");
        for layout in [Layout::Nodes, Layout::Wide] {
            all.push(serialize_as(&tree, geom, 0.0, layout, leaves).expect("fits the format"));
        }
    }
    all
}

/// The full validation accepts `words` and the trusted opening answers `rays` as it does.
fn same_answers(words: &[u32], rays: &[Ray]) -> Result<(), TestCaseError> {
    let checked = Scene::from_words(words);
    prop_assert!(
        checked.is_ok(),
        "a built tree fails validation: {:?}",
        checked.err()
    );
    let checked = checked.unwrap();
    let trusted = Scene::from_built_words(words).expect("validated words open trusted");
    prop_assert_eq!(trusted.wide_nodes().len(), checked.wide_nodes().len());
    for ray in rays {
        for mode in [Mode::Fast, Mode::Watertight] {
            let (a, b) = (
                checked.intersect_in(mode, ray),
                trusted.intersect_in(mode, ray),
            );
            prop_assert_eq!(
                (a.t.to_bits(), a.prim, a.u.to_bits(), a.v.to_bits()),
                (b.t.to_bits(), b.prim, b.u.to_bits(), b.v.to_bits()),
                "{:?} {:?}",
                mode,
                ray
            );
            prop_assert_eq!(
                checked.occluded_in(mode, ray),
                trusted.occluded_in(mode, ray)
            );
        }
    }
    Ok(())
}

/// Triangles with arbitrary (not grid) vertices in a box, some of them long and thin.
fn random_mesh() -> impl Strategy<Value = Geometry> {
    prop::collection::vec(
        (
            vec3(-4.0, 4.0),
            vec3(-1.0, 1.0),
            vec3(-1.0, 1.0),
            0.0f32..3.0,
        ),
        1..120,
    )
    .prop_map(|tris| Geometry {
        triangles: tris
            .into_iter()
            .map(|(a, d1, d2, s)| [a, a + d1, a + d2 * (1.0 + s * s)])
            .collect(),
        ..Geometry::default()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(96)))]

    #[test]
    fn every_built_grid_tree_validates_and_opens_the_same(
        geom in grid_geometry(4),
        cheap in any::<bool>(),
        rays in prop::collection::vec(traversal_ray(), 16),
    ) {
        for words in built(&geom, if cheap { 0.3 } else { 1.5 }) {
            same_answers(&words, &rays)?;
        }
    }

    #[test]
    fn every_built_random_mesh_validates_and_opens_the_same(
        geom in random_mesh(),
        rays in prop::collection::vec(traversal_ray(), 16),
    ) {
        for words in built(&geom, 1.0) {
            same_answers(&words, &rays)?;
        }
    }
}

/// Some mesh's words, with wide nodes.
fn sample() -> Vec<u32> {
    let triangles = (0..64)
        .map(|i| {
            let x = i as f32 * 0.25;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]
        })
        .collect();
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    built(&geom, 1.0).swap_remove(1)
}

#[test]
fn trusts_neither_the_header_nor_the_tree_shape() {
    let words = sample();
    assert!(Scene::from_built_words(&words).is_ok());
    assert!(matches!(
        Scene::from_built_words(&words[..HEADER_WORDS - 1]),
        Err(FormatError::TooShort)
    ));
    assert!(matches!(
        Scene::from_built_words(&words[..words.len() - 1]),
        Err(FormatError::LengthMismatch { .. })
    ));
    let mut bad = words.clone();
    bad[header::NODES_OFFSET] = words.len() as u32 - 8;
    seal(&mut bad);
    assert!(matches!(
        Scene::from_built_words(&bad),
        Err(FormatError::SectionOutOfBounds | FormatError::SectionsOverlap)
    ));
    // The root's above child pointing back at the root: a walk could loop.
    let mut bad = words.clone();
    let root = words[header::NODES_OFFSET] as usize;
    assert_ne!(bad[root + 1] & 3, 3, "the root is interior");
    bad[root + 1] &= 0xf;
    assert!(matches!(
        Scene::from_built_words(&bad),
        Err(FormatError::BadChild { .. })
    ));
    // The first wide node's first slot (entered: its box is not empty) pointing back at itself.
    let mut bad = words.clone();
    let wide = words[header::WIDE_OFFSET] as usize;
    assert_ne!(wide, 0, "the sample has wide nodes");
    bad[wide + REFS] = 0;
    assert!(matches!(
        Scene::from_built_words(&bad),
        Err(FormatError::BadWideNode { node: 0 })
    ));
}

#[test]
fn skips_the_checksum_and_geometry_only() {
    let words = sample();
    let mut damaged = words.clone();
    damaged[header::CHECKSUM] ^= 1;
    assert!(matches!(
        Scene::from_words(&damaged),
        Err(FormatError::Checksum)
    ));
    assert!(Scene::from_built_words(&damaged).is_ok());
}
