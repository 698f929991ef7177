//! Leaves cut into parts ("Parts of a leaf" in `kdray_core::format::wide`): the slots of one
//! wide node, its leaf children cut into as many parts as its free slots allow, each part's box,
//! and the order of each cut leaf's items (index-list entries or groups) that the parts' boxes
//! were computed for, which [`Wide::reorder`] writes into the words.

use super::{Wide, clipped_box, leaf_box, union};
use kdray_core::Scene;
use kdray_core::format::wide::{
    Bounds, EMPTY_BOX, Frontier, LeafRef, MAX_PARTS, NODE_WORDS, ORDERS, PART_GROUPS, PART_ITEMS,
    PART_LEAVES, WIDTH, WideNode, set_slot_box,
};
use kdray_core::format::{LeafPrims, header};
use kdray_core::group::{self, GROUP_WORDS};

impl Wide {
    /// Puts the items of the leaves cut into parts in the order their parts' boxes were
    /// computed for, in `words` (the node, index-list and groups sections the wide nodes were
    /// collapsed from).
    pub fn reorder(&self, words: &mut [u32]) {
        let grouped = words[header::GROUP_COUNT] != 0;
        let (section, size) = if grouped {
            (words[header::GROUPS_OFFSET] as usize, GROUP_WORDS)
        } else {
            (words[header::INDICES_OFFSET] as usize, 1)
        };
        let mut old = Vec::new();
        let mut rest = &self.orders[..];
        while let [start, n, tail @ ..] = rest {
            let (start, n) = (*start as usize, *n as usize);
            let (order, next) = tail.split_at(n);
            rest = next;
            let first = section + size * start;
            let run = &mut words[first..first + size * n];
            old.clear();
            old.extend_from_slice(run);
            for (to, &from) in run.chunks_exact_mut(size).zip(order) {
                to.copy_from_slice(&old[size * from as usize..][..size]);
            }
        }
    }
}

/// What one collapse keeps from node to node: [`Wide`]'s leaf orders, and buffers.
#[derive(Default)]
pub(super) struct Pass {
    pub(super) orders: Vec<u32>,
    /// The boxes of one leaf's items, clipped to its cell.
    items: Vec<Bounds>,
    /// One leaf's items' sort keys: the centre's coordinate's bits ordered as the floats, then
    /// the item's position.
    keys: Vec<u64>,
}

/// What one slot of a wide node holds.
#[derive(Clone, Copy)]
pub(super) enum Child {
    /// The binary node the next wide node stands for.
    Wide(u32),
    /// A leaf, or a part of one.
    Leaf(LeafRef),
}

/// The slots of one wide node: the greedy cut's children with the leaves that have room cut
/// into parts ("Parts of a leaf" in `kdray_core::format::wide`).
pub(super) struct Slots {
    pub(super) count: usize,
    pub(super) children: [Child; WIDTH],
    pub(super) cells: [Bounds; WIDTH],
    /// A leaf slot's box (unused for wide children, whose box is their nodes' union).
    pub(super) boxes: [Bounds; WIDTH],
    pub(super) orders: [u32; WIDTH],
}

impl Slots {
    /// A wide node with these counts and orders, every box empty and every reference 0.
    pub(super) fn skeleton(&self) -> WideNode {
        let mut node = [0u32; NODE_WORDS];
        for slot in 0..WIDTH {
            set_slot_box(&mut node, slot, EMPTY_BOX);
        }
        node[ORDERS..].copy_from_slice(&self.orders);
        node
    }
}

/// The items (index-list entries or groups) of a leaf and how many a part may hold.
fn items(prims: &LeafPrims) -> (usize, usize) {
    match prims {
        LeafPrims::Many(s) => (s.len(), PART_ITEMS),
        LeafPrims::Groups(g) => (g.len(), PART_GROUPS),
        LeafPrims::One(_) => (1, 1),
    }
}

/// `f`'s children, each leaf cut into as many parts as the node's free slots allow: a free slot
/// at a time to the leaf whose parts are the largest, while they hold more than a part's
/// items. Parts take their leaf's place, in slot order and in each octant's order (there
/// nearest corner first).
pub(super) fn slots(scene: &Scene, f: &Frontier, pass: &mut Pass) -> Slots {
    let prims: [LeafPrims; WIDTH] = core::array::from_fn(|k| {
        if k < f.count && f.leaves[k] {
            scene.leaf_prims(&scene.node(f.nodes[k]))
        } else {
            LeafPrims::One(None)
        }
    });
    let sizes = prims.each_ref().map(items);
    let mut parts = [1u32; WIDTH];
    for _ in f.count..WIDTH {
        // The leaf whose parts hold the most items, more than a part's (the first on a tie).
        let mut widest: Option<(usize, usize)> = None;
        for k in 0..f.count {
            let ((n, most), m) = (sizes[k], parts[k]);
            let size = n.div_ceil(m as usize);
            if f.leaves[k]
                && size > most
                && m < MAX_PARTS
                && f.nodes[k] < PART_LEAVES
                && widest.is_none_or(|(best, _)| size > best)
            {
                widest = Some((size, k));
            }
        }
        match widest {
            Some((_, k)) => parts[k] += 1,
            None => break,
        }
    }
    let mut out = Slots {
        count: 0,
        children: [Child::Wide(0); WIDTH],
        cells: [EMPTY_BOX; WIDTH],
        boxes: [EMPTY_BOX; WIDTH],
        orders: [0; WIDTH],
    };
    // first[k]: the first new slot of the cut's child k.
    let mut first = [0usize; WIDTH];
    for k in 0..f.count {
        first[k] = out.count;
        let m = parts[k];
        if f.leaves[k] {
            let at = out.count;
            if m == 1 {
                out.boxes[at] = leaf_box(scene, prims[k], f.cells[k]);
            } else {
                let start = scene.node(f.nodes[k]).payload();
                part_boxes(
                    scene,
                    (start, prims[k], f.cells[k]),
                    m,
                    &mut out.boxes[at..],
                    pass,
                );
            }
        }
        for part in 0..m {
            let at = out.count;
            out.cells[at] = f.cells[k];
            out.children[at] = if f.leaves[k] {
                Child::Leaf(LeafRef {
                    leaf: f.nodes[k],
                    part,
                    parts: m,
                })
            } else {
                Child::Wide(f.nodes[k])
            };
            out.count += 1;
        }
    }
    if out.count == f.count {
        // No leaf cut: the cut's own orders.
        out.orders = f.orders;
        return out;
    }
    for (octant, order) in out.orders.iter_mut().enumerate() {
        let mut word = (out.count as u32) << 24;
        let mut rank = 0;
        for p in 0..f.count {
            let k = (f.orders[octant] >> (3 * p) & 7) as usize;
            let n = parts[k] as usize;
            let mut these: [u64; WIDTH] = core::array::from_fn(|j| (first[k] + j) as u64);
            if n > 1 {
                for key in &mut these[..n] {
                    *key |= u64::from(near_key(out.boxes[*key as usize], octant)) << 32;
                }
                insertion_sort(&mut these[..n]);
            }
            for &slot in &these[..n] {
                let slot = slot as u32 as usize;
                word |= (slot as u32) << (3 * rank);
                rank += 1;
            }
        }
        *order = word;
    }
    out
}

