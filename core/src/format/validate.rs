//! [`Scene::from_words`]: the one validation pass every later access relies on.

use super::{
    FormatError, HEADER_WORDS, LINE_WORDS, MAGIC, MAX_DEPTH, SECTION_ALIGN, Scene, VERSION,
    checksum, contents, header, same_words, stored_triangle, stored_vertices, stride,
};
use crate::group;
use crate::node::Node;
use crate::simd::range::SceneRange;
use glam::Vec3;

/// A section's place: offset word, element count, words per element, contents bit (0 = always).
struct SectionSpec {
    offset_word: usize,
    count: usize,
    stride: usize,
    bit: u32,
}

/// How much of [`Scene::open`]'s checking the words need.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Origin {
    /// Words from outside (a file, bytes, the network): everything is checked.
    Outside,
    /// Words this process's own builder and serializer just wrote: only what keeps every access
    /// in range and every walk finite (see [`Scene::from_built_words`]).
    Built,
}

impl<'a> Scene<'a> {
    /// Validates `words` and returns a view of it. Runs in time linear in its length and never
    /// panics, whatever the words.
    ///
    /// # Errors
    /// The first problem found, as a [`FormatError`].
    pub fn from_words(words: &'a [u32]) -> Result<Self, FormatError> {
        Self::open(words, Origin::Outside)
    }

    /// Opens `words` that this process's own builder and serializer just wrote (the host
    /// library's `kdray::flat::serialize`), with only the checks that keep every access in range
    /// and every walk finite: the header (magic, version, length, contents, reserved words), the
    /// sections' bounds and overlaps, the scene box, the tree's pre-order layout and its leaves'
    /// ranges and ids (`validate_tree`, linear in the nodes and the index list), the
    /// groups' ranges and, for the wide section, that each reference a walk can enter points
    /// forward to a wide node or at a leaf in range.
    ///
    /// What it trusts, and so skips: the checksum (no storage or transfer in between can have
    /// damaged them), the geometry (finite vertices, each threshold equal to its recomputed
    /// [`crate::triangle::Triangle::min_det2`], every triangle and sphere inside the scene box),
    /// the input ids, the groups' contents (each rebuilt from its triangle records) and the wide
    /// nodes' leaves, orders and boxes (checked against the node section's leaves and cells). Those checks are what make a
    /// *crafted* file's answers the ones of the scene it stores; the builder makes them true by
    /// construction, and the tests check that [`Self::from_words`] accepts every tree it builds
    /// (`tests/tests/built_words.rs`).
    ///
    /// The packet walks' overflow bound ([`crate::simd::range::SceneRange`]: the scene box and
    /// the smallest threshold) is computed from the stored words as for validated ones; it holds
    /// because the builder's primitives lie in its box, which the tests check with the rest.
    ///
    /// Why it is safe on words that are wrong anyway: the core has no `unsafe`, so every access is
    /// bounds-checked, and what the walks rely on to end is kept: every child index (binary and
    /// wide) points forward, so no walk can loop. Wrong words give wrong answers or, at an access
    /// out of range, a panic, never undefined behaviour or an endless walk. Use [`Self::from_words`]
    /// for anything read from outside this process.
    ///
    /// # Errors
    /// The first problem found, as a [`FormatError`] (none for words the builder wrote).
    pub fn from_built_words(words: &'a [u32]) -> Result<Self, FormatError> {
        Self::open(words, Origin::Built)
    }

