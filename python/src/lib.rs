//! # kdray-python
//!
//! The extension module `kdray._kdray` behind the Python package `kdray` (`python/kdray/`): the
//! host library's loaders, SAH builder and serializer, and `kdray-core`'s walks, over numpy
//! arrays. The package's Python layer (`kdray/__init__.py`) checks types and shapes, converts
//! dtypes once (float32 rays, int64 faces) and broadcasts; this module takes the arrays as they
//! are then (read in place, C-contiguous), checks their values, and does the work with the GIL
//! released, on the package's pools (`pool`: a thread a core, or `threads`; fork-safe), Ctrl-C
//! checked while it runs (`run`).
//!
//! Every failure about the input is a `ValueError` naming the argument and the problem; the
//! Python layer raises the `TypeError`s. Memory that a size in the input asks for and that
//! cannot be had is a `MemoryError` (`stop`); Ctrl-C during a batch a `KeyboardInterrupt`.

mod block;
mod closest;
mod crossings;
mod instanced;
mod mapped;
mod merged;
mod mesh;
mod owned;
mod pickle;
mod pool;
mod rays;
mod run;
mod stop;

use kdray::build::Quality;
use kdray::flat::{self, Layout, Leaves};
use kdray_core::traverse::Mode;
use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use owned::{Options, Owned};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rays::Batch;
use std::path::PathBuf;
use stop::Stop;

fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

fn options(layout: &str, leaves: &str, quality: &str, threads: Option<usize>) -> PyResult<Options> {
    Ok(Options {
        layout: choice(
            "layout",
            layout,
            [("wide", Layout::Wide), ("nodes", Layout::Nodes)],
        )?,
        leaves: choice(
            "leaves",
            leaves,
            [("groups", Leaves::Groups), ("list", Leaves::List)],
        )?,
        quality: choice(
            "quality",
            quality,
            [("fast", Quality::Fast), ("high", Quality::High)],
        )?,
        parallel: threads != Some(1),
    })
}

/// The value of build option `name` that `value` names, or a `ValueError` naming the two.
fn choice<T: Copy>(name: &str, value: &str, [(a, x), (b, y)]: [(&str, T); 2]) -> PyResult<T> {
    if value == a {
        Ok(x)
    } else if value == b {
        Ok(y)
    } else {
        Err(value_error(format!(
            "{name}={value:?}: it must be '{a}' or '{b}'"
        )))
    }
}

fn slice<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| value_error(format!("{name} is not C-contiguous and aligned")))
}

/// A validated kd-tree over a triangle mesh (the package's `kdray.Scene` wraps it).
#[pyclass(frozen, module = "kdray._kdray")]
struct Tree {
    owned: Owned,
}

/// A batch of rays as the Python layer passes it (`kdray._Batch`, a tuple): origins and
/// directions `(k, 3)`, `tmin` and `tmax` `(k,)` (C-contiguous float32, `k` = 1 or `n`), the
/// number of rays `n`, and the batch's shape (for the Python layer).
#[derive(FromPyObject)]
struct RayArgs<'py>(
    PyReadonlyArray2<'py, f32>,
    PyReadonlyArray2<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    usize,
    #[allow(dead_code)] Bound<'py, PyAny>,
);

impl RayArgs<'_> {
    /// The arrays read in place, their lengths checked.
    fn batch(&self) -> PyResult<Batch<'_>> {
        let batch = Batch {
            origins: slice(&self.0, "origins")?,
            directions: slice(&self.1, "directions")?,
            tmin: slice(&self.2, "tmin")?,
            tmax: slice(&self.3, "tmax")?,
            n: self.4,
        };
        batch.check_lengths().map_err(value_error)?;
        Ok(batch)
    }
}

/// Checks `batch`'s values, then runs `f` without the GIL: on this thread for at most `few` rays
/// (`rays::CHUNK`, or `crossings::FEW` for every crossing, whose rays cost more), else on the pool
/// of `threads`, stopped by Ctrl-C (`run`).
fn traced<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    batch: &Batch,
    few: usize,
    f: impl FnOnce(&run::Cancel) -> Result<T, Stop> + Send,
) -> PyResult<T> {
    let work = |cancel: &run::Cancel| -> Result<T, Stop> {
        batch.check_values()?;
        f(cancel)
    };
    if batch.n <= few {
        // A few rays: on this thread, which is faster than handing them to a pool.
        return Ok(py.detach(|| work(&run::Cancel::new(false)))?);
    }
    Ok(run::detached(py, threads, work)?)
}

fn mode(watertight: bool) -> Mode {
    if watertight {
        Mode::Watertight
    } else {
        Mode::Fast
    }
}

