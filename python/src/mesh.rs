//! A Python user's mesh — an `(N, 3)` vertex array and an optional `(M, 3)` face array, as
//! trimesh and Open3D hold them — checked and turned into the triangles the host library's
//! builder takes (`owned::build`).
//!
//! Every refusal is a sentence naming the argument and the element, for the package's
//! `ValueError`.

use glam::Vec3;

/// The most triangles a mesh may have: the flat format's node fields hold 2³⁰ primitives.
const MAX_TRIANGLES: usize = 1 << 30;

/// The triangles of `vertices` (3 floats a vertex, row-major `(N, 3)`) and `faces` (3 vertex
/// indices a triangle; `None`: every 3 vertices are one triangle), in input order.
///
/// # Errors
/// A non-finite coordinate, a face index out of range, a vertex count that is not a multiple of
/// 3 without faces, more than [`MAX_TRIANGLES`] triangles, or a triangle whose edges overflow f32.
pub fn triangles(vertices: &[f32], faces: Option<&[i64]>) -> Result<Vec<[Vec3; 3]>, String> {
    if let Some(i) = vertices.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "vertices[{}, {}] is {} (in float32): every coordinate must be finite",
            i / 3,
            i % 3,
            number(vertices[i])
        ));
    }
    let n = vertices.len() / 3;
    let vertex = |i: usize| Vec3::from_slice(&vertices[3 * i..3 * i + 3]);
    let tris: Vec<[Vec3; 3]> = match faces {
        None => {
            if !n.is_multiple_of(3) {
                return Err(format!(
                    "vertices holds {n} vertices, not a multiple of 3: without faces, every 3 \
                     vertices are one triangle"
                ));
            }
            check_count(n / 3)?;
            (0..n / 3)
                .map(|t| [vertex(3 * t), vertex(3 * t + 1), vertex(3 * t + 2)])
                .collect()
        }
        Some(faces) => {
            if let Some(i) = faces.iter().position(|&f| f < 0 || f as u64 >= n as u64) {
                return Err(format!(
                    "faces[{}, {}] is {}, but vertices holds {n} vertices (indices 0 to {})",
                    i / 3,
                    i % 3,
                    faces[i],
                    n as i64 - 1
                ));
            }
            check_count(faces.len() / 3)?;
            faces
                .chunks_exact(3)
                .map(|f| {
                    [
                        vertex(f[0] as usize),
                        vertex(f[1] as usize),
                        vertex(f[2] as usize),
                    ]
                })
                .collect()
        }
    };
    // Finite vertices can still be too far apart for f32 edges (the kernels subtract them).
    if let Some(i) = tris
        .iter()
        .position(|t| !((t[1] - t[0]).is_finite() && (t[2] - t[0]).is_finite()))
    {
        return Err(format!(
            "triangle {i}: its edges overflow float32 (vertices too far apart)"
        ));
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
