//! The blocked layout (format v7's blocks section): the walk over blocks, alone or interleaved
//! (1 to 16 in flight, and in a stream without packets), returns exactly the hits of the walk
//! over nodes (t, primitive and barycentrics bit for bit, closest and any hit, fast and
//! watertight), on the same random grid scenes as the brute-force tests; and validation
//! rejects each kind of damage to a blocks section with its own error.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{BuildParams, build};
use kdray::flat::{Layout, Leaves, serialize_as};
use kdray_core::format::{FormatError, VERSION, contents, header, seal};
use kdray_core::traverse::Mode;
use kdray_core::traverse::blocked::{self, AXES_WORD, BLOCK_WORDS, REFS_WORD, kind};
use kdray_core::traverse::stream::{self, Config, InFlight, Packets};
use kdray_core::{Hit, Ray, Scene};
use kdray_tests::strategies::{grid_geometry, scattered_triangles, traversal_ray};
use proptest::prelude::*;

/// Both layouts of `geom`'s tree, built once.
fn both_layouts(geom: &Geometry, intersect_cost: f64) -> (Vec<u32>, Vec<u32>) {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        ..BuildParams::default()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    let words =
        |layout| serialize_as(&tree, geom, 0.0, layout, Leaves::List).expect("fits the format");
    (words(Layout::Nodes), words(Layout::Blocked))
}

fn bits(h: &Hit) -> [u32; 4] {
    [h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(96)))]

    #[test]
    fn blocked_walk_returns_the_node_walks_hits(
        geom in grid_geometry(3),
        isect in prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
        rays in prop::collection::vec(traversal_ray(), 40),
    ) {
        let (nodes, blocks) = both_layouts(&geom, isect);
        let classic = Scene::from_words(&nodes).unwrap();
        let blocked = Scene::from_words(&blocks).unwrap();
        prop_assert!(classic.blocks().is_empty());
        prop_assert!(!blocked.blocks().is_empty());
        for ray in &rays {
            for mode in [Mode::Fast, Mode::Watertight] {
                let (a, b) = (classic.intersect_in(mode, ray), blocked.intersect_in(mode, ray));
                prop_assert_eq!(bits(&a), bits(&b), "{:?} {:?}", mode, ray);
                prop_assert_eq!(classic.occluded_in(mode, ray), blocked.occluded_in(mode, ray));
            }
        }
    }

    /// The levers together: many walks over the blocks in flight (and a stream's single rays,
    /// sorted) return the node walk's hits ray by ray, whichever ray shares the walk with which.
    #[test]
    fn interleaved_blocked_walks_return_the_node_walks_hits(
        geom in grid_geometry(3),
        isect in prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
        rays in prop::collection::vec(traversal_ray(), 1..60),
    ) {
        let (nodes, blocks) = both_layouts(&geom, isect);
        let classic = Scene::from_words(&nodes).unwrap();
        let blocked = Scene::from_words(&blocks).unwrap();
        let n = rays.len();
        for mode in [Mode::Fast, Mode::Watertight] {
            let want: Vec<[u32; 4]> = rays.iter().map(|r| bits(&classic.intersect_in(mode, r))).collect();
            let want_occ: Vec<bool> = rays.iter().map(|r| classic.occluded_in(mode, r)).collect();
            for in_flight in [InFlight::One, InFlight::Four, InFlight::Eight, InFlight::Sixteen] {
                let mut hits = vec![Hit { t: -7.0, prim: 77, u: 7.0, v: 7.0 }; n];
                stream::intersect_interleaved(&blocked, mode, in_flight, &rays, &mut hits).unwrap();
                let got: Vec<[u32; 4]> = hits.iter().map(bits).collect();
                prop_assert_eq!(&got, &want, "{:?} {:?}", mode, in_flight);
                let mut occ = vec![!want_occ[0]; n];
                stream::occluded_interleaved(&blocked, mode, in_flight, &rays, &mut occ).unwrap();
                prop_assert_eq!(&occ, &want_occ, "{:?} {:?}", mode, in_flight);
                let config = Config { mode, packets: Packets::Off, in_flight, ..Config::default() };
                let mut scratch = vec![u64::MAX; stream::scratch_words(n)];
                stream::intersect(&blocked, &config, &rays, &mut hits, &mut scratch).unwrap();
                let got: Vec<[u32; 4]> = hits.iter().map(bits).collect();
                prop_assert_eq!(&got, &want, "stream {:?}", config);
                stream::occluded(&blocked, &config, &rays, &mut occ, &mut scratch).unwrap();
                prop_assert_eq!(&occ, &want_occ, "stream {:?}", config);
            }
        }
    }
}