#[pymethods]
impl Tree {
    /// Builds the tree over `vertices` (`(N, 3)` float32) and `faces` (`(M, 3)` int64, or none).
    #[staticmethod]
    #[pyo3(signature = (vertices, faces, layout, leaves, quality, threads))]
    fn build(
        py: Python<'_>,
        vertices: PyReadonlyArray2<'_, f32>,
        faces: Option<PyReadonlyArray2<'_, i64>>,
        layout: &str,
        leaves: &str,
        quality: &str,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let options = options(layout, leaves, quality, threads)?;
        let v = slice(&vertices, "vertices")?;
        let f = faces.as_ref().map(|f| slice(f, "faces")).transpose()?;
        let owned = py.detach(|| {
            pool::on_pool(threads, || -> Result<Owned, Stop> {
                let tris = mesh::triangles(v, f)?;
                owned::probe_build(tris.len())?;
                Ok(owned::build(tris, options)?)
            })?
        })?;
        Ok(Self { owned })
    }

    /// Loads a `.kdt` (validated), or a mesh file (`.ply`, `.ply.gz`, `.obj`, `.tri`) and builds it.
    #[staticmethod]
    #[pyo3(signature = (path, layout, leaves, quality, threads))]
    fn load(
        py: Python<'_>,
        path: PathBuf,
        layout: &str,
        leaves: &str,
        quality: &str,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let options = options(layout, leaves, quality, threads)?;
        let is_kdt = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("kdt"));
        let owned = py.detach(|| -> Result<Owned, Stop> {
            if is_kdt {
                let words = flat::read_kdt(&path).map_err(|e| e.to_string())?;
                Ok(Owned::from_words(&words).map_err(|e| format!("{}: {e}", path.display()))?)
            } else {
                let geom = kdray::input::load_input(&path, &[]).map_err(|e| e.to_string())?;
                if geom.triangles.is_empty() {
                    return Err(format!("{}: the mesh has no triangles", path.display()).into());
                }
                owned::probe_build(geom.triangles.len())?;
                Ok(
                    pool::on_pool(threads, || owned::build_geometry(&geom, options))?
                        .map_err(|e| format!("{}: {e}", path.display()))?,
                )
            }
        })?;
        Ok(Self { owned })
    }

    /// A tree from the words of a `.kdt` (validated): its bytes viewed as little-endian u32, kept
    /// in place when nothing can change them (`mapped::share`), else copied.
    #[staticmethod]
    fn from_words(py: Python<'_>, words: PyReadonlyArray1<'_, u32>) -> PyResult<Self> {
        let owned = match mapped::share(&words)? {
            Some(shared) => py.detach(|| Owned::validate(shared)),
            None => {
                let words = slice(&words, "data")?;
                py.detach(|| Owned::from_words(words))
            }
        };
        Ok(Self {
            owned: owned.map_err(|e| value_error(format!("data: {e}")))?,
        })
    }

    /// The `.kdt` bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        let words = self.owned.words();
        PyBytes::new_with(py, words.len() * 4, |buf| {
            for (b, w) in buf.chunks_exact_mut(4).zip(words) {
                b.copy_from_slice(&w.to_le_bytes());
            }
            Ok(())
        })
        .expect("writing bytes cannot fail")
    }

    /// Writes the `.kdt` file (whole or not at all).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| flat::write_kdt(&path, self.owned.words()))
            .map_err(|e| value_error(e.to_string()))
    }

    /// Counts, bounds and sizes.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let scene = self.owned.scene();
        let d = PyDict::new(py);
        let [lo, hi] = scene.bounds();
        d.set_item("triangles", scene.tri_count())?;
        d.set_item("nodes", scene.node_count())?;
        d.set_item("depth", scene.depth())?;
        d.set_item("bounds", (lo.to_array(), hi.to_array()))?;
        d.set_item("bytes", self.owned.words().len() * 4)?;
        d.set_item(
            "layout",
            if scene.wide_nodes().is_empty() {
                "nodes"
            } else {
                "wide"
            },
        )?;
        d.set_item("leaves", if scene.has_groups() { "groups" } else { "list" })?;
        d.set_item("build_ms", scene.build_ms())?;
        Ok(d)
    }

    /// One ray's closest hit, `(t, prim, u, v)`, without arrays (and with the GIL: it is short).
    #[pyo3(signature = (origin, direction, tmin, tmax, watertight))]
    fn raycast(
        &self,
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
        watertight: bool,
    ) -> PyResult<(f32, i64, f32, f32)> {
        let batch = Batch {
            origins: &origin,
            directions: &direction,
            tmin: &[tmin],
            tmax: &[tmax],
            n: 1,
        };
        batch.check_values().map_err(value_error)?;
        Ok(closest::closest_one(
            self.owned.scene(),
            &batch,
            mode(watertight),
        ))
    }

    /// Closest hits: `(t, prim, u, v, points or None, normals or None)`.
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
        Option<Bound<'py, PyArray1<f32>>>,
        Option<Bound<'py, PyArray1<f32>>>,
    )> {
        let batch = rays.batch()?;
        let scene = self.owned.scene();
        // The arrays are one recycled block's (`block`: fresh pages each call cost this VM
        // 2-8 ms on a million rays), written in place by the threads, uninitialized until then:
        // zeroing them took a quarter of a call's time on the bunny's primary rays.
        let n = batch.n;
        let extra = |on: bool| if on { 3 * n } else { 0 };
        let layout = block::Layout::new([
            (n, 4),
            (n, 8),
            (n, 4),
            (n, 4),
            (extra(points), 4),
            (extra(normals), 4),
        ]);
        let mut memory = block::Block::new(layout)?;
        let [t, prim, u, v, p, nrm] = memory.split(layout);
        let out = closest::Answers {
            t: block::typed(t, n),
            prim: block::typed(prim, n),
            u: block::typed(u, n),
            v: block::typed(v, n),
            points: points.then(|| block::typed(p, 3 * n)),
            normals: normals.then(|| block::typed(nrm, 3 * n)),
        };
        // The rays are checked as they are traced; a refused one is reported as
        // `check_values` words it.
        let work = |cancel: &run::Cancel| -> Result<(), Stop> {
            if closest::intersect(scene, &batch, mode(watertight), out, cancel) {
                Ok(())
            } else {
                Err(Stop::Value(match batch.check_values() {
                    Err(e) => e,
                    Ok(()) => "a ray could not be traced: please report this batch".to_string(),
                }))
            }
        };
        if batch.n <= rays::CHUNK {
            py.detach(|| work(&run::Cancel::new(false)))?;
        } else {
            run::detached(py, threads, work)?;
        }
        let memory = Bound::new(py, memory)?;
        // SAFETY: the layout is the block's, and `closest::intersect` wrote every element.
        unsafe {
            Ok((
                block::Block::array(&memory, layout, 0, n),
                block::Block::array(&memory, layout, 1, n),
                block::Block::array(&memory, layout, 2, n),
                block::Block::array(&memory, layout, 3, n),
                points.then(|| block::Block::array(&memory, layout, 4, 3 * n)),
                normals.then(|| block::Block::array(&memory, layout, 5, 3 * n)),
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
        let scene = self.owned.scene();
        let out = traced(py, threads, &batch, rays::CHUNK, |cancel| {
            rays::occluded(scene, &batch, mode(watertight), cancel)
        })?;
        Ok(PyArray1::from_vec(py, out))
    }

    /// Exact crossings per ray.
    #[pyo3(signature = (rays, threads))]
    fn count<'py>(
        &self,
        py: Python<'py>,
        rays: RayArgs<'py>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let batch = rays.batch()?;
        let scene = self.owned.scene();
        let out = traced(py, threads, &batch, crossings::FEW, |cancel| {
            crossings::count(scene, &batch, cancel)
        })?;
        Ok(PyArray1::from_vec(py, out))
    }

    /// Every exact crossing: `(ray, t, prim)`, flattened.
    #[allow(clippy::type_complexity)]
    #[pyo3(signature = (rays, threads))]
    fn all<'py>(
        &self,
        py: Python<'py>,
        rays: RayArgs<'py>,
        threads: Option<usize>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f32>>,
        Bound<'py, PyArray1<i64>>,
    )> {
        let batch = rays.batch()?;
        let scene = self.owned.scene();
        let (ray, t, prim) = traced(py, threads, &batch, crossings::FEW, |cancel| {
            crossings::all(scene, &batch, cancel)
        })?;
        Ok((
            PyArray1::from_vec(py, ray),
            PyArray1::from_vec(py, t),
            PyArray1::from_vec(py, prim),
        ))
    }

    /// Whether each point lies inside (odd exact crossings along +x).
    #[pyo3(signature = (points, threads))]
    fn contains<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let p = slice(&points, "points")?;
        let scene = self.owned.scene();
        let out = run::detached(py, threads, |cancel| {
            if let Some(i) = p.iter().position(|x| !x.is_finite()) {
                return Err(Stop::Value(format!(
                    "points[{}] is {}: every coordinate must be finite",
                    i / 3,
                    mesh::row(&p[i / 3 * 3..i / 3 * 3 + 3])
                )));
            }
            crossings::contains(scene, p, cancel)
        })?;
        Ok(PyArray1::from_vec(py, out))
    }
}

/// The extension module.
#[pymodule]
fn _kdray(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Tree>()?;
    m.add_class::<instanced::Top>()?;
    m.add_function(wrap_pyfunction!(instanced::check_rays, m)?)?;
    m.add_function(wrap_pyfunction!(merged::merge, m)?)?;
    m.add_function(wrap_pyfunction!(merged::merged_ids, m)?)?;
    m.add_function(wrap_pyfunction!(pickle::words, m)?)?;
    m.add_function(wrap_pyfunction!(mapped::map_kdt, m)?)?;
    m.add("CONTAINS_DIRECTION", crossings::CONTAINS_DIRECTION)?;
    m.add("ISA", kdray_core::isa::name())?;
    m.add("MAX_THREADS", pool::max_threads())?;
    Ok(())
}
