//! `Scene::from_words`: never panics on arbitrary words, and rejects each kind of corruption
//! with its own error.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray_core::format::{FormatError, HEADER_WORDS, MAGIC, VERSION, contents, header, seal};
use kdray_core::node::Node;
use kdray_core::{Ray, Scene};
use proptest::prelude::*;

/// A fan of overlapping triangles, scrambled along x so that the builder's leaf order is not
/// the input order.
fn fan() -> Vec<[Vec3; 3]> {
    (0..12)
        .map(|i| {
            let a = (i * 5 % 12) as f32 * 0.5;
            [
                Vec3::new(a, 0.0, 0.0),
                Vec3::new(a + 1.0, 0.0, 0.3),
                Vec3::new(a, 1.0, -0.2),
            ]
        })
        .collect()
}

/// A small valid scene: [`fan`] and two spheres, built with the real builder.
fn valid_words() -> Vec<u32> {
    let geom = Geometry {
        triangles: fan(),
        spheres: vec![
            (Vec3::new(2.0, 3.0, 0.0), 0.5),
            (Vec3::new(-1.0, 0.0, 1.0), 0.25),
        ],
        ..Geometry::default()
    };
    let tree = build(
        &geom,
        &BuildParams {
            parallel: false,
            ..BuildParams::default()
        },
        None,
    )
    .unwrap();
    serialize(&tree, &geom, 1.0).unwrap()
}

fn check(words: &[u32]) -> Result<(), FormatError> {
    Scene::from_words(words).map(|_| ())
}

/// The first interior node and the first leaf with more than one primitive.
fn find_nodes(words: &[u32]) -> (usize, Option<usize>) {
    let base = words[header::NODES_OFFSET] as usize;
    let n = words[header::NODE_COUNT] as usize;
    let node = |i: usize| Node::from_words([words[base + 2 * i], words[base + 2 * i + 1]]);
    let interior = (0..n).find(|&i| !node(i).is_leaf()).unwrap();
    let many = (0..n).find(|&i| node(i).is_leaf() && node(i).prim_count() > 1);
    (base + 2 * interior, many.map(|i| base + 2 * i))
}

