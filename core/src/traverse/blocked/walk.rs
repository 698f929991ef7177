//! The walk over blocks: the walk of [`crate::traverse`] (pbrt-v3's, with its exact rules) on the
//! blocked layout, one cache line per three levels, each block decided for one ray at once with
//! no branch per slot, as resumable steps ([`Stepper`]), so that the one-ray walk and the
//! interleaved walk of [`crate::traverse::stream`] both run it.
//!
//! **Entering a block** (at the root slot a block reference names, with the interval the ray
//! enters it with) the walk computes the distances to its seven planes with one 8-wide operation
//! ([`plane_distances`]: the same `(split − o) · (1/d)[axis]` f32 operations as the node walk, so
//! the same bits), then decides all eight bottom cells at once, one per lane (Fuetterling et al.
//! 2017, "Accelerated Single Ray Tracing for Wide Vector Units", HPG, §4, on three kd levels; the
//! tables are in [`super::lanes`]):
//! - a lane's interval is the entry interval clipped, at each of the (up to) three interior slots
//!   above it, as the node walk clips it there: by the plane's distance as an exit when the lane
//!   is on the slot's near side, as an entry when on the far side (near and far by the sign of
//!   `1/d` on the slot's axis); in conservative mode by the [`widen`]ed bracket; not at all when
//!   the distance is NaN (a ray lying in the plane, which visits both sides);
//! - a lane is entered when it stands for a child the subtree reaches (a leaf higher up is its
//!   leftmost bottom lane, `lm(p)`; the lanes under it are not references), is not an empty leaf,
//!   and its interval is not empty. The node walk enters a child when each plane on the way keeps
//!   the interval non-empty, comparing each new bound with the bounds set above it; that is every
//!   pair of bounds on the path, so the same cells as `entry ≤ exit` of the lane's interval.
//! - the nearest entered lane becomes the ray's next cell at once, the others are pushed on the
//!   stack with their intervals, one 8-wide store each, farthest first, all in the node walk's
//!   depth-first order (near child first at every slot), so the walk reaches leaves in exactly
//!   the node walk's order, with the same intervals; a sort by entry distance would change which
//!   of two primitives at the same `t` is found first.
//!
//! Every pending item is then a reference (a child block with its root slot, or a leaf); popping
//! one applies the node walk's skip of a node entered beyond the closest candidate
//! ([`entry_with_slack`]): the node walk checks it at every node on the way down, with a closest
//! candidate that changes only at leaves, and the lane's entry is the largest of those nodes'
//! entries, so checking it once at the lane decides the same. Validation makes the blocked tree
//! the node tree, so both walks return the same hits bit for bit (ties included);
//! `tests/tests/blocked.rs` and `tests/tests/groups.rs` check it.
//!
//! A step is one block (its planes, cells and push), or one phase of a leaf. With `HIDE` (the
//! interleaved walk) the steps that read far data end [`Progress::Far`] after asking the cache
//! for it, as the node walk's do ([`crate::traverse::steps`]): a pop of a child block after a leaf
//! (its block is read at the next step), and a leaf's loads: its node (a leaf is named by its node,
//! see [`super`]), index list and triangles, one step each. Entering the nearest child of the block
//! just decided is [`Progress::Near`]: the child blocks were asked for when the ray entered their
//! parent (`prefetch_children`).

use super::lanes::{
    ABOVE, ACTIVE_BIT, CELLS, COMPACT, FIELD_SHIFT, ORDER, SLOT, SLOT_BIT, VALID_BIT, not_interior,
};
use super::{AXES_WORD, Block, REFS_WORD, kind};
use crate::format::{LeafPrims, MAX_DEPTH, Scene};
use crate::ray::Ray;
use crate::traverse::steps::{Progress, Query, Stepper};
#[cfg(doc)]
use crate::traverse::widen;
use crate::traverse::{Contents, TINY, WIDEN, entry_interval, entry_with_slack};
use wide::{f32x8, u32x8};

/// Bit 0 and bit 1 of slot `k`'s axis field (lane `k`; lane 7 holds no slot).
const AXIS_BIT0: [u32; 8] = [1, 1 << 2, 1 << 4, 1 << 6, 1 << 8, 1 << 10, 1 << 12, 0];
const AXIS_BIT1: [u32; 8] = [2, 2 << 2, 2 << 4, 2 << 6, 2 << 8, 2 << 10, 2 << 12, 0];

