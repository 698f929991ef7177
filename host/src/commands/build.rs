//! `kdray build` and `kdray info`.

use super::with_progress;
use core::sync::atomic::{AtomicU64, Ordering};
use indicatif::{ProgressBar, ProgressStyle};
use kdray::build::{BuildParams, PROGRESS_TOTAL, Quality};
use kdray::error::{Error, Result};
use kdray::{Geometry, files, flat, input, load};
use kdray_core::Scene;
use kdray_core::format::contents;
use std::path::Path;
use std::time::Instant;

/// Builder settings shared by `build` and `trace`.
#[derive(clap::Args, Clone, Debug)]
pub struct BuildArgs {
    /// SAH cost of one primitive test (of one group of four with `--leaves groups` or `--quality
    /// fast`), relative to one traversal step (finite, > 0) [default: 80, or 3 with `--leaves
    /// groups` or `--quality fast`].
    #[arg(long, value_parser = parse_cost)]
    pub isect_cost: Option<f64>,
    /// SAH cost of one traversal step (finite, > 0).
    #[arg(long, default_value_t = BuildParams::default().traversal_cost, value_parser = parse_cost)]
    pub trav_cost: f64,
    /// Fraction of the cost saved by cutting off empty space, in [0, 1).
    #[arg(long, default_value_t = BuildParams::default().empty_bonus, value_parser = parse_bonus)]
    pub empty_bonus: f64,
    /// Maximum tree depth (default 8 + 1.3·log2 N).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Build on one thread.
    #[arg(long)]
    pub serial_build: bool,
    /// How the tree is stored: `wide` (the default: the nodes and a copy collapsed into
    /// eight-wide nodes with tight boxes, which single rays walk eight cells a step; 1.8-1.9x as
    /// fast on the dragon's diffuse rays as `nodes`, docs/BENCHMARKS.md "Wide nodes"), or `nodes`
    /// (8-byte nodes only: the smallest file, what packets walk). (`blocked` was retired in
    /// format 12: `wide` replaces it.)
    #[arg(long, value_name = "nodes|wide", default_value = "wide", value_parser = parse_layout)]
    pub layout: flat::Layout,
    /// How a leaf holds its triangles: `list` (ids in an index list; any scene, and every target
    /// loads it: the firmware and the WASM page leave the group kernels out), or `groups`
    /// (inline, four to a 176-byte group, tested four at a time by single rays, with the SAH
    /// priced in groups; triangles-only scenes; format v9; README "Command line"). Default:
    /// `list` for `build` (a file every target loads); for `trace` from a mesh or scene,
    /// `groups` when it has triangles only (1.3-1.4x faster single rays), else `list`.
    #[arg(long, value_enum)]
    pub leaves: Option<flat::Leaves>,
    /// How hard the builder searches: `high` (the exact sweep and perfect splits at every node)
    /// or `fast` (binned planes on nodes of 32 primitives and more, straddlers split by the plane
    /// alone; 3x faster than `high` on the dragon, diffuse rays 8.5 % more instructions with
    /// `--leaves groups`, 16.5 % with `list`: docs/BUILD.md, "Quality"). Same format either way.
    #[arg(long, value_enum, default_value_t = Quality::default())]
    pub quality: Quality,
}

impl Default for BuildArgs {
    fn default() -> Self {
        let p = BuildParams::default();
        Self {
            isect_cost: None,
            trav_cost: p.traversal_cost,
            empty_bonus: p.empty_bonus,
            max_depth: p.max_depth,
            serial_build: !p.parallel,
            layout: flat::Layout::Wide,
            leaves: None,
            quality: p.quality,
        }
    }
}

impl BuildArgs {
    /// The leaves of a tree built to be traced here (`trace`, `rays`): `--leaves`, or by default
    /// groups for a scene of triangles only and index lists for one with spheres.
    pub fn leaves_for(&self, geom: &Geometry) -> flat::Leaves {
        self.leaves.unwrap_or_else(|| flat::Leaves::for_host(geom))
    }

