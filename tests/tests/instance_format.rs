//! The top level's words against damage and crafting (`kdray_core::instance`, "Validation"):
//! each kind refused with its own error, the checksum first; every single word replaced (and the
//! checksum recomputed, as a crafted file would) refused or accepted without a panic, and an
//! accepted one still traced in bounded time; the builder's output accepted.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray::instances::{Placement, top_level};
use kdray_core::format::seal;
use kdray_core::instance::{
    Affine, HEADER_WORDS, InstanceError, InstancedScene, NODE_WORDS, RECORD_WORDS, header, node,
    record,
};
use kdray_core::traverse::Mode;
use kdray_core::{Ray, Scene};

fn mesh_words() -> Vec<u32> {
    let p = |x, y, z| Vec3::new(x, y, z);
    let geom = Geometry {
        triangles: vec![
            [p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0)],
            [p(0.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(0.0, 1.0, 0.5)],
        ],
        ..Geometry::default()
    };
    let tree = build(&geom, &BuildParams::default(), None).unwrap();
    serialize(&tree, &geom, 0.0).unwrap()
}

/// Nine instances (two leaves' worth and more) of the mesh, turned, mirrored and scaled.
fn placements() -> Vec<Placement> {
    (0..9)
        .map(|k| {
            let (s, c) = (k as f32 * 0.7).sin_cos();
            let m = if k % 2 == 0 { 1.0 } else { -2.0 };
            Placement {
                bottom: 0,
                transform: Affine([
                    c * m,
                    -s,
                    0.0,
                    k as f32 * 3.0,
                    s * m,
                    c,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    1.0 + k as f32,
                    -(k as f32),
                ]),
                user_id: k,
            }
        })
        .collect()
}

fn record_word(words: &[u32], instance: usize, at: usize) -> usize {
    let nodes = words[header::NODE_COUNT] as usize;
    HEADER_WORDS + NODE_WORDS * nodes + RECORD_WORDS * instance + at
}

/// The word of the root's first slot that references a node (nine instances: the root's eight
/// slots hold seven records and one node of two).
fn root_child_ref(words: &[u32]) -> usize {
    (0..8)
        .map(|s| HEADER_WORDS + node::REFS + s)
        .find(|&at| words[at] & node::RECORD_REF == 0)
        .expect("a node under the root")
}

/// `words` changed by `edit`, then resealed.
fn crafted(words: &[u32], edit: impl FnOnce(&mut Vec<u32>)) -> Vec<u32> {
    let mut w = words.to_vec();
    edit(&mut w);
    seal(&mut w);
    w
}

#[test]
fn each_kind_of_damage_has_its_error() {
    let mesh = mesh_words();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let words = top_level(&bottoms, &placements()).unwrap();
    let open = |w: &[u32]| InstancedScene::from_words(w, &bottoms).map(|_| ());
    assert_eq!(open(&words), Ok(()));
    assert_eq!(open(&words[..10]), Err(InstanceError::TooShort));
    assert!(matches!(
        open(&words[..words.len() - 1]),
        Err(InstanceError::LengthMismatch { .. })
    ));
    // A flipped bit anywhere: the checksum.
    for i in [header::VERSION + 5, words.len() / 2, words.len() - 1] {
        let mut w = words.clone();
        w[i] ^= 1 << 9;
        assert_eq!(open(&w), Err(InstanceError::Checksum), "word {i}");
    }
    assert_eq!(open(&mesh), Err(InstanceError::SingleMesh));
    // And the single-mesh reader refuses a top level.
    assert_eq!(
        Scene::from_words(&words).map(|_| ()),
        Err(kdray_core::FormatError::TopLevel)
    );
    // Version 1 (binary nodes) and a future version: refused by number.
    for v in [1, 3] {
        assert_eq!(
            open(&crafted(&words, |w| w[header::VERSION] = v)),
            Err(InstanceError::UnsupportedVersion(v))
        );
    }
    assert_eq!(
        open(&crafted(&words, |w| w[7] = 1)),
        Err(InstanceError::ReservedNotZero)
    );
    assert_eq!(
        InstancedScene::from_words(&words, &[bottoms[0], bottoms[0]]).map(|_| ()),
        Err(InstanceError::BottomCount {
            header: 1,
            actual: 2
        })
    );
    let r = |i, at| record_word(&words, i, at);
    assert_eq!(
        open(&crafted(&words, |w| w[r(3, record::BOTTOM)] = 1)),
        Err(InstanceError::BadBottom { instance: 3 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[r(4, record::TRANSFORM + 5)] =
            f32::NAN.to_bits())),
        Err(InstanceError::NonFiniteTransform { instance: 4 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[r(4, record::INVERSE)] =
            f32::INFINITY.to_bits())),
        Err(InstanceError::NonFiniteTransform { instance: 4 })
    );
    // A singular transform: its first row zero.
    assert_eq!(
        open(&crafted(&words, |w| {
            for k in 0..3 {
                w[r(2, record::TRANSFORM + k)] = 0;
            }
        })),
        Err(InstanceError::Singular { instance: 2 })
    );
    // Nearly singular: the third row the first's within 1e-12.
    assert_eq!(
        open(&crafted(&words, |w| {
            for k in 0..3 {
                w[r(2, record::TRANSFORM + 8 + k)] = w[r(2, record::TRANSFORM + k)];
            }
        })),
        Err(InstanceError::Singular { instance: 2 })
    );
    // The inverse of another instance, or off in its translation.
    assert_eq!(
        open(&crafted(&words, |w| {
            for k in 0..12 {
                w[r(5, record::INVERSE + k)] = w[r(6, record::INVERSE + k)];
            }
        })),
        Err(InstanceError::InverseMismatch { instance: 5 })
    );
    assert_eq!(
        open(&crafted(&words, |w| {
            let at = r(5, record::INVERSE + 3);
            w[at] = (f32::from_bits(w[at]) + 0.01).to_bits();
        })),
        Err(InstanceError::InverseMismatch { instance: 5 })
    );
    // A box that leaves out part of the instance.
    assert_eq!(
        open(&crafted(&words, |w| {
            let at = r(1, record::BOX + 3);
            w[at] = (f32::from_bits(w[at]) - 0.25).to_bits();
        })),
        Err(InstanceError::BadInstanceBox { instance: 1 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[r(1, record::BOX)] = f32::NAN.to_bits())),
        Err(InstanceError::BadInstanceBox { instance: 1 })
    );
    // The root's child node pointing back at the root, or past the end.
    let child = root_child_ref(&words);
    assert_eq!(
        open(&crafted(&words, |w| w[child] = 0)),
        Err(InstanceError::BadChild { node: 0 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[child] = 1000)),
        Err(InstanceError::BadChild { node: 0 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[header::DEPTH] += 1)),
        Err(InstanceError::BadDepth)
    );
    assert_eq!(
        open(&crafted(&words, |w| w[header::INSTANCE_COUNT] = 0)),
        Err(InstanceError::BadCounts)
    );
    assert_eq!(
        open(&crafted(&words, |w| w[header::NODE_COUNT] = u32::MAX)),
        Err(InstanceError::BadCounts)
    );
}

