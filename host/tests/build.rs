//! The builder's depth rule: pbrt-v3's automatic limit, past which only nodes holding more than
//! `DEEP_LEAF_PRIMS` primitives may split, for at most `DEEP_LEVELS` more levels; an explicit
//! `max_depth` is a hard limit.

use glam::Vec3;
use kdray::build::{
    BuildNode, BuildParams, DEEP_LEAF_PRIMS, DEEP_LEVELS, FAST_DEEP_LEAF_PRIMS,
    FAST_REFERENCE_BUDGET, Quality, REFERENCE_BUDGET, build,
};
use kdray::geometry::Geometry;
use std::collections::BTreeSet;

mod meshes;

/// [`meshes::uv_sphere`] of `n × n` quads as geometry.
fn uv_sphere(n: u32) -> Geometry {
    Geometry {
        triangles: meshes::uv_sphere(n, Vec3::ZERO, 1.0),
        ..Geometry::default()
    }
}

/// Walks the tree; calls `interior(depth, primitives in the subtree)` for each interior node and
/// returns the tree's depth and its subtree's primitives.
fn walk(
    node: &BuildNode,
    depth: u32,
    interior: &mut impl FnMut(u32, usize),
) -> (u32, BTreeSet<u32>) {
    match node {
        BuildNode::Leaf(prims) => (depth, prims.iter().copied().collect()),
        BuildNode::Interior { children, .. } => {
            let (db, mut below) = walk(&children[0], depth + 1, interior);
            let (da, above) = walk(&children[1], depth + 1, interior);
            below.extend(above);
            interior(depth, below.len());
            (db.max(da), below)
        }
    }
}

#[test]
fn past_the_automatic_limit_only_crowded_nodes_split() {
    let geom = uv_sphere(40);
    let params = BuildParams {
        parallel: false,
        ..BuildParams::default()
    };
    let (soft, hard) = params.depth_limits(geom.triangles.len());
    assert_eq!(hard, soft + DEEP_LEVELS);
    let tree = build(&geom, &params, None).unwrap();
    // The poles make the rule matter: some nodes do split past the automatic limit.
    past_the_limit_only_crowded_nodes_split(&tree.root, (soft, hard), DEEP_LEAF_PRIMS);
}

/// Asserts the depth rule on a built tree: no deeper than `hard`, every interior node at or past
/// `soft` holding more than `deep_leaf_prims` primitives, and at least one such node.
fn past_the_limit_only_crowded_nodes_split(
    root: &BuildNode,
    (soft, hard): (u32, u32),
    deep_leaf_prims: usize,
) {
    let mut deep_interiors = 0;
    let (depth, _) = walk(root, 0, &mut |d, prims| {
        if d >= soft {
            deep_interiors += 1;
            assert!(
                prims > deep_leaf_prims,
                "an interior node at depth {d} (limit {soft}) holds only {prims} primitives"
            );
        }
    });
    assert!(depth <= hard, "depth {depth} past the hard limit {hard}");
    assert!(deep_interiors > 0, "no node split past depth {soft}");
}

#[test]
fn an_explicit_max_depth_is_hard() {
    let geom = uv_sphere(40);
    let (soft, _) = BuildParams::default().depth_limits(geom.triangles.len());
    let params = BuildParams {
        parallel: false,
        max_depth: Some(soft),
        ..BuildParams::default()
    };
    assert_eq!(params.depth_limits(geom.triangles.len()), (soft, soft));
    let tree = build(&geom, &params, None).unwrap();
    let (depth, _) = walk(&tree.root, 0, &mut |_, _| {});
    assert!(
        depth <= soft,
        "depth {depth} past the explicit limit {soft}"
    );
}

/// Primitive references held by the leaves.
fn references(node: &BuildNode) -> usize {
    match node {
        BuildNode::Leaf(prims) => prims.len(),
        BuildNode::Interior { children, .. } => references(&children[0]) + references(&children[1]),
    }
}

