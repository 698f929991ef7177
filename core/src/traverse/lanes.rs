//! A single ray's leaf in the group kernels' lanes ([`crate::simd::group`]): up to eight of the
//! leaf's triangles a test, in the leaf's order, so that the closest-hit and any-hit queries
//! ([`super::steps`]) keep the one-at-a-time walk's hits, ties included.
//!
//! Where a test's triangles come from depends on the layout and the mode: a grouped leaf's
//! groups in fast mode (their stored `v0` and edges, two groups a test, the last one alone); a
//! listed leaf's triangles, and in watertight mode a grouped leaf's too (by the groups' ids),
//! gathered from the triangles section, whose vertices the watertight kernel needs bit for bit.

use super::Contents;
use crate::format::{LeafPrims, Scene};
use crate::group::{self, Group, PAD_ID, WIDTH};
use crate::ray::Ray;
use crate::simd::group::{Gathered, GroupLanes, Pair, intersect_group, intersect_group_watertight};
use crate::simd::kernels::PrimHits;
use crate::simd::lanes::Lanes;
use crate::watertight::Shear;

/// A query that takes a leaf's triangles a test at a time.
pub trait LaneQuery {
    /// The ray as it stands (its `tmax` shrunk to the closest hit so far) and its shear.
    fn ray(&self) -> (Ray, Shear);
    /// Takes one test's hits; true to stop the leaf (and the walk) at once.
    fn take<G: GroupLanes>(&mut self, g: G, found: &PrimHits<G::L>) -> bool;
}

/// Runs `q` over the leaf's triangles in lanes: `Some(stopped)` when the leaf is one the lanes
/// take (two or more triangles, triangles-only contents with the core's `groups` feature), `None`
/// otherwise (the caller tests it one primitive at a time).
#[inline(always)]
pub fn leaf<C: Contents, Q: LaneQuery>(scene: &Scene, prims: LeafPrims, q: &mut Q) -> Option<bool> {
    if !C::GROUPS {
        return None;
    }
    match prims {
        LeafPrims::Groups(groups) if !C::WATERTIGHT => {
            let mut pairs = groups.chunks_exact(2);
            let stopped = pairs.any(|p| stored(Pair(&p[0], &p[1]), q))
                || pairs.remainder().iter().any(|g| stored(g, q));
            Some(stopped)
        }
        LeafPrims::Groups(groups) => Some(groups.chunks(2).any(|p| {
            let (ids, n) = ids_of(p);
            gathered::<C, Q>(scene, &ids[..n], q)
        })),
        LeafPrims::Many(ids) => Some(
            ids.chunks(2 * WIDTH)
                .any(|ids| gathered::<C, Q>(scene, ids, q)),
        ),
        _ => None,
    }
}

/// One fast-mode test of a group or a pair of groups as stored.
#[inline(always)]
fn stored<G: GroupLanes, Q: LaneQuery>(g: G, q: &mut Q) -> bool {
    let (ray, _) = q.ray();
    let found = intersect_group(g, &ray);
    q.take(g, &found)
}

/// One test of triangles `ids` (one to eight) gathered from the triangles section, in `C`'s mode.
#[inline(always)]
fn gathered<C: Contents, Q: LaneQuery>(scene: &Scene, ids: &[u32], q: &mut Q) -> bool {
    if ids.len() > WIDTH {
        test(scene.gather8(ids), q, C::WATERTIGHT)
    } else {
        test(scene.gather4(ids), q, C::WATERTIGHT)
    }
}

#[inline(always)]
fn test<L: Lanes, Q: LaneQuery>(g: Gathered<'_, L>, q: &mut Q, watertight: bool) -> bool {
    let (ray, shear) = q.ray();
    let found = if watertight {
        intersect_group_watertight(g, &ray, &shear)
    } else {
        intersect_group(g, &ray)
    };
    q.take(g, &found)
}

/// The triangle ids of one or two of a leaf's groups, in lane order, and how many there are
/// (padding lanes, [`PAD_ID`], come only at the end of a leaf's last group).
#[inline(always)]
fn ids_of(groups: &[Group]) -> ([u32; 2 * WIDTH], usize) {
    let mut ids = [PAD_ID; 2 * WIDTH];
    let mut n = 0;
    for g in groups {
        for id in group::ids(g) {
            if id != PAD_ID {
                ids[n] = id;
                n += 1;
            }
        }
    }
    (ids, n)
}