/// A scene deep enough for several levels of blocks: 300 triangles scattered on a grid, many
/// overlapping (so that some leaves hold several).
fn scattered() -> Geometry {
    scattered_triangles(300)
}

/// Which shapes the blocks of `blocks` have: a leaf slot at level 1, at level 2, a root at
/// level 1, at level 2, an empty leaf.
fn block_shapes(blocks: &[blocked::Block]) -> [bool; 5] {
    let mut seen = [false; 5];
    for b in blocks {
        for s in 1..7 {
            let parent = (s - 1) / 2;
            let level = if s < 3 { 0 } else { 1 };
            if blocked::is_interior(b, parent) && !blocked::is_interior(b, s) {
                seen[level] = true;
            }
            if blocked::is_root(b, s) {
                seen[2 + level] = true;
            }
        }
        seen[4] |= (1..15).any(|p| blocked::is_empty_at(b, p));
    }
    seen
}

/// Rays on and across the integer planes of [`scattered`]: from grid points and points between,
/// along the axes (±0 components) and diagonals, so that many lie in split planes.
fn grid_rays() -> Vec<Ray> {
    let dirs = [
        Vec3::X,
        -Vec3::Y,
        Vec3::Z,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(0.0, -1.0, -1.0),
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(-3.0, 1.0, -2.0),
        Vec3::new(-0.0, 0.5, -0.0),
    ];
    let mut rays = Vec::new();
    for i in 0..60 {
        let o = Vec3::new(
            (i * 5 % 11) as f32 - 1.0,
            (i * 3 % 9) as f32 - 1.0,
            (i * 7 % 13) as f32 - 1.0,
        ) + if i % 3 == 0 {
            Vec3::splat(0.5)
        } else {
            Vec3::ZERO
        };
        for d in dirs {
            rays.push(Ray::new(o, d.normalize()));
            rays.push(Ray::new(o, -d.normalize()).with_range(-1.5, 4.0));
        }
    }
    rays
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(48)))]

    /// Trees of every size up to several blocks, with leaves high and low in blocks and shared
    /// blocks of packed subtrees (see `block_shapes_are_all_covered`): the walk deciding a
    /// block's cells at once returns the node walk's hits, one ray at a time and interleaved.
    #[test]
    fn blocks_of_every_shape_return_the_node_walks_hits(
        n in 1usize..300,
        isect in prop_oneof![Just(2.0), Just(20.0), Just(80.0), Just(400.0)],
    ) {
        let (nodes, blocks) = both_layouts(&scattered_triangles(n), isect);
        let classic = Scene::from_words(&nodes).unwrap();
        let blocked = Scene::from_words(&blocks).unwrap();
        let rays = grid_rays();
        for mode in [Mode::Fast, Mode::Watertight] {
            let want: Vec<[u32; 4]> = rays.iter().map(|r| bits(&classic.intersect_in(mode, r))).collect();
            let got: Vec<[u32; 4]> = rays.iter().map(|r| bits(&blocked.intersect_in(mode, r))).collect();
            prop_assert_eq!(&got, &want, "{:?}", mode);
            let mut hits = vec![Hit::MISS; rays.len()];
            stream::intersect_interleaved(&blocked, mode, InFlight::Eight, &rays, &mut hits).unwrap();
            let got: Vec<[u32; 4]> = hits.iter().map(bits).collect();
            prop_assert_eq!(&got, &want, "interleaved {:?}", mode);
            for r in &rays {
                prop_assert_eq!(classic.occluded_in(mode, r), blocked.occluded_in(mode, r));
            }
        }
    }
}

