//! The scalar walk over blocks: the walk of [`crate::traverse`] (pbrt-v3's, with its exact rules)
//! on the blocked layout, one cache line per three levels, as resumable steps ([`Stepper`]), so
//! that the one-ray walk and the interleaved walk of [`crate::stream`] both run it.
//!
//! On entering a block, one ray computes the distances to all seven of its planes at once
//! ([`plane_distances`]: 8-wide, the same `(split − o) · (1/d)[axis]` f32 operations as the
//! node walk, so the same bits), then descends up to three levels from those without another
//! load. Every decision is the node walk's, in the same order: near and far by the sign of
//! `1/d`, both children for a NaN plane distance, empty children only clipping the interval, the
//! closest-candidate skip with [`entry_with_slack`], and in conservative mode the [`widen`]ed
//! distances. Validation makes the blocked tree the node tree, so both walks visit the same
//! leaves in the same order with the same intervals, and return the same hits bit for bit
//! (ties included); `tests/tests/blocked.rs` checks it. A step is one position of a block (a
//! node of the node walk), a block reference (the node the child block's root slot repeats: the
//! step only moves there, deciding nothing), or one phase of a leaf; the phases and the lazily
//! computed distances below change when data is read, never what is decided.
//!
//! With `HIDE` (the interleaved walk) the steps that read far data end [`Progress::Far`] after
//! asking the cache for it, as the node walk's do ([`crate::walk`]): a pop to another block (its
//! distances are computed at the next step, when the line has had time to arrive), and a leaf's
//! loads: its node (a leaf is named by its node, see [`super`]), index list and triangles, one
//! step each. Descending inside a block, a pop that stays in the block, and entering a child
//! block are [`Progress::Near`]: the first two read the line the ray holds, and the child blocks
//! were asked for when the ray entered their parent (`prefetch_children`), a descent of one to
//! three levels earlier. Ending entering steps `Far` instead (the child's distances one step
//! later, with a prefetch of it) ran slower on the dragon (docs/BENCHMARKS.md, "The levers
//! together"), as switching rays at far descents did for the node walk.

use super::{AXES_WORD, Block, is_empty_at, is_interior, kind, reference_at};
use crate::format::{LeafPrims, MAX_DEPTH, Scene};
use crate::ray::Ray;
use crate::traverse::{Contents, entry_interval, entry_with_slack, widen};
use crate::walk::{Progress, Query, Stepper};
use wide::{f32x8, u32x8};

/// One pending far child: block, position in it, and its `(tmin, tmax)`.
type Pending = (u32, u32, f32, f32);

/// Bit 0 and bit 1 of slot `k`'s axis field (lane `k`; lane 7 holds no slot).
const AXIS_BIT0: [u32; 8] = [1, 1 << 2, 1 << 4, 1 << 6, 1 << 8, 1 << 10, 1 << 12, 0];
const AXIS_BIT1: [u32; 8] = [2, 2 << 2, 2 << 4, 2 << 6, 2 << 8, 2 << 10, 2 << 12, 0];

/// The distance along the ray to each slot's plane, `(split − o[axis]) · inv_dir[axis]`, in
/// lanes 0..7 (lane 7 and slots that are not interior nodes hold values nobody reads). The
/// origin and inverse direction are picked per lane by the axis bits (x when both are 0, y for
/// bit 0 alone, z for bit 1), then one subtraction and one multiplication, rounded as the scalar
/// ones are.
#[inline(always)]
pub fn plane_distances(block: &Block, origin: [f32; 3], inv_dir: [f32; 3]) -> [f32; 8] {
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
    ((planes - pick(origin)) * pick(inv_dir)).to_array()
}