#[test]
fn valid_scene_is_accepted_and_traced() {
    let words = valid_words();
    let scene = Scene::from_words(&words).unwrap();
    assert_eq!(scene.tri_count(), 12);
    assert_eq!(scene.sphere_count(), 2);
    let hit = scene.intersect(&Ray::new(Vec3::new(2.0, 3.0, 5.0), Vec3::NEG_Z));
    assert_eq!(hit.prim, 12);
    assert!((hit.t - 4.5).abs() < 1e-5);
    // Triangles are stored in leaf order; the input ids are a permutation back to input order.
    assert!(scene.contents() & contents::INPUT_IDS != 0);
    let mut ids: Vec<u32> = (0..12).map(|i| scene.input_id(i)).collect();
    assert_ne!(ids, (0..12).collect::<Vec<_>>());
    ids.sort_unstable();
    assert_eq!(ids, (0..12).collect::<Vec<_>>());
    assert_eq!(
        (scene.input_id(12), scene.input_id(u32::MAX)),
        (12, u32::MAX)
    );
    // Each hit's input id names the input triangle a brute-force loop over the input finds.
    for k in 0..40 {
        let ray = Ray::new(Vec3::new(0.1 + k as f32 * 0.15, 0.3, 5.0), Vec3::NEG_Z);
        let hit = scene.intersect(&ray);
        let nearest = fan()
            .iter()
            .enumerate()
            .filter_map(|(i, v)| {
                let t = kdray_core::Triangle::from_vertices(v[0], v[1], v[2]).intersect(&ray)?;
                Some((t.0, i as u32))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(
            nearest.map(|n| n.1),
            hit.is_hit().then(|| scene.input_id(hit.prim))
        );
    }
}

/// Every single-bit flip of a valid file is refused (by the checksum, or before it by the magic,
/// version or length checks); the probe that found 5,293 of 11,904 flips accepted in version 4
/// ran the same loop over a larger scene.
#[test]
fn every_single_bit_flip_is_refused() {
    let good = valid_words();
    let mut accepted = Vec::new();
    for i in 0..good.len() {
        for bit in 0..32 {
            let mut w = good.clone();
            w[i] ^= 1 << bit;
            if check(&w).is_ok() {
                accepted.push((i, bit));
            }
        }
    }
    assert!(
        accepted.is_empty(),
        "accepted flips (word, bit): {accepted:?}"
    );
    let mut w = good.clone();
    w[good.len() / 2] ^= 1 << 7;
    assert_eq!(check(&w), Err(FormatError::Checksum));
    assert!(
        FormatError::Checksum.to_string().contains("rebuild it"),
        "a damaged file's message says what to do"
    );
}

/// Files of the versions before this one are refused with a message saying to rebuild them:
/// each stored something this build reads otherwise.
#[test]
fn older_versions_ask_for_a_rebuild() {
    for version in [
        5,  // triangles as `v0, e1, e2`, not the vertices the watertight kernel needs
        7,  // `+inf` as the threshold of a triangle whose `|e1 × e2|²` overflows f32
        10, // wide nodes cut three levels down, not by the greedy cut
        11, // could carry the cache-line blocks section, retired in 12
        12, // wide nodes that could not cut a leaf into parts (its references read the same)
    ] {
        let mut w = valid_words();
        w[header::VERSION] = version;
        seal(&mut w);
        let err = check(&w).unwrap_err();
        assert_eq!(err, FormatError::UnsupportedVersion(version));
        assert!(err.to_string().contains("rebuild the file"), "{err}");
    }
}

/// Stored vertices that are finite but whose edge `v1 − v0` overflows are refused (Möller–Trumbore
/// computes the edges at load and would see infinities).
#[test]
fn vertices_whose_edges_overflow_are_refused() {
    let mut w = valid_words();
    let tris = w[header::TRIS_OFFSET] as usize;
    w[tris] = 3.0e38f32.to_bits();
    w[tris + 3] = (-3.0e38f32).to_bits();
    seal(&mut w);
    assert_eq!(check(&w), Err(FormatError::NonFiniteGeometry));
}

/// A file that sets the retired blocks bit is refused with an error that names the blocks and
/// says how to rebuild; the two header words that held the blocks' count and offset must be 0.
#[test]
fn the_retired_blocks_bit_and_words_are_refused() {
    let mut w = valid_words();
    w[header::CONTENTS] |= contents::RETIRED_BLOCKS;
    seal(&mut w);
    let err = check(&w).unwrap_err();
    assert_eq!(err, FormatError::BlocksRetired);
    let msg = err.to_string();
    assert!(
        msg.contains("blocks") && msg.contains("retired") && msg.contains("kdray build"),
        "{msg}"
    );
    for word in header::UNUSED {
        let mut w = valid_words();
        w[word] = 16;
        seal(&mut w);
        assert_eq!(check(&w), Err(FormatError::ReservedNotZero), "word {word}");
    }
}

/// A triangle with area whose threshold overflows even from the scaled normal (`|e1 × e2|` ≥
/// 7.7e25: f32 cannot trace it right) is refused, although the stored `+inf` is the threshold its
/// vertices give: `+inf` stands for "never hit", which is right only for a degenerate triangle.
#[test]
fn triangles_too_large_for_f32_are_refused() {
    let mut w = valid_words();
    let tris = w[header::TRIS_OFFSET] as usize;
    let verts = [[0.0f32, 0.0, 0.0], [1.0e13, 0.0, 0.0], [0.0, 1.0e13, 0.0]];
    for (k, v) in verts.iter().flatten().enumerate() {
        w[tris + k] = v.to_bits();
    }
    let [a, b, c] = verts.map(Vec3::from);
    let tri = kdray_core::Triangle::from_vertices(a, b, c);
    assert!(tri.is_too_large() && tri.min_det2() == f32::INFINITY);
    w[tris + 9] = tri.min_det2().to_bits();
    seal(&mut w);
    assert_eq!(check(&w), Err(FormatError::NonFiniteGeometry));
    // The same triangle 100 times smaller has a finite threshold (its `|e1 × e2|²` overflows,
    // the scaled one does not) and is a valid, hittable triangle as far as this check goes.
    let small = kdray_core::Triangle::from_vertices(a * 1e-2, b * 1e-2, c * 1e-2);
    assert!(!small.is_too_large());
    assert!(small.geometric_normal().length_squared().is_infinite());
    assert!(small.min_det2().is_finite() && small.min_det2() > 0.0);
}

/// A file of an older version (4: no checksum, reserved words from 24) is refused with a
/// message saying to rebuild it, not as damaged.
#[test]
fn old_version_asks_for_a_rebuild() {
    let mut w = valid_words();
    w[header::VERSION] = 4;
    w[header::CHECKSUM] = 0;
    w[header::CHECKSUM + 1] = 0;
    let err = check(&w).unwrap_err();
    assert_eq!(err, FormatError::UnsupportedVersion(4));
    assert!(err.to_string().contains("rebuild the file"), "{err}");
}

/// Geometry and splits outside the header's bounds are refused even when the file is re-sealed
/// (a crafted file, not a damaged one).
#[test]
fn geometry_outside_the_bounds_is_refused() {
    let good = valid_words();
    let resealed = |f: &dyn Fn(&mut Vec<u32>)| {
        let mut w = good.clone();
        f(&mut w);
        seal(&mut w);
        check(&w)
    };
    let tris = good[header::TRIS_OFFSET] as usize;
    // Triangle 0's v0 moved 1 past the box in x, its threshold recomputed to match.
    let max_x = f32::from_bits(good[header::BOUNDS + 3]);
    assert_eq!(
        resealed(&|w| {
            w[tris] = (max_x + 1.0).to_bits();
            let v = |k: usize| {
                let f = |j: usize| f32::from_bits(w[tris + 3 * k + j]);
                Vec3::new(f(0), f(1), f(2))
            };
            let tri = kdray_core::Triangle::from_vertices(v(0), v(1), v(2));
            w[tris + 9] = tri.min_det2().to_bits();
        }),
        Err(FormatError::OutsideBounds { prim: 0 })
    );
    // A bounds box shrunk by a little cuts off some primitive.
    let min_y = f32::from_bits(good[header::BOUNDS + 1]);
    assert!(matches!(
        resealed(&|w| w[header::BOUNDS + 1] = (min_y + 0.01).to_bits()),
        Err(FormatError::OutsideBounds { .. })
    ));
    let spheres = good[header::SPHERES_OFFSET] as usize;
    assert_eq!(
        resealed(&|w| w[spheres + 3] = 100.0f32.to_bits()),
        Err(FormatError::OutsideBounds { prim: 12 })
    );
    let (interior, _) = find_nodes(&good);
    assert!(matches!(
        resealed(&|w| w[interior] = 1e6f32.to_bits()),
        Err(FormatError::BadSplit { .. })
    ));
}

#[test]
fn each_corruption_has_its_own_error() {
    let good = valid_words();
    // Each corruption is re-sealed, as a crafted file would be, so that the check behind the
    // checksum is the one that must catch it.
    let corrupt = |f: &dyn Fn(&mut Vec<u32>)| {
        let mut w = good.clone();
        f(&mut w);
        seal(&mut w);
        check(&w)
    };
    assert_eq!(check(&good[..HEADER_WORDS - 1]), Err(FormatError::TooShort));
    assert_eq!(
        corrupt(&|w| w[header::MAGIC] ^= 1),
        Err(FormatError::BadMagic)
    );
    assert_eq!(
        corrupt(&|w| w[header::VERSION] = VERSION + 1),
        Err(FormatError::UnsupportedVersion(VERSION + 1))
    );
    assert_eq!(
        corrupt(&|w| w[header::CONTENTS] |= 1 << 20),
        Err(FormatError::BadContents)
    );
    assert_eq!(
        corrupt(&|w| w[header::CONTENTS] &= !contents::SPHERES),
        Err(FormatError::BadContents)
    );
    // Truncation and trailing words.
    assert!(matches!(
        corrupt(&|w| {
            w.pop();
        }),
        Err(FormatError::LengthMismatch { .. })
    ));
    assert!(matches!(
        corrupt(&|w| w.push(0)),
        Err(FormatError::LengthMismatch { .. })
    ));
    // The header's last word is the wide section's offset since format v10 (no reserved word
    // is left): an offset with the WIDE bit clear is refused.
    assert_eq!(
        corrupt(&|w| w[HEADER_WORDS - 1] = 7),
        Err(FormatError::BadContents)
    );
    // A count whose section size overflows, and one that runs past the end.
    assert_eq!(
        corrupt(&|w| w[header::TRI_COUNT] = u32::MAX),
        Err(FormatError::CountOverflow)
    );
    assert_eq!(
        corrupt(&|w| w[header::SPHERE_COUNT] += 1000),
        Err(FormatError::SectionOutOfBounds)
    );
    assert_eq!(
        corrupt(&|w| w[header::TRIS_OFFSET] = 8),
        Err(FormatError::SectionOutOfBounds)
    );
    assert_eq!(
        corrupt(&|w| w[header::TRIS_OFFSET] += 1),
        Err(FormatError::SectionOutOfBounds)
    );
    assert_eq!(
        corrupt(&|w| w[header::SPHERES_OFFSET] = w[header::TRIS_OFFSET]),
        Err(FormatError::SectionsOverlap)
    );
    assert_eq!(
        corrupt(&|w| w[header::BOUNDS] = f32::NAN.to_bits()),
        Err(FormatError::BadBounds)
    );
    assert_eq!(
        corrupt(&|w| w[header::BOUNDS] = 1e30f32.to_bits()),
        Err(FormatError::BadBounds),
        "min above max"
    );
    let tris = good[header::TRIS_OFFSET] as usize;
    assert_eq!(
        corrupt(&|w| w[tris + 4] = f32::INFINITY.to_bits()),
        Err(FormatError::NonFiniteGeometry)
    );
    // A stored triangle threshold that is not the one the vertices give (0 would let a
    // degenerate or grazing ray through).
    assert_eq!(
        corrupt(&|w| w[tris + 9] = 0),
        Err(FormatError::NonFiniteGeometry)
    );
    let spheres = good[header::SPHERES_OFFSET] as usize;
    assert_eq!(
        corrupt(&|w| w[spheres + 3] = (-1.0f32).to_bits()),
        Err(FormatError::NonFiniteGeometry)
    );
    assert_eq!(
        corrupt(&|w| w[header::DEPTH] += 1),
        Err(FormatError::BadDepth)
    );
    let (interior, many) = find_nodes(&good);
    assert!(matches!(
        corrupt(&|w| w[interior] = f32::NAN.to_bits()),
        Err(FormatError::BadSplit { .. })
    ));
    // Above child pointing back at its parent (a cycle), and past the end.
    assert!(matches!(
        corrupt(&|w| w[interior + 1] &= 3),
        Err(FormatError::BadChild { .. })
    ));
    assert!(matches!(
        corrupt(&|w| w[interior + 1] |= 0x3fff_fff0 << 2),
        Err(FormatError::BadChild { .. })
    ));
    // Each interior node's empty-child bits, flipped one at a time, in both directions: a bit
    // claiming an empty child that holds primitives (or is interior), and a clear bit on an empty
    // leaf.
    let base = good[header::NODES_OFFSET] as usize;
    let mut set_bits = 0;
    for i in 0..good[header::NODE_COUNT] as usize {
        let node = Node::from_words([good[base + 2 * i], good[base + 2 * i + 1]]);
        if node.is_leaf() {
            continue;
        }
        set_bits += node.empty_children().iter().filter(|&&e| e).count();
        for bit in [2, 3] {
            assert_eq!(
                corrupt(&|w| w[base + 2 * i + 1] ^= 1 << bit),
                Err(FormatError::BadEmptyFlag { node: i as u32 })
            );
        }
    }
    assert!(set_bits > 0, "the scene should have empty leaves");
    // A leaf naming a primitive that does not exist, and an index-list range past its end.
    let many = many.expect("the scene has a multi-primitive leaf");
    let one_missing = |w: &mut Vec<u32>| {
        w[many] = 10_000;
        w[many + 1] = Node::leaf(1, 0).words()[1];
    };
    assert!(matches!(
        corrupt(&one_missing),
        Err(FormatError::BadPrimitive { .. })
    ));
    assert!(matches!(
        corrupt(&|w| w[many] = u32::MAX - 1),
        Err(FormatError::BadPrimitive { .. })
    ));
    let indices = good[header::INDICES_OFFSET] as usize;
    assert_eq!(
        corrupt(&|w| w[indices + 1] = 10_000),
        Err(FormatError::BadIndex { index: 1 })
    );
    // Leaves must use the index list in turn (see `leaves_sharing_an_index_range_are_refused`).
    assert!(matches!(
        corrupt(&|w| w[many] += 1),
        Err(FormatError::IndexOrder { .. } | FormatError::BadPrimitive { .. })
    ));
    let ids = good[header::INPUT_IDS_OFFSET] as usize;
    assert_eq!(
        corrupt(&|w| w[ids + 3] = 12),
        Err(FormatError::BadInputId { triangle: 3 })
    );
    assert_eq!(
        corrupt(&|w| w[header::CONTENTS] &= !contents::INPUT_IDS),
        Err(FormatError::BadContents)
    );
}

#[test]
fn a_dag_of_shared_nodes_is_rejected_not_walked() {
    // 40 interior nodes whose children are both the next node: 2^40 paths if walked naively.
    let n = 41u32;
    let mut w = vec![0u32; HEADER_WORDS];
    w[header::MAGIC] = MAGIC;
    w[header::VERSION] = VERSION;
    w[header::NODE_COUNT] = n;
    w[header::DEPTH] = 40;
    w[header::NODES_OFFSET] = HEADER_WORDS as u32;
    for i in 0..n - 1 {
        w.extend(Node::interior(0, 0.0, i + 1, [false; 2]).words());
    }
    w.extend(Node::leaf(0, 0).words());
    w[header::TOTAL_WORDS] = w.len() as u32;
    seal(&mut w);
    assert!(matches!(check(&w), Err(FormatError::BadChild { .. })));
}

#[test]
fn a_tree_deeper_than_the_stack_is_rejected() {
    // A valid chain: every interior node's below child is a leaf, the above child goes deeper.
    let depth = kdray_core::format::MAX_DEPTH as u32 + 1;
    let mut w = vec![0u32; HEADER_WORDS];
    let mut nodes = Vec::new();
    for i in 0..depth {
        nodes.push(Node::interior(0, 0.0, 2 * i + 2, [true, i + 1 == depth]));
        nodes.push(Node::leaf(0, 0));
    }
    nodes.push(Node::leaf(0, 0));
    w[header::MAGIC] = MAGIC;
    w[header::VERSION] = VERSION;
    w[header::NODE_COUNT] = nodes.len() as u32;
    w[header::DEPTH] = depth;
    w[header::NODES_OFFSET] = HEADER_WORDS as u32;
    w.extend(nodes.iter().flat_map(|n| n.words()));
    w[header::TOTAL_WORDS] = w.len() as u32;
    seal(&mut w);
    assert_eq!(check(&w), Err(FormatError::BadDepth));
}

/// A complete tree of `depth` levels below the root (all splits at x = 0), whose `2^depth` leaves
/// hold `per_leaf` primitive references each into an index list of `n_indices` zeros: leaf `k`'s
/// range starts at `start(k)`. One sphere at the origin is primitive 0.
fn tree_of_leaves(
    depth: u32,
    per_leaf: u32,
    n_indices: u32,
    start: &dyn Fn(u32) -> u32,
) -> Vec<u32> {
    fn push(nodes: &mut Vec<Node>, level: u32, leaves: &mut u32, leaf: &dyn Fn(u32) -> Node) {
        if level == 0 {
            nodes.push(leaf(*leaves));
            *leaves += 1;
            return;
        }
        let at = nodes.len();
        nodes.push(Node::leaf(0, 0));
        push(nodes, level - 1, leaves, leaf);
        let above = nodes.len() as u32;
        nodes[at] = Node::interior(0, 0.0, above, [false; 2]);
        push(nodes, level - 1, leaves, leaf);
    }
    let mut nodes = Vec::new();
    push(&mut nodes, depth, &mut 0, &|k| {
        Node::leaf(per_leaf, start(k))
    });
    let mut w = vec![0u32; HEADER_WORDS];
    w[header::MAGIC] = MAGIC;
    w[header::VERSION] = VERSION;
    w[header::CONTENTS] = contents::SPHERES;
    w[header::NODE_COUNT] = nodes.len() as u32;
    w[header::SPHERE_COUNT] = 1;
    w[header::INDEX_COUNT] = n_indices;
    w[header::DEPTH] = depth;
    for k in 0..6 {
        w[header::BOUNDS + k] = if k < 3 { -1.0f32 } else { 1.0 }.to_bits();
    }
    w[header::NODES_OFFSET] = w.len() as u32;
    w.extend(nodes.iter().flat_map(|n| n.words()));
    w.resize(w.len().next_multiple_of(8), 0);
    w[header::INDICES_OFFSET] = w.len() as u32;
    w.resize(w.len() + n_indices as usize, 0);
    w.resize(w.len().next_multiple_of(8), 0);
    w[header::SPHERES_OFFSET] = w.len() as u32;
    w.extend([0.0f32, 0.0, 0.0, 0.5].map(f32::to_bits));
    w[header::TOTAL_WORDS] = w.len() as u32;
    seal(&mut w);
    w
}

/// Issue 20's probe: 131,072 leaves all naming one 500,000-entry range of the index list, a 4 MB
/// file, took 40 s to validate (every leaf re-checked the range: leaves × range checks). Leaves
/// must now use the list in turn, so the second leaf is refused at once and validation stays
/// linear in the words. The same shape with each leaf on its own range is accepted, and there the
/// leaves' references add up to exactly the list's length: the work of validating them, and the
/// most primitives one ray can test, are bounded by the file's length.
#[test]
fn leaves_sharing_an_index_range_are_refused() {
    // Smaller than the probe (1,024 leaves × 20,000), to keep the test quick on a build that
    // still accepted it; the rule refuses any size at the second leaf.
    let (depth, per_leaf) = (10u32, 20_000u32);
    let shared = tree_of_leaves(depth, per_leaf, per_leaf, &|_| 0);
    // The root's below subtree runs down to leaf 0 at node `depth`; leaf 1 is the next node.
    assert_eq!(
        check(&shared),
        Err(FormatError::IndexOrder { node: depth + 1 })
    );
    // Two neighbouring leaves swapped, and overlapping by one entry.
    let swapped = tree_of_leaves(3, 2, 16, &|k| 2 * (k ^ 1));
    assert!(matches!(
        check(&swapped),
        Err(FormatError::IndexOrder { .. })
    ));
    let overlapping = tree_of_leaves(3, 2, 16, &|k| k);
    assert!(matches!(
        check(&overlapping),
        Err(FormatError::IndexOrder { .. })
    ));
    // A list longer than the leaves use.
    let longer = tree_of_leaves(3, 2, 17, &|k| 2 * k);
    assert_eq!(check(&longer), Err(FormatError::UnusedIndices { from: 16 }));
    let tiled = tree_of_leaves(6, 100, 64 * 100, &|k| 100 * k);
    let scene = Scene::from_words(&tiled).unwrap();
    assert_eq!(leaf_references(&scene), 64 * 100);
    assert!(leaf_references(&scene) <= tiled.len() as u64);
    let hit = scene.intersect(&Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z));
    assert_eq!((hit.prim, hit.t), (0, 4.5));
}

/// The primitive references of the leaves with an index list, summed over the nodes: what
/// validating them costs, and a bound on what one walk tests.
fn leaf_references(scene: &Scene) -> u64 {
    (0..scene.node_count())
        .map(|i| scene.node(i))
        .filter(|n| n.is_leaf() && n.prim_count() > 1)
        .map(|n| u64::from(n.prim_count()))
        .sum()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: kdray_tests::cases(2000), ..ProptestConfig::default() })]

    /// Arbitrary words never panic (and mostly fail the magic test) ...
    #[test]
    fn arbitrary_words_never_panic(words in prop::collection::vec(any::<u32>(), 0..200)) {
        let _ = check(&words);
    }

    /// ... so also mutate a valid scene in a few random words and re-seal it, which reaches the
    /// deep checks; a mutation that still validates must trace without panicking.
    #[test]
    fn mutated_scenes_never_panic(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u32>()), 1..6)) {
        let mut words = valid_words();
        let len = words.len();
        for (at, value) in edits {
            words[at.index(len)] = value;
        }
        seal(&mut words);
        if let Ok(scene) = Scene::from_words(&words) {
            // Whatever the mutation, an accepted file's leaves reference at most the index
            // list's entries, each once: linear validation and walks.
            prop_assert!(leaf_references(&scene) <= words[header::INDEX_COUNT] as u64);
            for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.3, 0.4, -0.5).normalize()] {
                let _ = scene.intersect(&Ray::new(Vec3::new(1.0, 0.5, 0.0), d));
                let _ = scene.occluded(&Ray::new(Vec3::new(1.0, 0.5, 0.0), d));
            }
        }
    }
}

