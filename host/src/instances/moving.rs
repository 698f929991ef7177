//! Instances that move every frame: the top level refitted instead of rebuilt.
//!
//! [`TopLevel`] keeps the words [`super::top_level`] wrote and which placement each record holds.
//! When the same placements move ([`TopLevel::move_to`]: as many, in the same order), the tree
//! keeps its shape and each slot its instance or node; each record is written anew (transform,
//! inverse, bottom, id and world box, as the build writes them) and each slot's box becomes its
//! record's, or its node's slots' union, again, from the last node to the first (the nodes are
//! in pre-order, so a node's children come after it). No sort, and a placement that did not change (the same
//! transform, bottom scene and id, bit for bit) keeps its record as it is: for 10,000 instances
//! that all move, a refit is about half the instructions of a build (`cargo run --release -p
//! kdray --example instances`).
//!
//! The checksum is left stale until the words leave the process: a program opens what it just
//! built with [`kdray_core::instance::InstancedScene::from_built_words`] (which does not read
//! the checksum) from [`TopLevel::built_words`], and stores [`TopLevel::sealed_words`] or
//! [`TopLevel::into_words`]. Sealing 10,000 instances' words is a serial chain of some 380,000
//! multiplications, a third of a refit's time.
//!
//! A refitted tree answers exactly as a rebuilt one would (every node's box still contains its
//! instances', so no hit is lost), but the instances under one node may have drifted apart,
//! so a ray enters more boxes. The refit keeps the sum of its nodes' box areas: once that sum
//! exceeds [`REBUILD_GROWTH`] times the sum right after the last build, the tree is built anew
//! instead.

use super::{Placement, box_words, built, item};
use glam::Vec3;
use kdray_core::format::{Scene, seal};
use kdray_core::instance::{HEADER_WORDS, NODE_WORDS, Node, RECORD_WORDS, header, node, record};
use kdray_core::traverse::wide::{EMPTY_BOX, set_slot_box, slot_box};

/// How far the sum of the nodes' box areas may grow by refits before the tree is rebuilt.
pub const REBUILD_GROWTH: f64 = 1.5;

/// A top level that can move: its words and the placement each record holds.
#[derive(Debug)]
pub struct TopLevel {
    words: Vec<u32>,
    /// Whether the checksum words hold the words' checksum.
    sealed: bool,
    /// `order[r]`: the index in the placements of the instance record `r` holds.
    order: Vec<u32>,
    /// The sum of the nodes' box areas right after the last build.
    built_area: f64,
    /// The boxes of the bottom scenes placed: all a record depends on of its scene.
    bottom_boxes: Vec<[Vec3; 2]>,
    /// [`Self::move_to`]'s buffer of new records, kept from one move to the next.
    scratch: Vec<(usize, [u32; RECORD_WORDS])>,
}

impl Clone for TopLevel {
    /// The same top level; the clone's buffer for moves starts empty.
    fn clone(&self) -> Self {
        Self {
            words: self.words.clone(),
            sealed: self.sealed,
            order: self.order.clone(),
            built_area: self.built_area,
            bottom_boxes: self.bottom_boxes.clone(),
            scratch: Vec::new(),
        }
    }
}

/// What [`TopLevel::move_to`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Moved {
    /// The tree kept its shape; boxes and records were written anew.
    Refitted,
    /// The tree was built anew: a different number of placements, bottom scenes of other boxes,
    /// or refits had loosened it past [`REBUILD_GROWTH`].
    Rebuilt,
}

impl TopLevel {
    /// The top level placing `bottoms` as `placements` say ([`super::top_level`]'s words).
    ///
    /// # Errors
    /// As [`super::top_level`].
    pub fn build(bottoms: &[Scene], placements: &[Placement]) -> Result<Self, String> {
        let (words, order) = built(bottoms, placements)?;
        let built_area = area_sum(&words);
        Ok(Self {
            words,
            sealed: false,
            order,
            built_area,
            bottom_boxes: bottoms.iter().map(Scene::bounds).collect(),
            scratch: Vec::new(),
        })
    }

    /// The words as this process built them, for
    /// [`kdray_core::instance::InstancedScene::from_built_words`]: their checksum may be stale
    /// ([`Self::sealed_words`] for words that leave the process).
    pub fn built_words(&self) -> &[u32] {
        &self.words
    }

    /// The words with their checksum, as [`super::top_level`] returns them: what a file stores
    /// and [`kdray_core::instance::InstancedScene::from_words`] accepts.
    pub fn sealed_words(&mut self) -> &[u32] {
        if !self.sealed {
            seal(&mut self.words);
            self.sealed = true;
        }
        &self.words
    }

    /// The words with their checksum ([`Self::sealed_words`]), kept.
    pub fn into_words(mut self) -> Vec<u32> {
        self.sealed_words();
        self.words
    }

