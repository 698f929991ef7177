//! The SAH kd-tree builder: event-based O(N log N) construction after Wald & Havran 2006, with
//! perfect splits (primitives clipped to the node box, [`clip`]), the empty-space bonus and
//! pbrt-v3's termination rules (PBR 3rd ed., §4.4.2).
//!
//! Per node: find the cheapest plane with one sweep per axis over sorted event lists
//! ([`events::best_split_on_axis`]); classify primitives as below-only, above-only or straddling
//! by one pass over the winning axis' events; split each axis' list by that classification (order
//! is kept, no re-sort); clip the straddling primitives to each child box and merge their new,
//! freshly sorted events in. Children are built in parallel with rayon when large enough.
//!
//! That is [`Quality::High`]. [`Quality::Fast`] ([`fast`]) makes the same kind of tree with the
//! same costs and rules from a list of clipped boxes per node, binning the planes of large nodes
//! ([`binned`]). Both price planes with [`events::AxisSah`], where the node and leaf costs are
//! ([`BuildParams`]'s costs and group size).

pub mod binned;
pub mod clip;
pub mod events;
pub mod fast;
mod params;

pub use params::*;

use crate::geometry::Geometry;
use crate::par::join;
use clip::Aabb;
use core::sync::atomic::{AtomicU64, Ordering};
use events::{Costs, Event, Split};
use glam::Vec3;
use kdray_core::Triangle;

/// A built tree before flattening.
#[derive(Debug, PartialEq)]
pub enum BuildNode {
    /// Global primitive ids.
    Leaf(Vec<u32>),
    Interior {
        axis: u8,
        split: f32,
        children: Box<[BuildNode; 2]>,
    },
}

/// The result of a build.
#[derive(Debug)]
pub struct Tree {
    pub root: BuildNode,
    /// Box of all primitives (the root node's box).
    pub bounds: Aabb,
    /// Whether it was built on rayon's pool ([`BuildParams::parallel`]): the serializer then
    /// works there too ([`crate::flat::serialize_as`]; the words are the same either way).
    pub parallel: bool,
}

impl Tree {
    /// The root, taken out of the tree (which frees nothing more).
    pub fn into_root(mut self) -> BuildNode {
        core::mem::replace(&mut self.root, BuildNode::Leaf(Vec::new()))
    }
}

impl Drop for Tree {
    /// A tree built on the pool is freed there too: its top levels' subtrees at once (freeing
    /// a million nodes one by one is a serial tail of the build, 2–4 % of it).
    fn drop(&mut self) {
        if self.parallel {
            let root = core::mem::replace(&mut self.root, BuildNode::Leaf(Vec::new()));
            free(root, FREE_LEVELS);
        }
    }
}

/// Levels whose subtrees a tree built on the pool frees at once.
const FREE_LEVELS: u32 = 4;

fn free(node: BuildNode, levels: u32) {
    if levels > 0
        && let BuildNode::Interior { children, .. } = node
    {
        let [below, above] = *children;
        join(true, || free(below, levels - 1), || free(above, levels - 1));
    }
}

/// What the builder makes of a triangle.
enum Kind {
    NonFinite,
    /// Too large for f32 arithmetic ([`Triangle::is_too_large`]).
    TooLarge,
    /// No finite threshold: left out of the tree.
    Degenerate,
    /// In the tree, with its box.
    Live(Aabb),
}

/// Primitive access for the builder: global id → clipped bounds.
struct Prims<'a> {
    tris: &'a [[Vec3; 3]],
    spheres: &'a [(Vec3, f32)],
}

impl Prims<'_> {
    fn clip(&self, id: u32, bounds: &Aabb) -> Option<Aabb> {
        let n_tris = self.tris.len();
        match self.tris.get(id as usize) {
            Some(tri) => clip::clip_triangle(tri, bounds),
            None => {
                let (c, r) = self.spheres[id as usize - n_tris];
                clip::clip_sphere(c, r, bounds)
            }
        }
    }

    /// The bounds of primitive `id`'s parts below and above the plane `axis = pos`, within
    /// `within` (its box in the node): [`clip::split_triangle`], or the box cut for a sphere.
    fn split(&self, id: u32, axis: usize, pos: f32, within: &Aabb) -> (Option<Aabb>, Option<Aabb>) {
        match self.tris.get(id as usize) {
            Some(tri) => clip::split_triangle(tri, axis, pos, within),
            None => {
                let (b, a) = within.split(axis, pos);
                ((!b.is_empty()).then_some(b), (!a.is_empty()).then_some(a))
            }
        }
    }

    fn bounds(&self, id: u32) -> Aabb {
        match self.tris.get(id as usize) {
            Some(tri) => Aabb::around(tri),
            None => {
                let (c, r) = self.spheres[id as usize - self.tris.len()];
                clip::clip_sphere(
                    c,
                    r,
                    &Aabb {
                        min: Vec3::MIN,
                        max: Vec3::MAX,
                    },
                )
                .unwrap_or(Aabb::EMPTY)
            }
        }
    }
}