    fn open(words: &'a [u32], origin: Origin) -> Result<Self, FormatError> {
        let outside = origin == Origin::Outside;
        if words.len() < HEADER_WORDS {
            return Err(FormatError::TooShort);
        }
        let h = |i: usize| words[i];
        if h(header::MAGIC) == super::TOP_LEVEL_MAGIC {
            return Err(FormatError::TopLevel);
        }
        if h(header::MAGIC) != MAGIC {
            return Err(FormatError::BadMagic);
        }
        if h(header::VERSION) != VERSION {
            return Err(FormatError::UnsupportedVersion(h(header::VERSION)));
        }
        if h(header::TOTAL_WORDS) as usize != words.len() {
            return Err(FormatError::LengthMismatch {
                header: h(header::TOTAL_WORDS),
                actual: words.len(),
            });
        }
        let stored = u64::from(h(header::CHECKSUM)) | u64::from(h(header::CHECKSUM + 1)) << 32;
        if outside && stored != checksum(words) {
            return Err(FormatError::Checksum);
        }
        if words[header::RESERVED..HEADER_WORDS]
            .iter()
            .chain(&words[header::UNUSED])
            .any(|&w| w != 0)
        {
            return Err(FormatError::ReservedNotZero);
        }
        let contents = h(header::CONTENTS);
        if contents & contents::RETIRED_BLOCKS != 0 {
            return Err(FormatError::BlocksRetired);
        }
        let (n_nodes, n_tris, n_spheres, n_indices) = (
            h(header::NODE_COUNT) as usize,
            h(header::TRI_COUNT) as usize,
            h(header::SPHERE_COUNT) as usize,
            h(header::INDEX_COUNT) as usize,
        );
        let n_prims = h(header::TRI_COUNT)
            .checked_add(h(header::SPHERE_COUNT))
            .ok_or(FormatError::CountOverflow)?;
        let tri_bit = if n_tris > 0 { contents::TRIANGLES } else { 0 };
        let sphere_bit = if n_spheres > 0 { contents::SPHERES } else { 0 };
        if contents & !contents::ALL != 0
            || contents & (contents::TRIANGLES | contents::SPHERES) != tri_bit | sphere_bit
            || (contents & (contents::NORMALS | contents::UVS | contents::INPUT_IDS) != 0
                && n_tris == 0)
        {
            return Err(FormatError::BadContents);
        }
        let specs = [
            SectionSpec {
                offset_word: header::NODES_OFFSET,
                count: n_nodes,
                stride: stride::NODE,
                bit: 0,
            },
            SectionSpec {
                offset_word: header::INDICES_OFFSET,
                count: n_indices,
                stride: 1,
                bit: 0,
            },
            SectionSpec {
                offset_word: header::TRIS_OFFSET,
                count: n_tris,
                stride: stride::TRIANGLE,
                bit: contents::TRIANGLES,
            },
            SectionSpec {
                offset_word: header::SPHERES_OFFSET,
                count: n_spheres,
                stride: stride::SPHERE,
                bit: contents::SPHERES,
            },
            SectionSpec {
                offset_word: header::NORMALS_OFFSET,
                count: n_tris,
                stride: stride::NORMALS,
                bit: contents::NORMALS,
            },
            SectionSpec {
                offset_word: header::UVS_OFFSET,
                count: n_tris,
                stride: stride::UVS,
                bit: contents::UVS,
            },
            SectionSpec {
                offset_word: header::MATERIALS_OFFSET,
                count: n_prims as usize,
                stride: 1,
                bit: contents::MATERIALS,
            },
            SectionSpec {
                offset_word: header::INPUT_IDS_OFFSET,
                count: n_tris,
                stride: 1,
                bit: contents::INPUT_IDS,
            },
            SectionSpec {
                offset_word: header::GROUPS_OFFSET,
                count: h(header::GROUP_COUNT) as usize,
                stride: stride::GROUP,
                bit: contents::GROUPS,
            },
            SectionSpec {
                offset_word: header::WIDE_OFFSET,
                count: h(header::WIDE_COUNT) as usize,
                stride: stride::WIDE,
                bit: contents::WIDE,
            },
        ];
        if contents & contents::WIDE == 0 && h(header::WIDE_COUNT) != 0 {
            return Err(FormatError::BadContents);
        }
        // Groups hold triangles only, and replace the index list.
        let grouped = contents & contents::GROUPS != 0;
        if (!grouped && h(header::GROUP_COUNT) != 0)
            || (grouped && (n_tris == 0 || n_spheres != 0 || n_indices != 0))
        {
            return Err(FormatError::BadContents);
        }
        if grouped && !cfg!(feature = "groups") {
            return Err(FormatError::GroupsLeftOut);
        }
        // (start, end) of each section, (0, 0) when absent.
        let mut ranges = [(0usize, 0usize); 10];
        for (range, spec) in ranges.iter_mut().zip(specs.iter()) {
            let offset = h(spec.offset_word) as usize;
            let present = if spec.bit == 0 {
                spec.count > 0
            } else {
                contents & spec.bit != 0
            };
            if !present {
                if offset != 0 {
                    return Err(FormatError::BadContents);
                }
                continue;
            }
            let len = spec
                .count
                .checked_mul(spec.stride)
                .ok_or(FormatError::CountOverflow)?;
            let end = offset.checked_add(len).ok_or(FormatError::CountOverflow)?;
            // Wide nodes start on a cache line (16 words), the others on 8 words.
            let align = if spec.bit == contents::WIDE {
                LINE_WORDS
            } else {
                SECTION_ALIGN
            };
            if offset < HEADER_WORDS || !offset.is_multiple_of(align) || end > words.len() {
                return Err(FormatError::SectionOutOfBounds);
            }
            *range = (offset, end);
        }
        // Pairwise overlap test on at most 10 sections: no sort, no allocation.
        for (i, a) in ranges.iter().enumerate() {
            for b in &ranges[i + 1..] {
                if a.1 > a.0 && b.1 > b.0 && a.0 < b.1 && b.0 < a.1 {
                    return Err(FormatError::SectionsOverlap);
                }
            }
        }
        let words_of = |i: usize| &words[ranges[i].0..ranges[i].1];
        let floats_of = |i: usize| bytemuck::cast_slice::<u32, f32>(words_of(i));
        let bounds_f: [f32; 6] =
            core::array::from_fn(|k| f32::from_bits(words[header::BOUNDS + k]));
        let bounds = [
            Vec3::new(bounds_f[0], bounds_f[1], bounds_f[2]),
            Vec3::new(bounds_f[3], bounds_f[4], bounds_f[5]),
        ];
        if !(bounds[0].is_finite() && bounds[1].is_finite() && bounds[0].cmple(bounds[1]).all()) {
            return Err(FormatError::BadBounds);
        }
        #[cfg_attr(feature = "wide", allow(unused_mut))]
        let mut scene = Scene {
            contents,
            build_ms: f32::from_bits(h(header::BUILD_MS)),
            depth: h(header::DEPTH),
            bounds,
            nodes: words_of(0).as_chunks().0,
            indices: words_of(1),
            tris: floats_of(2).as_chunks().0,
            spheres: floats_of(3),
            normals: floats_of(4),
            uvs: floats_of(5),
            materials: words_of(6),
            input_ids: words_of(7),
            groups: words_of(8).as_chunks().0,
            wide: words_of(9).as_chunks().0,
            range: SceneRange::new(bounds, f32::INFINITY),
        };
        if outside {
            scene.check_geometry(n_tris)?;
        }
        // Thresholds are finite or `+inf` here (checked, or so written by this process's
        // builder), so the fold sees no NaN.
        let min_threshold = scene.tris.iter().fold(f32::INFINITY, |m, t| m.min(t[9]));
        scene.range = SceneRange::new(bounds, min_threshold);
        if scene.nodes.is_empty() {
            return Err(FormatError::BadDepth);
        }
        let depth = scene.validate_tree(n_prims, origin)?;
        if depth != scene.depth {
            return Err(FormatError::BadDepth);
        }
        if contents & contents::WIDE != 0 {
            #[cfg(feature = "wide")]
            if outside {
                super::wide::validate::validate(&scene, scene.wide)?;
            } else {
                super::wide::validate::forward_refs(&scene, scene.wide)?;
            }
            // Without the `wide` feature nothing walks the section: it is set aside unread (the
            // walks take the binary nodes, with the same closest hits), so the build links no
            // validation of it (5.8 KB of the firmware's `.text`). So `wide_nodes()` is empty in
            // such a build whatever the file holds.
            #[cfg(not(feature = "wide"))]
            {
                scene.wide = &[];
            }
        }
        Ok(scene)
    }