/// The scenes of `blocks_of_every_shape_return_the_node_walks_hits` hold every shape of block the
/// walk masks lanes for.
#[test]
fn block_shapes_are_all_covered() {
    let mut seen = [false; 5];
    for n in (1..300).step_by(7) {
        for isect in [2.0, 20.0, 80.0, 400.0] {
            let (_, words) = both_layouts(&scattered_triangles(n), isect);
            let scene = Scene::from_words(&words).unwrap();
            for (s, b) in seen.iter_mut().zip(block_shapes(scene.blocks())) {
                *s |= b;
            }
        }
    }
    assert_eq!(
        seen, [true; 5],
        "leaf at 1, leaf at 2, root at 1, root at 2, empty"
    );
}

/// The blocked words of [`scattered`] and the word offset of its blocks section.
fn blocked_words() -> (Vec<u32>, usize) {
    let (_, words) = both_layouts(&scattered(), 80.0);
    let base = words[header::BLOCKS_OFFSET] as usize;
    assert!(words[header::BLOCK_COUNT] >= 4, "several blocks");
    (words, base)
}

/// The word of the first reference of `kind` in the section, and the block holding it.
fn first_ref(words: &[u32], base: usize, k: u32) -> (usize, u32) {
    let n = words[header::BLOCK_COUNT] as usize;
    (0..n)
        .flat_map(|b| (0..8).map(move |r| (b, base + b * BLOCK_WORDS + REFS_WORD + r)))
        // A used reference of this kind (unused ones are 0, which reads as block 0).
        .find(|&(_, w)| words[w] & 3 == k && words[w] != 0)
        .map(|(b, w)| (w, b as u32))
        .expect("a reference of that kind")
}

fn corrupt(edit: impl Fn(&mut Vec<u32>, usize)) -> Result<(), FormatError> {
    let (mut w, base) = blocked_words();
    edit(&mut w, base);
    seal(&mut w);
    Scene::from_words(&w).map(|_| ())
}

#[test]
fn the_blocked_scene_is_accepted_and_its_blocks_are_cache_lines() {
    let (w, base) = blocked_words();
    assert_eq!(base % 16, 0);
    let scene = Scene::from_words(&w).unwrap();
    assert_eq!(scene.contents() & contents::BLOCKED, contents::BLOCKED);
    assert_eq!(scene.blocks().len(), w[header::BLOCK_COUNT] as usize);
}

#[test]
fn references_out_of_range_backwards_or_out_of_turn_are_refused() {
    let (w, base) = blocked_words();
    let (at, b) = first_ref(&w, base, kind::BLOCK);
    let (n, child) = (w[header::BLOCK_COUNT], w[at] >> 5);
    assert!(child + 2 < n, "a later block to jump to");
    // A reference to block `block`, slot `slot`.
    let set = |block: u32, slot: u32| {
        corrupt(move |w, _| w[at] = blocked::reference(kind::BLOCK, 8 * block + slot))
    };
    let refused = Err(FormatError::BadBlockRef { block: b });
    assert_eq!(set(n, 0), refused, "out of range");
    assert_eq!(set(u32::MAX >> 5, 0), refused, "far out of range");
    assert_eq!(set(b, 0), refused, "to itself");
    assert_eq!(set(0, 0), refused, "back to the root");
    assert_eq!(set(n - 1, 0), refused, "skipping blocks");
    assert_eq!(set(child, 7), refused, "slot 7 is no slot");
    // Slot 1 of a block whose slot 0 is interior is no root (or not interior at all).
    assert!(blocked::is_interior(&block(&w, base, child), 0));
    assert_eq!(set(child, 1), refused, "into the middle of a subtree");
    // A leaf reference naming another node than the one at its place.
    let (leaf, lb) = first_ref(&w, base, kind::LEAF);
    let other = corrupt(move |w, _| w[leaf] += 4);
    assert_eq!(other, Err(FormatError::BadBlockRef { block: lb }));
}

fn block(w: &[u32], base: usize, b: u32) -> blocked::Block {
    w[base + b as usize * BLOCK_WORDS..][..BLOCK_WORDS]
        .try_into()
        .unwrap()
}