/// Everything a recursive build step shares.
struct Ctx<'a> {
    prims: Prims<'a>,
    params: BuildParams,
    costs: Costs,
    /// [`BuildParams::depth_limits`] for this build.
    depth_limits: (u32, u32),
    /// Progress in parts per 2³², summed over finished leaves.
    progress: Option<&'a AtomicU64>,
}

impl Ctx<'_> {
    /// Whether a node at `depth` holding `n` primitives, allowed `refs` references
    /// ([`REFERENCE_BUDGET`]), may split (else it is a leaf).
    fn may_split(&self, depth: u32, n: usize, refs: f64) -> bool {
        let (soft, hard) = self.depth_limits;
        n > self.params.max_prims
            && depth < hard
            && (depth < soft || n > self.params.deep_leaf_prims)
            && n as f64 <= refs
    }

    /// Whether a node of `n` primitives takes its best plane `split` (pbrt-v3's rules, and the
    /// leaf SAH for groups), and the count of bad refinements its children inherit.
    fn accept(&self, split: Split, n: usize, bad_refines: u32) -> Option<(Split, u32)> {
        let leaf_cost = self.costs.intersect * self.costs.tests(n);
        let bad_refines = bad_refines + u32::from(split.cost > leaf_cost);
        // Priced in groups, a node of at most four groups' triangles stops as soon as no split
        // beats it (Embree's leaf SAH); pbrt's allowance of bad refines was made for
        // per-primitive leaves.
        let grouped_stop =
            self.costs.group > 1 && split.cost >= leaf_cost && n <= 4 * self.costs.group;
        if grouped_stop || (split.cost > 4.0 * leaf_cost && n < 16) || bad_refines >= 3 {
            return None;
        }
        Some((split, bad_refines))
    }

    /// A leaf over `prims` (global ids), counted as `weight` of the progress.
    fn leaf(&self, prims: Vec<u32>, weight: u64) -> BuildNode {
        if let Some(p) = self.progress {
            p.fetch_add(weight, Ordering::Relaxed);
        }
        BuildNode::Leaf(prims)
    }

    /// The bounds of primitive `id`'s part inside `bounds` (exact for triangles), or `None`.
    fn clip(&self, id: u32, bounds: &Aabb) -> Option<Aabb> {
        self.prims.clip(id, bounds)
    }
}

/// Units of [`build`]'s progress counter that make up the whole build.
pub const PROGRESS_TOTAL: u64 = 1 << 32;