/// The distance along the ray to each slot's plane, `(split − o[axis]) · inv_dir[axis]`, in
/// lanes 0..7, and the inverse direction on each slot's axis (lane 7 and slots that are not
/// interior nodes hold values nobody reads). The origin and inverse direction are picked per lane
/// by the axis bits (x when both are 0, y for bit 0 alone, z for bit 1), then one subtraction and
/// one multiplication, rounded as the scalar ones are.
#[inline(always)]
pub fn plane_distances(block: &Block, origin: [f32; 3], inv_dir: [f32; 3]) -> (f32x8, f32x8) {
    let axes = u32x8::splat(block[AXES_WORD]);
    let zero = u32x8::ZERO;
    let bit0: f32x8 = bytemuck::cast((axes & u32x8::new(AXIS_BIT0)).simd_ne(zero));
    let bit1: f32x8 = bytemuck::cast((axes & u32x8::new(AXIS_BIT1)).simd_ne(zero));
    let pick = |v: [f32; 3]| {
        let [x, y, z] = v.map(f32x8::splat);
        bit1.select(z, bit0.select(y, x))
    };
    let planes: [u32; 8] = core::array::from_fn(|k| block[k]);
    let planes: f32x8 = bytemuck::cast(planes);
    let inv = pick(inv_dir);
    ((planes - pick(origin)) * inv, inv)
}

/// [`widen`] lane by lane (the same operations, so the same bits for every number; NaN lanes
/// are not read).
#[inline(always)]
fn widen8(t: f32x8) -> (f32x8, f32x8) {
    let (a, b) = (t * f32x8::splat(1.0 - WIDEN), t * f32x8::splat(1.0 + WIDEN));
    (
        a.fast_min(b) - f32x8::splat(TINY),
        a.fast_max(b) + f32x8::splat(TINY),
    )
}

/// Asks the cache for the child blocks of `block` (block `index`) as the walk enters it, so that
/// the one it descends to (and the far ones it may come back to) are on their way while it
/// decides the block (Embree prefetches the children of a BVH node the same way). On the
/// dragon's diffuse rays: 661 → 621 ms (docs/BENCHMARKS.md, "Cache-line blocks"). Eight
/// prefetches, a reference that is no block asking for the block itself (in cache), so that no
/// branch depends on the references' kinds.
#[inline(always)]
fn prefetch_children(blocks: &[Block], block: &Block, index: usize) {
    for &r in &block[REFS_WORD..] {
        let child = if r & 3 == kind::BLOCK {
            (r >> 5) as usize
        } else {
            index
        };
        if let Some(c) = blocks.get(child) {
            crate::prefetch::t0(c);
        }
    }
}

/// The cells one block left for later, as pushed: reference, entry and exit per lane, nearest
/// last, and how many are left.
#[derive(Clone, Copy, Debug)]
struct Group {
    refs: [u32; 8],
    tmin: [f32; 8],
    tmax: [f32; 8],
    left: usize,
}

/// The cells a ray has yet to visit, a group per block: a block's cells are pushed by one 8-wide
/// store each of references, entries and exits. (One `heapless` vector, so that starting a ray
/// writes no memory: three vectors side by side had the compiler clear two of their buffers for
/// every ray, 6 % of the time of the dragon's primary rays.)
///
/// Capacity: the groups on the stack are those of the blocks on the way from the root to the
/// current cell, each at least one level deep, and validation bounds the tree's depth by
/// [`MAX_DEPTH`].
#[derive(Clone, Debug)]
struct Cells(heapless::Vec<Group, { MAX_DEPTH + 1 }>);

