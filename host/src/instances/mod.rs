//! The top level of a scene of many meshes: meshes (bottom-level scenes, each today's word array
//! from [`crate::flat::serialize`]) placed by affine transforms → the words of the top level that
//! [`kdray_core::instance::InstancedScene::from_words`] validates and walks (its layout, word by
//! word: `kdray_core::instance`).
//!
//! Moving instances rebuilds the top level alone: [`top_level`] reads each bottom scene's box,
//! never its tree, and runs in `O(n log n)` for `n` instances (each node's instances split into
//! up to eight groups at medians of the longest axis of their centres, down to single
//! instances), so a
//! frame that moves instances pays for that and not for the meshes
//! (`cargo run --release -p kdray --example instances` times it for 10,000 instances). The same
//! instances moved again refit the tree instead of rebuilding it ([`TopLevel::move_to`],
//! `moving.rs`).
//!
//! ```
//! use kdray::Geometry;
//! use kdray::build::{BuildParams, build};
//! use kdray::glam::Vec3;
//! use kdray::instances::{Placement, top_level};
//! use kdray_core::instance::{Affine, InstancedScene};
//! use kdray_core::{Ray, Scene};
//!
//! let geom = Geometry { triangles: vec![[Vec3::ZERO, Vec3::X, Vec3::Y]], ..Geometry::default() };
//! let tree = build(&geom, &BuildParams::default(), None).unwrap();
//! let mesh = kdray::flat::serialize(&tree, &geom, 0.0).unwrap();
//! let bottoms = [Scene::from_words(&mesh).unwrap()];
//! // Two copies: one as it is, one moved 5 along z and mirrored in x.
//! let moved = Affine([-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 5.0]);
//! let placements = [
//!     Placement { bottom: 0, transform: Affine::IDENTITY, user_id: 7 },
//!     Placement { bottom: 0, transform: moved, user_id: 8 },
//! ];
//! let words = top_level(&bottoms, &placements).unwrap();
//! let top = InstancedScene::from_words(&words, &bottoms).unwrap();
//! let hit = top.intersect(&Ray::new(Vec3::new(-0.25, 0.25, 9.0), Vec3::NEG_Z));
//! assert_eq!(hit.user_id, 8);
//! assert_eq!(hit.t, 4.0);
//! ```

use glam::Vec3;
use kdray_core::Ray;
use kdray_core::format::{Scene, seal};
use kdray_core::instance::{
    Affine, HEADER_WORDS, InstanceHit, InstancedScene, MAGIC, NODE_WORDS, Node, RECORD_WORDS,
    VERSION, WIDTH, header, node, record,
};
use kdray_core::traverse::Mode;
use kdray_core::traverse::wide::{EMPTY_BOX, set_slot_box};

mod moving;
pub use moving::{Moved, REBUILD_GROWTH, TopLevel};

/// The closest hit of each of `rays` through `scene` in `mode`, into `hits` (as many): the
/// two-level single-ray walk ([`InstancedScene::intersect_in`]), what `kdray trace` runs on a
/// scene file with instances.
pub fn trace_rays(scene: &InstancedScene, mode: Mode, rays: &[Ray], hits: &mut [InstanceHit]) {
    for (hit, ray) in hits.iter_mut().zip(rays) {
        *hit = scene.intersect_in(mode, ray);
    }
}

/// One instance: which bottom scene, where, and the id its hits report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Index into the bottom scenes.
    pub bottom: u32,
    /// Object → world.
    pub transform: Affine,
    /// Reported with each hit on this instance ([`kdray_core::instance::InstanceHit::user_id`]).
    pub user_id: u32,
}

/// An instance on its way into the tree: its world box and its record.
struct Item {
    bounds: [Vec3; 2],
    record: [u32; RECORD_WORDS],
}

/// What the splits sort: an item's centre, each coordinate as an integer in the order of
/// [`f32::total_cmp`] ([`ordered`]: the same comparisons, so the same tree, as comparing the
/// floats, in an integer compare instead of a call), and its index.
#[derive(Clone, Copy)]
struct Key {
    centre: [u32; 3],
    at: u32,
}