/// The boxes of the `m` parts of a leaf (its first item's index in the index list or the groups,
/// its primitives and its cell), into `boxes[..m]`, once its items are ordered along the widest
/// axis of their boxes' centres (their boxes clipped to the cell; ties by position): pushes
/// `[start, n, order…]` onto the pass's orders, the positions of its `n` items in that order.
fn part_boxes(
    scene: &Scene,
    (start, prims, cell): (u32, LeafPrims, Bounds),
    m: u32,
    boxes: &mut [Bounds],
    pass: &mut Pass,
) {
    let items = &mut pass.items;
    items.clear();
    match prims {
        LeafPrims::Many(list) => items.extend(
            list.iter()
                .map(|&p| clipped_box(scene, p, cell).unwrap_or(EMPTY_BOX)),
        ),
        LeafPrims::Groups(groups) => items.extend(
            groups
                .iter()
                .map(|g| leaf_box(scene, LeafPrims::Groups(core::slice::from_ref(g)), cell)),
        ),
        LeafPrims::One(_) => items.push(leaf_box(scene, prims, cell)),
    }
    let n = items.len();
    let centre = |b: &Bounds| (b[0] + b[1]) * 0.5;
    let (lo, hi) = items
        .iter()
        .filter(|b| b[0].cmple(b[1]).all())
        .fold((EMPTY_BOX[0], EMPTY_BOX[1]), |(lo, hi), b| {
            (lo.min(centre(b)), hi.max(centre(b)))
        });
    let axis = (hi - lo).max_position();
    pass.keys.clear();
    pass.keys.extend(
        items
            .iter()
            .enumerate()
            .map(|(i, b)| u64::from(ordered(centre(b)[axis])) << 32 | i as u64),
    );
    // A leaf's groups are full but for its last (validation reads them so): that one stays last.
    let partial = match prims {
        LeafPrims::Groups(groups) => groups
            .last()
            .is_some_and(|g| group::ids(g)[3] == group::PAD_ID),
        _ => false,
    };
    insertion_sort(&mut pass.keys[..n - usize::from(partial)]);
    let at = |k: u32| (u64::from(k) * n as u64 / u64::from(m)) as usize;
    for (part, b) in boxes[..m as usize].iter_mut().enumerate() {
        let part = part as u32;
        let run = &mut pass.keys[at(part)..at(part + 1)];
        *b = run.iter().fold(EMPTY_BOX, |all, &key| {
            union(all, items[key as u32 as usize])
        });
        // Within a part, the leaf's own order (of its ids, ascending as the builder leaves
        // them): two triangles of one part that tie at the same `t` resolve as they do in a
        // leaf that is not cut (as a tree of the same triangles merged with others does).
        for key in run.iter_mut() {
            *key &= u64::from(u32::MAX);
        }
        insertion_sort(run);
    }
    pass.orders.extend([start, n as u32]);
    pass.orders.extend(pass.keys.iter().map(|&key| key as u32));
}

/// Sorts `keys`: by insertion up to 32 (a leaf's items, most often: fewer instructions than the
/// standard sort's on such short runs), else the standard sort.
fn insertion_sort(keys: &mut [u64]) {
    if keys.len() > 32 {
        keys.sort_unstable();
        return;
    }
    for i in 1..keys.len() {
        let key = keys[i];
        let mut j = i;
        while j > 0 && keys[j - 1] > key {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = key;
    }
}

/// `x`'s bits, in the order `f32::total_cmp` puts the floats.
fn ordered(x: f32) -> u32 {
    let bits = x.to_bits();
    if bits >> 31 != 0 {
        !bits
    } else {
        bits | 1 << 31
    }
}

/// How far along the octant's diagonal the box's nearest corner lies (the parts' order; an
/// empty box last).
fn near_key(b: Bounds, octant: usize) -> u32 {
    ordered(
        (0..3)
            .map(|a| {
                if octant >> a & 1 != 0 {
                    -b[1][a]
                } else {
                    b[0][a]
                }
            })
            .sum(),
    )
}