    /// The geometry is finite, each threshold is its triangle's recomputed
    /// [`crate::triangle::Triangle::min_det2`], every hittable primitive lies inside the bounds
    /// and every input id names a triangle.
    fn check_geometry(&self, n_tris: usize) -> Result<(), FormatError> {
        let finite = |s: &[f32]| s.iter().all(|x| x.is_finite());
        let triangles_ok = self.tris.iter().all(|t| {
            let tri = stored_triangle(t);
            finite(&t[..9])
                && tri.e1.is_finite()
                && tri.e2.is_finite()
                && tri.min_det2().to_bits() == t[9].to_bits()
                && !tri.is_too_large()
        });
        if !(triangles_ok && finite(self.spheres) && finite(self.normals) && finite(self.uvs))
            || self
                .spheres
                .chunks_exact(stride::SPHERE)
                .any(|s| !(s[3] > 0.0))
        {
            return Err(FormatError::NonFiniteGeometry);
        }
        self.check_inside_bounds()?;
        if let Some(i) = self.input_ids.iter().position(|&id| id as usize >= n_tris) {
            return Err(FormatError::BadInputId { triangle: i as u32 });
        }
        Ok(())
    }

    /// Walks the tree once depth-first, below child first, checking that the nodes are visited in
    /// exactly the order `0, 1, 2, …` (the pre-order layout the builder writes). That makes every
    /// child index greater than its parent's, every node reachable exactly once, and so bounds
    /// every later walk. Returns the tree's depth.
    ///
    /// The leaves' index-list ranges must tile the list in that same order (see "Cost of
    /// validation" in the [module doc](super)): one pass over the list checks every id, and each
    /// leaf costs O(1), so the whole walk is linear in the words.
    ///
    /// Words from this process's builder ([`Origin::Built`]) skip only the groups' contents.
    fn validate_tree(&self, n_prims: u32, origin: Origin) -> Result<u32, FormatError> {
        let n_nodes = self.node_count();
        if let Some(i) = self.indices.iter().position(|&p| p >= n_prims) {
            return Err(FormatError::BadIndex { index: i as u32 });
        }
        // Where the next leaf with an index list (or groups) must start.
        let mut next_index = 0usize;
        // Pending above-children and their depths; capacity bounds the depth we accept.
        let mut stack: heapless::Vec<(u32, u32), MAX_DEPTH> = heapless::Vec::new();
        let mut next = 0u32; // the index the pre-order walk must visit next
        let mut current = Some((0u32, 0u32));
        let mut max_depth = 0;
        while let Some((index, depth)) = current {
            if index != next || index >= n_nodes {
                return Err(FormatError::BadChild { node: index });
            }
            if depth as usize > MAX_DEPTH {
                return Err(FormatError::BadDepth);
            }
            max_depth = max_depth.max(depth);
            next += 1;
            let node = self.node(index);
            if node.is_leaf() {
                self.validate_leaf(index, node, n_prims, origin, &mut next_index)?;
                current = stack.pop();
            } else {
                let axis = node.axis();
                let inside = (self.bounds[0][axis]..=self.bounds[1][axis]).contains(&node.split());
                if !inside {
                    return Err(FormatError::BadSplit { node: index });
                }
                let above = node.above_child();
                if above <= index + 1 || above >= n_nodes {
                    return Err(FormatError::BadChild { node: index });
                }
                let empty = [index + 1, above].map(|i| self.node(i).is_empty_leaf());
                if node.empty_children() != empty {
                    return Err(FormatError::BadEmptyFlag { node: index });
                }
                stack
                    .push((above, depth + 1))
                    .map_err(|_| FormatError::BadDepth)?;
                current = Some((index + 1, depth + 1));
            }
        }
        if next != n_nodes {
            return Err(FormatError::BadChild { node: next });
        }
        let listed = if self.has_groups() {
            self.groups.len()
        } else {
            self.indices.len()
        };
        if next_index != listed {
            return Err(FormatError::UnusedIndices {
                from: next_index as u32,
            });
        }
        Ok(max_depth)
    }

