//! Writing the flat format (`kdray_core::format`) from a built tree, `.kdt` files, and the tree
//! statistics `kdray info` prints.

use crate::build::clip::Aabb;
use crate::build::{BuildParams, Tree};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::par;
use kdray_core::format::wide::WideNode;
use kdray_core::format::{self, HEADER_WORDS, SECTION_ALIGN, contents, header, stride};
use kdray_core::{Scene, Triangle};
use std::io::Write;
use std::path::Path;

mod tree;

/// How the tree is stored: the node section alone, or also collapsed into wide nodes
/// (`kdray_core::format::wide`), which the single-ray queries then walk. (Format 7 to 11's
/// cache-line blocks, `Blocked`, were retired in format 12: the wide nodes walk single rays
/// faster; docs/BENCHMARKS.md, "Retired: blocks and interleaved walks".)
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layout {
    /// 8-byte nodes only (pbrt-v3's layout): the smallest file, what packets and targets built
    /// without the core's `wide` feature walk.
    #[default]
    Nodes,
    /// The nodes and a wide section: eight children a node, each with a tight box
    /// (`kdray_core::format::wide`), which the single-ray queries then walk.
    Wide,
}

/// How a leaf of several triangles holds them: as a run of the index list, or inline in
/// struct-of-arrays groups of four (`kdray_core::group`), which the single-ray walk tests four at
/// a time.
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Leaves {
    /// Primitive ids in the index list (any scene).
    #[default]
    List,
    /// Triangles in groups of four (a scene of triangles only).
    Groups,
}

impl Leaves {
    /// The leaves for a tree traced on this machine (`kdray trace`, `render`): groups for a
    /// scene of triangles only, index lists for one with spheres (groups hold triangles only).
    pub fn for_host(geom: &Geometry) -> Self {
        if geom.spheres.is_empty() {
            Leaves::Groups
        } else {
            Leaves::List
        }
    }

    /// The builder's defaults for a tree stored with these leaves: pbrt-v3's costs for index
    /// lists, [`BuildParams::grouped`] (the SAH priced in groups) for groups.
    pub fn build_params(self) -> BuildParams {
        match self {
            Leaves::List => BuildParams::default(),
            Leaves::Groups => BuildParams::grouped(),
        }
    }
}

/// [`serialize_as`] in the default [`Layout`] and [`Leaves`].
///
/// # Errors
/// See [`serialize_as`].
pub fn serialize(
    tree: &Tree,
    geom: &Geometry,
    build_ms: f32,
) -> core::result::Result<Vec<u32>, String> {
    serialize_as(tree, geom, build_ms, Layout::default(), Leaves::default())
}

/// Flattens `tree` in depth-first order (below child first: the order `Scene::from_words`
/// requires), appends the geometry sections the scene needs, and for [`Layout::Wide`] the wide
/// section. On rayon's pool when the tree was built there ([`Tree::parallel`]); the words are
/// the same either way.
///
/// # Errors
/// A tree too large for the node fields (2³⁰ nodes or primitives in one leaf) or the wide nodes;
/// [`Leaves::Groups`] for a scene with spheres.
pub fn serialize_as(
    tree: &Tree,
    geom: &Geometry,
    build_ms: f32,
    layout: Layout,
    leaves: Leaves,
) -> core::result::Result<Vec<u32>, String> {
    let (mut words, wide) = sections(tree, geom, build_ms, layout, leaves)?;
    if !wide.is_empty() {
        words.resize(words.len().next_multiple_of(format::LINE_WORDS), 0);
        words.extend_from_slice(wide.as_flattened());
    }
    finish(&mut words, wide.len())?;
    Ok(words)
}

/// [`serialize_as`]'s words written into the buffer `alloc` makes for their number, exactly
/// that many words (once, with no copy after: the Python package's own pages), which it returns.
///
/// # Errors
/// As [`serialize_as`]; `alloc`'s.
pub fn serialize_into<B: core::ops::DerefMut<Target = [u32]>>(
    tree: &Tree,
    geom: &Geometry,
    build_ms: f32,
    layout: Layout,
    leaves: Leaves,
    alloc: impl FnOnce(usize) -> core::result::Result<B, String>,
) -> core::result::Result<B, String> {
    let (words, wide) = sections(tree, geom, build_ms, layout, leaves)?;
    let wide_at = if wide.is_empty() {
        words.len()
    } else {
        words.len().next_multiple_of(format::LINE_WORDS)
    };
    let n = words.len();
    let mut out = alloc(wide_at + wide.len() * format::stride::WIDE)?;
    // Copied in runs on the pool where the tree was built (the fresh pages' faults too).
    const RUN: usize = 4096;
    let wide_words = wide.as_flattened();
    par::fill(tree.parallel, &mut out[..n], RUN, |i, o| {
        o.copy_from_slice(&words[i * RUN..][..o.len()]);
    });
    drop(words);
    out[n..wide_at].fill(0);
    par::fill(tree.parallel, &mut out[wide_at..], RUN, |i, o| {
        o.copy_from_slice(&wide_words[i * RUN..][..o.len()]);
    });
    finish(&mut out, wide.len())?;
    Ok(out)
}