/// Asks the cache for the child blocks of `block` as the walk enters it, so that the one it
/// descends to (and the far ones it may come back to) are on their way while it decides the
/// block's three levels (Embree prefetches the children of a BVH node the same way). On the
/// dragon's diffuse rays: 661 → 621 ms (docs/BENCHMARKS.md, "Cache-line blocks").
#[inline(always)]
fn prefetch_children(blocks: &[Block], block: &Block) {
    for &r in &block[super::REFS_WORD..] {
        if r & 3 == kind::BLOCK
            && let Some(c) = blocks.get((r >> 5) as usize)
        {
            crate::prefetch::t0(c);
        }
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

/// The block walk's state for one ray: the ray's origin and reciprocal direction, the block and
/// position it is at with the block's plane distances, the interval, the closest candidate so
/// far, the leaf phase, and the pending far children.
#[derive(Clone, Debug)]
pub struct BlockState<'s> {
    origin: [f32; 3],
    inv: [f32; 3],
    index: u32,
    block: &'s Block,
    p: usize,
    t: [f32; 8],
    tmin: f32,
    tmax: f32,
    best_t: f32,
    /// With `HIDE`, after a pop to another block: its plane distances are still to be computed.
    stale: bool,
    phase: u8,
    stack: heapless::Vec<Pending, MAX_DEPTH>,
}

impl<'s> Stepper for Blocks<'_, 's> {
    type State = BlockState<'s>;

    #[inline(always)]
    fn empty_state() -> BlockState<'s> {
        BlockState {
            origin: [0.0; 3],
            inv: [0.0; 3],
            index: 0,
            block: &[0; super::BLOCK_WORDS],
            p: 0,
            t: [0.0; 8],
            tmin: 0.0,
            tmax: 0.0,
            best_t: 0.0,
            stale: false,
            phase: phase::START,
            stack: heapless::Vec::new(),
        }
    }

    /// Clips the ray to the scene's box as the node walk does and starts at block 0's slot 0.
    #[inline(always)]
    fn begin<C: Contents>(&self, ray: &Ray, s: &mut BlockState<'s>) -> bool {
        let scene = self.0;
        let Some((tmin, tmax)) = entry_interval::<C>(ray, scene.bounds()) else {
            return false;
        };
        let blocks = scene.blocks();
        let Some(root) = blocks.first() else {
            return false;
        };
        (s.origin, s.inv) = (ray.origin.to_array(), ray.dir.recip().to_array());
        (s.tmin, s.tmax, s.best_t) = (tmin, tmax, ray.tmax);
        (s.index, s.block, s.p) = (0, root, 0);
        s.t = plane_distances(root, s.origin, s.inv);
        prefetch_children(blocks, root);
        (s.stale, s.phase) = (false, phase::START);
        s.stack.clear();
        true
    }

    /// One position of the front-to-back walk: the node walk's step ([`crate::walk`], where the
    /// conservative mode is explained) on the block's slots and references.
    #[inline(always)]
    fn step<C: Contents, Q: Query, const HIDE: bool>(
        &self,
        s: &mut BlockState<'s>,
        q: &mut Q,
    ) -> Progress {
        let (scene, blocks) = (self.0, self.0.blocks());
        if HIDE && s.stale {
            s.t = plane_distances(s.block, s.origin, s.inv);
            s.stale = false;
        }
        let (block, p) = (s.block, s.p);
        // The node walk's skip of a node entered beyond the closest candidate (see there).
        if s.best_t < entry_with_slack(s.tmin) {
            return self.next_pending::<HIDE>(s);
        }
        if is_interior(block, p) {
            let axis = super::axis(block, p) as usize;
            let t_plane = s.t[p];
            let (far_start, near_end) = if C::CONSERVATIVE {
                widen(t_plane)
            } else {
                (t_plane, t_plane)
            };
            let (below, above) = (2 * p + 1, 2 * p + 2);
            let (near, far) = if s.inv[axis] < 0.0 {
                (above, below)
            } else {
                (below, above)
            };
            let visit_near = !(near_end < s.tmin) && !is_empty_at(block, near);
            let visit_far = !(far_start > s.tmax) && !is_empty_at(block, far);
            // At most one pending item per level, and validation bounds the depth by
            // MAX_DEPTH: the push cannot fail.
            match (visit_near, visit_far) {
                (true, true) => {
                    let _ = s
                        .stack
                        .push((s.index, far as u32, s.tmin.max(far_start), s.tmax));
                    s.tmax = s.tmax.min(near_end);
                    s.p = near;
                }
                (true, false) => {
                    s.tmax = s.tmax.min(near_end);
                    s.p = near;
                }
                (false, true) => {
                    s.tmin = s.tmin.max(far_start);
                    s.p = far;
                }
                (false, false) => return self.next_pending::<HIDE>(s),
            }
            return Progress::Near;
        }
        let r = reference_at(block, p);
        let value = r >> 2;
        let one = [value];
        let prims: LeafPrims = match r & 3 {
            kind::BLOCK => {
                s.index = value >> 3;
                s.block = &blocks[s.index as usize];
                s.p = (value & 7) as usize;
                prefetch_children(blocks, s.block);
                s.t = plane_distances(s.block, s.origin, s.inv);
                return Progress::Near;
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

impl<'s> Blocks<'_, 's> {
    /// Pops the next pending position, or ends the walk. A pop to another block asks the cache
    /// for it with `HIDE` (its distances wait for the next step); a pop inside the block reads
    /// only the line the ray holds.
    #[inline(always)]
    fn next_pending<const HIDE: bool>(&self, s: &mut BlockState<'s>) -> Progress {
        let Some((index, p, tmin, tmax)) = s.stack.pop() else {
            return Progress::Done;
        };
        (s.p, s.tmin, s.tmax) = (p as usize, tmin, tmax);
        if index == s.index {
            return Progress::Near;
        }
        s.index = index;
        s.block = &self.0.blocks()[index as usize];
        if HIDE {
            crate::prefetch::t0(s.block);
            s.stale = true;
        } else {
            s.t = plane_distances(s.block, s.origin, s.inv);
        }
        Progress::Far
    }
}
