//! A Python user's mesh — an `(N, 3)` vertex array and an optional `(M, 3)` face array, as
//! trimesh and Open3D hold them — checked and turned into the triangles the host library's
//! builder takes (`owned::build`).
//!
//! Every refusal is a sentence naming the argument and the element, for the package's
//! `ValueError`.
//!
//! The arrays are copied before they are read: the GIL is released during a build, so another
//! Python thread may write them meanwhile (numpy arrays are mutable), and a face index checked
//! and then read again could have changed in between (it panicked, `PanicException`). A copy
//! made while they are written may hold a mix of old and new values, but it is checked as it is
//! built from, so it is refused or built, never half-checked.

use crate::stop::{self, Stop};
use glam::Vec3;

/// The most triangles a mesh may have: the flat format's node fields hold 2³⁰ primitives.
const MAX_TRIANGLES: usize = 1 << 30;

/// The triangles of `vertices` (3 floats a vertex, row-major `(N, 3)`) and `faces` (3 vertex
/// indices a triangle; `None`: every 3 vertices are one triangle), in input order.
///
/// # Errors
/// A non-finite coordinate, a face index out of range, a vertex count that is not a multiple of
/// 3 without faces, more than [`MAX_TRIANGLES`] triangles, or a triangle whose edges overflow f32
/// ([`Stop::Value`]); no memory for the copies or the triangles ([`Stop::Memory`]).
pub fn triangles(vertices: &[f32], faces: Option<&[i64]>) -> Result<Vec<[Vec3; 3]>, Stop> {
    let vertices = copy(vertices, "a copy of the vertices")?;
    let faces = faces.map(|f| copy(f, "a copy of the faces")).transpose()?;
    let count = faces.as_ref().map_or(vertices.len() / 9, |f| f.len() / 3);
    let mut tris = Vec::new();
    stop::reserve(
        &mut tris,
        count.min(MAX_TRIANGLES + 1),
        "the mesh's triangles",
    )?;
    checked(&vertices, faces.as_deref(), tris)
}

/// `src` copied, or [`Stop::Memory`] naming `what`.
fn copy<T: Copy>(src: &[T], what: &str) -> Result<Vec<T>, Stop> {
    let mut v = Vec::new();
    stop::reserve(&mut v, src.len(), what)?;
    v.extend_from_slice(src);
    Ok(v)
}

/// [`triangles`] of arrays that nothing else writes, into `tris` (room reserved).
fn checked(
    vertices: &[f32],
    faces: Option<&[i64]>,
    mut tris: Vec<[Vec3; 3]>,
) -> Result<Vec<[Vec3; 3]>, Stop> {
    if let Some(i) = vertices.iter().position(|x| !x.is_finite()) {
        return Err(Stop::Value(format!(
            "vertices[{}, {}] is {} (in float32): every coordinate must be finite",
            i / 3,
            i % 3,
            number(vertices[i])
        )));
    }
    let n = vertices.len() / 3;
    let vertex = |i: usize| Vec3::from_slice(&vertices[3 * i..3 * i + 3]);
    match faces {
        None => {
            if !n.is_multiple_of(3) {
                return Err(Stop::Value(format!(
                    "vertices holds {n} vertices, not a multiple of 3: without faces, every 3 \
                     vertices are one triangle"
                )));
            }
            check_count(n / 3)?;
            tris.extend((0..n / 3).map(|t| [vertex(3 * t), vertex(3 * t + 1), vertex(3 * t + 2)]));
        }
        Some(faces) => {
            if let Some(i) = faces.iter().position(|&f| f < 0 || f as u64 >= n as u64) {
                return Err(Stop::Value(format!(
                    "faces[{}, {}] is {}, but vertices holds {n} vertices (indices 0 to {})",
                    i / 3,
                    i % 3,
                    faces[i],
                    n as i64 - 1
                )));
            }
            check_count(faces.len() / 3)?;
            tris.extend(faces.chunks_exact(3).map(|f| {
                [
                    vertex(f[0] as usize),
                    vertex(f[1] as usize),
                    vertex(f[2] as usize),
                ]
            }));
        }
    }
    // Finite vertices can still be too far apart for f32 edges (the kernels subtract them).
    if let Some(i) = tris
        .iter()
        .position(|t| !((t[1] - t[0]).is_finite() && (t[2] - t[0]).is_finite()))
    {
        return Err(Stop::Value(format!(
            "triangle {i}: its edges overflow float32 (vertices too far apart)"
        )));
    }
    Ok(tris)
}

/// A float as Python prints it: `nan`, `inf`, `-inf`, `0.5`.
pub fn number(x: f32) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{x}")
    }
}

/// A row of floats as Python prints a tuple of them: `(nan, 0, 1.5)`.
pub fn row(xs: &[f32]) -> String {
    let parts: Vec<String> = xs.iter().map(|&x| number(x)).collect();
    format!("({})", parts.join(", "))
}

fn check_count(n: usize) -> Result<(), String> {
    if n > MAX_TRIANGLES {
        Err(format!(
            "{n} triangles: more than a kd-tree file holds ({MAX_TRIANGLES})"
        ))
    } else {
        Ok(())
    }
}
