//! Scenes of many meshes (`kdray.Instances`): bottom-level trees (the package's `Tree`s, shared
//! with the `kdray.Scene`s they came from) placed by affine transforms under a top level
//! (`kdray::instances::top_level`, walked by `kdray_core::instance`).
//!
//! A [`Top`] is immutable: the Python layer makes a new one whenever placements change or a mesh
//! is added or removed, which builds the top level alone (`O(n log n)` in the instances) and
//! shares every bottom tree as it is; the same placements moved make theirs by a refit of this
//! one's (`Top::moved`, `kdray::instances::TopLevel::move_to`). Each placement's record carries
//! its index in the arrays given here as its user id, so a hit names the geometry and the
//! placement the Python layer gave for it.
//!
//! The batches trace each ray by the two-level single-ray walk
//! (`InstancedScene::intersect_in`, `occluded_in`), the rays converted as every batch converts
//! them (`rays::Batch::convert`: unit directions, intervals scaled) on the package's pools
//! without the GIL, Ctrl-C checked between pieces (`run`).

use crate::Tree;
use crate::block;
use crate::closest::chunks_or_none;
use crate::rays::{Batch, CHUNK, for_chunks, trace_pieces};
use crate::run::{self, Cancel, cancelled};
use crate::stop::{self, Stop};
use crate::{RayArgs, mode, slice, value_error};
use kdray::instances::{Placement, TopLevel};
use kdray_core::Scene;
use kdray_core::instance::{Affine, InstanceHit, InstancedScene};
use kdray_core::traverse::Mode;
use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use self_cell::self_cell;
use std::mem::MaybeUninit;

/// What a top level holds: its words, the bottom scenes it indexes and the trees that own
/// their words.
struct Parts {
    top: TopLevel,
    /// Views of `trees`' words (see [`views`] for their lifetime).
    scenes: Vec<Scene<'static>>,
    /// Held, never read: they keep the words `scenes` view alive.
    _trees: Vec<Py<Tree>>,
}

/// Views of `trees`' words, for [`Parts`] that keep `trees`.
fn views(trees: &[Py<Tree>]) -> Vec<Scene<'static>> {
    trees
        .iter()
        .map(|t| {
            let scene: Scene<'_> = *t.get().owned.scene();
            // SAFETY: the scene borrows the words of a frozen `Tree`, which never moves nor
            // changes them while it lives, and the `Parts` these views go into keep each tree
            // alive as long as themselves (the scenes are dropped before the trees, and never
            // handed out with a longer lifetime than `&self`'s: `Levels` borrows them).
            unsafe { std::mem::transmute::<Scene<'_>, Scene<'static>>(scene) }
        })
        .collect()
}

impl Parts {
    /// A view of the same trees (for a top level that places them anew).
    fn trees(&self, py: Python<'_>) -> Vec<Py<Tree>> {
        self._trees.iter().map(|t| t.clone_ref(py)).collect()
    }
}

/// The message for a placement that [`TopLevel`] refused (`refused`, naming its index): the
/// first placement that fails a check, named by its geometry and instance, and why.
fn explain(
    scenes: &[Scene],
    placements: &[Placement],
    geometry: &[i64],
    instance: &[i64],
    refused: String,
) -> String {
    placements
        .iter()
        .enumerate()
        .find_map(|(k, p)| {
            let name = || format!("geometry {}, instance {}", geometry[k], instance[k]);
            let Some(scene) = scenes.get(p.bottom as usize) else {
                return Some(format!("{}: no such mesh", name()));
            };
            if !p.transform.is_finite() {
                return Some(format!("{}: the transform is not finite", name()));
            }
            if p.transform.inverse().is_none() {
                return Some(format!(
                    "{}: the transform is singular (or nearly: its rows are almost dependent), so \
                     it has no inverse",
                    name()
                ));
            }
            p.transform.world_box(scene.bounds()).is_none().then(|| {
                format!(
                    "{}: the transform carries the mesh beyond float32's range",
                    name()
                )
            })
        })
        .unwrap_or(refused)
}