/// Seals `words` (the header's counts and checksum), the last `wide` wide nodes (0: none) on
/// the line boundary where they start.
fn finish(words: &mut [u32], wide: usize) -> core::result::Result<(), String> {
    words[header::TOTAL_WORDS] =
        u32::try_from(words.len()).map_err(|_| "scene larger than 2^32 words".to_string())?;
    if wide > 0 {
        words[header::WIDE_OFFSET] = (words.len() - wide * format::stride::WIDE) as u32;
        words[header::WIDE_COUNT] = wide as u32;
        words[header::CONTENTS] |= contents::WIDE;
    }
    format::seal(words);
    Ok(())
}

/// The scene's words but the wide section, not sealed, and for [`Layout::Wide`] its wide nodes.
fn sections(
    tree: &Tree,
    geom: &Geometry,
    build_ms: f32,
    layout: Layout,
    leaves: Leaves,
) -> core::result::Result<(Vec<u32>, Vec<WideNode>), String> {
    if leaves == Leaves::Groups && !geom.spheres.is_empty() {
        return Err(
            "triangle groups (--leaves groups) need a scene of triangles only; \
                    this one has spheres: use --leaves list"
                .to_string(),
        );
    }
    let parallel = tree.parallel;
    let (mut nodes, mut indices, depth) = tree::flatten(&tree.root, parallel)?;
    let input_ids = tree::leaf_order(&mut nodes, &mut indices, geom.triangles.len());
    let reordered = input_ids.as_ref().map(|ids| reorder(geom, ids, parallel));
    let geom = reordered.as_ref().unwrap_or(geom);
    let n_tris = geom.triangles.len();
    let groups = match leaves {
        Leaves::List => Vec::new(),
        Leaves::Groups => tree::to_groups(&mut nodes, &mut indices, geom),
    };
    let mut c = 0;
    if n_tris > 0 {
        c |= contents::TRIANGLES;
    }
    if !geom.spheres.is_empty() {
        c |= contents::SPHERES;
    }
    if geom.normals.is_some() && n_tris > 0 {
        c |= contents::NORMALS;
    }
    if geom.uvs.is_some() && n_tris > 0 {
        c |= contents::UVS;
    }
    let materials: Vec<u32> = if (geom.tri_materials.iter())
        .chain(&geom.sphere_materials)
        .any(|&m| m != 0)
    {
        c |= contents::MATERIALS;
        (0..geom.prim_count())
            .map(|i| {
                if i < n_tris {
                    geom.tri_materials.get(i).copied().unwrap_or(0)
                } else {
                    geom.sphere_materials.get(i - n_tris).copied().unwrap_or(0)
                }
            })
            .collect()
    } else {
        Vec::new()
    };

    let normals = geom.normals.as_ref().filter(|_| c & contents::NORMALS != 0);
    let uvs = geom.uvs.as_ref().filter(|_| c & contents::UVS != 0);
    let ids = input_ids.as_deref().filter(|_| n_tris > 0);
    if ids.is_some() {
        c |= contents::INPUT_IDS;
    }
    if !groups.is_empty() {
        c |= contents::GROUPS;
    }
    // Where each section goes (header slot, words, whether the scene has it), in file order;
    // the words are then allocated at once, zero (fresh pages, which the writers below touch
    // first, on the pool where they run there), and each section written in place.
    let plan = [
        (header::NODES_OFFSET, stride::NODE * nodes.len(), true),
        (header::INDICES_OFFSET, indices.len(), !indices.is_empty()),
        (
            header::TRIS_OFFSET,
            stride::TRIANGLE * n_tris,
            c & contents::TRIANGLES != 0,
        ),
        (
            header::SPHERES_OFFSET,
            stride::SPHERE * geom.spheres.len(),
            c & contents::SPHERES != 0,
        ),
        (
            header::NORMALS_OFFSET,
            stride::NORMALS * normals.map_or(0, Vec::len),
            normals.is_some(),
        ),
        (
            header::UVS_OFFSET,
            stride::UVS * uvs.map_or(0, Vec::len),
            uvs.is_some(),
        ),
        (
            header::MATERIALS_OFFSET,
            materials.len(),
            c & contents::MATERIALS != 0,
        ),
        (
            header::INPUT_IDS_OFFSET,
            ids.map_or(0, <[u32]>::len),
            ids.is_some(),
        ),
        (
            header::GROUPS_OFFSET,
            stride::GROUP * groups.len(),
            !groups.is_empty(),
        ),
    ];
    let mut at = HEADER_WORDS;
    let spans = plan.map(|(_, len, present)| {
        if !present {
            return 0..0;
        }
        at = at.next_multiple_of(SECTION_ALIGN);
        at += len;
        at - len..at
    });
    let mut words = vec![0u32; at];
    for ((slot, _, present), span) in plan.iter().zip(&spans) {
        if *present {
            words[*slot] = span.start as u32;
        }
    }
    let [
        nodes_at,
        indices_at,
        tris_at,
        spheres_at,
        normals_at,
        uvs_at,
        materials_at,
        ids_at,
        groups_at,
    ] = spans;
    par::fill(parallel, &mut words[nodes_at], stride::NODE, |i, out| {
        out.copy_from_slice(&nodes[i].words());
    });
    words[indices_at].copy_from_slice(&indices);
    par::fill(parallel, &mut words[tris_at], stride::TRIANGLE, |i, out| {
        let t = &geom.triangles[i];
        let [a, b, c] = t.map(|v| v.to_array());
        let threshold = Triangle::from_vertices(t[0], t[1], t[2]).min_det2();
        for (w, v) in out
            .iter_mut()
            .zip(a.into_iter().chain(b).chain(c).chain([threshold]))
        {
            *w = v.to_bits();
        }
    });
    let bits = |out: &mut [u32], values: &mut dyn Iterator<Item = f32>| {
        for (w, v) in out.iter_mut().zip(values) {
            *w = v.to_bits();
        }
    };
    bits(
        &mut words[spheres_at],
        &mut geom
            .spheres
            .iter()
            .flat_map(|(ctr, r)| [ctr.x, ctr.y, ctr.z, *r]),
    );
    if let Some(normals) = normals {
        bits(
            &mut words[normals_at],
            &mut normals.iter().flatten().flat_map(|v| v.to_array()),
        );
    }
    if let Some(uvs) = uvs {
        bits(
            &mut words[uvs_at],
            &mut uvs.iter().flatten().flat_map(|v| v.to_array()),
        );
    }
    words[materials_at].copy_from_slice(&materials);
    if let Some(ids) = ids {
        words[ids_at].copy_from_slice(ids);
    }
    words[groups_at].copy_from_slice(groups.as_flattened());
    if !groups.is_empty() {
        words[header::GROUP_COUNT] = groups.len() as u32;
    }
    let total =
        u32::try_from(words.len()).map_err(|_| "scene larger than 2^32 words".to_string())?;
    words[header::MAGIC] = format::MAGIC;
    words[header::VERSION] = format::VERSION;
    words[header::CONTENTS] = c;
    words[header::TOTAL_WORDS] = total;
    words[header::NODE_COUNT] = nodes.len() as u32;
    words[header::TRI_COUNT] = n_tris as u32;
    words[header::SPHERE_COUNT] = geom.spheres.len() as u32;
    words[header::INDEX_COUNT] = indices.len() as u32;
    words[header::DEPTH] = depth;
    let b = tree.bounds;
    for (k, v) in [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z]
        .into_iter()
        .enumerate()
    {
        words[header::BOUNDS + k] = v.to_bits();
    }
    words[header::BUILD_MS] = build_ms.to_bits();
    let wide = match layout {
        Layout::Nodes => Vec::new(),
        Layout::Wide => {
            // The words were serialized just above: opened without validating them again (the
            // tests validate every tree the builder makes, wide sections included).
            let scene = Scene::from_built_words(&words).map_err(|e| format!("internal: {e}"))?;
            let wide = crate::wide::to_wide(&scene, parallel)?;
            wide.reorder(&mut words);
            wide.nodes
        }
    };
    Ok((words, wide))
}

