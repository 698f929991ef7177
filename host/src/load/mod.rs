//! Mesh loaders: PLY (ASCII or binary, optionally gzipped), Wavefront OBJ and the raw `.tri`
//! triangle soup (docs/FORMATS.md), each turned into a [`Geometry`] of triangles in input order.
//!
//! Every loader refuses, with an [`Error`] naming the file (and the line, for text formats where
//! it can be known), rather than panicking: unreadable or truncated files, indices out of range,
//! faces with fewer than three vertices, non-finite coordinates, and meshes without a single
//! triangle. Polygons with more than three vertices are fan-triangulated,
//! `(v0, v1, v2), (v0, v2, v3), …`, so a mesh's triangle order follows its face order.
//!
//! Per-vertex normals and texture coordinates are kept when the whole mesh has them and dropped
//! otherwise (the [`Geometry`] holds them for all triangles or for none).

mod obj;
mod ply;
mod tri;

pub use ply::{MAX_INFLATED, inflated_size};
pub use tri::{decode_tri, encode_tri};

use crate::error::{Error, Result};
use crate::geometry::Geometry;
use std::path::Path;

/// The mesh formats [`load_mesh`] understands, chosen by file name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// `.ply`
    Ply,
    /// `.ply.gz`: a gzip-compressed PLY file.
    PlyGz,
    /// `.obj`
    Obj,
    /// `.tri`: little-endian `u32 n`, then `n × 9 f32`.
    Tri,
}

impl MeshFormat {
    /// The format named by `path`'s extension (case-insensitive), if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        if name.ends_with(".ply.gz") {
            Some(Self::PlyGz)
        } else if name.ends_with(".ply") {
            Some(Self::Ply)
        } else if name.ends_with(".obj") {
            Some(Self::Obj)
        } else if name.ends_with(".tri") {
            Some(Self::Tri)
        } else {
            None
        }
    }
}

/// Loads the mesh at `path`, choosing the format by its extension: `.ply`, `.ply.gz`, `.obj` or
/// `.tri`. Materials are left empty (all 0) and there are no spheres.
///
/// # Errors
/// An unknown extension, an I/O failure, or any malformed content (see the module doc); the
/// error names `path` and, for ASCII PLY and OBJ, the line where that is known.
pub fn load_mesh(path: &Path) -> Result<Geometry> {
    let Some(format) = MeshFormat::from_path(path) else {
        return Err(Error::new(
            path,
            "unknown mesh format: expected a .ply, .ply.gz, .obj or .tri file",
        ));
    };
    decode_mesh(format, path, &crate::files::read(path)?)
}

/// Decodes the bytes of a mesh file in `format`; `path` only names it in errors. What
/// [`load_mesh`] does once it has read the file (the fuzz targets call it directly).
///
/// # Errors
/// As [`load_mesh`], except for I/O.
pub fn decode_mesh(format: MeshFormat, path: &Path, bytes: &[u8]) -> Result<Geometry> {
    let geometry = match format {
        MeshFormat::Ply => ply::decode(path, bytes, false)?,
        MeshFormat::PlyGz => ply::decode(path, bytes, true)?,
        MeshFormat::Obj => obj::decode(path, bytes)?,
        MeshFormat::Tri => tri::decode_tri(bytes)
            .map(|triangles| Geometry {
                triangles,
                ..Geometry::default()
            })
            .map_err(|msg| Error::new(path, msg))?,
    };
    check_geometry(path, &geometry)?;
    Ok(geometry)
}

/// The checks every loader's result must pass: at least one triangle, finite vertices, and
/// attribute lists as long as the triangle list. Loaders report a finer location first (the
/// vertex or its line); this is the net under all of them.
pub(crate) fn check_geometry(path: &Path, g: &Geometry) -> Result<()> {
    if g.triangles.is_empty() {
        return Err(Error::new(path, "the mesh has no triangles"));
    }
    check_buildable(path, g)
}