impl Cells {
    /// Pushes the first `n` lanes (the last on top).
    #[inline(always)]
    fn push8(&mut self, refs: u32x8, tmin: f32x8, tmax: f32x8, n: usize) {
        if n > 0 {
            // Within capacity for every validated tree (see above).
            let _ = self.0.push(Group {
                refs: refs.to_array(),
                tmin: tmin.to_array(),
                tmax: tmax.to_array(),
                left: n,
            });
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32, f32)> {
        let top = self.0.last_mut()?;
        let i = (top.left - 1) & 7;
        top.left = i;
        let cell = (top.refs[i], top.tmin[i], top.tmax[i]);
        if i == 0 {
            self.0.pop();
        }
        Some(cell)
    }
}

/// The walk over a scene's blocks section, as a [`Stepper`] (the node walk's is the scene's own).
#[derive(Clone, Copy, Debug)]
pub struct Blocks<'a, 's>(&'a Scene<'s>);

impl<'a, 's> Blocks<'a, 's> {
    /// The walk over `scene`'s blocks, if it has a blocks section.
    #[inline(always)]
    pub fn new(scene: &'a Scene<'s>) -> Option<Self> {
        (!scene.blocks().is_empty()).then_some(Self(scene))
    }
}

/// With `HIDE`, where a leaf's loads stand (the node walk's leaf phases, with one more: the
/// blocks name a leaf of several primitives by its node, which holds its count and offset).
mod phase {
    /// Nothing asked for yet.
    pub const START: u8 = 0;
    /// The leaf's node was asked for.
    pub const NODE: u8 = 1;
    /// Its index list was.
    pub const LIST: u8 = 2;
    /// Its triangles were: test them.
    pub const TEST: u8 = 3;
}

/// The block walk's state for one ray: the ray's origin and reciprocal direction, the reference
/// it is at (a block and root slot, or a leaf) with its interval, the closest candidate so far,
/// the leaf phase, and the cells still to visit.
#[derive(Clone, Debug)]
pub struct BlockState {
    origin: [f32; 3],
    inv: [f32; 3],
    at: u32,
    tmin: f32,
    tmax: f32,
    best_t: f32,
    phase: u8,
    stack: Cells,
}

impl Stepper for Blocks<'_, '_> {
    type State = BlockState;

    #[inline(always)]
    fn empty_state() -> BlockState {
        BlockState {
            origin: [0.0; 3],
            inv: [0.0; 3],
            at: 0,
            tmin: 0.0,
            tmax: 0.0,
            best_t: 0.0,
            phase: phase::START,
            stack: Cells(heapless::Vec::new()),
        }
    }

    /// Clips the ray to the scene's box as the node walk does and starts at block 0's slot 0.
    #[inline(always)]
    fn begin<C: Contents>(&self, ray: &Ray, s: &mut BlockState) -> bool {
        let scene = self.0;
        let Some((tmin, tmax)) = entry_interval::<C>(ray, scene.bounds()) else {
            return false;
        };
        if scene.blocks().is_empty() {
            return false;
        }
        (s.origin, s.inv) = (ray.origin.to_array(), ray.dir.recip().to_array());
        (s.tmin, s.tmax, s.best_t) = (tmin, tmax, ray.tmax);
        s.at = super::reference(kind::BLOCK, 0);
        s.phase = phase::START;
        s.stack.0.clear();
        true
    }