    /// Every hittable triangle (finite threshold) and every sphere lies inside the header's
    /// bounds: a triangle's stored vertices exactly, a sphere's `c ± r` within 4 ulp of the
    /// bounds' magnitude (the rounding of `c ± r`).
    fn check_inside_bounds(&self) -> Result<(), FormatError> {
        let [lo, hi] = self.bounds;
        let slack = lo.abs().max(hi.abs()) * (4.0 * f32::EPSILON);
        let (lo_s, hi_s) = (lo - slack, hi + slack);
        let inside = |p: Vec3, lo: Vec3, hi: Vec3| p.cmpge(lo).all() && p.cmple(hi).all();
        for (i, t) in self.tris.iter().enumerate() {
            if t[9] == f32::INFINITY {
                continue; // never hit, and the builder leaves it out of the bounds
            }
            if !stored_vertices(t).iter().all(|&v| inside(v, lo, hi)) {
                return Err(FormatError::OutsideBounds { prim: i as u32 });
            }
        }
        for i in 0..self.sphere_count() {
            let s = self.sphere(i);
            let r = Vec3::splat(s.radius);
            if !(inside(s.center - r, lo_s, hi_s) && inside(s.center + r, lo_s, hi_s)) {
                let prim = self.tri_count() + i;
                return Err(FormatError::OutsideBounds { prim });
            }
        }
        Ok(())
    }