    /// The index in the placements of the instance each record holds (a hit's
    /// [`instance`](kdray_core::instance::InstanceHit::instance) indexes the records).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Places the instances as `placements` now say: a refit when they are as many as before
    /// over bottom scenes of the same boxes (the same instances, in the same order, moved, or
    /// given another of the scenes or id), else, or once refits have loosened the tree past
    /// [`REBUILD_GROWTH`], a new build.
    ///
    /// # Errors
    /// As [`super::top_level`]; the top level is then left as it was.
    pub fn move_to(
        &mut self,
        bottoms: &[Scene],
        placements: &[Placement],
    ) -> Result<Moved, String> {
        let boxes: Vec<[Vec3; 2]> = bottoms.iter().map(Scene::bounds).collect();
        if placements.len() != self.order.len() || boxes != self.bottom_boxes {
            *self = Self::build(bottoms, placements)?;
            return Ok(Moved::Rebuilt);
        }
        let nodes = self.words[header::NODE_COUNT] as usize;
        let first_record = HEADER_WORDS + NODE_WORDS * nodes;
        // The changed records first, so that a refused placement changes nothing; into the
        // last move's buffer (a frame's 10,000 records are 1.3 MB of fresh pages otherwise).
        let changed = &mut self.scratch;
        changed.clear();
        for (r, &p) in self.order.iter().enumerate() {
            let at = first_record + RECORD_WORDS * r;
            let placed = &placements[p as usize];
            if !same(&self.words[at..at + RECORD_WORDS], placed) {
                changed.push((at, item(bottoms, p as usize, placed)?.record));
            }
        }
        for (at, record) in &self.scratch {
            self.words[*at..at + RECORD_WORDS].copy_from_slice(record);
        }
        self.sealed = false;
        let area = refit_boxes(&mut self.words, first_record);
        if area > REBUILD_GROWTH * self.built_area {
            *self = Self::build(bottoms, placements)?;
            return Ok(Moved::Rebuilt);
        }
        Ok(Moved::Refitted)
    }
}

/// Whether `stored` is the record of `placed` (its transform, bottom scene and id, bit for bit):
/// then its inverse and box are too, if its bottom scene is the same one.
fn same(stored: &[u32], placed: &Placement) -> bool {
    stored[record::TRANSFORM..record::TRANSFORM + 12] == placed.transform.to_words()
        && stored[record::BOTTOM] == placed.bottom
        && stored[record::USER_ID] == placed.user_id
}

/// The box stored at `words[at..at + 6]`.
fn read_box(words: &[u32], at: usize) -> [Vec3; 2] {
    let f = |k: usize| f32::from_bits(words[at + k]);
    [Vec3::new(f(0), f(1), f(2)), Vec3::new(f(3), f(4), f(5))]
}

/// Half the surface area of `b` (the SAH's measure of how often a ray enters it).
fn half_area(b: [Vec3; 2]) -> f64 {
    let e = (b[1] - b[0]).as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The union of `nd`'s used slots' boxes.
fn node_box(nd: &Node) -> [Vec3; 2] {
    (0..nd[node::COUNT] as usize)
        .map(|s| slot_box(nd, s))
        .fold(EMPTY_BOX, |a, b| [a[0].min(b[0]), a[1].max(b[1])])
}

/// The nodes of the top level `words`.
fn nodes_of(words: &[u32]) -> &[Node] {
    let n = words[header::NODE_COUNT] as usize;
    words[HEADER_WORDS..HEADER_WORDS + NODE_WORDS * n]
        .as_chunks()
        .0
}

/// The sum of the nodes' [`half_area`]s (a node's box: its slots' union).
fn area_sum(words: &[u32]) -> f64 {
    nodes_of(words)
        .iter()
        .map(|nd| half_area(node_box(nd)))
        .sum()
}

/// Sets every slot's box to its record's box or to the union of its node's slots, last node
/// first (the nodes are in pre-order: a node's children come after it), and the header's bounds
/// to the root's union; returns the sum of the nodes' [`half_area`]s. The records start at word
/// `first_record`, right after the nodes.
fn refit_boxes(words: &mut [u32], first_record: usize) -> f64 {
    let (head, records) = words.split_at_mut(first_record);
    let (nodes, _) = head[HEADER_WORDS..].as_chunks_mut::<NODE_WORDS>();
    let mut area = 0.0;
    for n in (0..nodes.len()).rev() {
        for s in 0..nodes[n][node::COUNT] as usize {
            let reference = nodes[n][node::REFS + s];
            let b = if reference & node::RECORD_REF != 0 {
                let r = (reference & !node::RECORD_REF) as usize;
                read_box(records, RECORD_WORDS * r + record::BOX)
            } else {
                node_box(&nodes[reference as usize])
            };
            set_slot_box(&mut nodes[n], s, b);
        }
        area += half_area(node_box(&nodes[n]));
    }
    let root = node_box(&nodes[0]);
    head[header::BOUNDS..header::BOUNDS + 6].copy_from_slice(&box_words(root));
    area
}