    /// One block (its cells decided and pushed, the nearest taken), or one phase of a leaf.
    #[inline(always)]
    fn step<C: Contents, Q: Query, const HIDE: bool>(
        &self,
        s: &mut BlockState,
        q: &mut Q,
    ) -> Progress {
        let scene = self.0;
        // The node walk's skip of a node entered beyond the closest candidate (see there).
        if s.best_t < entry_with_slack(s.tmin) {
            s.phase = phase::START;
            return self.next_pending::<HIDE>(s);
        }
        let r = s.at;
        let value = r >> 2;
        let one = [value];
        let prims: LeafPrims = match r & 3 {
            kind::BLOCK => {
                if self.enter::<C>(s, value) {
                    return Progress::Near;
                }
                return self.next_pending::<HIDE>(s);
            }
            kind::LEAF => {
                if HIDE && s.phase == phase::START {
                    scene.prefetch_node(value);
                    s.phase = phase::NODE;
                    return Progress::Far;
                }
                let node = scene.node(value);
                if HIDE && s.phase == phase::NODE {
                    let list = scene.prefetch_leaf(&node);
                    s.phase = if list { phase::LIST } else { phase::TEST };
                    return Progress::Far;
                }
                let leaf = scene.leaf_prims(&node);
                if HIDE && s.phase == phase::LIST {
                    scene.prefetch_prims(leaf.listed());
                    s.phase = phase::TEST;
                    return Progress::Far;
                }
                leaf
            }
            kind::ONE => {
                if HIDE && s.phase == phase::START {
                    scene.prefetch_prims(&one);
                    s.phase = phase::TEST;
                    return Progress::Far;
                }
                LeafPrims::One(Some(one[0]))
            }
            // Never pushed: an empty leaf is reached only as a whole tree, and tests nothing.
            _ => LeafPrims::One(None),
        };
        s.phase = phase::START;
        let (closest, stop) = q.leaf::<C>(scene, prims);
        s.best_t = closest;
        if stop {
            return Progress::Done;
        }
        self.next_pending::<HIDE>(s)
    }
}

impl Blocks<'_, '_> {
    /// Decides the block and root slot of `value` (a block reference's value) for the ray with
    /// the interval in `s` (see the module doc): moves `s` to the nearest cell it enters and
    /// pushes the others; false when it enters none.
    #[inline(always)]
    fn enter<C: Contents>(&self, s: &mut BlockState, value: u32) -> bool {
        let blocks = self.0.blocks();
        let index = (value >> 3) as usize;
        let block = &blocks[index];
        prefetch_children(blocks, block, index);
        let (d, inv) = plane_distances(block, s.origin, s.inv);
        let flags = block[AXES_WORD];
        // Which lanes the subtree reaches and which levels bound them; which slots' near child
        // is the above one.
        let cells = u32x8::splat(CELLS[(value & 7) as usize][not_interior(flags)]);
        let neg = inv.to_bitmask() & 0x7f;
        let negs = u32x8::splat(neg);
        let d_bits: u32x8 = bytemuck::cast(d);
        let (inf, ninf) = (f32x8::splat(f32::INFINITY), f32x8::splat(f32::NEG_INFINITY));
        let mut lo = f32x8::splat(s.tmin);
        let mut hi = f32x8::splat(s.tmax);
        for k in 0..3 {
            let t: f32x8 = bytemuck::cast(d_bits.shuffle(u32x8::new(SLOT[k])));
            let (far_start, near_end) = if C::CONSERVATIVE { widen8(t) } else { (t, t) };
            let active = u32x8::new(ACTIVE_BIT[k]);
            let bounds: f32x8 = bytemuck::cast((cells & active).simd_eq(active));
            // A NaN distance clips nothing (the ray lies in the plane: both sides, whole).
            let bounds = bounds & t.simd_eq(t);
            let bit = u32x8::new(SLOT_BIT[k]);
            let far: f32x8 = bytemuck::cast((negs & bit).simd_eq(bit) ^ u32x8::new(ABOVE[k]));
            lo = lo.fast_max((bounds & far).select(far_start, ninf));
            hi = hi.fast_min((bounds & !far).select(near_end, inf));
        }
        let valid = u32x8::new(VALID_BIT);
        let refs = u32x8::new(core::array::from_fn(|i| block[REFS_WORD + i]));
        let three = u32x8::splat(kind::EMPTY);
        let enter = (cells & valid).simd_eq(valid)
            & !(refs & three).simd_eq(three)
            & bytemuck::cast::<_, u32x8>(lo.simd_le(hi));
        // The lanes in the node walk's order: the nearest entered one is taken at once (from
        // registers and the block's line, not through the stack), the others pushed farthest
        // first.
        let fields = u32x8::new(FIELD_SHIFT);
        let seven = u32x8::splat(7);
        let order_word = ORDER[neg as usize];
        let order = (u32x8::splat(order_word) >> fields) & seven;
        let entered = enter.shuffle(order).to_bitmask() & 0xff;
        if entered == 0 {
            return false;
        }
        let nearest = (order_word >> (3 * entered.trailing_zeros())) & 7;
        let first = |v: f32x8| -> f32 {
            let v: u32x8 = bytemuck::cast(v);
            f32::from_bits(v.shuffle(u32x8::splat(nearest)).to_array()[0])
        };
        (s.at, s.tmin, s.tmax) = (block[REFS_WORD + nearest as usize], first(lo), first(hi));
        let rest = entered & (entered - 1);
        let picked = (u32x8::splat(COMPACT[rest as usize]) >> fields) & seven;
        let lanes = order.shuffle(picked);
        let cast =
            |v: f32x8| -> f32x8 { bytemuck::cast(bytemuck::cast::<_, u32x8>(v).shuffle(lanes)) };
        s.stack.push8(
            refs.shuffle(lanes),
            cast(lo),
            cast(hi),
            rest.count_ones() as usize,
        );
        true
    }

    /// Takes the next pending cell, or ends the walk: a child block is asked for with `HIDE` and
    /// read at the next step ([`Progress::Far`]); a leaf asks for its own loads.
    #[inline(always)]
    fn next_pending<const HIDE: bool>(&self, s: &mut BlockState) -> Progress {
        let Some((at, tmin, tmax)) = s.stack.pop() else {
            return Progress::Done;
        };
        (s.at, s.tmin, s.tmax) = (at, tmin, tmax);
        if at & 3 != kind::BLOCK {
            return Progress::Near;
        }
        if HIDE && let Some(b) = self.0.blocks().get((at >> 5) as usize) {
            crate::prefetch::t0(b);
        }
        Progress::Far
    }
}
