//! A build on rayon's pool (`BuildParams::parallel`, the default) writes the same words as a
//! build on one thread, and `serialize_into` (the words written into the caller's buffer) the
//! same words as `serialize_as`: the tree, and the serializer's parallel parts — the flattening of the
//! top levels' subtrees, the triangles section, the renumbering, the wide section's subtrees —
//! whatever the quality, layout and leaves. On meshes large enough that every parallel part
//! runs (more triangles than a task of the serializer takes, subtrees past the builder's
//! threshold).

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, Quality, build};
use kdray::closed::icosphere;
use kdray::flat::{Layout, Leaves, serialize_as, serialize_into};
use kdray_core::Scene;

/// An icosphere of 81,920 triangles with a shell of 4,000 overlapping triangles inside it (long,
/// thin, crossing many cells: straddlers at every level).
fn mesh() -> Geometry {
    let mut triangles = icosphere(6).triangles();
    triangles.extend((0..4000).map(|i| {
        let a = i as f32 * 0.618_034;
        let p = Vec3::new(a.sin(), a.cos(), (a * 0.37).sin()) * 0.6;
        [p, -p * 0.9, p + Vec3::new(0.01, 0.02, -0.015)]
    }));
    Geometry {
        triangles,
        ..Geometry::default()
    }
}

#[test]
fn pool_and_one_thread_write_the_same_words() {
    let geom = mesh();
    for quality in [Quality::Fast, Quality::High] {
        for leaves in [Leaves::List, Leaves::Groups] {
            let words = |parallel: bool, layout: Layout| {
                let params = BuildParams {
                    parallel,
                    ..leaves.build_params()
                }
                .with_quality(quality);
                let tree = build(&geom, &params, None).expect("the mesh builds");
                serialize_as(&tree, &geom, 0.0, layout, leaves).expect("it fits the format")
            };
            for layout in [Layout::Nodes, Layout::Wide] {
                let one = words(false, layout);
                let pool = words(true, layout);
                let what = format!("{quality:?}, {leaves:?}, {layout:?}");
                assert_eq!(one.len(), pool.len(), "{what}: lengths differ");
                if let Some(k) = (0..one.len()).find(|&k| one[k] != pool[k]) {
                    panic!("{what}: word {k} of {} differs", one.len());
                }
                let tree = build(&geom, &leaves.build_params().with_quality(quality), None)
                    .expect("the mesh builds");
                let into =
                    serialize_into(&tree, &geom, 0.0, layout, leaves, |n| Ok(vec![u32::MAX; n]))
                        .expect("it fits the format");
                assert!(into == pool, "{what}: the words written in place differ");
                let scene = Scene::from_words(&pool).expect("the pool's words validate");
                assert!(
                    scene.node_count() > 1000,
                    "{what}: a tree of several levels"
                );
                assert_eq!(
                    scene.wide_nodes().is_empty(),
                    layout == Layout::Nodes,
                    "{what}"
                );
            }
        }
    }
}