/// `x`'s bits turned so that unsigned integer order is [`f32::total_cmp`]'s order: negative
/// values (sign set) reversed below the positive ones.
fn ordered(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// The float whose [`ordered`] key is `k`.
fn unordered(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

/// The words of the top level placing `bottoms` as `placements` say, records in the tree's
/// leaf order (a hit's [`instance`](kdray_core::instance::InstanceHit::instance) indexes them;
/// its `user_id` is the placement's).
///
/// # Errors
/// No placement, more than `u32::MAX`, a bottom index out of range, a transform that is not
/// finite or not invertible ([`Affine::inverse`]), or one that carries its bottom scene's box
/// beyond f32: a message naming the placement.
pub fn top_level(bottoms: &[Scene], placements: &[Placement]) -> Result<Vec<u32>, String> {
    let (mut words, _) = built(bottoms, placements)?;
    seal(&mut words);
    Ok(words)
}

/// [`top_level`]'s words, not yet sealed (the checksum words zero), and, record by record, the
/// index of the placement it holds.
fn built(bottoms: &[Scene], placements: &[Placement]) -> Result<(Vec<u32>, Vec<u32>), String> {
    if placements.is_empty() {
        return Err("a top level needs at least one instance".into());
    }
    u32::try_from(placements.len()).map_err(|_| "more than 2^32 - 1 instances".to_string())?;
    let items = placements
        .iter()
        .enumerate()
        .map(|(i, p)| item(bottoms, i, p))
        .collect::<Result<Vec<_>, _>>()?;
    // The median splits move these 16-byte keys, not the items (a record is 128 bytes).
    let mut keys: Vec<Key> = items
        .iter()
        .enumerate()
        .map(|(at, it)| Key {
            centre: ((it.bounds[0] + it.bounds[1]) * 0.5)
                .to_array()
                .map(ordered),
            at: at as u32,
        })
        .collect();
    let mut nodes = Vec::with_capacity(placements.len() / (WIDTH - 1) + 1);
    let mut records = Vec::with_capacity(placements.len());
    let mut order = Vec::with_capacity(placements.len());
    let (depth, bounds) = if keys.len() == 1 {
        // One instance: a root of one record slot.
        let mut root = empty_node();
        set_slot(&mut root, 0, items[0].bounds, node::RECORD_REF);
        root[node::COUNT] = 1;
        nodes.push(root);
        records.push(items[0].record);
        order.push(0);
        (0, items[0].bounds)
    } else {
        subtree(&items, &mut keys, &mut nodes, &mut records, &mut order, 0)
    };
    let total = HEADER_WORDS + NODE_WORDS * nodes.len() + RECORD_WORDS * records.len();
    let mut words = vec![0u32; HEADER_WORDS];
    words.reserve(total - HEADER_WORDS);
    words[header::MAGIC] = MAGIC;
    words[header::VERSION] = VERSION;
    words[header::TOTAL_WORDS] = u32::try_from(total).map_err(|_| "top level too large")?;
    words[header::INSTANCE_COUNT] = records.len() as u32;
    words[header::NODE_COUNT] = nodes.len() as u32;
    words[header::BOTTOM_COUNT] = bottoms.len() as u32;
    words[header::DEPTH] = depth;
    // The root's slots' union is the union of every record's box: the world bounds.
    words[header::BOUNDS..header::BOUNDS + 6].copy_from_slice(&box_words(bounds));
    words.extend(nodes.iter().flatten());
    words.extend(records.iter().flatten());
    Ok((words, order))
}

/// Placement `i`'s record and box.
fn item(bottoms: &[Scene], i: usize, p: &Placement) -> Result<Item, String> {
    let bottom = bottoms.get(p.bottom as usize).ok_or_else(|| {
        format!(
            "instance {i}: bottom scene {} out of range ({} given)",
            p.bottom,
            bottoms.len()
        )
    })?;
    let inverse = p
        .transform
        .inverse()
        .ok_or_else(|| format!("instance {i}: transform is not finite or not invertible"))?;
    let bounds = p
        .transform
        .world_box(bottom.bounds())
        .ok_or_else(|| format!("instance {i}: transform carries the mesh beyond f32's range"))?;
    let mut r = [0u32; RECORD_WORDS];
    r[record::TRANSFORM..record::TRANSFORM + 12].copy_from_slice(&p.transform.to_words());
    r[record::INVERSE..record::INVERSE + 12].copy_from_slice(&inverse.to_words());
    r[record::BOTTOM] = p.bottom;
    r[record::USER_ID] = p.user_id;
    r[record::BOX..record::BOX + 6].copy_from_slice(&box_words(bounds));
    Ok(Item { bounds, record: r })
}

fn box_words(b: [Vec3; 2]) -> [u32; 6] {
    let [lo, hi] = b;
    [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z].map(f32::to_bits)
}

/// An empty node: every slot's box min `+∞`, max `−∞`, every reference 0, count 0.
fn empty_node() -> Node {
    let mut nd = [0u32; NODE_WORDS];
    for s in 0..WIDTH {
        set_slot_box(&mut nd, s, EMPTY_BOX);
    }
    nd
}

/// Sets slot `s` of `nd`: its box and reference.
fn set_slot(nd: &mut Node, s: usize, b: [Vec3; 2], reference: u32) {
    set_slot_box(nd, s, b);
    nd[node::REFS + s] = reference;
}

/// Appends the node over the items that `keys` name (more than one) to `nodes`, and its subtree
/// after it in pre-order, and the records in the order a depth-first walk in slot order meets
/// them to `records`; returns the subtree's depth below `depth`'s level and its box. The keys
/// are split into up to eight groups by median splits, the largest group split next, along
/// the longest axis of its centres; a group of one is a record slot, a larger one a node. A
/// slot's box is its record's, or its node's slots' union (so only a record slot reads an item,
/// scattered in memory; min and max are exact, so it is the union of the items' boxes all the
/// same).
fn subtree(
    items: &[Item],
    keys: &mut [Key],
    nodes: &mut Vec<Node>,
    records: &mut Vec<[u32; RECORD_WORDS]>,
    order: &mut Vec<u32>,
    depth: u32,
) -> (u32, [Vec3; 2]) {
    let at = nodes.len();
    nodes.push(empty_node());
    // The groups as ranges of `keys`, in slot order.
    let mut groups = [(0usize, 0usize); WIDTH];
    groups[0] = (0, keys.len());
    let mut count = 1;
    while count < WIDTH {
        let (g, &(lo, hi)) = groups[..count]
            .iter()
            .enumerate()
            .max_by_key(|(g, r)| (r.1 - r.0, usize::MAX - g))
            .expect("a group");
        if hi - lo < 2 {
            break;
        }
        let mid = lo + median_split(&mut keys[lo..hi]);
        groups.copy_within(g + 1..count, g + 2);
        (groups[g], groups[g + 1]) = ((lo, mid), (mid, hi));
        count += 1;
    }
    let (mut deepest, mut lo, mut hi) = (depth, Vec3::INFINITY, Vec3::NEG_INFINITY);
    for (s, &(a, b)) in groups[..count].iter().enumerate() {
        let (reference, bounds) = if b - a == 1 {
            let k = keys[a].at as usize;
            let reference = node::RECORD_REF | records.len() as u32;
            records.push(items[k].record);
            order.push(k as u32);
            (reference, items[k].bounds)
        } else {
            let reference = nodes.len() as u32;
            let (d, bounds) = subtree(items, &mut keys[a..b], nodes, records, order, depth + 1);
            deepest = deepest.max(d);
            (reference, bounds)
        };
        set_slot(&mut nodes[at], s, bounds, reference);
        (lo, hi) = (lo.min(bounds[0]), hi.max(bounds[1]));
    }
    nodes[at][node::COUNT] = count as u32;
    (deepest, [lo, hi])
}

/// Reorders `keys` (two or more) about the median of the longest axis of their centres and
/// returns the median's index: the keys before it lie below it on that axis, those from it on
/// above.
fn median_split(keys: &mut [Key]) -> usize {
    let (mut clo, mut chi) = ([u32::MAX; 3], [0u32; 3]);
    for k in keys.iter() {
        for a in 0..3 {
            (clo[a], chi[a]) = (clo[a].min(k.centre[a]), chi[a].max(k.centre[a]));
        }
    }
    let extent = Vec3::from_array(chi.map(unordered)) - Vec3::from_array(clo.map(unordered));
    let axis = extent.max_position();
    let mid = keys.len() / 2;
    keys.select_nth_unstable_by_key(mid, |k| k.centre[axis]);
    mid
}

#[cfg(test)]
mod tests {
    use super::{ordered, unordered};

    /// The integer keys the splits compare order floats exactly as `f32::total_cmp` does, so
    /// that the tree is the one the float comparisons built, and turn back into the same float.
    #[test]
    fn ordered_keys_compare_as_total_cmp() {
        let values = [
            f32::NEG_INFINITY,
            f32::MIN,
            -1.5,
            -f32::MIN_POSITIVE,
            -1.0e-45,
            -0.0,
            0.0,
            1.0e-45,
            f32::MIN_POSITIVE,
            0.75,
            1.0,
            3.0e38,
            f32::MAX,
            f32::INFINITY,
        ];
        for a in values {
            assert_eq!(unordered(ordered(a)).to_bits(), a.to_bits(), "{a}");
            for b in values {
                assert_eq!(
                    ordered(a).cmp(&ordered(b)),
                    a.total_cmp(&b),
                    "{a} against {b}"
                );
            }
        }
    }
}