/// `geom` with its triangles (on the pool when `parallel`; and their normals, texture coordinates and materials) in the order
/// `input_ids` gives.
fn reorder(geom: &Geometry, input_ids: &[u32], parallel: bool) -> Geometry {
    let pick = |i: &u32| *i as usize;
    Geometry {
        triangles: par::map(parallel, input_ids.len(), |k| {
            geom.triangles[pick(&input_ids[k])]
        }),
        normals: geom
            .normals
            .as_ref()
            .map(|n| input_ids.iter().map(|i| n[pick(i)]).collect()),
        uvs: geom
            .uvs
            .as_ref()
            .map(|u| input_ids.iter().map(|i| u[pick(i)]).collect()),
        tri_materials: if geom.tri_materials.is_empty() {
            Vec::new()
        } else {
            input_ids
                .iter()
                .map(|i| geom.tri_materials.get(pick(i)).copied().unwrap_or(0))
                .collect()
        },
        spheres: geom.spheres.clone(),
        sphere_materials: geom.sphere_materials.clone(),
    }
}

/// Writes words as a little-endian `.kdt` file, whole or not at all ([`crate::files::write_atomic`]).
pub fn write_kdt(path: &Path, words: &[u32]) -> Result<()> {
    stage_kdt(path, words)?.commit()
}

