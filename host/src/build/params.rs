//! The builder's parameters: the SAH's costs, the termination and depth rules, the quality.

use super::events::Costs;
use super::fast;

/// Builder parameters. The defaults are pbrt-v3's, except where measurement chose otherwise
/// (see `docs/BUILD.md`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildParams {
    /// Cost of one traversal step, relative to `intersect_cost`.
    pub traversal_cost: f64,
    /// Cost of one primitive test.
    pub intersect_cost: f64,
    /// Fraction of the cost saved when a split cuts off empty space.
    pub empty_bonus: f64,
    /// A node with at most this many primitives becomes a leaf.
    pub max_prims: usize,
    /// Depth limit; `None` is `8 + 1.3·log2(N)` rounded (pbrt-v3), where a node holding more than
    /// [`BuildParams::deep_leaf_prims`] primitives may still split for
    /// [`BuildParams::deep_levels`] more levels. Both are capped by the core's stack. An explicit
    /// limit is a hard one.
    pub max_depth: Option<u32>,
    /// Build subtrees on the rayon pool (with the `cli` feature; one thread without it).
    pub parallel: bool,
    /// Primitives one leaf test takes: 1, or 4 for leaves stored in triangle groups
    /// (`kdray::flat::Leaves::Groups`), which the SAH then prices in groups.
    pub group: usize,
    /// Past the automatic depth limit, a node holding more than this many primitives may still
    /// split, for up to [`BuildParams::deep_levels`] more levels ([`DEEP_LEAF_PRIMS`],
    /// [`GROUPED_DEEP_LEAF_PRIMS`] for grouped leaves, [`FAST_DEEP_LEAF_PRIMS`] at `fast`).
    pub deep_leaf_prims: usize,
    /// How many levels past the automatic depth limit the nodes of
    /// [`BuildParams::deep_leaf_prims`] may go ([`DEEP_LEVELS`]; at `fast`, [`FAST_DEEP_LEVELS`]:
    /// down to the core's stack).
    pub deep_levels: u32,
    /// Which builder makes the tree ([`Quality`]); the SAH and the rules above are the same.
    pub quality: Quality,
    /// The `fast` builder's settings (unused by `high`).
    pub fast: fast::FastParams,
    /// References a build may make per primitive ([`super::REFERENCE_BUDGET`] by default): a
    /// node whose primitives were duplicated more than this many times over along its path is a
    /// leaf.
    pub reference_budget: f64,
}

/// How hard the builder searches, as Embree's build quality: both make valid trees of the same
/// format with the same cost model (docs/BUILD.md, "Quality").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Quality {
    /// The exact event sweep with perfect splits at every node (Wald & Havran 2006).
    #[default]
    High,
    /// Binned planes on all but the smallest nodes, the exact sweep on those ([`fast`]);
    /// straddlers split by the plane alone by default ([`fast::FastParams::clip_min`]); at most
    /// [`FAST_REFERENCE_BUDGET`] references a triangle along a path, and past the depth limit
    /// only nodes of more than [`FAST_DEEP_LEAF_PRIMS`] primitives split
    /// ([`BuildParams::with_quality`]).
    #[cfg_attr(
        feature = "cli",
        value(
            help = "Binned planes on all but the smallest nodes, the exact sweep on those; \
                      straddlers split by the plane alone; at most 2 references a triangle \
                      along a path, past the depth limit only nodes of more than 32 triangles \
                      split: for building at run time"
        )
    )]
    Fast,
}

impl core::str::FromStr for Quality {
    type Err = String;

    /// `"high"` or `"fast"` (the names `--quality` takes), for bindings that get a string.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "high" => Ok(Quality::High),
            "fast" => Ok(Quality::Fast),
            _ => Err(format!("the quality must be 'high' or 'fast', got '{s}'")),
        }
    }
}

impl Default for BuildParams {
    fn default() -> Self {
        Self {
            traversal_cost: 1.0,
            intersect_cost: 80.0,
            empty_bonus: 0.5,
            max_prims: 1,
            max_depth: None,
            parallel: true,
            group: 1,
            deep_leaf_prims: DEEP_LEAF_PRIMS,
            deep_levels: DEEP_LEVELS,
            quality: Quality::default(),
            fast: fast::FastParams::default(),
            reference_budget: super::REFERENCE_BUDGET,
        }
    }
}

impl BuildParams {
    /// These parameters built at `quality`. [`Quality::Fast`] also bounds the references a
    /// path may make ([`FAST_REFERENCE_BUDGET`]) and lets only nodes of more than
    /// [`FAST_DEEP_LEAF_PRIMS`] primitives split past the depth limit, down to the core's stack
    /// ([`FAST_DEEP_LEVELS`]): a tree for a user who builds at run time (docs/BUILD.md, "The
    /// first answer").
    pub fn with_quality(self, quality: Quality) -> Self {
        match quality {
            Quality::High => Self { quality, ..self },
            Quality::Fast => Self {
                quality,
                reference_budget: FAST_REFERENCE_BUDGET,
                deep_leaf_prims: FAST_DEEP_LEAF_PRIMS,
                deep_levels: FAST_DEEP_LEVELS,
                ..self
            },
        }
    }