/// A soup of large triangles crossing each other everywhere: every plane cuts most of them, and
/// without a bound perfect splits duplicate them at every level (this one: 432 references a
/// triangle; a 200,000-triangle soup made 44.6 M nodes). The reference budget holds the leaves to
/// about `2 · REFERENCE_BUDGET · N` references (37 a triangle here), the same tree on one thread
/// or many.
#[test]
fn a_soup_of_crossing_triangles_stays_within_the_reference_budget() {
    let mut seed = 7u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let triangles: Vec<[Vec3; 3]> = (0..10000)
        .map(|_| {
            let c = Vec3::new(next(), next(), next());
            let mut v = || c + 0.6 * (Vec3::new(next(), next(), next()) - 0.5);
            [v(), v(), v()]
        })
        .collect();
    let n = triangles.len();
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    for quality in [Quality::High, Quality::Fast] {
        let params = BuildParams::default().with_quality(quality);
        let serial = BuildParams {
            parallel: false,
            ..params
        };
        let tree = build(&geom, &serial, None).unwrap();
        let refs = references(&tree.root);
        // 2 · the budget per triangle (REFERENCE_BUDGET = 32 at `high`, FAST_REFERENCE_BUDGET = 2
        // at `fast`); without the budget this soup makes 4.3 M references.
        const { assert!(REFERENCE_BUDGET == 32.0 && FAST_REFERENCE_BUDGET == 2.0) };
        let bound = (2.0 * params.reference_budget) as usize * n;
        assert!(
            refs <= bound,
            "{quality:?}: {refs} references for {n} triangles (bound {bound})"
        );
        // Still a tree that splits: the soup's references exceed its triangles.
        let floor = if quality == Quality::High { 8 * n } else { n };
        assert!(
            refs > floor,
            "{quality:?}: {refs} references for {n} triangles"
        );
        let parallel = build(&geom, &params, None).unwrap();
        assert!(tree.root == parallel.root, "{quality:?}");
    }
}

/// The largest leaf of the tree.
fn largest_leaf(node: &BuildNode) -> usize {
    match node {
        BuildNode::Leaf(prims) => prims.len(),
        BuildNode::Interior { children, .. } => {
            largest_leaf(&children[0]).max(largest_leaf(&children[1]))
        }
    }
}

/// `fast` on a scene of separate objects: 216 spheres scattered over a box, each cut-off of the
/// empty space between them a level of the automatic limit's. Past that limit only nodes of more
/// than `FAST_DEEP_LEAF_PRIMS` triangles split, and they may go down to the core's stack, so no
/// leaf keeps spheres' worth of triangles (with no levels past the limit, as before, the largest
/// held 528, about two spheres; here 40).
#[test]
fn fast_trees_of_scattered_objects_split_crowded_nodes_past_the_automatic_limit() {
    let mut seed = 11u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let mut triangles = Vec::new();
    for i in 0..216 {
        let cell = Vec3::new((i % 6) as f32, ((i / 6) % 6) as f32, (i / 36) as f32);
        let centre = 10.0 * cell + Vec3::new(next(), next(), next()) * 6.0;
        triangles.extend(meshes::uv_sphere(12, centre, 0.5 + 2.0 * next()));
    }
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    let params = BuildParams {
        parallel: false,
        ..BuildParams::grouped().with_quality(Quality::Fast)
    };
    assert_eq!(params.deep_leaf_prims, FAST_DEEP_LEAF_PRIMS);
    let (soft, hard) = params.depth_limits(geom.triangles.len());
    assert_eq!(hard, kdray_core::format::MAX_DEPTH as u32);
    let tree = build(&geom, &params, None).unwrap();
    let largest = largest_leaf(&tree.root);
    assert!(largest <= 64, "a leaf of {largest} triangles");
    past_the_limit_only_crowded_nodes_split(&tree.root, (soft, hard), FAST_DEEP_LEAF_PRIMS);
}