/// Builds the tree over `geom`'s triangles and spheres. Degenerate triangles (no area in f32:
/// [`Triangle::min_det2`] is `+inf`) are left out of the tree: no kernel hits them.
/// `progress`, when given, grows to [`PROGRESS_TOTAL`].
///
/// # Errors
/// Non-finite coordinates or radii, which loaders reject before this point, and triangles too
/// large for the kernels' f32 arithmetic ([`Triangle::is_too_large`]).
pub fn build(
    geom: &Geometry,
    params: &BuildParams,
    progress: Option<&AtomicU64>,
) -> Result<Tree, String> {
    // One pass over the triangles (on the pool for a parallel build) says what each is; the
    // errors then name the first triangle of each kind, non-finite ones before too large ones.
    let kinds = crate::par::map(params.parallel, geom.triangles.len(), |i| {
        let t = &geom.triangles[i];
        if !t.iter().all(|v| v.is_finite()) {
            return Kind::NonFinite;
        }
        let k = Triangle::from_vertices(t[0], t[1], t[2]);
        if k.is_too_large() {
            Kind::TooLarge
        } else if k.min_det2() < f32::INFINITY {
            Kind::Live(Aabb::around(t))
        } else {
            // Degenerate (no finite threshold: `Triangle::min_det2`): never hit by any kernel,
            // so it stays out of the tree.
            Kind::Degenerate
        }
    });
    if let Some(i) = kinds.iter().position(|k| matches!(k, Kind::NonFinite)) {
        return Err(format!("triangle {i} has a non-finite coordinate"));
    }
    if let Some(i) = geom
        .spheres
        .iter()
        .position(|(c, r)| !(c.is_finite() && r.is_finite() && *r > 0.0))
    {
        return Err(format!(
            "sphere {i} has a non-finite centre or a radius that is not > 0"
        ));
    }
    if let Some(i) = kinds.iter().position(|k| matches!(k, Kind::TooLarge)) {
        return Err(format!(
            "triangle {i} is too large for f32 arithmetic: its edges' cross product reaches \
             7.7e25 (edges beyond about 8e12); scale the scene down"
        ));
    }
    let prims = Prims {
        tris: &geom.triangles,
        spheres: &geom.spheres,
    };
    let n_tris = geom.triangles.len() as u32;
    let mut refs: Vec<fast::Ref> = kinds
        .iter()
        .zip(0..)
        .filter_map(|(k, id)| match k {
            Kind::Live(bounds) => Some(fast::Ref {
                id,
                bounds: *bounds,
            }),
            _ => None,
        })
        .collect();
    drop(kinds);
    refs.extend((n_tris..geom.prim_count() as u32).map(|id| fast::Ref {
        id,
        bounds: prims.bounds(id),
    }));
    let bounds = refs.iter().fold(Aabb::EMPTY, |a, r| a.union(&r.bounds));
    let ctx = Ctx {
        prims,
        params: *params,
        costs: params.costs(),
        depth_limits: params.depth_limits(refs.len()),
        progress,
    };
    if refs.is_empty() {
        if let Some(p) = progress {
            p.fetch_add(PROGRESS_TOTAL, Ordering::Relaxed);
        }
        return Ok(Tree {
            root: BuildNode::Leaf(Vec::new()),
            bounds: Aabb {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
            },
            parallel: params.parallel,
        });
    }
    let share = Share {
        weight: PROGRESS_TOTAL,
        refs: params.reference_budget * refs.len() as f64,
    };
    if params.quality == Quality::Fast {
        let root = fast::build(&ctx, refs, bounds, share);
        return Ok(Tree {
            root,
            bounds,
            parallel: params.parallel,
        });
    }
    let events: [Vec<Event>; 3] = core::array::from_fn(|axis| {
        let mut list = Vec::with_capacity(2 * refs.len());
        for (local, r) in refs.iter().enumerate() {
            events::push_events(&mut list, &r.bounds, axis, local as u32);
        }
        events::sort_events(&mut list);
        list
    });
    let live = refs.iter().map(|r| r.id).collect();
    drop(refs);
    let root = build_node(&ctx, live, events, bounds, 0, 0, share);
    Ok(Tree {
        root,
        bounds,
        parallel: params.parallel,
    })
}

/// Side of each primitive after classification.
const BOTH: u8 = 0;
const BELOW: u8 = 1;
const ABOVE: u8 = 2;

/// Below this many primitives children are built on the current thread.
const PARALLEL_MIN: usize = 2048;

/// Builds the subtree over `prims` (global ids; position = local id) whose events are `events`.
fn build_node(
    ctx: &Ctx,
    prims: Vec<u32>,
    events: [Vec<Event>; 3],
    bounds: Aabb,
    depth: u32,
    bad_refines: u32,
    share: Share,
) -> BuildNode {
    let n = prims.len();
    let weight = share.weight;
    if !ctx.may_split(depth, n, share.refs) {
        return ctx.leaf(prims, weight);
    }
    let best = (0..3)
        .filter_map(|axis| events::best_split_on_axis(&events[axis], n, &bounds, axis, &ctx.costs))
        .min_by(|a, b| a.cost.total_cmp(&b.cost));
    let Some((split, bad_refines)) = best.and_then(|s| ctx.accept(s, n, bad_refines)) else {
        return ctx.leaf(prims, weight);
    };
    let (below_box, above_box) = bounds.split(split.axis, split.pos);
    let cut = Cut {
        split,
        below: below_box,
        above: above_box,
        child_depth: depth + 1,
        share,
    };
    let (below, above) = partition(ctx, &prims, events, &cut);
    drop(prims);
    let (sb, sa) = share.split(below.0.len(), above.0.len());
    let build_below = || build_node(ctx, below.0, below.1, below_box, depth + 1, bad_refines, sb);
    let build_above = || build_node(ctx, above.0, above.1, above_box, depth + 1, bad_refines, sa);
    let children = join(
        ctx.params.parallel && n >= PARALLEL_MIN,
        build_below,
        build_above,
    );
    BuildNode::Interior {
        axis: split.axis as u8,
        split: split.pos,
        children: Box::new([children.0, children.1]),
    }
}