    /// The builder's settings for a tree stored with `leaves`: the SAH priced in groups of four
    /// with `--leaves groups`, and at `--quality fast` whatever the leaves (the single-ray walks
    /// test a listed leaf's triangles four at a time too), so that `--quality fast --leaves
    /// list` builds the npm and Python packages' default tree; else pbrt-v3's per-triangle
    /// costs.
    pub fn params(&self, leaves: flat::Leaves) -> BuildParams {
        let base = match self.quality {
            Quality::Fast => BuildParams::grouped(),
            Quality::High => leaves.build_params(),
        };
        BuildParams {
            traversal_cost: self.trav_cost,
            intersect_cost: self.isect_cost.unwrap_or(base.intersect_cost),
            empty_bonus: self.empty_bonus,
            max_depth: self.max_depth,
            parallel: !self.serial_build,
            ..base.with_quality(self.quality)
        }
    }
}

/// The seed written into render descriptions: `kdray render`'s default, so that a target renders
/// what `kdray render SCENE.toml` does.
pub const DESCRIPTION_SEED: u64 = 1;

/// Parses `--layout`: `nodes` or `wide`; the retired `blocked` is a usage error that says what
/// replaces it.
fn parse_layout(s: &str) -> core::result::Result<flat::Layout, String> {
    match s {
        "nodes" => Ok(flat::Layout::Nodes),
        "wide" => Ok(flat::Layout::Wide),
        "blocked" => Err(
            "the blocked layout was retired in format 12: use `--layout wide` (the \
                          default), whose wide nodes walk single rays faster (docs/BENCHMARKS.md, \
                          \"Retired: blocks and interleaved walks\")"
                .to_string(),
        ),
        _ => Err(format!("the layout must be nodes or wide, got '{s}'")),
    }
}

/// Parses an SAH cost: a finite number above 0 (a usage error otherwise).
fn parse_cost(s: &str) -> core::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(c) if c.is_finite() && c > 0.0 => Ok(c),
        _ => Err(format!("a cost must be a finite number above 0, got '{s}'")),
    }
}

/// Parses the empty-space bonus: a fraction in [0, 1) (1 would make cutting empty space free, and
/// the tree split until the depth limit).
fn parse_bonus(s: &str) -> core::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(b) if (0.0..1.0).contains(&b) => Ok(b),
        _ => Err(format!(
            "the empty bonus must be a number in [0, 1), got '{s}'"
        )),
    }
}

/// Builds `geom` with a progress bar; returns the words, the build time in ms and the process's
/// CPU time during the build in ms ([`kdray::cpu::process_ms`], `None` where the system does not
/// say).
/// Geometry the flat format cannot hold is refused first, naming `path` (the input).
pub fn build_words(
    path: &Path,
    geom: &Geometry,
    params: &BuildParams,
    layout: flat::Layout,
    leaves: flat::Leaves,
) -> Result<(Vec<u32>, f64, Option<f64>)> {
    load::check_buildable(path, geom)?;
    let prims = (geom.triangles.len() + geom.spheres.len()) as u64;
    kdray::memory::ensure(
        path,
        prims * kdray::memory::BUILD_BYTES_PER_PRIM,
        &format!("a build of {prims} primitives"),
        &format!(
            "a build takes about {} bytes a primitive",
            kdray::memory::BUILD_BYTES_PER_PRIM
        ),
    )?;
    let progress = AtomicU64::new(0);
    let bar = ProgressBar::new(1000).with_message(format!("building {}", path.display()));
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {percent}% {elapsed}")
            .expect("valid template"),
    );
    // The build runs on its own thread and times itself, so the progress polling adds nothing
    // to build_ms.
    let (tree, build_ms, cpu_ms) = with_progress(
        &bar,
        || progress.load(Ordering::Relaxed) * 1000 / PROGRESS_TOTAL,
        || {
            let (t0, c0) = (Instant::now(), kdray::cpu::process_ms());
            let tree = kdray::build::build(geom, params, Some(&progress));
            let cpu = c0.zip(kdray::cpu::process_ms()).map(|(a, b)| b - a);
            (tree, t0.elapsed().as_secs_f64() * 1e3, cpu)
        },
    );
    let tree = tree.map_err(|e| Error::new(path, e))?;
    let words = flat::serialize_as(&tree, geom, build_ms as f32, layout, leaves)
        .map_err(|e| Error::new(path, e))?;
    if let Err(e) = Scene::from_words(&words) {
        let msg = format!("the built tree does not validate ({e}): please report this input");
        return Err(Error::new(path, msg));
    }
    Ok((words, build_ms, cpu_ms))
}