/// What the builder and the flat format need of any geometry, meshes and scenes alike, checked
/// before a build so that the error names the input (not the output it would have been written
/// to): finite vertices whose edges `v1 − v0`, `v2 − v0` are finite too (vertices ±3e38 apart
/// overflow f32) and whose cross product leaves the parallel threshold finite
/// (`Triangle::is_too_large`), triangles small enough for the scene's size
/// ([`crate::reach::check_scene`]), spheres whose box `c ± r` is finite, attribute lists as long
/// as the triangles.
///
/// # Errors
/// The first primitive that breaks a rule, by index.
pub fn check_buildable(path: &Path, g: &Geometry) -> Result<()> {
    if let Some(i) = g
        .triangles
        .iter()
        .position(|t| !t.iter().all(|v| v.is_finite()))
    {
        return Err(Error::new(
            path,
            format!("triangle {i} has a non-finite vertex"),
        ));
    }
    if let Some(i) = g
        .triangles
        .iter()
        .position(|t| !((t[1] - t[0]).is_finite() && (t[2] - t[0]).is_finite()))
    {
        let msg = format!("triangle {i}: its edges overflow f32 (vertices too far apart)");
        return Err(Error::new(path, msg));
    }
    if let Some(i) = g
        .triangles
        .iter()
        .position(|t| kdray_core::Triangle::from_vertices(t[0], t[1], t[2]).is_too_large())
    {
        let msg = format!(
            "triangle {i} is too large for f32 arithmetic: its edges' cross product reaches \
             7.7e25 (edges beyond about 8e12); scale the scene down"
        );
        return Err(Error::new(path, msg));
    }
    crate::reach::check_scene(path, g)?;
    if let Some(i) = g.spheres.iter().position(|&(c, r)| {
        !((c - glam::Vec3::splat(r)).is_finite() && (c + glam::Vec3::splat(r)).is_finite())
    }) {
        let msg = format!("sphere {i}: centre ± radius overflows f32");
        return Err(Error::new(path, msg));
    }
    let n = g.triangles.len();
    let same = |len: Option<usize>| len.is_none_or(|len| len == n);
    if !same(g.normals.as_ref().map(Vec::len)) || !same(g.uvs.as_ref().map(Vec::len)) {
        return Err(Error::new(
            path,
            "internal: attribute count differs from triangle count",
        ));
    }
    Ok(())
}

/// Fan-triangulates a polygon given as vertex indices: `(c0, c1, c2), (c0, c2, c3), …`.
pub(crate) fn fan(corners: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    let first = corners.first().copied().unwrap_or(0);
    corners.windows(2).skip(1).map(move |w| [first, w[0], w[1]])
}

/// The 1-based line of byte `offset` in `text` (offsets past the end give the last line). It
/// reads `text` up to `offset`: for one error; [`LineIndex`] for the lines of many offsets.
pub(crate) fn line_of_offset(text: &[u8], offset: usize) -> usize {
    let end = offset.min(text.len());
    scanned(end);
    1 + text[..end].iter().filter(|&&b| b == b'\n').count()
}

/// The lines of many offsets in one text, in time linear in the text: the newlines are found in
/// one pass, then each offset's line is a binary search. (Calling [`line_of_offset`] per entry
/// rescanned the text from its start each time: 40,000 `[[sphere]]` tables took 12 s to load.)
pub(crate) struct LineIndex {
    /// Byte offsets of the text's newlines, ascending.
    newlines: Vec<usize>,
}

impl LineIndex {
    pub(crate) fn new(text: &[u8]) -> Self {
        scanned(text.len());
        let newlines = (text.iter().enumerate())
            .filter_map(|(i, &b)| (b == b'\n').then_some(i))
            .collect();
        Self { newlines }
    }

    /// As [`line_of_offset`] gives it.
    pub(crate) fn line(&self, offset: usize) -> usize {
        1 + self.newlines.partition_point(|&nl| nl < offset)
    }
}

#[cfg(test)]
thread_local! {
    /// Bytes read by the line-number helpers on this thread, for tests that bound that work.
    pub(crate) static SCANNED: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// Counts `n` bytes read by a line-number helper (in tests only).
#[inline]
fn scanned(n: usize) {
    #[cfg(test)]
    SCANNED.with(|c| c.set(c.get() + n));
    #[cfg(not(test))]
    let _ = n;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        let f = |s: &str| MeshFormat::from_path(Path::new(s));
        assert_eq!(f("a/b.PLY"), Some(MeshFormat::Ply));
        assert_eq!(f("b.ply.gz"), Some(MeshFormat::PlyGz));
        assert_eq!(f("b.obj"), Some(MeshFormat::Obj));
        assert_eq!(f("b.tri"), Some(MeshFormat::Tri));
        assert_eq!(f("b.gz"), None);
        assert_eq!(f("b.stl"), None);
        assert_eq!(f(""), None);
    }

    #[test]
    fn unknown_extension_is_an_error_naming_the_file() {
        let err = load_mesh(Path::new("some/mesh.stl")).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("mesh.stl") && text.contains("unknown mesh format"),
            "{text}"
        );
    }

    #[test]
    fn fan_order() {
        let tris: Vec<_> = fan(&[4, 5, 6, 7, 8]).collect();
        assert_eq!(tris, vec![[4, 5, 6], [4, 6, 7], [4, 7, 8]]);
        assert_eq!(fan(&[1, 2, 3]).collect::<Vec<_>>(), vec![[1, 2, 3]]);
        assert_eq!(fan(&[1, 2]).count(), 0);
        assert_eq!(fan(&[]).count(), 0);
    }

    #[test]
    fn lines_of_offsets() {
        let t = b"a\nbc\n\nd";
        assert_eq!(line_of_offset(t, 0), 1);
        assert_eq!(line_of_offset(t, 2), 2);
        assert_eq!(line_of_offset(t, 5), 3);
        assert_eq!(line_of_offset(t, 6), 4);
        assert_eq!(line_of_offset(t, 100), 4);
        let index = LineIndex::new(t);
        for offset in 0..=t.len() + 2 {
            assert_eq!(
                index.line(offset),
                line_of_offset(t, offset),
                "offset {offset}"
            );
        }
    }
}