type Side = (Vec<u32>, [Vec<Event>; 3]);

/// Pushes the new events that sort before `e`, then `e` renumbered to `prim`: one step of merging
/// a child's list from its parent's (already sorted) and the straddlers' (sorted apart).
#[inline]
fn merge_push(out: &mut Vec<Event>, new: &[Event], next_new: &mut usize, e: Event, prim: u32) {
    let key = e.key();
    while *next_new < new.len() && new[*next_new].key() < key {
        out.push(new[*next_new]);
        *next_new += 1;
    }
    out.push(Event { prim, ..e });
}

/// Per-thread buffers reused across nodes: most nodes are small, and allocating these per node
/// cost a quarter of the build time.
#[derive(Default)]
struct Scratch {
    side: Vec<u8>,
    map_b: Vec<u32>,
    map_a: Vec<u32>,
    clipped: Vec<(u32, Option<Aabb>, Option<Aabb>)>,
    new_b: Vec<Event>,
    new_a: Vec<Event>,
}

thread_local! {
    static SCRATCH: core::cell::RefCell<Scratch> = core::cell::RefCell::new(Scratch::default());
}

/// A chosen split of one node: the plane, the children's boxes and their depth.
struct Cut {
    split: Split,
    below: Aabb,
    above: Aabb,
    child_depth: u32,
    /// The node's share, which its children divide.
    share: Share,
}

/// References to primitives a build may make, per primitive: a subtree is allowed its part of
/// `REFERENCE_BUDGET · N` in proportion to its primitives, so that a node whose primitives were
/// duplicated more than this many times over along its path (straddlers, counted in both
/// children) is a leaf. Leaves then hold at most about `2 · REFERENCE_BUDGET · N` references in
/// all, and the build's memory and time are bounded whatever the input; the rule depends only on
/// the path, so serial and parallel builds make the same tree. Meshes stay below it (at 16 the
/// dragon's tree lost 4 of its 1.2 M nodes; at 32 it is the same tree); a soup of 200,000 large
/// random triangles did not: 44.6 M nodes and 3.8 GB resident in 51 s without it (which trapped
/// the npm package's WebAssembly memory), 0.57 M nodes and 185 MB in 4.4 s with it.
pub const REFERENCE_BUDGET: f64 = 32.0;

/// What a subtree inherits from its parent in proportion to its primitives: its part of the
/// progress counter, and of the [`REFERENCE_BUDGET`].
#[derive(Clone, Copy, Debug)]
struct Share {
    weight: u64,
    refs: f64,
}

impl Share {
    /// The children's shares, by their primitive counts.
    fn split(self, below: usize, above: usize) -> (Share, Share) {
        let total = below + above;
        let (wb, fb) = match (self.weight as u128 * below as u128).checked_div(total as u128) {
            Some(wb) => (wb as u64, below as f64 / total as f64),
            None => (self.weight / 2, 0.5),
        };
        (
            Share {
                weight: wb,
                refs: self.refs * fb,
            },
            Share {
                weight: self.weight - wb,
                refs: self.refs * (1.0 - fb),
            },
        )
    }
}

/// Classifies primitives against the cut and splits the event lists (Wald & Havran 2006, §5.2).
/// Event lists are made only for children that may still split ([`Ctx::may_split`]): a child
/// bound to be a leaf needs only its primitive list.
fn partition(ctx: &Ctx, prims: &[u32], events: [Vec<Event>; 3], cut: &Cut) -> (Side, Side) {
    SCRATCH.with_borrow_mut(|s| partition_with(s, ctx, prims, events, cut))
}

