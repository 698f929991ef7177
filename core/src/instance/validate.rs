//! [`InstancedScene::from_words`]: the one validation pass the top level's walks rely on (what
//! it checks and what it costs: "Validation" in [`super`]).

use super::{
    HEADER_WORDS, InstanceError, InstancedScene, MAGIC, MAX_DEPTH, NODE_WORDS, RECORD_WORDS,
    VERSION, affine_at, box_at, header, node, record,
};
use crate::format::{self, Scene, checksum};
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

/// The tree: one tree in pre-order no deeper than [`MAX_DEPTH`], each box finite and inside its
/// parent's (the root's inside `bounds`), the leaves' ranges tiling `records` in node order,
/// each record's box inside its leaf's. Returns the depth. One pass over the nodes with a stack
/// of the second children still to come (at most one per level).
fn check_tree(
    nodes: &[[u32; NODE_WORDS]],
    records: &[[u32; RECORD_WORDS]],
    bounds: [Vec3; 2],
) -> Result<u32, InstanceError> {
    // (the index a second child must have, its depth, its parent's box)
    let mut pending = [(0u32, 0u32, bounds); MAX_DEPTH + 1];
    let mut len = 0;
    let (mut depth, mut parent) = (0u32, bounds);
    let (mut deepest, mut next_record) = (0u32, 0usize);
    for (i, nd) in nodes.iter().enumerate() {
        let at = i as u32;
        if depth as usize > MAX_DEPTH {
            return Err(InstanceError::BadDepth);
        }
        deepest = deepest.max(depth);
        let b = box_at(&nd[node::BOX..]);
        if !is_box(b) || !inside(b, parent) {
            return Err(InstanceError::BadNodeBox { node: at });
        }
        let (word, count) = (nd[node::CHILD_OR_FIRST], nd[node::COUNT] as usize);
        if count == 0 {
            // Interior: the first child is the next node, the second comes later.
            if word as usize <= i + 1 || word as usize >= nodes.len() || len == pending.len() {
                return Err(InstanceError::BadChild { node: at });
            }
            pending[len] = (word, depth + 1, b);
            len += 1;
            (depth, parent) = (depth + 1, b);
            continue;
        }
        let first = word as usize;
        let end = first.checked_add(count).filter(|&e| e <= records.len());
        let Some(end) = end.filter(|_| first == next_record) else {
            return Err(InstanceError::RecordOrder { node: at });
        };
        for (k, r) in records[first..end].iter().enumerate() {
            if !inside(box_at(&r[record::BOX..]), b) {
                return Err(InstanceError::BadInstanceBox {
                    instance: (first + k) as u32,
                });
            }
        }
        next_record = end;
        // The next node must be the second child most recently deferred, or there is none.
        if len == 0 {
            if i + 1 != nodes.len() {
                return Err(InstanceError::BadChild { node: at + 1 });
            }
            break;
        }
        len -= 1;
        let (second, d, pb) = pending[len];
        if second as usize != i + 1 {
            return Err(InstanceError::BadChild { node: second });
        }
        (depth, parent) = (d, pb);
    }
    if len != 0 {
        return Err(InstanceError::BadChild {
            node: nodes.len() as u32 - 1,
        });
    }
    if next_record != records.len() {
        return Err(InstanceError::RecordOrder {
            node: nodes.len() as u32 - 1,
        });
    }
    Ok(deepest)
}
