//! Parts of a leaf in the wide section (format v13): a leaf child of a wide node with free slots
//! takes several, each holding a run of the leaf's items under a box of its own. The builder
//! cuts the large leaves of the packages' trees (lists and groups) into parts that partition
//! each leaf; the walk over them answers as the node walk does; validation refuses parts out of
//! turn, missing, encoded otherwise or boxed wrongly.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, Quality, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::format::wide::{LeafRef, PART_REF};
use kdray_core::format::{FormatError, LeafPrims, header, seal};
use kdray_core::sampling::Pcg32;
use kdray_core::traverse::Mode;
use kdray_core::traverse::wide::{BOXES, LEAF_REF, NODE_WORDS, ORDERS, REFS, WideNode};
use kdray_core::{Ray, Scene};

/// The host's test meshes (`host/tests/meshes`): a UV sphere's `fast` leaves hold a dozen
/// triangles or more, as the packages' trees of scanned meshes do.
#[path = "../../host/tests/meshes/mod.rs"]
mod meshes;

/// A unit UV sphere of `n`×`n` quads.
fn sphere(n: u32) -> Geometry {
    Geometry {
        triangles: meshes::uv_sphere(n, Vec3::ZERO, 1.0),
        ..Geometry::default()
    }
}

/// `geom`'s `fast` tree (the packages' default builder) with `leaves`, as nodes and as wide
/// nodes.
fn trees(geom: &Geometry, leaves: Leaves) -> (Vec<u32>, Vec<u32>) {
    let params = BuildParams {
        parallel: false,
        ..leaves.build_params().with_quality(Quality::Fast)
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    let words = |layout| serialize_as(&tree, geom, 0.0, layout, leaves).expect("fits the format");
    (words(Layout::Nodes), words(Layout::Wide))
}

/// Every leaf reference of `wide`, with its wide node and slot.
fn leaf_refs(wide: &[WideNode]) -> Vec<(usize, usize, LeafRef)> {
    let mut out = Vec::new();
    for (w, node) in wide.iter().enumerate() {
        let count = (node[ORDERS] >> 24) as usize;
        for k in 0..count {
            if node[REFS + k] & LEAF_REF != 0 {
                out.push((w, k, LeafRef::decode(node[REFS + k])));
            }
        }
    }
    out
}

#[test]
fn large_leaves_are_cut_into_parts_that_partition_them() {
    for leaves in [Leaves::List, Leaves::Groups] {
        let (_, words) = trees(&sphere(48), leaves);
        let scene = Scene::from_words(&words).unwrap();
        let refs = leaf_refs(scene.wide_nodes());
        let cut = refs.iter().filter(|r| r.2.parts > 1).count();
        assert!(
            cut > 20,
            "{leaves:?}: {cut} parts of {} leaf slots",
            refs.len()
        );
        for (i, &(w, k, r)) in refs.iter().enumerate() {
            if r.part != 0 {
                continue;
            }
            let whole: Vec<u32> = scene.leaf_prims(&scene.node(r.leaf)).ids().collect();
            let mut joined = Vec::new();
            for (j, &(pw, pk, p)) in refs[i..i + r.parts as usize].iter().enumerate() {
                assert_eq!(
                    (pw, pk),
                    (w, k + j),
                    "the parts of a leaf fill consecutive slots"
                );
                assert_eq!((p.leaf, p.part, p.parts), (r.leaf, j as u32, r.parts));
                let part = scene.leaf_prims(&scene.node(p.leaf)).part(p.part, p.parts);
                joined.extend(part.ids());
            }
            assert_eq!(joined, whole, "{leaves:?}: leaf {}'s parts", r.leaf);
        }
    }
}

#[test]
fn a_leafs_parts_hold_its_items_once_for_any_count() {
    let list: Vec<u32> = (100..140).collect();
    for n in 0..=list.len() {
        for m in 1..=8u32 {
            let joined: Vec<u32> = (0..m)
                .flat_map(|k| LeafPrims::Many(&list[..n]).part(k, m).ids())
                .collect();
            assert_eq!(joined, list[..n], "{n} items in {m} parts");
        }
    }
    let one: Vec<Vec<u32>> = (0..3)
        .map(|k| LeafPrims::One(Some(7)).part(k, 3).ids().collect())
        .collect();
    assert_eq!(one, [vec![], vec![], vec![7]]);
}

#[test]
fn walks_over_parts_answer_as_the_node_walk() {
    let geom = sphere(48);
    let mut rng = Pcg32::new(7, 1);
    let mut unit = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
    let rays: Vec<Ray> = (0..4000)
        .map(|_| {
            let origin = unit() * 1.5;
            // Half aimed at the surface near a random point, half at random.
            let towards = unit().normalize_or(Vec3::X) * 0.9;
            Ray::new(origin, (towards - origin).normalize_or(Vec3::Z))
        })
        .collect();
    for leaves in [Leaves::List, Leaves::Groups] {
        let (nodes, wide) = trees(&geom, leaves);
        let (nodes, wide) = (
            Scene::from_words(&nodes).unwrap(),
            Scene::from_words(&wide).unwrap(),
        );
        let mut hits = 0;
        for mode in [Mode::Fast, Mode::Watertight] {
            for ray in &rays {
                let (got, want) = (wide.intersect_in(mode, ray), nodes.intersect_in(mode, ray));
                assert_eq!(
                    got.t.to_bits(),
                    want.t.to_bits(),
                    "{leaves:?} {mode:?} {ray:?}"
                );
                assert_eq!(wide.occluded_in(mode, ray), want.is_hit());
                hits += usize::from(got.is_hit());
            }
        }
        assert!(hits > 2000, "{leaves:?}: {hits} hits");
    }
}

/// `words` with `f` applied to its wide nodes, resealed; what validation says.
fn damaged(words: &[u32], f: impl Fn(&mut [WideNode])) -> Result<(), FormatError> {
    let mut w = words.to_vec();
    let (at, n) = (
        w[header::WIDE_OFFSET] as usize,
        w[header::WIDE_COUNT] as usize,
    );
    f(w[at..at + n * NODE_WORDS].as_chunks_mut().0);
    seal(&mut w);
    Scene::from_words(&w).map(|_| ())
}

#[test]
fn damaged_parts_are_refused() {
    let (_, words) = trees(&sphere(48), Leaves::List);
    let scene = Scene::from_words(&words).unwrap();
    let refs = leaf_refs(scene.wide_nodes());
    let &(w, k, r) = refs
        .iter()
        .find(|(_, _, r)| r.part == 0 && r.parts >= 3)
        .expect("a leaf cut into three parts or more");
    let with = |part: u32, parts: u32| LeafRef { part, parts, ..r }.encode();
    let bad_node = |e: Result<(), FormatError>| matches!(e, Err(FormatError::BadWideNode { .. }));
    // Two parts swapped; a part named twice; a part's count changed; the first part left out
    // (a later part where the leaf should start).
    assert!(bad_node(
        damaged(&words, |s| s[w].swap(REFS + k, REFS + k + 1))
    ));
    assert!(bad_node(
        damaged(&words, |s| s[w][REFS + k + 1] = with(0, r.parts))
    ));
    assert!(bad_node(
        damaged(&words, |s| s[w][REFS + k + 1] = with(1, r.parts + 1))
    ));
    assert!(bad_node(
        damaged(&words, |s| s[w][REFS + k] = with(1, r.parts))
    ));
    // The last part dropped: a leaf cut into one part fewer (whose first part's box then
    // misses the items it gains, or whose parts end before the node's last slot).
    let fewer = damaged(&words, |s| {
        for j in 0..r.parts - 1 {
            s[w][REFS + k + j as usize] = with(j, r.parts - 1);
        }
    });
    assert!(
        matches!(
            fewer,
            Err(FormatError::BadWideNode { .. } | FormatError::BadWideBox { .. })
        ),
        "{fewer:?}"
    );
    // A whole leaf encoded as a part of one (not as the writer encodes it).
    let &(ww, wk, whole) = refs.iter().find(|(_, _, r)| r.parts == 1).unwrap();
    assert!(bad_node(damaged(&words, |s| s[ww][REFS + wk] =
        LEAF_REF | PART_REF | whole.leaf)));
    // A part's box squeezed to the plane x = its middle: each part is checked against its
    // own items.
    let lo_x = BOXES + k;
    let hi_x = BOXES + 8 + k;
    let shrunk = damaged(&words, |s| {
        let mid = (f32::from_bits(s[w][lo_x]) + f32::from_bits(s[w][hi_x])) / 2.0;
        s[w][hi_x] = mid.to_bits();
        s[w][lo_x] = mid.to_bits();
    });
    assert!(
        matches!(shrunk, Err(FormatError::BadWideBox { .. })),
        "{shrunk:?}"
    );
    // The undamaged words validate.
    assert!(damaged(&words, |_| {}).is_ok());
}