    /// A leaf's primitives exist: its one id is below `n_prims`, or its index-list range is the
    /// one starting at `next_index` (the ids in it were checked once, in [`Self::validate_tree`]),
    /// which it then advances past.
    fn validate_leaf(
        &self,
        index: u32,
        node: Node,
        n_prims: u32,
        origin: Origin,
        next_index: &mut usize,
    ) -> Result<(), FormatError> {
        let bad = FormatError::BadPrimitive { node: index };
        match node.prim_count() {
            0 => Ok(()),
            1 if node.payload() < n_prims => Ok(()),
            1 => Err(bad),
            n if self.has_groups() => self.validate_groups(index, node, n, origin, next_index),
            n => {
                let start = node.payload() as usize;
                let end = start.checked_add(n as usize).ok_or(bad)?;
                if end > self.indices.len() {
                    return Err(bad);
                }
                // Leaves sharing or skipping part of the list: a shared range re-read per leaf
                // made validation (and every walk through those leaves) quadratic in the file.
                if start != *next_index {
                    return Err(FormatError::IndexOrder { node: index });
                }
                *next_index = end;
                Ok(())
            }
        }
    }

    /// A leaf's groups ([`crate::group`]): the `⌈n/4⌉` starting at `next_group`, each equal, word
    /// for word, to the group [`group::pack`] makes of its ids' triangle records (ids below
    /// TRI_COUNT, the last group's spare lanes padding). Each group is checked once, at the leaf
    /// that owns it (the groups tile the section in node order).
    fn validate_groups(
        &self,
        index: u32,
        node: Node,
        n: u32,
        origin: Origin,
        next_group: &mut usize,
    ) -> Result<(), FormatError> {
        let bad = FormatError::BadPrimitive { node: index };
        let start = node.payload() as usize;
        let end = start
            .checked_add(group::groups_for(n) as usize)
            .ok_or(bad)?;
        if end > self.groups.len() {
            return Err(bad);
        }
        if start != *next_group {
            return Err(FormatError::IndexOrder { node: index });
        }
        *next_group = end;
        if origin == Origin::Built {
            return Ok(());
        }
        let mut left = n as usize;
        for g in &self.groups[start..end] {
            let real = left.min(group::WIDTH);
            left -= real;
            let ids = group::ids(g);
            let mut lanes = [(0, [Vec3::ZERO; 3], 0.0); group::WIDTH];
            for (lane, &id) in lanes.iter_mut().zip(&ids[..real]) {
                let t = self.tris.get(id as usize).ok_or(bad)?;
                *lane = (id, stored_vertices(t), t[9]);
            }
            if !same_words(&group::pack(&lanes[..real]), g) {
                return Err(FormatError::BadGroup { node: index });
            }
        }
        Ok(())
    }
}