#[test]
fn bad_axes_and_unused_words_are_refused() {
    let high = corrupt(|w, base| w[base + AXES_WORD] |= 1 << 20);
    assert_eq!(high, Err(FormatError::BadBlockFlags { block: 0 }));
    // Find a block with an unused slot (axis 3) and give it a plane, then an axis.
    let (w, base) = blocked_words();
    let n = w[header::BLOCK_COUNT] as usize;
    let (b, s) = (0..n)
        .flat_map(|b| (1..7).map(move |s| (b, s)))
        .find(|&(b, s)| (w[base + b * BLOCK_WORDS + AXES_WORD] >> (2 * s)) & 3 == 3)
        .expect("a block with a leaf or unused slot");
    let at = base + b * BLOCK_WORDS;
    let plane = corrupt(move |w, _| w[at + s] = 1.0f32.to_bits());
    assert_eq!(plane, Err(FormatError::BadBlockFlags { block: b as u32 }));
    // Any stray axis below a slot that is not interior, or a set unused reference.
    let stray = corrupt(move |w, _| {
        let lowest = (0..7)
            .rev()
            .find(|&k| (w[at + AXES_WORD] >> (2 * k)) & 3 == 3)
            .unwrap();
        w[at + AXES_WORD] &= !(3 << (2 * lowest));
    });
    assert!(
        matches!(
            stray,
            Err(FormatError::BadBlockFlags { .. } | FormatError::BlockMismatch { .. })
        ),
        "{stray:?}"
    );
}

#[test]
fn a_blocked_tree_that_differs_from_the_nodes_is_refused() {
    let split = corrupt(|w, base| w[base] = (f32::from_bits(w[base]) + 0.25).to_bits());
    assert_eq!(split, Err(FormatError::BlockMismatch { block: 0 }));
    let axis = corrupt(|w, base| {
        let a = w[base + AXES_WORD] & 3;
        w[base + AXES_WORD] = (w[base + AXES_WORD] & !3) | ((a + 1) % 3);
    });
    assert!(
        matches!(axis, Err(FormatError::BlockMismatch { block: 0 })),
        "{axis:?}"
    );
    let (w, base) = blocked_words();
    let (one, b) = first_ref(&w, base, kind::ONE);
    let n_tris = w[header::TRI_COUNT];
    let other_prim =
        corrupt(move |w, _| w[one] = blocked::reference(kind::ONE, ((w[one] >> 2) + 1) % n_tris));
    assert_eq!(other_prim, Err(FormatError::BlockMismatch { block: b }));
    // Emptied without its empty bit, the block is inconsistent; with every empty bit set, the
    // flags disagree with the references.
    let emptied = corrupt(move |w, _| w[one] = blocked::EMPTY);
    assert_eq!(emptied, Err(FormatError::BadBlockFlags { block: b }));
    let all_empty = corrupt(|w, base| w[base + AXES_WORD] |= 0x3fff << (blocked::EMPTY_SHIFT + 1));
    assert_eq!(all_empty, Err(FormatError::BadBlockFlags { block: 0 }));
}

#[test]
fn a_misplaced_or_undeclared_blocks_section_is_refused() {
    let misaligned = corrupt(|w, _| w[header::BLOCKS_OFFSET] -= 8);
    assert!(
        matches!(
            misaligned,
            Err(FormatError::SectionOutOfBounds | FormatError::SectionsOverlap)
        ),
        "{misaligned:?}"
    );
    let undeclared = corrupt(|w, _| w[header::CONTENTS] &= !contents::BLOCKED);
    assert_eq!(undeclared, Err(FormatError::BadContents));
    let no_blocks = corrupt(|w, _| w[header::BLOCK_COUNT] = 0);
    assert_eq!(no_blocks, Err(FormatError::BadContents));
}

#[test]
fn damage_to_a_block_is_a_checksum_error_and_version_6_asks_for_a_rebuild() {
    let (mut w, base) = blocked_words();
    w[base + REFS_WORD] ^= 1 << 9;
    assert_eq!(
        Scene::from_words(&w).map(|_| ()),
        Err(FormatError::Checksum)
    );
    let (mut w, _) = blocked_words();
    w[header::VERSION] = 6;
    seal(&mut w);
    let err = Scene::from_words(&w).map(|_| ()).unwrap_err();
    assert_eq!(err, FormatError::UnsupportedVersion(6));
    assert_eq!(VERSION, 10);
    assert!(err.to_string().contains("rebuild"), "{err}");
}
