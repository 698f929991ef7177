//! [`InstancedScene::from_words`]: the one validation pass the top level's walks rely on (what
//! it checks and what it costs: "Validation" in [`super`]).

use super::{
    HEADER_WORDS, InstanceError, InstancedScene, MAGIC, MAX_DEPTH, NODE_WORDS, Node, RECORD_WORDS,
    VERSION, WIDTH, affine_at, box_at, header, node, record,
};
use crate::format::{self, Scene, checksum};
use crate::traverse::wide::{EMPTY_BOX, slot_box};
use glam::Vec3;

/// Whether `b` is finite with `min ≤ max` on every axis.
fn is_box(b: [Vec3; 2]) -> bool {
    b[0].is_finite() && b[1].is_finite() && b[0].cmple(b[1]).all()
}

/// Whether `inner` lies inside `outer` (both finite).
fn inside(inner: [Vec3; 2], outer: [Vec3; 2]) -> bool {
    inner[0].cmpge(outer[0]).all() && inner[1].cmple(outer[1]).all()
}

impl<'a, 'b> InstancedScene<'a, 'b> {
    /// Validates the top level `words` against the bottom scenes it indexes and returns a view of
    /// both. Runs in time linear in `words.len()` (each record's check is a fixed number of f64
    /// operations) and never panics, whatever the words.
    ///
    /// # Errors
    /// The first problem found, as an [`InstanceError`] (the list: "Validation" in [`super`]).
    pub fn from_words(words: &'a [u32], bottoms: &'b [Scene<'b>]) -> Result<Self, InstanceError> {
        Self::open(words, bottoms, true)
    }

    /// Opens a top level that this process's own builder has just written (the host's
    /// `kdray::instances::top_level`, when instances move): the header, each record's bottom
    /// index and the tree's shape — what keeps every walk in range and finite — but not the
    /// checksum, the reserved words or the records' transforms, inverses and boxes in f64, which
    /// the builder makes true and the tests check on every top level it builds. Words from
    /// outside (files, bytes, pickles, the network) go through [`Self::from_words`]. Linear in
    /// the nodes and records, never panics.
    ///
    /// # Errors
    /// As [`Self::from_words`], for the checks it makes.
    pub fn from_built_words(
        words: &'a [u32],
        bottoms: &'b [Scene<'b>],
    ) -> Result<Self, InstanceError> {
        Self::open(words, bottoms, false)
    }