/// [`write_kdt`] up to the rename: the file written in full next to `path`, not yet in place
/// ([`crate::files::Staged`]).
///
/// # Errors
/// As [`write_kdt`].
pub fn stage_kdt(path: &Path, words: &[u32]) -> Result<crate::files::Staged> {
    crate::files::stage(path, |w| {
        words
            .iter()
            .try_for_each(|word| w.write_all(&word.to_le_bytes()))
    })
}

/// Words whose first one lies on a 64-byte boundary, so that the wide section (at a multiple of
/// 16 words in the file) is made of whole cache lines; a `Vec<u32>` is only 4-byte aligned (and
/// a large one from the system allocator typically 16 bytes past a page), which would split every
/// line of a wide node across two. Derefs to the words.
#[derive(Clone, Debug)]
pub struct Aligned {
    buf: Vec<u32>,
    start: usize,
}

impl Aligned {
    /// A 64-byte aligned copy of `words`.
    pub fn new(words: &[u32]) -> Self {
        let mut buf = vec![0u32; words.len() + 15];
        let start = (64 - buf.as_ptr() as usize % 64) % 64 / 4;
        buf[start..start + words.len()].copy_from_slice(words);
        buf.truncate(start + words.len());
        Self { buf, start }
    }
}

impl core::ops::Deref for Aligned {
    type Target = [u32];
    fn deref(&self) -> &[u32] {
        &self.buf[self.start..]
    }
}

/// Reads a `.kdt` file (a regular file) into words, not validated: open them with
/// `Scene::from_words`, as every caller does (each validated them a second time while this
/// validated too: `kdray trace FILE.kdt`, `info`, `rays` and the Python package's `Scene.load`
/// paid twice the load, issue 38).
///
/// # Errors
/// A file that cannot be read or is not a whole number of words.
pub fn read_kdt(path: &Path) -> Result<Vec<u32>> {
    let bytes = crate::files::read(path)?;
    if !bytes.len().is_multiple_of(4) {
        return Err(Error::new(
            path,
            format!(
                "{} bytes is not a whole number of 32-bit words",
                bytes.len()
            ),
        ));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

/// What `kdray info` reports about a tree.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeStats {
    pub nodes: u32,
    pub leaves: u32,
    pub empty_leaves: u32,
    /// Primitive references in non-empty leaves divided by their number.
    pub mean_prims_per_leaf: f64,
    /// The most primitives in one leaf.
    pub max_prims_per_leaf: u32,
    pub depth: u32,
    /// Expected cost of a random ray through the root box, in the given cost units.
    pub sah_cost: f64,
    pub bytes: usize,
    pub bytes_per_prim: f64,
    /// Bytes per triangle (0 without triangles).
    pub bytes_per_tri: f64,
}

/// Walks a validated scene to gather [`TreeStats`], pricing nodes with `params`' costs.
pub fn stats(scene: &Scene, words: usize, params: &BuildParams) -> TreeStats {
    let [lo, hi] = scene.bounds();
    let root = Aabb { min: lo, max: hi };
    let root_area = root.area();
    let mut s = TreeStats {
        nodes: scene.node_count(),
        leaves: 0,
        empty_leaves: 0,
        mean_prims_per_leaf: 0.0,
        max_prims_per_leaf: 0,
        depth: scene.depth(),
        sah_cost: 0.0,
        bytes: words * 4,
        bytes_per_prim: (words * 4) as f64 / scene.prim_count().max(1) as f64,
        bytes_per_tri: if scene.tri_count() > 0 {
            (words * 4) as f64 / scene.tri_count() as f64
        } else {
            0.0
        },
    };
    let mut refs = 0u64;
    let mut stack = vec![(0u32, root)];
    while let Some((i, b)) = stack.pop() {
        let node = scene.node(i);
        let p = if root_area > 0.0 {
            b.area() / root_area
        } else {
            1.0
        };
        if node.is_leaf() {
            s.leaves += 1;
            let n = node.prim_count();
            if n == 0 {
                s.empty_leaves += 1;
            }
            refs += n as u64;
            s.max_prims_per_leaf = s.max_prims_per_leaf.max(n);
            s.sah_cost += params.intersect_cost * n as f64 * p;
        } else {
            s.sah_cost += params.traversal_cost * p;
            let (below, above) = b.split(node.axis(), node.split());
            stack.push((i + 1, below));
            stack.push((node.above_child(), above));
        }
    }
    let non_empty = s.leaves - s.empty_leaves;
    s.mean_prims_per_leaf = if non_empty > 0 {
        refs as f64 / non_empty as f64
    } else {
        0.0
    };
    s
}