/// Leaf order moves every per-triangle section with its triangle: stored triangle `k` has the
/// vertices, normals, texture coordinates and material of input triangle `input_id(k)`.
#[test]
fn per_triangle_sections_follow_the_leaf_order() {
    let triangles = fan();
    let n = triangles.len();
    let normals: Vec<[Vec3; 3]> = (0..n)
        .map(|i| [Vec3::new(i as f32, 0.0, 1.0).normalize(), Vec3::Z, Vec3::Y])
        .collect();
    let uvs: Vec<[glam::Vec2; 3]> = (0..n)
        .map(|i| {
            [
                glam::Vec2::new(i as f32, 0.5),
                glam::Vec2::ZERO,
                glam::Vec2::ONE,
            ]
        })
        .collect();
    let geom = Geometry {
        triangles: triangles.clone(),
        normals: Some(normals.clone()),
        uvs: Some(uvs.clone()),
        tri_materials: (0..n as u32).map(|i| i % 5).collect(),
        spheres: vec![(Vec3::new(2.0, 3.0, 0.0), 0.5)],
        sphere_materials: vec![7],
    };
    let params = BuildParams {
        parallel: false,
        ..BuildParams::default()
    };
    let words = serialize(&build(&geom, &params, None).unwrap(), &geom, 1.0).unwrap();
    let scene = Scene::from_words(&words).unwrap();
    assert!(scene.reorders_triangles());
    for k in 0..n as u32 {
        let i = scene.input_id(k) as usize;
        let v = triangles[i];
        let want = kdray_core::Triangle::from_vertices(v[0], v[1], v[2]);
        assert_eq!(scene.triangle(k), want, "stored {k} = input {i}");
        assert_eq!(scene.vertex_normals(k), Some(normals[i]));
        assert_eq!(scene.vertex_uvs(k), Some(uvs[i]));
        assert_eq!(scene.material(k), i as u32 % 5);
    }
    assert_eq!(
        scene.material(n as u32),
        7,
        "spheres keep their ids and materials"
    );
}