    /// [`Self::from_words`] with `full`, [`Self::from_built_words`] without.
    fn open(words: &'a [u32], bottoms: &'b [Scene<'b>], full: bool) -> Result<Self, InstanceError> {
        if words.len() < HEADER_WORDS {
            return Err(InstanceError::TooShort);
        }
        let h = |i: usize| words[i];
        match h(header::MAGIC) {
            MAGIC => {}
            format::MAGIC => return Err(InstanceError::SingleMesh),
            _ => return Err(InstanceError::BadMagic),
        }
        if h(header::VERSION) != VERSION {
            return Err(InstanceError::UnsupportedVersion(h(header::VERSION)));
        }
        if h(header::TOTAL_WORDS) as usize != words.len() {
            return Err(InstanceError::LengthMismatch {
                header: h(header::TOTAL_WORDS),
                actual: words.len(),
            });
        }
        let stored = u64::from(h(header::CHECKSUM)) | u64::from(h(header::CHECKSUM + 1)) << 32;
        if full && stored != checksum(words) {
            return Err(InstanceError::Checksum);
        }
        if full
            && header::RESERVED
                .iter()
                .any(|r| words[r.clone()].iter().any(|&w| w != 0))
        {
            return Err(InstanceError::ReservedNotZero);
        }
        let (n_inst, n_nodes) = (
            h(header::INSTANCE_COUNT) as usize,
            h(header::NODE_COUNT) as usize,
        );
        let nodes_end = n_nodes
            .checked_mul(NODE_WORDS)
            .and_then(|n| n.checked_add(HEADER_WORDS));
        let total = nodes_end.and_then(|end| {
            n_inst
                .checked_mul(RECORD_WORDS)
                .and_then(|r| r.checked_add(end))
        });
        let (Some(nodes_end), Some(total)) = (nodes_end, total) else {
            return Err(InstanceError::BadCounts);
        };
        if n_inst == 0 || n_nodes == 0 || total != words.len() {
            return Err(InstanceError::BadCounts);
        }
        if h(header::BOTTOM_COUNT) as usize != bottoms.len() {
            return Err(InstanceError::BottomCount {
                header: h(header::BOTTOM_COUNT),
                actual: bottoms.len(),
            });
        }
        if h(header::DEPTH) as usize > MAX_DEPTH {
            return Err(InstanceError::BadDepth);
        }
        let bounds = box_at(&words[header::BOUNDS..]);
        if !is_box(bounds) {
            return Err(InstanceError::BadBounds);
        }
        let (nodes, _) = words[HEADER_WORDS..nodes_end].as_chunks::<NODE_WORDS>();
        let (records, _) = words[nodes_end..].as_chunks::<RECORD_WORDS>();
        for (i, r) in records.iter().enumerate() {
            if full {
                check_record(i as u32, r, bottoms, bounds)?;
            } else if r[record::BOTTOM] as usize >= bottoms.len() {
                return Err(InstanceError::BadBottom { instance: i as u32 });
            }
        }
        let depth = check_tree(nodes, records, bounds)?;
        if depth != h(header::DEPTH) {
            return Err(InstanceError::BadDepth);
        }
        Ok(Self {
            nodes,
            records,
            bottoms,
            bounds,
            depth,
        })
    }
}

/// One instance record: its bottom index, transform, inverse and box.
fn check_record(
    instance: u32,
    r: &[u32; RECORD_WORDS],
    bottoms: &[Scene],
    bounds: [Vec3; 2],
) -> Result<(), InstanceError> {
    let bottom = bottoms
        .get(r[record::BOTTOM] as usize)
        .ok_or(InstanceError::BadBottom { instance })?;
    let (m, inv) = (
        affine_at(r, record::TRANSFORM),
        affine_at(r, record::INVERSE),
    );
    if !m.is_finite() || !inv.is_finite() {
        return Err(InstanceError::NonFiniteTransform { instance });
    }
    if !m.is_invertible() {
        return Err(InstanceError::Singular { instance });
    }
    if !m.inverts(&inv) {
        return Err(InstanceError::InverseMismatch { instance });
    }
    let b = box_at(&r[record::BOX..]);
    if !is_box(b) || !inside(b, bounds) || !m.box_contains_image(b, bottom.bounds()) {
        return Err(InstanceError::BadInstanceBox { instance });
    }
    Ok(())
}

/// The tree: the nodes and records met in index order by a depth-first walk in slot order
/// (so every reference points forward and names each node and record once), no deeper than
/// [`MAX_DEPTH`], each node's count in 1..=8 with the slots past it empty and its reserved words
/// zero, each used slot's box finite and inside its parent slot's (the root's inside `bounds`),
/// each record's box inside its slot's. Returns the depth. One pass over the slots with a stack
/// of the nodes on the way down.
fn check_tree(
    nodes: &[Node],
    records: &[[u32; RECORD_WORDS]],
    bounds: [Vec3; 2],
) -> Result<u32, InstanceError> {
    // (a node on the way down, its next slot, the box its parent's slot gave it)
    let mut path: heapless::Vec<(usize, usize, [Vec3; 2]), { MAX_DEPTH + 1 }> =
        heapless::Vec::new();
    check_node(nodes, 0)?;
    let _ = path.push((0, 0, bounds));
    let (mut next_node, mut next_record, mut deepest) = (1usize, 0usize, 0u32);
    while let Some(top) = path.last_mut() {
        let (n, slot, parent) = *top;
        let nd = &nodes[n];
        if slot == nd[node::COUNT] as usize {
            path.pop();
            continue;
        }
        top.1 += 1;
        let b = slot_box(nd, slot);
        if !is_box(b) || !inside(b, parent) {
            return Err(InstanceError::BadNodeBox { node: n as u32 });
        }
        let r = nd[node::REFS + slot];
        if r & node::RECORD_REF != 0 {
            let i = (r & !node::RECORD_REF) as usize;
            if i != next_record || i >= records.len() {
                return Err(InstanceError::RecordOrder { node: n as u32 });
            }
            if !inside(box_at(&records[i][record::BOX..]), b) {
                return Err(InstanceError::BadInstanceBox { instance: i as u32 });
            }
            next_record += 1;
            continue;
        }
        let child = r as usize;
        if child != next_node || child >= nodes.len() {
            return Err(InstanceError::BadChild { node: n as u32 });
        }
        check_node(nodes, child)?;
        next_node += 1;
        if path.push((child, 0, b)).is_err() {
            return Err(InstanceError::BadDepth);
        }
        deepest = deepest.max(path.len() as u32 - 1);
    }
    if next_node != nodes.len() {
        return Err(InstanceError::BadChild {
            node: next_node as u32,
        });
    }
    if next_record != records.len() {
        return Err(InstanceError::RecordOrder {
            node: nodes.len() as u32 - 1,
        });
    }
    Ok(deepest)
}

/// Node `n`'s count in 1..=8, its slots past the count empty (min `+∞`, max `−∞`, reference 0)
/// and its reserved words zero.
fn check_node(nodes: &[Node], n: usize) -> Result<(), InstanceError> {
    let nd = &nodes[n];
    let count = nd[node::COUNT] as usize;
    let empty = |s: usize| slot_box(nd, s) == EMPTY_BOX && nd[node::REFS + s] == 0;
    if !(1..=WIDTH).contains(&count)
        || !(count..WIDTH).all(empty)
        || nd[node::RESERVED].iter().any(|&w| w != 0)
    {
        return Err(InstanceError::BadChild { node: n as u32 });
    }
    Ok(())
}
