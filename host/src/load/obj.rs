//! Wavefront OBJ meshes through `tobj`.
//!
//! `tobj` reports errors without a line, and accepts some input we must refuse (a NaN coordinate,
//! a face with one or two vertices, which it would turn into degenerate triangles). So the text is
//! first checked here line by line — numbers, index ranges, face sizes — and errors name the
//! line. What `tobj` then parses is a cleaned copy holding only the `v`, `vt`, `vn` and `f` lines
//! (positions already divided by their optional `w`; colours, objects, groups, materials, lines
//! and points dropped), so it sees one model whose faces are in file order and cannot stumble
//! over the parts of OBJ we do not use.
//!
//! Normals and texture coordinates are kept when every face vertex names one (`f v/vt/vn`).

use crate::error::{Error, Result};
use crate::geometry::Geometry;
use core::fmt::Write as _;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Checks and loads OBJ bytes; `path` names the file in errors.
pub(super) fn decode(path: &Path, bytes: &[u8]) -> Result<Geometry> {
    let text = core::str::from_utf8(bytes).map_err(|e| {
        let line = super::line_of_offset(bytes, e.valid_up_to());
        Error::at_line(path, line, "the file is not valid UTF-8 text")
    })?;
    let scan = prescan(text).map_err(|(line, msg)| Error::at_line(path, line, msg))?;
    if scan.faces == 0 {
        return Err(Error::new(path, "the mesh has no triangles (no `f` lines)"));
    }
    // `..Default::default()` covers the field tobj's optional `merging` feature adds.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut scan.clean.as_bytes(), &options, no_materials)
        .map_err(|e| Error::new(path, format!("invalid OBJ: {e}")))?;

    let internal = || Error::new(path, "invalid OBJ: tobj gave an index out of range");
    let mut g = Geometry::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut keep_normals = scan.all_normals;
    let mut keep_uvs = scan.all_uvs;
    for model in &models {
        let m = &model.mesh;
        keep_normals &= m.normal_indices.len() == m.indices.len();
        keep_uvs &= m.texcoord_indices.len() == m.indices.len();
        for k in 0..m.indices.len() / 3 {
            let corners = |indices: &[u32]| -> Option<[u32; 3]> {
                indices.get(3 * k..3 * k + 3)?.try_into().ok()
            };
            let tri = corners(&m.indices)
                .and_then(|c| gather(c, |i| item::<3>(&m.positions, i).map(Vec3::from)));
            g.triangles.push(tri.ok_or_else(internal)?);
            if keep_normals {
                let n = corners(&m.normal_indices)
                    .and_then(|c| gather(c, |i| item::<3>(&m.normals, i).map(Vec3::from)));
                normals.push(n.ok_or_else(internal)?);
            }
            if keep_uvs {
                let t = corners(&m.texcoord_indices)
                    .and_then(|c| gather(c, |i| item::<2>(&m.texcoords, i).map(Vec2::from)));
                uvs.push(t.ok_or_else(internal)?);
            }
        }
    }
    g.normals = keep_normals.then_some(normals);
    g.uvs = keep_uvs.then_some(uvs);
    Ok(g)
}

/// Item `i` of a flat array of `N`-float items.
fn item<const N: usize>(data: &[f32], i: u32) -> Option<[f32; N]> {
    data.get((i as usize).checked_mul(N)?..)?
        .first_chunk::<N>()
        .copied()
}

/// The three corners' values, if all exist.
fn gather<T>(c: [u32; 3], f: impl Fn(u32) -> Option<T>) -> Option<[T; 3]> {
    Some([f(c[0])?, f(c[1])?, f(c[2])?])
}

/// What the line-by-line check found.
#[derive(Debug, Default)]
struct Scan {
    /// The `v`/`vt`/`vn`/`f` lines, normalized, for `tobj`.
    clean: String,
    faces: usize,
    all_normals: bool,
    all_uvs: bool,
}

/// An error at a 1-based line.
type LineError = (usize, String);

