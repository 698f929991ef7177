//! A JavaScript user's mesh — positions and optional indices, as three.js's `BufferGeometry`
//! holds them — checked and turned into the host library's [`Geometry`], then built and
//! serialized by the same code as `kdray build` (`kdray::build`, `kdray::flat`).
//!
//! Every refusal is a sentence naming the array and the element, for the package's `Error`.

use glam::Vec3;
use kdray::Geometry;
use kdray::build::{self, BuildParams, Quality};
use kdray::flat::{self, Layout, Leaves};

/// The most triangles a mesh may have: the flat format's node fields hold 2³⁰ primitives, and a
/// 32-bit module's memory (4 GiB) would run out long before.
const MAX_TRIANGLES: usize = 1 << 26;

/// The triangles of `positions` (3 floats a vertex) and `indices` (3 a triangle; `None`: every
/// 9 floats of `positions` are one triangle), in input order.
///
/// # Errors
/// A length that is not a multiple of 3 (or 9), a non-finite coordinate, an index past the last
/// vertex, or more than `MAX_TRIANGLES` (2²⁶) triangles.
pub fn triangles(positions: &[f32], indices: Option<&[u32]>) -> Result<Vec<[Vec3; 3]>, String> {
    if !positions.len().is_multiple_of(3) {
        return Err(format!(
            "positions has {} floats, not a multiple of 3 (x, y, z a vertex)",
            positions.len()
        ));
    }
    if let Some(i) = positions.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "positions[{i}] is {} (vertex {}): every coordinate must be finite",
            js_number(positions[i]),
            i / 3
        ));
    }
    let vertex = |i: usize| Vec3::from_slice(&positions[3 * i..3 * i + 3]);
    let vertices = positions.len() / 3;
    let tris: Vec<[Vec3; 3]> = match indices {
        None => {
            if !vertices.is_multiple_of(3) {
                return Err(format!(
                    "positions holds {vertices} vertices, not a multiple of 3: without indices, \
                     every 3 vertices (9 floats) are one triangle"
                ));
            }
            check_count(vertices / 3)?;
            (0..vertices / 3)
                .map(|t| [vertex(3 * t), vertex(3 * t + 1), vertex(3 * t + 2)])
                .collect()
        }
        Some(idx) => {
            if !idx.len().is_multiple_of(3) {
                return Err(format!(
                    "indices has {} entries, not a multiple of 3 (3 a triangle)",
                    idx.len()
                ));
            }
            if let Some(i) = idx.iter().position(|&v| v as usize >= vertices) {
                return Err(format!(
                    "indices[{i}] is {}, but positions holds only {vertices} vertices",
                    idx[i]
                ));
            }
            check_count(idx.len() / 3)?;
            idx.chunks_exact(3)
                .map(|t| {
                    [
                        vertex(t[0] as usize),
                        vertex(t[1] as usize),
                        vertex(t[2] as usize),
                    ]
                })
                .collect()
        }
    };
    // Finite vertices can still be too far apart for f32 edges (the flat format stores what
    // the kernels subtract).
    if let Some(i) = tris
        .iter()
        .position(|t| !((t[1] - t[0]).is_finite() && (t[2] - t[0]).is_finite()))
    {
        return Err(format!(
            "triangle {i}: its edges overflow f32 (vertices too far apart)"
        ));
    }
    Ok(tris)
}

fn check_count(n: usize) -> Result<(), String> {
    if n > MAX_TRIANGLES {
        Err(format!(
            "{n} triangles: more than this module builds ({MAX_TRIANGLES})"
        ))
    } else {
        Ok(())
    }
}

/// How JavaScript spells a non-finite number.
fn js_number(x: f32) -> &'static str {
    if x.is_nan() {
        "NaN"
    } else if x > 0.0 {
        "Infinity"
    } else {
        "-Infinity"
    }
}

/// Builds the SAH kd-tree over `tris` on this thread at `quality`, serializes it in `layout` and
/// validates the words as any loaded scene is.
///
/// # Errors
/// What the builder or serializer refuses (a tree too large for the format).
pub fn build_words(
    tris: Vec<[Vec3; 3]>,
    layout: Layout,
    leaves: Leaves,
    quality: Quality,
) -> Result<Vec<u32>, String> {
    let geom = Geometry {
        triangles: tris,
        ..Geometry::default()
    };
    // Priced in groups of four whatever the leaves: the single-ray walks test a listed leaf's
    // triangles four at a time too.
    let params = BuildParams {
        parallel: false,
        ..BuildParams::grouped()
    }
    .with_quality(quality);
    let tree = build::build(&geom, &params, None)?;
    // The build time field of the header: not measured here (wasm32 has no clock in std).
    // Opened by the caller with `Scene::from_built_words`: the tests validate every tree the
    // builder makes, so the package does not again (it was 19 % of a torus knot's build).
    flat::serialize_as(&tree, &geom, 0.0, layout, leaves)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_name_the_element() {
        let e = triangles(&[0.0, 1.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0], None).unwrap_err();
        assert!(e.contains("positions[2] is NaN (vertex 0)"), "{e}");
        let e = triangles(&[0.0; 9], Some(&[0, 1, 3])).unwrap_err();
        assert!(
            e.contains("indices[2] is 3") && e.contains("only 3 vertices"),
            "{e}"
        );
        let e = triangles(&[0.0; 8], None).unwrap_err();
        assert!(e.contains("8 floats"), "{e}");
        let e = triangles(&[0.0; 12], None).unwrap_err();
        assert!(e.contains("4 vertices"), "{e}");
        let e = triangles(&[0.0; 9], Some(&[0, 1])).unwrap_err();
        assert!(e.contains("indices has 2 entries"), "{e}");
        let big = [-3e38, 0.0, 0.0, 3e38, 0.0, 0.0, 0.0, 1.0, 0.0];
        let e = triangles(&big, None).unwrap_err();
        assert!(e.contains("overflow"), "{e}");
    }

    #[test]
    fn indexed_and_flat_give_the_same_triangles() {
        let pos = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
        let idx = [0, 1, 2, 2, 1, 3];
        let a = triangles(&pos, Some(&idx)).unwrap();
        let flat: Vec<f32> = idx
            .iter()
            .flat_map(|&i| pos[3 * i as usize..3 * i as usize + 3].to_vec())
            .collect();
        assert_eq!(a, triangles(&flat, None).unwrap());
        assert_eq!(a[1][2], Vec3::new(1.0, 1.0, 0.0));
    }
}
