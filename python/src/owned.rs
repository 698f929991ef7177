//! A scene together with the words it views: the words are checked once
//! ([`Scene::from_words`] is a pass over all of them, too slow per call) and the [`Scene`] kept
//! next to them, in one self-referential cell (`self_cell`, so without `unsafe` here).
//!
//! Where the words come from: a mesh built by the host library's SAH builder and serializer
//! ([`build`]: what `kdray build` does; opened with [`Scene::from_built_words`], trusted as this
//! process's own), a `.kdt` file or its bytes ([`Owned::from_words`]: validated), a
//! memory-mapped `.kdt` or a Python buffer kept in place ([`Owned::validate`]).

use crate::mapped::Words;
use crate::stop::{self, Stop};
use glam::Vec3;
use kdray::Geometry;
use kdray::build::{self, BuildParams, Quality};
use kdray::flat::{self, Layout, Leaves};
use kdray_core::Scene;
use kdray_core::format::contents;
use self_cell::self_cell;

self_cell!(
    /// The words of a tree (64-byte aligned: the wide section on whole cache lines) and the
    /// validated scene that borrows them.
    pub struct Owned {
        owner: Words,
        #[covariant]
        dependent: Scene,
    }
);

impl Owned {
    /// Validates `words` and keeps them. Scenes with spheres are refused: this package traces
    /// triangle meshes (its answers name triangles; its `contains` counts triangle crossings).
    ///
    /// # Errors
    /// What validation finds wrong (the core's `FormatError`), or spheres.
    pub fn from_words(words: &[u32]) -> Result<Self, String> {
        Self::validate(crate::mapped::copy(words)?)
    }

    /// [`Owned::from_words`] for words kept where they are (a mapped file's:
    /// [`crate::mapped::map`]; an immutable Python buffer's: [`crate::mapped::share`]).
    ///
    /// # Errors
    /// As [`Owned::from_words`].
    pub fn validate(words: Words) -> Result<Self, String> {
        Self::open(words, false)
    }

    /// Keeps `words` that [`build_geometry`] just wrote, opened with [`Scene::from_built_words`]
    /// (header, sections and tree shape checked; the checksum, geometry and wide nodes trusted:
    /// the Rust tests validate every tree the builder makes).
    ///
    /// # Errors
    /// As [`Owned::from_words`] (none expected).
    fn from_built_words(words: Words) -> Result<Self, String> {
        Self::open(words, true)
    }

    fn open(words: Words, built: bool) -> Result<Self, String> {
        let owned = Owned::try_new(words, |w| {
            if built {
                Scene::from_built_words(w)
            } else {
                Scene::from_words(w)
            }
        })
        .map_err(|e| format!("not a valid kd-tree: {e}"))?;
        if owned.scene().contents() & contents::SPHERES != 0 {
            return Err(
                "the scene holds spheres: this package traces triangle meshes only".to_string(),
            );
        }
        Ok(owned)
    }

    pub fn scene(&self) -> &Scene<'_> {
        self.borrow_dependent()
    }

    pub fn words(&self) -> &[u32] {
        self.borrow_owner()
    }
}

/// How to build: the stored layout and leaves, the builder's quality, and whether subtrees are
/// built on the rayon pool.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub layout: Layout,
    pub leaves: Leaves,
    pub quality: Quality,
    pub parallel: bool,
}

/// Checks that a build of `triangles` triangles can have its memory (the builder's allocations
/// are not fallible: this probes their measured peak at once, as `kdray build` does,
/// `kdray::memory::BUILD_BYTES_PER_PRIM` a triangle).
///
/// # Errors
/// [`Stop::Memory`] if it cannot.
pub fn probe_build(triangles: usize) -> Result<(), Stop> {
    stop::probe(
        (triangles as u64).saturating_mul(kdray::memory::BUILD_BYTES_PER_PRIM),
        &format!("a build of {triangles} triangles"),
    )
}

/// Builds the SAH kd-tree over `triangles` (input order), serializes it and opens it with
/// [`Scene::from_built_words`] (not validated again as a loaded file is).
///
/// # Errors
/// What the builder or the serializer refuses (a triangle too large for the kernels' f32, a tree
/// too large for the format).
pub fn build(triangles: Vec<[Vec3; 3]>, options: Options) -> Result<Owned, String> {
    if triangles.is_empty() {
        return Err("the mesh has no triangles".to_string());
    }
    let geom = Geometry {
        triangles,
        ..Geometry::default()
    };
    build_geometry(&geom, options)
}

/// [`build`] for a loaded [`Geometry`] (a mesh file), which must hold triangles only.
///
/// # Errors
/// As [`build`]; spheres.
pub fn build_geometry(geom: &Geometry, options: Options) -> Result<Owned, String> {
    if !geom.spheres.is_empty() {
        return Err("the scene holds spheres: this package traces triangle meshes only".into());
    }
    // Priced in groups of four whatever the leaves: the single-ray walks test a listed leaf's
    // triangles four at a time too.
    let params = BuildParams {
        parallel: options.parallel,
        ..BuildParams::grouped()
    }
    .with_quality(options.quality);
    let start = std::time::Instant::now();
    let tree = build::build(geom, &params, None)?;
    let ms = start.elapsed().as_secs_f32() * 1e3;
    // Written straight onto pages of their own (huge pages where the kernel has them:
    // `mapped::Fresh`), with no copy of the whole tree after it.
    let words = flat::serialize_into(
        &tree,
        geom,
        ms,
        options.layout,
        options.leaves,
        crate::mapped::Fresh::new,
    )?;
    drop(tree);
    Owned::from_built_words(words.seal()?)
        .map_err(|e| format!("the built tree does not open ({e}): please report this mesh"))
}