/// Placement `k` of `bottom` and `transforms` (`(n, 12)`), its user id `k`.
fn placements(bottom: &[u32], transforms: &[f32]) -> Vec<Placement> {
    (0..bottom.len())
        .map(|k| Placement {
            bottom: bottom[k],
            transform: affine(transforms, k),
            user_id: k as u32,
        })
        .collect()
}

type Walk<'a> = InstancedScene<'a, 'a>;

self_cell!(
    /// The parts and the validated top level that borrows them.
    struct Levels {
        owner: Parts,
        #[covariant]
        dependent: Walk,
    }
);

/// A top level over shared bottom trees (module doc; `kdray.Instances` wraps it).
#[pyclass(frozen, module = "kdray._kdray")]
pub struct Top {
    levels: Levels,
    /// Per placement (the records' user ids): its bottom scene, and the Python layer's geometry
    /// and placement ids.
    bottom: Vec<u32>,
    geometry: Vec<i64>,
    instance: Vec<i64>,
}

/// Rays between two looks at the cancel flag within a piece: a ray may enter thousands of
/// placements, so a whole piece (up to `rays::MAX_PIECE` rays) could outlast Ctrl-C by seconds.
const CANCEL_EVERY: usize = 1024;

/// Where a batch's closest hits go (a whole batch's, or one piece's): `Tree.intersect`'s arrays
/// (`closest::Answers`) and the hits' geometry and instance ids (−1 for a miss), every element
/// written unless the batch is refused.
struct Answers<'a> {
    t: &'a mut [MaybeUninit<f32>],
    prim: &'a mut [MaybeUninit<i64>],
    u: &'a mut [MaybeUninit<f32>],
    v: &'a mut [MaybeUninit<f32>],
    geometry: &'a mut [MaybeUninit<i64>],
    instance: &'a mut [MaybeUninit<i64>],
    points: Option<&'a mut [MaybeUninit<f32>]>,
    normals: Option<&'a mut [MaybeUninit<f32>]>,
}

impl Answers<'_> {
    /// Writes the answer of ray `j` (of these arrays): `t` in the batch's units, the triangle in its
    /// mesh's input order, the barycentrics `uv`, the hit's `[geometry, instance]` ids.
    #[inline]
    fn write(&mut self, j: usize, t: f32, prim: i64, [u, v]: [f32; 2], [g, i]: [i64; 2]) {
        self.t[j].write(t);
        self.prim[j].write(prim);
        self.u[j].write(u);
        self.v[j].write(v);
        self.geometry[j].write(g);
        self.instance[j].write(i);
    }

    /// Writes ray `j`'s point and normal where asked for (NaN for a miss).
    #[inline]
    fn write_geometry(&mut self, j: usize, point: [f32; 3], normal: [f32; 3]) {
        for (out, xyz) in [(&mut self.points, point), (&mut self.normals, normal)] {
            if let Some(out) = out.as_deref_mut() {
                for (o, x) in out[3 * j..3 * j + 3].iter_mut().zip(xyz) {
                    o.write(x);
                }
            }
        }
    }
}

/// The 3×4 row-major transform of row `i` of `transforms` (12 floats a row).
fn affine(transforms: &[f32], i: usize) -> Affine {
    let mut m = [0.0; 12];
    m.copy_from_slice(&transforms[12 * i..12 * i + 12]);
    Affine(m)
}

impl Top {
    /// The top level of `parts`, just built or refitted here: opened as the builder's own
    /// words (the tree's shape and the bottom indices checked, not the checksum and the records'
    /// f64 checks).
    fn open(
        parts: Parts,
        bottom: Vec<u32>,
        geometry: Vec<i64>,
        instance: Vec<i64>,
    ) -> PyResult<Self> {
        let levels = Levels::try_new(parts, |p| {
            InstancedScene::from_built_words(p.top.built_words(), &p.scenes)
        })
        .map_err(|e| {
            value_error(format!(
                "the top level does not validate ({e}): please report"
            ))
        })?;
        Ok(Self {
            levels,
            bottom,
            geometry,
            instance,
        })
    }