/// Two numberings of triangles, on a mesh of many: `Hit::prim` is the storage order, which the
/// serializer makes the leaves' order, and `Scene::input_id` maps it back to the mesh's. A ray
/// aimed at the centre of each of an icosphere's 1,280 triangles, along its inward normal, hits
/// that triangle: `input_id(hit.prim)` is the aimed index, and `prim` alone is not, for most of
/// them — in every layout and leaf kind, for single rays and the ray stream.
#[test]
fn hits_map_to_the_mesh_order_on_a_mesh_of_many_triangles() {
    use kdray::flat::{Layout, Leaves, serialize_as};
    use kdray_core::traverse::stream;
    let triangles = kdray::closed::icosphere(3).triangles();
    assert_eq!(triangles.len(), 1280);
    let geom = Geometry {
        triangles: triangles.clone(),
        ..Geometry::default()
    };
    let rays: Vec<Ray> = triangles
        .iter()
        .map(|&[a, b, c]| {
            let centre = (a + b + c) / 3.0;
            let normal = (b - a).cross(c - a).normalize();
            Ray::new(centre + normal, -normal)
        })
        .collect();
    for (layout, leaves) in [
        (Layout::Nodes, Leaves::List),
        (Layout::Wide, Leaves::List),
        (Layout::Wide, Leaves::Groups),
    ] {
        let tree = build(&geom, &leaves.build_params(), None).unwrap();
        let words = serialize_as(&tree, &geom, 0.0, layout, leaves).unwrap();
        let scene = Scene::from_words(&words).unwrap();
        assert!(scene.reorders_triangles());
        let mut streamed = vec![kdray_core::Hit::MISS; rays.len()];
        let mut scratch = vec![0u64; stream::scratch_words(rays.len())];
        let config = stream::Config::default();
        stream::intersect(&scene, &config, &rays, &mut streamed, &mut scratch).unwrap();
        let mut moved = 0;
        for (i, (ray, s)) in rays.iter().zip(&streamed).enumerate() {
            let hit = scene.intersect(ray);
            assert_eq!(
                scene.input_id(hit.prim),
                i as u32,
                "{layout:?} {leaves:?}: ray {i}"
            );
            assert_eq!(s.prim, hit.prim, "{layout:?} {leaves:?}: ray {i}, stream");
            moved += usize::from(hit.prim != i as u32);
        }
        assert!(
            moved > rays.len() / 2,
            "{layout:?} {leaves:?}: only {moved} moved"
        );
    }
}