    /// The defaults for leaves stored in groups of four (docs/BUILD.md, "Triangle groups"): the
    /// SAH priced in groups, intersection cost 3 (a group test costs about three interior steps
    /// in instructions), and every node free to split down to the hard depth limit
    /// ([`GROUPED_DEEP_LEAF_PRIMS`] = 0).
    pub fn grouped() -> Self {
        Self {
            intersect_cost: GROUPED_INTERSECT_COST,
            group: kdray_core::group::WIDTH,
            deep_leaf_prims: GROUPED_DEEP_LEAF_PRIMS,
            ..Self::default()
        }
    }
}

/// [`Quality::Fast`]'s [`BuildParams::reference_budget`]: a node whose triangles were
/// duplicated more than twice over along its path is a leaf. With the levels past the depth limit
/// dropped (before [`FAST_DEEP_LEAF_PRIMS`]), it made the dragon-2 decimation's build 2.8× fewer
/// instructions than the budget of 32 with every level (6.9 K against 19.4 K a triangle) for a
/// random ray 2.2× as costly (1,935 instructions against 898), and 66 bytes a triangle with index
/// lists against 272 with groups (docs/BUILD.md, "The first answer").
pub const FAST_REFERENCE_BUDGET: f64 = 2.0;

/// [`BuildParams::grouped`]'s intersection cost.
pub const GROUPED_INTERSECT_COST: f64 = 3.0;
/// [`BuildParams::grouped`]'s [`BuildParams::deep_leaf_prims`]: 0, so every node may split
/// (by the same cost rules) down to the hard limit. The wide nodes' boxes cull what the deeper
/// levels cut off: on the dragon's diffuse rays 1,958 instructions a ray became 1,481 (−24 %;
/// 32 before, 16: 1,791, 8: 1,591, 4: 1,496), primary 548 → 472, the bunny's 1,115 → 1,001 and
/// 470 → 443, for 22 % more bytes on the dragon (112.6 → 137.8 MB; docs/BUILD.md, "The depth rule
/// for wide nodes").
pub const GROUPED_DEEP_LEAF_PRIMS: usize = 0;

impl BuildParams {
    /// The depth limits for `n` primitives: `(soft, hard)`. Past `soft` only nodes holding more
    /// than [`BuildParams::deep_leaf_prims`] primitives split; at `hard` none does.
    pub fn depth_limits(&self, n: usize) -> (u32, u32) {
        let cap = kdray_core::format::MAX_DEPTH as u32;
        match self.max_depth {
            Some(d) => (d.min(cap), d.min(cap)),
            None => {
                let auto = (8.0 + 1.3 * (n.max(1) as f64).log2()).round() as u32;
                (
                    auto.min(cap),
                    auto.saturating_add(self.deep_levels).min(cap),
                )
            }
        }
    }

    pub(super) fn costs(&self) -> Costs {
        Costs {
            traversal: self.traversal_cost,
            intersect: self.intersect_cost,
            empty_bonus: self.empty_bonus,
            group: self.group.max(1),
        }
    }
}

/// Past the automatic depth limit, a node holding more than this many primitives may still split
/// (by the same cost rules), for up to [`DEEP_LEVELS`] more levels. pbrt-v3's limit alone leaves
/// the dragon's densest regions in leaves of 10–160 triangles, where both walks spend their time;
/// letting only those continue costs 28 % more nodes (5 % more bytes) and makes single rays
/// 20–30 % faster, 8-wide packets about as fast (docs/BUILD.md).
pub const DEEP_LEAF_PRIMS: usize = 8;
/// See [`DEEP_LEAF_PRIMS`].
pub const DEEP_LEVELS: u32 = 6;

/// [`Quality::Fast`]'s [`BuildParams::deep_leaf_prims`]: past the automatic depth limit, a node
/// of more than 32 primitives may still split, down to the core's stack ([`FAST_DEEP_LEVELS`]).
/// Each cut-off of empty space takes a level, so a scene of separate objects (100 meshes in a
/// box: the automatic limit, 31 levels, reached with leaves of up to 898 triangles) or a
/// finely cut mesh ran out of levels before its leaves were small: on the 100 meshes, random
/// rays 1,858 → 837 instructions for 55 % more build; on the dragon 1,397 → 1,297 (−7 %),
/// diffuse −11 %, for 2.9 % more build and 67 → 68 bytes a triangle. 16 cut the dragon's rays
/// 5 % more for 10 % more build; 64 left the dragon as it was and the 100 meshes' random rays
/// at 979 (docs/BUILD.md, "`fast` past the depth limit").
pub const FAST_DEEP_LEAF_PRIMS: usize = 32;
/// See [`FAST_DEEP_LEAF_PRIMS`]: every level the core's stack allows
/// ([`kdray_core::format::MAX_DEPTH`]).
pub const FAST_DEEP_LEVELS: u32 = kdray_core::format::MAX_DEPTH as u32;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qualities_parse_by_name_and_others_are_refused_by_name() {
        assert_eq!("high".parse::<Quality>(), Ok(Quality::High));
        assert_eq!("fast".parse::<Quality>(), Ok(Quality::Fast));
        let e = "medium".parse::<Quality>().unwrap_err();
        assert!(e.contains("'medium'") && e.contains("'fast'"), "{e}");
    }
}