    fn walk(&self) -> &Walk<'_> {
        self.levels.borrow_dependent()
    }

    /// `(geometry, instance)` of a hit's record (−1, −1 for a miss).
    fn ids(&self, user: u32) -> (i64, i64) {
        match self.geometry.get(user as usize) {
            Some(&g) => (g, self.instance[user as usize]),
            None => (-1, -1),
        }
    }

    /// Writes the closest hit of every ray of `batch` into `out`, on the current pool; false
    /// (`out` partly written) at a ray that `check_values` refuses. Stops early, `out` partly
    /// written, once `cancel` is set.
    fn trace(&self, batch: &Batch, mode: Mode, out: Answers, cancel: &Cancel) -> bool {
        let c = batch.pieces();
        let count = batch.n.div_ceil(c);
        // Each piece: its first ray, and its part of every array.
        let pieces: Vec<(usize, Answers)> = out
            .t
            .chunks_mut(c)
            .zip(out.prim.chunks_mut(c))
            .zip(out.u.chunks_mut(c))
            .zip(out.v.chunks_mut(c))
            .zip(out.geometry.chunks_mut(c))
            .zip(out.instance.chunks_mut(c))
            .zip(chunks_or_none(out.points, 3 * c, count))
            .zip(chunks_or_none(out.normals, 3 * c, count))
            .enumerate()
            .map(
                |(k, (((((((t, prim), u), v), geometry), instance), points), normals))| {
                    let piece = Answers {
                        t,
                        prim,
                        u,
                        v,
                        geometry,
                        instance,
                        points,
                        normals,
                    };
                    (k * c, piece)
                },
            )
            .collect();
        trace_pieces(pieces, cancel, |(start, p)| {
            self.trace_piece(batch, mode, start, p, cancel)
        })
    }

    /// Traces the piece of `batch` from ray `start` into `p` (its part of the answers); false
    /// at a ray that `check_values` refuses.
    fn trace_piece(
        &self,
        batch: &Batch,
        mode: Mode,
        start: usize,
        mut p: Answers,
        cancel: &Cancel,
    ) -> bool {
        let (mut rays, mut lengths) = (Vec::new(), Vec::new());
        if !batch.convert(start..start + p.t.len(), &mut rays, &mut lengths) {
            return false;
        }
        let walk = self.walk();
        let geometry = p.points.is_some() || p.normals.is_some();
        for (j, (ray, &len)) in rays.iter().zip(&lengths).enumerate() {
            if j % CANCEL_EVERY == 0 && cancelled(cancel) {
                return true;
            }
            let h = walk.intersect_in(mode, ray);
            if !h.is_hit() {
                p.write(j, f32::INFINITY, -1, [0.0; 2], [-1; 2]);
                if geometry {
                    p.write_geometry(j, [f32::NAN; 3], [f32::NAN; 3]);
                }
                continue;
            }
            let t = t_of(h.t, len);
            let (g, i) = self.ids(h.user_id);
            p.write(j, t, prim_of(walk, &h), [h.u, h.v], [g, i]);
            if geometry {
                let point = batch.point(start + j, t);
                let normal = walk.geometric_normal(&h, ray).normalize().to_array();
                p.write_geometry(j, point, normal);
            }
        }
        true
    }
}

/// A hit's `t` in the batch's units (over the direction's length `len`).
#[inline]
fn t_of(t: f32, len: f64) -> f32 {
    if len == 1.0 {
        t
    } else {
        (f64::from(t) / len) as f32
    }
}

/// A hit's triangle in its mesh's input order.
#[inline]
fn prim_of(walk: &Walk, h: &InstanceHit) -> i64 {
    i64::from(walk.bottom_of(h.instance).input_id(h.prim))
}

/// Runs `work` on this thread for a few rays, else on the pool of `threads` (as `traced` in
/// lib.rs).
fn run_batch<T: Send>(
    py: Python<'_>,
    n: usize,
    threads: Option<usize>,
    work: impl FnOnce(&Cancel) -> Result<T, Stop> + Send,
) -> Result<T, Stop> {
    if n <= CHUNK {
        py.detach(|| work(&Cancel::new(false)))
    } else {
        run::detached(py, threads, work)
    }
}