/// Checks every line `tobj` would read; see the module doc.
fn prescan(text: &str) -> core::result::Result<Scan, LineError> {
    let mut scan = Scan {
        clean: String::with_capacity(text.len()),
        all_normals: true,
        all_uvs: true,
        ..Scan::default()
    };
    let (mut nv, mut nvt, mut nvn) = (0usize, 0usize, 0usize);
    for (i, line) in text.lines().enumerate() {
        let no = i + 1;
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let words: Vec<&str> = words.collect();
        match key {
            "v" => {
                let x = numbers(&words, no)?;
                let p = match x.len() {
                    3 | 6 => [x[0], x[1], x[2]],
                    4 if x[3] != 0.0 => [x[0] / x[3], x[1] / x[3], x[2] / x[3]],
                    4 => return Err((no, "vertex weight w is 0".into())),
                    n => {
                        let msg = format!(
                            "a vertex needs 3, 4 (with w) or 6 (with rgb) numbers, found {n}"
                        );
                        return Err((no, msg));
                    }
                };
                finite(&p, no)?;
                nv += 1;
                let _ = writeln!(scan.clean, "v {} {} {}", p[0], p[1], p[2]);
            }
            "vt" => {
                let x = numbers(&words, no)?;
                let (u, v) = match x.len() {
                    1 => (x[0], 0.0),
                    2 | 3 => (x[0], x[1]),
                    n => {
                        let msg = format!("a texture coordinate needs 1 to 3 numbers, found {n}");
                        return Err((no, msg));
                    }
                };
                finite(&[u, v], no)?;
                nvt += 1;
                let _ = writeln!(scan.clean, "vt {u} {v}");
            }
            "vn" => {
                let x = numbers(&words, no)?;
                if x.len() != 3 {
                    return Err((no, format!("a normal needs 3 numbers, found {}", x.len())));
                }
                finite(&x, no)?;
                nvn += 1;
                let _ = writeln!(scan.clean, "vn {} {} {}", x[0], x[1], x[2]);
            }
            "f" => {
                if words.len() < 3 {
                    let msg = format!("a face needs at least 3 vertices, found {}", words.len());
                    return Err((no, msg));
                }
                scan.clean.push_str("f ");
                for w in &words {
                    let mut parts = w.split('/');
                    let v = parts.next().unwrap_or("");
                    let vt = parts.next().unwrap_or("");
                    let vn = parts.next().unwrap_or("");
                    if parts.next().is_some() {
                        return Err((no, format!("bad face vertex `{w}`: more than v/vt/vn")));
                    }
                    let v = resolve(v, nv, "vertex", no)?
                        .ok_or_else(|| (no, format!("face vertex `{w}` has no position index")))?;
                    let vt = resolve(vt, nvt, "texture coordinate", no)?;
                    let vn = resolve(vn, nvn, "normal", no)?;
                    scan.all_uvs &= vt.is_some();
                    scan.all_normals &= vn.is_some();
                    let _ = write!(scan.clean, " {}/", v + 1);
                    for (k, x) in [vt, vn].into_iter().enumerate() {
                        if let Some(x) = x {
                            let _ = write!(scan.clean, "{}", x + 1);
                        }
                        scan.clean.push(if k == 0 { '/' } else { ' ' });
                    }
                }
                scan.clean.push('\n');
                scan.faces += 1;
            }
            _ => {}
        }
    }
    Ok(scan)
}

fn numbers(words: &[&str], line: usize) -> core::result::Result<Vec<f32>, LineError> {
    words
        .iter()
        .map(|w| {
            w.parse::<f32>()
                .map_err(|_| (line, format!("`{w}` is not a number")))
        })
        .collect()
}

fn finite(x: &[f32], line: usize) -> core::result::Result<(), LineError> {
    match x.iter().find(|v| !v.is_finite()) {
        Some(v) => Err((line, format!("coordinate {v} is not finite"))),
        None => Ok(()),
    }
}

/// A face's 1-based (or negative, relative) index into the `count` items read so far, as a
/// 0-based index; `None` for an empty field.
fn resolve(
    field: &str,
    count: usize,
    what: &str,
    line: usize,
) -> core::result::Result<Option<usize>, LineError> {
    if field.is_empty() {
        return Ok(None);
    }
    let i: i64 = field
        .parse()
        .map_err(|_| (line, format!("`{field}` is not a {what} index")))?;
    let resolved = match i {
        1.. => usize::try_from(i - 1).ok(),
        ..0 => usize::try_from(i.unsigned_abs())
            .ok()
            .and_then(|back| count.checked_sub(back)),
        0 => None,
    };
    match resolved {
        Some(r) if r < count => Ok(Some(r)),
        _ => Err((
            line,
            format!("{what} index {i} is out of range ({count} defined so far)"),
        )),
    }
}