/// The builder's own words opened without the checksum and the records' f64 checks
/// (`from_built_words`, what the packages run when instances move) still refuse what would take
/// a walk out of range: a bottom index, a child pointer, counts, a length, a depth.
#[test]
fn built_words_keep_the_checks_that_bound_the_walk() {
    let mesh = mesh_words();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let words = top_level(&bottoms, &placements()).unwrap();
    let open = |w: &[u32]| InstancedScene::from_built_words(w, &bottoms).map(|_| ());
    assert_eq!(open(&words), Ok(()));
    // Not checked: the checksum (a flipped bit in a user id is accepted).
    let mut w = words.clone();
    w[record_word(&words, 0, record::USER_ID)] ^= 1 << 9;
    assert_eq!(open(&w), Ok(()));
    // Checked, without resealing (the checksum is not what refuses them).
    let edit = |f: &dyn Fn(&mut Vec<u32>)| {
        let mut w = words.clone();
        f(&mut w);
        w
    };
    assert_eq!(open(&words[..10]), Err(InstanceError::TooShort));
    assert!(matches!(
        open(&words[..words.len() - 1]),
        Err(InstanceError::LengthMismatch { .. })
    ));
    assert_eq!(open(&mesh), Err(InstanceError::SingleMesh));
    assert_eq!(
        open(&edit(&|w| w[record_word(&words, 3, record::BOTTOM)] = 1)),
        Err(InstanceError::BadBottom { instance: 3 })
    );
    let child = root_child_ref(&words);
    assert_eq!(
        open(&edit(&|w| w[child] = 0)),
        Err(InstanceError::BadChild { node: 0 })
    );
    assert_eq!(
        open(&edit(&|w| w[child] = 1000)),
        Err(InstanceError::BadChild { node: 0 })
    );
    assert_eq!(
        open(&edit(&|w| w[header::DEPTH] += 1)),
        Err(InstanceError::BadDepth)
    );
    assert_eq!(
        open(&edit(&|w| w[header::NODE_COUNT] = u32::MAX)),
        Err(InstanceError::BadCounts)
    );
    assert_eq!(
        open(&edit(
            &|w| w[record_word(&words, 1, record::BOX)] = f32::NAN.to_bits()
        )),
        Err(InstanceError::BadInstanceBox { instance: 1 })
    );
}