#[pymethods]
impl Top {
    /// A top level placing `trees[bottom[k]]` by `transforms[k]` (`(n, 12)` float32, 3×4
    /// row-major), reporting `geometry[k]`, `instance[k]` for its hits.
    #[staticmethod]
    fn build(
        py: Python<'_>,
        trees: Vec<Py<Tree>>,
        bottom: PyReadonlyArray1<'_, u32>,
        transforms: PyReadonlyArray2<'_, f32>,
        geometry: PyReadonlyArray1<'_, i64>,
        instance: PyReadonlyArray1<'_, i64>,
    ) -> PyResult<Self> {
        let (b, m) = (slice(&bottom, "bottom")?, slice(&transforms, "transforms")?);
        let (g, i) = (slice(&geometry, "geometry")?, slice(&instance, "instance")?);
        let n = b.len();
        if m.len() != 12 * n || g.len() != n || i.len() != n {
            return Err(value_error(
                "bottom, transforms, geometry and instance differ in length",
            ));
        }
        if u32::try_from(n).is_err() {
            return Err(value_error(format!("{n} instances: at most 2^32 - 1")));
        }
        let scenes = views(&trees);
        let top = py.detach(|| {
            let placed = placements(b, m);
            // The checks run again only when the build refuses a placement, to name it by its
            // geometry and instance and say why (a frame of 10,000 placements that all pass
            // pays for their inverses and boxes once, in the build).
            TopLevel::build(&scenes, &placed)
                .map_err(|refused| explain(&scenes, &placed, g, i, refused))
        });
        let parts = Parts {
            top: top.map_err(value_error)?,
            scenes,
            _trees: trees,
        };
        Self::open(parts, b.to_vec(), g.to_vec(), i.to_vec())
    }

    /// This top level with its placements moved to `transforms` (`(n, 12)` float32, as many
    /// rows as placements, the same order): the tree refitted, or built anew once refits have
    /// loosened it (`TopLevel::move_to`); the same trees and ids. This one is left as it is.
    fn moved(&self, py: Python<'_>, transforms: PyReadonlyArray2<'_, f32>) -> PyResult<Self> {
        let m = slice(&transforms, "transforms")?;
        if m.len() != 12 * self.bottom.len() {
            return Err(value_error(format!(
                "{} transforms for {} placements",
                m.len() / 12,
                self.bottom.len()
            )));
        }
        let parts = self.levels.borrow_owner();
        let top = py.detach(|| {
            let placed = placements(&self.bottom, m);
            let mut top = parts.top.clone();
            top.move_to(&parts.scenes, &placed)
                .map(|_| top)
                .map_err(|refused| {
                    explain(
                        &parts.scenes,
                        &placed,
                        &self.geometry,
                        &self.instance,
                        refused,
                    )
                })
        });
        let trees = parts.trees(py);
        let parts = Parts {
            top: top.map_err(value_error)?,
            scenes: views(&trees),
            _trees: trees,
        };
        Self::open(
            parts,
            self.bottom.clone(),
            self.geometry.clone(),
            self.instance.clone(),
        )
    }