/// Loads a `.kdt`, or loads and builds anything else (refusing to write over an input named in
/// `outputs`). Returns the words and, when it built them, the build time in ms (`None` for a
/// `.kdt`: nothing was built now; the time stored in the file is `Scene::build_ms`).
pub fn load_scene_words(
    path: &Path,
    args: &BuildArgs,
    outputs: &[&Path],
) -> Result<(Vec<u32>, Option<f64>)> {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("kdt"))
    {
        return Ok((flat::read_kdt(path)?, None));
    }
    let geom = input::load_input(path, outputs)?;
    let leaves = args.leaves_for(&geom);
    let (words, ms, _) = build_words(path, &geom, &args.params(leaves), args.layout, leaves)?;
    Ok((words, Some(ms)))
}

/// `kdray build`: the tree into `out` and, for a scene file, its render description into
/// `description` (what a firmware or WASM target needs besides the tree: camera, settings,
/// materials, lights; `kdray_core::description`). Both outputs are checked before the work.
pub fn build(input: &Path, out: &Path, description: Option<&Path>, args: &BuildArgs) -> Result<()> {
    let outputs: Vec<&Path> = core::iter::once(out).chain(description).collect();
    files::check_outputs(&[input], &outputs)?;
    let file = match description {
        Some(_) => Some(kdray::scene::load_scene(input)?),
        None => None,
    };
    let geom = match &file {
        Some(file) => {
            files::check_not_inputs(&file.mesh_files(), &outputs)?;
            file.geometry()?
        }
        None => input::load_input(input, &outputs)?,
    };
    reset_peak_resident();
    // A file may go to a target whose core leaves the group kernels out: lists unless asked.
    let leaves = args.leaves.unwrap_or(flat::Leaves::List);
    let (words, build_ms, cpu_ms) =
        build_words(input, &geom, &args.params(leaves), args.layout, leaves)?;
    let peak = peak_resident()
        .map(|b| format!(", peak_mib={}", b.div_ceil(1 << 20)))
        .unwrap_or_default();
    let cpu = cpu_ms
        .map(|ms| format!(", cpu_ms={ms:.0}"))
        .unwrap_or_default();
    let scene = Scene::from_words(&words).map_err(|e| Error::new(input, e.to_string()))?;
    // Both outputs are made, then staged, before either is put in place: a description that
    // fails leaves no tree behind, and the tree appears only with its description.
    let desc = match (&file, description) {
        (Some(file), Some(path)) => Some((
            path,
            kdray::description::encode(file, &words, DESCRIPTION_SEED)?,
        )),
        _ => None,
    };
    let mut staged = vec![flat::stage_kdt(out, &words)?];
    if let Some((path, desc)) = &desc {
        staged.push(flat::stage_kdt(path, desc)?);
    }
    files::commit_all(staged)?;
    let desc = desc.map(|(path, d)| (path, d.len()));
    println!(
        "wrote {}: {} triangles, {} spheres, {} nodes, {} bytes, build_ms={build_ms:.1}{cpu}{peak}",
        out.display(),
        scene.tri_count(),
        scene.sphere_count(),
        scene.node_count(),
        words.len() * 4
    );
    if let Some((path, len)) = desc {
        println!("wrote {}: render description, {len} words", path.display());
    }
    Ok(())
}

