//! The greedy cut that makes a wide node's children (`kdray_core::format::wide::frontier`),
//! checked on the trees of random scenes, node by node: the children are a cut of the subtree
//! (every non-empty leaf below the node lies under exactly one child, and no child is an empty
//! leaf), the cut is full (fewer than seven children only when no child can be opened), and each
//! octant's order word is a permutation of the slots in which every child comes before the
//! later ones along a direction of that octant.

use kdray::build::{BuildParams, build};
use kdray::flat::{Leaves, serialize_as};
use kdray_core::Scene;
use kdray_core::format::wide::{Bounds, MAX_OPEN_DEPTH, WIDTH, frontier};
use kdray_tests::strategies::{grid_geometry, scattered_triangles};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// The non-empty leaves of the subtree at `i`, in depth-first order.
fn leaves_below(scene: &Scene, i: u32, out: &mut Vec<u32>) {
    let n = scene.node(i);
    if n.is_leaf() {
        if !n.is_empty_leaf() {
            out.push(i);
        }
        return;
    }
    leaves_below(scene, i + 1, out);
    leaves_below(scene, n.above_child(), out);
}

/// How many levels `target` lies below `root`, or `None` if it is not in `root`'s subtree.
fn depth_below(scene: &Scene, root: u32, target: u32) -> Option<usize> {
    if root == target {
        return Some(0);
    }
    let n = scene.node(root);
    if n.is_leaf() {
        return None;
    }
    [root + 1, n.above_child()]
        .into_iter()
        .find_map(|c| depth_below(scene, c, target))
        .map(|d| d + 1)
}

/// Whether `a` lies before `b` along some axis for a direction in `octant` (bit `k` set: the
/// direction's component `k` is negative).
fn before(a: &Bounds, b: &Bounds, octant: usize) -> bool {
    (0..3).any(|k| {
        if octant >> k & 1 == 0 {
            a[1][k] <= b[0][k]
        } else {
            a[0][k] >= b[1][k]
        }
    })
}

/// Checks the cut of binary node `b` (cell `cell`) and, recursively, of its interior children.
fn check_cut(scene: &Scene, b: u32, cell: Bounds) -> Result<usize, TestCaseError> {
    let f = frontier(|i| scene.node(i), b, cell);
    prop_assert!(f.count <= WIDTH);
    let mut want = Vec::new();
    leaves_below(scene, b, &mut want);
    let mut got = Vec::new();
    for k in 0..f.count {
        let n = scene.node(f.nodes[k]);
        prop_assert!(!n.is_empty_leaf(), "slot {k} is an empty leaf");
        prop_assert_eq!(n.is_leaf(), f.leaves[k]);
        leaves_below(scene, f.nodes[k], &mut got);
    }
    prop_assert_eq!(
        &got,
        &want,
        "the children's leaves are the subtree's, once each"
    );
    if f.count < WIDTH - 1 {
        for k in (0..f.count).filter(|&k| !f.leaves[k]) {
            let depth = depth_below(scene, b, f.nodes[k]).expect("a child lies below its node");
            prop_assert!(
                depth >= MAX_OPEN_DEPTH,
                "{} children, and slot {k} (depth {depth}) could still be opened",
                f.count
            );
        }
    }
    for (octant, &word) in f.orders.iter().enumerate() {
        prop_assert_eq!((word >> 24) as usize, f.count);
        let slots: Vec<usize> = (0..f.count)
            .map(|r| (word >> (3 * r) & 7) as usize)
            .collect();
        let mut sorted = slots.clone();
        sorted.sort_unstable();
        prop_assert_eq!(
            sorted,
            (0..f.count).collect::<Vec<_>>(),
            "octant {} order",
            octant
        );
        for (r, &i) in slots.iter().enumerate() {
            for &j in &slots[r + 1..] {
                prop_assert!(
                    before(&f.cells[i], &f.cells[j], octant),
                    "octant {octant}: slot {i} is not in front of slot {j}"
                );
            }
        }
    }
    let mut nodes = 1;
    for k in (0..f.count).filter(|&k| !f.leaves[k]) {
        nodes += check_cut(scene, f.nodes[k], f.cells[k])?;
    }
    Ok(nodes)
}

/// The tree of `geom` with `leaves`, in the node layout.
fn tree_words(geom: &kdray::Geometry, leaves: Leaves, intersect_cost: f64) -> Vec<u32> {
    let params = BuildParams {
        intersect_cost,
        parallel: false,
        ..leaves.build_params()
    };
    let tree = build(geom, &params, None).expect("finite geometry builds");
    serialize_as(&tree, geom, 0.0, kdray::flat::Layout::Nodes, leaves).expect("fits the format")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(kdray_tests::cases(128)))]

    #[test]
    fn the_greedy_cut_is_a_full_cut_in_front_to_back_order(
        geom in grid_geometry(3),
        isect in prop_oneof![Just(80.0), Just(2.0), Just(20.0)],
    ) {
        let words = tree_words(&geom, Leaves::List, isect);
        let scene = Scene::from_words(&words).unwrap();
        check_cut(&scene, 0, scene.bounds())?;
    }
}

/// On a scene with a deep tree, wide nodes hold at least four children on average (v10's cut
/// three levels down held two on the dragon's tree, whose SAH cuts off empty space often).
#[test]
fn wide_nodes_of_a_deep_tree_are_full() {
    let geom = scattered_triangles(4000);
    let words = tree_words(&geom, Leaves::Groups, 3.0);
    let scene = Scene::from_words(&words).unwrap();
    let wide = check_cut(&scene, 0, scene.bounds()).expect("the cut's properties hold");
    let mut leaves = Vec::new();
    leaves_below(&scene, 0, &mut leaves);
    // Every wide node but the root is a child, as is every non-empty leaf.
    let children = (wide - 1 + leaves.len()) as f64;
    let fill = children / wide as f64;
    assert!(
        fill >= 4.0,
        "{fill:.2} children per wide node ({wide} nodes)"
    );
}