    /// Counts, bounds and sizes of the top level.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let walk = self.walk();
        let d = PyDict::new(py);
        let [lo, hi] = walk.bounds();
        d.set_item("instances", walk.instance_count())?;
        d.set_item("nodes", walk.node_count())?;
        d.set_item("depth", walk.depth())?;
        d.set_item("bounds", (lo.to_array(), hi.to_array()))?;
        d.set_item(
            "bytes",
            self.levels.borrow_owner().top.built_words().len() * 4,
        )?;
        Ok(d)
    }

    /// One ray's closest hit: `(t, prim, u, v, geometry, instance)`.
    #[pyo3(signature = (origin, direction, tmin, tmax, watertight))]
    fn raycast(
        &self,
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
        watertight: bool,
    ) -> PyResult<(f32, i64, f32, f32, i64, i64)> {
        let batch = Batch {
            origins: &origin,
            directions: &direction,
            tmin: &[tmin],
            tmax: &[tmax],
            n: 1,
        };
        batch.check_values().map_err(value_error)?;
        let (ray, len) = batch.ray(0);
        let walk = self.walk();
        let h = walk.intersect_in(mode(watertight), &ray);
        if !h.is_hit() {
            return Ok((f32::INFINITY, -1, 0.0, 0.0, -1, -1));
        }
        let (g, i) = self.ids(h.user_id);
        Ok((t_of(h.t, len), prim_of(walk, &h), h.u, h.v, g, i))
    }

    /// Closest hits: `(t, prim, u, v, geometry, instance, points or None, normals or None)`.
    #[allow(clippy::type_complexity)]
    #[pyo3(signature = (rays, watertight, points, normals, threads))]
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        rays: RayArgs<'py>,
        watertight: bool,
        points: bool,
        normals: bool,
        threads: Option<usize>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<i64>>,
        Option<Bound<'py, PyArray1<f32>>>,
        Option<Bound<'py, PyArray1<f32>>>,
    )> {
        let batch = rays.batch()?;
        // One recycled block for every array, written in place by the threads (as
        // `Tree.intersect`'s: `block`).
        let n = batch.n;
        let extra = |on: bool| if on { 3 * n } else { 0 };
        let layout = block::Layout::new([
            (n, 4),
            (n, 8),
            (n, 4),
            (n, 4),
            (n, 8),
            (n, 8),
            (extra(points), 4),
            (extra(normals), 4),
        ]);
        let mut memory = block::Block::new(layout)?;
        let [t, prim, u, v, g, i, p, nrm] = memory.split(layout);
        let out = Answers {
            t: block::typed(t, n),
            prim: block::typed(prim, n),
            u: block::typed(u, n),
            v: block::typed(v, n),
            geometry: block::typed(g, n),
            instance: block::typed(i, n),
            points: points.then(|| block::typed(p, 3 * n)),
            normals: normals.then(|| block::typed(nrm, 3 * n)),
        };
        run_batch(py, n, threads, |cancel| {
            if self.trace(&batch, mode(watertight), out, cancel) {
                Ok(())
            } else {
                Err(Stop::Value(match batch.check_values() {
                    Err(e) => e,
                    Ok(()) => "a ray could not be traced: please report this batch".to_string(),
                }))
            }
        })?;
        let memory = Bound::new(py, memory)?;
        // SAFETY: the layout is the block's, and `trace` wrote every element.
        unsafe {
            Ok((
                block::Block::array(&memory, layout, 0, n),
                block::Block::array(&memory, layout, 1, n),
                block::Block::array(&memory, layout, 2, n),
                block::Block::array(&memory, layout, 3, n),
                block::Block::array(&memory, layout, 4, n),
                block::Block::array(&memory, layout, 5, n),
                points.then(|| block::Block::array(&memory, layout, 6, 3 * n)),
                normals.then(|| block::Block::array(&memory, layout, 7, 3 * n)),
            ))
        }
    }

    /// Whether anything lies along each ray.
    #[pyo3(signature = (rays, watertight, threads))]
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        rays: RayArgs<'py>,
        watertight: bool,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let batch = rays.batch()?;
        let walk = self.walk();
        let mode = mode(watertight);
        let out = run_batch(py, batch.n, threads, |cancel| {
            batch.check_values()?;
            let mut out = stop::filled(batch.n, false, "occluded's answers")?;
            let c = batch.pieces();
            for_chunks(&mut out, c, |k, out| {
                if cancelled(cancel) {
                    return;
                }
                for (j, o) in out.iter_mut().enumerate() {
                    if j % CANCEL_EVERY == 0 && cancelled(cancel) {
                        return;
                    }
                    *o = walk.occluded_in(mode, &batch.ray(k * c + j).0);
                }
            });
            Ok(out)
        })?;
        Ok(PyArray1::from_vec(py, out))
    }
}

/// Checks a batch's rays as the batch calls do, for a scene of no instances (which answers
/// every ray with a miss).
#[pyfunction]
pub(crate) fn check_rays(py: Python<'_>, rays: RayArgs<'_>) -> PyResult<()> {
    let batch = rays.batch()?;
    py.detach(|| batch.check_values()).map_err(value_error)
}