/// Starts the process's peak resident size over from its present size (Linux: `clear_refs`
/// value 5; elsewhere nothing), so that [`peak_resident`] measures what follows.
fn reset_peak_resident() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident size in bytes since [`reset_peak_resident`] (Linux `VmHWM`), or
/// `None` where the system does not say. A build's peak: the geometry, which was resident
/// before, and the builder's, serializer's and validator's memory at their largest.
fn peak_resident() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

pub fn info(file: &Path) -> Result<()> {
    let words = flat::read_kdt(file)?;
    let scene = Scene::from_words(&words).map_err(|e| Error::new(file, e.to_string()))?;
    let s = flat::stats(&scene, words.len(), &BuildParams::default());
    let [lo, hi] = scene.bounds();
    println!("file            {}", file.display());
    println!("triangles       {}", scene.tri_count());
    println!("spheres         {}", scene.sphere_count());
    let names = [
        (contents::TRIANGLES, "triangles"),
        (contents::SPHERES, "spheres"),
        (contents::NORMALS, "normals"),
        (contents::UVS, "uvs"),
        (contents::MATERIALS, "materials"),
        (
            contents::INPUT_IDS,
            "input-ids (triangles stored in leaf order)",
        ),
        (contents::GROUPS, "groups"),
        (contents::WIDE, "wide"),
    ];
    let present: Vec<&str> = names
        .iter()
        .filter(|(bit, _)| scene.contents() & bit != 0)
        .map(|(_, name)| *name)
        .collect();
    println!(
        "contents        {:#08b} {}",
        scene.contents(),
        present.join(", ")
    );
    println!("bounds          [{lo}] .. [{hi}]");
    println!("nodes           {}", s.nodes);
    println!("leaves          {}", s.leaves);
    println!("empty leaves    {}", s.empty_leaves);
    println!(
        "prims per leaf  {:.3} (mean over non-empty leaves)",
        s.mean_prims_per_leaf
    );
    println!("max prims/leaf  {}", s.max_prims_per_leaf);
    println!("depth           {}", s.depth);
    println!(
        "sah cost        {:.3} (traversal 1, intersection 80)",
        s.sah_cost
    );
    println!("bytes           {}", s.bytes);
    let node_bytes = scene.node_count() as usize * 8;
    let wide_bytes = scene.wide_nodes().len() * 256;
    if wide_bytes > 0 {
        println!(
            "layout          wide ({} wide nodes, {wide_bytes} bytes; {node_bytes} bytes of nodes)",
            scene.wide_nodes().len()
        );
        let (cut, parts) = leaf_parts(scene.wide_nodes());
        println!("leaf parts      {cut} leaves cut into {parts} parts, each with a box of its own");
    } else {
        println!("layout          nodes ({node_bytes} bytes of nodes)");
    }
    let groups = words[kdray_core::format::header::GROUP_COUNT] as usize;
    if scene.has_groups() {
        println!(
            "leaves hold     groups ({groups} groups of four triangles, {} bytes)",
            groups * kdray_core::group::GROUP_WORDS * 4
        );
    } else {
        println!("leaves hold     lists (primitive ids in the index list)");
    }
    println!("bytes per prim  {:.2}", s.bytes_per_prim);
    if scene.tri_count() > 0 {
        println!("bytes per tri   {:.2}", s.bytes_per_tri);
    }
    println!("build ms        {:.1}", scene.build_ms());
    Ok(())
}

/// How many leaves the wide nodes cut into parts, and into how many parts in all.
fn leaf_parts(wide: &[kdray_core::format::wide::WideNode]) -> (usize, usize) {
    use kdray_core::format::wide::{LEAF_REF, LeafRef, ORDERS, REFS};
    let refs = wide.iter().flat_map(|node| {
        let count = (node[ORDERS] >> 24) as usize;
        node[REFS..REFS + count].iter().copied()
    });
    let parts = refs
        .filter(|&r| r & LEAF_REF != 0)
        .map(LeafRef::decode)
        .filter(|r| r.parts > 1);
    parts.fold((0, 0), |(cut, all), r| {
        (cut + usize::from(r.part == 0), all + 1)
    })
}