fn partition_with(
    s: &mut Scratch,
    ctx: &Ctx,
    prims: &[u32],
    events: [Vec<Event>; 3],
    cut: &Cut,
) -> (Side, Side) {
    let (split, below_box, above_box) = (&cut.split, &cut.below, &cut.above);
    let n = prims.len();
    let side = &mut s.side;
    side.clear();
    side.resize(n, BOTH);
    for e in &events[split.axis] {
        let p = &mut side[e.prim as usize];
        match e.kind {
            events::END if e.pos <= split.pos => *p = BELOW,
            events::START if e.pos >= split.pos => *p = ABOVE,
            events::PLANAR => {
                *p = if e.pos < split.pos || (e.pos == split.pos && split.planar_below) {
                    BELOW
                } else {
                    ABOVE
                }
            }
            _ => {}
        }
    }
    // Straddling primitives, clipped to each child (perfect splits). A part that the exact clip
    // finds empty on one side leaves the primitive on the other side only.
    s.clipped.clear();
    for (local, &p) in side.iter().enumerate() {
        if p == BOTH {
            let id = prims[local];
            let (b, a) = (ctx.clip(id, below_box), ctx.clip(id, above_box));
            // Rounding can in principle empty both: keep the primitive, conservatively, below.
            let b = if b.is_none() && a.is_none() {
                Some(*below_box)
            } else {
                b
            };
            s.clipped.push((local as u32, b, a));
        }
    }
    // New local ids: below/above-only primitives in order, then straddlers.
    const NONE: u32 = u32::MAX;
    s.map_b.clear();
    s.map_b.resize(n, NONE);
    s.map_a.clear();
    s.map_a.resize(n, NONE);
    let (mut prims_b, mut prims_a) = (Vec::new(), Vec::new());
    for (local, &p) in side.iter().enumerate() {
        if p == BELOW {
            s.map_b[local] = prims_b.len() as u32;
            prims_b.push(prims[local]);
        } else if p == ABOVE {
            s.map_a[local] = prims_a.len() as u32;
            prims_a.push(prims[local]);
        }
    }
    for &(local, b, a) in &s.clipped {
        if b.is_some() {
            s.map_b[local as usize] = prims_b.len() as u32;
            prims_b.push(prims[local as usize]);
        }
        if a.is_some() {
            s.map_a[local as usize] = prims_a.len() as u32;
            prims_a.push(prims[local as usize]);
        }
    }
    let mut ev_b: [Vec<Event>; 3] = Default::default();
    let mut ev_a: [Vec<Event>; 3] = Default::default();
    let (share_b, share_a) = cut.share.split(prims_b.len(), prims_a.len());
    let need_b = ctx.may_split(cut.child_depth, prims_b.len(), share_b.refs);
    let need_a = ctx.may_split(cut.child_depth, prims_a.len(), share_a.refs);
    if !need_b && !need_a {
        return ((prims_b, ev_b), (prims_a, ev_a));
    }
    // A side that needs no events is marked BOTH so the passes below skip its events.
    if !need_b || !need_a {
        let drop_side = if need_b { ABOVE } else { BELOW };
        for p in s.side.iter_mut() {
            if *p == drop_side {
                *p = BOTH;
            }
        }
    }
    for (axis, list) in events.into_iter().enumerate() {
        s.new_b.clear();
        s.new_a.clear();
        for &(local, b, a) in &s.clipped {
            if let Some(b) = b.filter(|_| need_b) {
                events::push_events(&mut s.new_b, &b, axis, s.map_b[local as usize]);
            }
            if let Some(a) = a.filter(|_| need_a) {
                events::push_events(&mut s.new_a, &a, axis, s.map_a[local as usize]);
            }
        }
        events::sort_events(&mut s.new_b);
        events::sort_events(&mut s.new_a);
        let (mut count_b, mut count_a) = (s.new_b.len(), s.new_a.len());
        for e in &list {
            match s.side[e.prim as usize] {
                BELOW => count_b += 1,
                ABOVE => count_a += 1,
                _ => {}
            }
        }
        let mut out_b = Vec::with_capacity(count_b);
        let mut out_a = Vec::with_capacity(count_a);
        let (mut ib, mut ia) = (0, 0);
        // One pass over the parent's sorted list, merging the straddlers' sorted new events in.
        for e in list {
            match s.side[e.prim as usize] {
                BELOW => merge_push(&mut out_b, &s.new_b, &mut ib, e, s.map_b[e.prim as usize]),
                ABOVE => merge_push(&mut out_a, &s.new_a, &mut ia, e, s.map_a[e.prim as usize]),
                _ => {}
            }
        }
        out_b.extend_from_slice(&s.new_b[ib..]);
        out_a.extend_from_slice(&s.new_a[ia..]);
        ev_b[axis] = out_b;
        ev_a[axis] = out_a;
    }
    ((prims_b, ev_b), (prims_a, ev_a))
}
