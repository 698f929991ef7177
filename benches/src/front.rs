//! The builder settings measured by the `front` binary (docs/BUILD.md, "The front"): each a
//! name, the leaves the tree is stored with, and the builder's parameters. The trees are written
//! with the wide section, as the packages and `kdray trace` write them.

use kdray::build::{
    BuildParams, DEEP_LEAF_PRIMS, GROUPED_DEEP_LEAF_PRIMS, Quality, REFERENCE_BUDGET,
};
use kdray::flat::Leaves;

/// One builder setting.
#[derive(Clone, Copy, Debug)]
pub struct Setting {
    pub name: &'static str,
    pub leaves: Leaves,
    pub params: BuildParams,
}

/// The settings, the packages' default first (the others are compared with its answers).
pub fn settings() -> Vec<Setting> {
    // The packages price leaves in groups of four whatever they store: the single-ray walks
    // test a listed leaf four triangles at a time too.
    let fast = BuildParams::grouped().with_quality(Quality::Fast);
    let high = BuildParams::grouped().with_quality(Quality::High);
    let budget = |reference_budget| BuildParams {
        reference_budget,
        ..fast
    };
    let deep = BuildParams {
        reference_budget: REFERENCE_BUDGET,
        deep_leaf_prims: GROUPED_DEEP_LEAF_PRIMS,
        ..fast
    };
    let lists = |name, params| Setting {
        name,
        leaves: Leaves::List,
        params,
    };
    let groups = |name, params| Setting {
        name,
        leaves: Leaves::Groups,
        params,
    };
    vec![
        lists("lists-fast", fast),
        groups("groups-fast", fast),
        lists("lists-fast-budget4", budget(4.0)),
        lists("lists-fast-budget32", budget(REFERENCE_BUDGET)),
        lists("lists-fast-deep", deep),
        groups("groups-fast-deep", deep),
        groups("groups-high-deep", high),
        lists(
            "lists-high-pbrt",
            BuildParams {
                deep_leaf_prims: DEEP_LEAF_PRIMS,
                ..BuildParams::default()
            },
        ),
    ]
}
