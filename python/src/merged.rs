//! `kdray.Instances(..., merge=True)`: one tree over every mesh's triangles where every mesh is
//! placed once by the identity ([`merge`]), and its answers named as the two-level walk names
//! them ([`merged_ids`]: a merged triangle's mesh, and its index in that mesh).

use crate::Tree;
use crate::stop::{self, Stop};
use crate::value_error;
use kdray_core::Scene;
use numpy::{PyArray1, PyReadonlyArray1, PyReadwriteArray1};
use pyo3::prelude::*;

/// One tree over the triangles of `trees`, in order (each tree's in its input order, as stored:
/// the same f32 vertices), built with `layout`, `leaves`, `quality`: `kdray.Instances(...,
/// merge=True)` where every mesh is placed once by the identity, whose answers are then those
/// of the two-level walk, bit for bit, from one walk instead of one per mesh.
#[pyfunction]
#[pyo3(signature = (trees, layout, leaves, quality, threads))]
pub(crate) fn merge(
    py: Python<'_>,
    trees: Vec<Py<Tree>>,
    layout: &str,
    leaves: &str,
    quality: &str,
    threads: Option<usize>,
) -> PyResult<Tree> {
    let options = crate::options(layout, leaves, quality, threads)?;
    let scenes: Vec<&Scene> = trees.iter().map(|t| t.get().owned.scene()).collect();
    let owned = py.detach(|| {
        crate::pool::on_pool(threads, || -> Result<crate::owned::Owned, Stop> {
            let total: usize = scenes.iter().map(|s| s.tri_count() as usize).sum();
            crate::owned::probe_build(total)?;
            let mut tris = Vec::new();
            stop::reserve(&mut tris, total, "the merged triangles")?;
            for s in &scenes {
                let from = tris.len();
                tris.resize(from + s.tri_count() as usize, [glam::Vec3::ZERO; 3]);
                for i in 0..s.tri_count() {
                    tris[from + s.input_id(i) as usize] = s.vertices(i);
                }
            }
            Ok(crate::owned::build(tris, options)?)
        })?
    })?;
    Ok(Tree { owned })
}

/// An array of ids for Python.
type Ids<'py> = Bound<'py, PyArray1<i64>>;

/// A merged tree's answers as the two-level walk gives them: `prim` (the merged tree's
/// triangles, −1 for a miss) rewritten in place to each triangle's index in its mesh, and
/// `(geometry, instance)` returned: `ids[k]` and 0 for a triangle of mesh `k` (whose triangles
/// are `first[k]..first[k + 1]`, `first` ascending from 0), −1 and −1 for a miss. One pass
/// without the GIL, instead of numpy's search and three `where`s over the whole batch (a tenth
/// of a million random rays' time on 100 meshes).
#[pyfunction]
pub(crate) fn merged_ids<'py>(
    py: Python<'py>,
    mut prim: PyReadwriteArray1<'py, i64>,
    first: PyReadonlyArray1<'py, i64>,
    ids: PyReadonlyArray1<'py, i64>,
) -> PyResult<(Ids<'py>, Ids<'py>)> {
    let (first, ids) = (crate::slice(&first, "first")?, crate::slice(&ids, "ids")?);
    if first.len() != ids.len() + 1 || first.first() != Some(&0) || !first.is_sorted() {
        return Err(value_error(
            "first must ascend from 0 with one more entry than ids",
        ));
    }
    let prim = prim
        .as_slice_mut()
        .map_err(|_| value_error("prim is not C-contiguous and aligned"))?;
    let total = *first.last().unwrap_or(&0);
    let n = prim.len();
    let (geometry, instance) = py.detach(|| -> Result<_, Stop> {
        let what = "the merged answers' ids";
        let (mut geometry, mut instance) = (Vec::new(), Vec::new());
        stop::reserve(&mut geometry, n, what)?;
        stop::reserve(&mut instance, n, what)?;
        for p in prim.iter_mut() {
            if (0..total).contains(p) {
                // The mesh whose range holds `p`: the last `first[k] <= p` (k < ids.len()
                // since p < total).
                let k = first.partition_point(|&f| f <= *p) - 1;
                *p -= first[k];
                geometry.push(ids[k]);
                instance.push(0);
            } else {
                *p = -1;
                geometry.push(-1);
                instance.push(-1);
            }
        }
        Ok((geometry, instance))
    })?;
    Ok((
        PyArray1::from_vec(py, geometry),
        PyArray1::from_vec(py, instance),
    ))
}