/// The wide nodes' own rules, each refused: a count outside 1..=8, a used slot emptied or an
/// unused one filled, a reserved word set, records or nodes referenced out of the depth-first
/// order (swapped, repeated, backwards), a slot's box outside its parent's or around less than
/// its record's.
#[test]
fn wide_nodes_break_their_rules_and_are_refused() {
    let mesh = mesh_words();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let words = top_level(&bottoms, &placements()).unwrap();
    let open = |w: &[u32]| InstancedScene::from_words(w, &bottoms).map(|_| ());
    assert_eq!(words[header::NODE_COUNT], 2, "a root and one node of two");
    let root = |at: usize| HEADER_WORDS + at;
    let child = root_child_ref(&words);
    let first_record = (0..8)
        .map(|s| root(node::REFS + s))
        .find(|&at| words[at] == node::RECORD_REF)
        .expect("record 0 under the root");
    for count in [0, 7, 9, u32::MAX] {
        assert_eq!(
            open(&crafted(&words, |w| w[root(node::COUNT)] = count)),
            Err(InstanceError::BadChild { node: 0 }),
            "count {count}"
        );
    }
    assert_eq!(
        open(&crafted(&words, |w| w[root(node::RESERVED.start + 3)] = 1)),
        Err(InstanceError::BadChild { node: 0 })
    );
    // The second node's slot past its count (two) given a box.
    let second = |at: usize| HEADER_WORDS + NODE_WORDS + at;
    assert_eq!(
        open(&crafted(&words, |w| w[second(node::BOXES + 3)] = 0)),
        Err(InstanceError::BadChild { node: 1 })
    );
    // Two records swapped, one named twice, the node named as a record.
    assert_eq!(
        open(&crafted(&words, |w| w.swap(first_record, first_record + 1))),
        Err(InstanceError::RecordOrder { node: 0 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[first_record + 1] = w[first_record])),
        Err(InstanceError::RecordOrder { node: 0 })
    );
    assert!(open(&crafted(&words, |w| w[child] = node::RECORD_REF | 8)).is_err());
    // A slot's box not finite, outside the bounds, or smaller than its record's.
    let slot = first_record - root(node::REFS);
    assert_eq!(
        open(&crafted(&words, |w| w[root(slot)] = f32::NAN.to_bits())),
        Err(InstanceError::BadNodeBox { node: 0 })
    );
    assert_eq!(
        open(&crafted(&words, |w| w[root(slot)] = (-1.0e6f32).to_bits())),
        Err(InstanceError::BadNodeBox { node: 0 })
    );
    assert_eq!(
        open(&crafted(&words, |w| {
            let at = root(slot + 8);
            w[at] = (f32::from_bits(w[at]) - 0.5).to_bits();
        })),
        Err(InstanceError::BadInstanceBox { instance: 0 })
    );
}

/// One instance: a root of one record slot; two: a root of two.
#[test]
fn one_and_two_instances_make_a_root_of_records() {
    let mesh = mesh_words();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    for n in [1, 2] {
        let words = top_level(&bottoms, &placements()[..n]).unwrap();
        assert_eq!(words[header::NODE_COUNT], 1);
        assert_eq!(words[HEADER_WORDS + node::COUNT], n as u32);
        let top = InstancedScene::from_words(&words, &bottoms).unwrap();
        assert_eq!((top.instance_count(), top.depth()), (n as u32, 0));
        // Straight down onto instance 0's first triangle (the identity turned by 0).
        let hit = top.intersect(&Ray::new(Vec3::new(0.7, 0.2, 5.0), Vec3::NEG_Z));
        assert_eq!((hit.user_id, hit.t), (0, 5.0));
    }
}

/// Every word of a top level replaced by each of a few values, resealed: refused with an error or
/// accepted, never a panic, and an accepted one traces a fan of rays in both modes, any hit
/// agreeing with closest hit — opened by `from_words`, and by `from_built_words`, which checks
/// less and so accepts more: its walks must stay in range all the same.
#[test]
fn every_word_replaced_is_refused_or_traced() {
    let mesh = mesh_words();
    let bottoms = [Scene::from_words(&mesh).unwrap()];
    let words = top_level(&bottoms, &placements()).unwrap();
    let values = [
        0u32,
        1,
        2,
        u32::MAX,
        f32::NAN.to_bits(),
        f32::INFINITY.to_bits(),
        (-1.0f32).to_bits(),
        1.0f32.to_bits(),
        1.0e30f32.to_bits(),
    ];
    for built in [false, true] {
        let name = if built {
            "from_built_words"
        } else {
            "from_words"
        };
        let mut accepted = 0;
        for i in 0..words.len() {
            if i == header::CHECKSUM || i == header::CHECKSUM + 1 {
                continue;
            }
            for &v in &values {
                let w = crafted(&words, |w| w[i] = v);
                let top = if built {
                    InstancedScene::from_built_words(&w, &bottoms)
                } else {
                    InstancedScene::from_words(&w, &bottoms)
                };
                let Ok(top) = top else {
                    continue;
                };
                accepted += 1;
                for k in 0..16 {
                    let a = k as f32 * 0.4;
                    let ray = Ray::new(
                        Vec3::new(12.0 * a.cos(), 12.0 * a.sin(), 5.0),
                        Vec3::new(-a.cos(), -a.sin(), -0.4).normalize(),
                    );
                    for mode in [Mode::Fast, Mode::Watertight] {
                        let hit = top.intersect_in(mode, &ray);
                        assert_eq!(
                            top.occluded_in(mode, &ray),
                            hit.is_hit(),
                            "{name}: word {i} = {v:#x}"
                        );
                    }
                }
            }
        }
        // Some replacements are harmless (a user id, a box grown, a reserved-free bit of a
        // float).
        assert!(accepted > 0, "{name}");
    }
}
