//! PLY meshes through `ply-rs-bw`: ASCII, binary little- and big-endian, optionally gzipped.
//!
//! Read from the `vertex` element: `x y z` (any scalar type, usually float or double), optional
//! normals `nx ny nz` and texture coordinates (`u v`, `s t` or `texture_u texture_v`). From the
//! `face` element: `vertex_indices` or `vertex_index`, a list of any integer type. Other elements
//! and properties are read past and ignored.
//!
//! Line numbers: the parser reports the line of its own errors; for ours (a bad index, a NaN) in
//! an ASCII file the line of element `i` is computed from the header's length and the counts of
//! the elements before it, since the ASCII payload holds one element per line. Binary files are
//! located by element index instead ("vertex 12", "face 3").

use super::fan;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use flate2::read::MultiGzDecoder;
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult,
    PropertyType, ScalarType,
};
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Slots of [`Elem::attrs`].
const X: usize = 0;
const NX: usize = 3;
const U: usize = 6;
const V: usize = 7;

/// The vertex property names we read, by slot.
fn slot(name: &str) -> Option<usize> {
    Some(match name {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "u" | "s" | "texture_u" | "texture_s" => U,
        "v" | "t" | "texture_v" | "texture_t" => V,
        _ => return None,
    })
}

fn is_index_list(name: &str) -> bool {
    matches!(name, "vertex_indices" | "vertex_index")
}

/// One parsed element of any kind: the vertex attributes we know, and a face's index list kept in
/// the type the file declared (the common `int` and `uint` lists are filled in place).
#[derive(Default)]
struct Elem {
    attrs: [f32; 8],
    indices: Indices,
}

#[derive(Default)]
enum Indices {
    #[default]
    None,
    I32(Vec<i32>),
    U32(Vec<u32>),
    Other(Vec<i64>),
}

impl Indices {
    fn len(&self) -> usize {
        match self {
            Self::None => 0,
            Self::I32(v) => v.len(),
            Self::U32(v) => v.len(),
            Self::Other(v) => v.len(),
        }
    }

    fn get(&self, i: usize) -> i64 {
        match self {
            Self::None => -1,
            Self::I32(v) => i64::from(v[i]),
            Self::U32(v) => i64::from(v[i]),
            Self::Other(v) => v[i],
        }
    }
}

impl PropertyAccess for Elem {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let scalar = match property {
            Property::Char(x) => f64::from(x),
            Property::UChar(x) => f64::from(x),
            Property::Short(x) => f64::from(x),
            Property::UShort(x) => f64::from(x),
            Property::Int(x) => f64::from(x),
            Property::UInt(x) => f64::from(x),
            Property::Float(x) => f64::from(x),
            Property::Double(x) => x,
            list if is_index_list(name) => {
                let wide: Vec<i64> = match list {
                    Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
                    Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
                    Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
                    Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
                    Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
                    Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
                    // Refused in `check_header` before the payload is read.
                    _ => return PropertyAccessResult::UnsupportedType,
                };
                self.indices = Indices::Other(wide);
                return PropertyAccessResult::Set;
            }
            _ => return PropertyAccessResult::Ignored,
        };
        match slot(name) {
            Some(s) => {
                // A double beyond f32's range becomes ±inf and is refused as non-finite.
                self.attrs[s] = scalar as f32;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }

    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        match slot(name) {
            Some(s) => {
                self.attrs[s] = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }

    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if !is_index_list(name) {
            return BeginList::UseSetter;
        }
        self.indices = Indices::I32(Vec::new());
        match &mut self.indices {
            Indices::I32(v) => BeginList::Fill(v),
            _ => BeginList::UseSetter,
        }
    }

    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if !is_index_list(name) {
            return BeginList::UseSetter;
        }
        self.indices = Indices::U32(Vec::new());
        match &mut self.indices {
            Indices::U32(v) => BeginList::Fill(v),
            _ => BeginList::UseSetter,
        }
    }
}

/// What the header says the file holds.
struct Layout {
    ascii: bool,
    /// Line of the first payload line (ASCII).
    first_data_line: usize,
    /// Payload line offset of the `vertex` and `face` elements.
    vertex_offset: usize,
    face_offset: usize,
    normals: bool,
    uvs: bool,
}

/// Loads the PLY file at `path`, gunzipping it first when `gz`.
pub(super) fn load(path: &Path, gz: bool) -> Result<Geometry> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    if gz {
        parse(path, BufReader::new(MultiGzDecoder::new(file)))
    } else {
        parse(path, BufReader::new(file))
    }
}

fn parse<R: BufRead>(path: &Path, source: R) -> Result<Geometry> {
    let parser = Parser::<Elem>::new();
    let mut reader = Reader::new(source);
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| parse_error(path, &e, true))?;
    let layout = check_header(path, &header, reader.line())?;
    let mut payload = parser
        .read_payload(&mut reader, &header)
        .map_err(|e| parse_error(path, &e, layout.ascii))?;
    let vertices = payload.swap_remove("vertex").unwrap_or_default();
    let faces = payload.swap_remove("face").unwrap_or_default();
    drop(payload);
    let at = |offset: usize, i: usize, msg: String| match layout.ascii {
        true => Error::at_line(path, layout.first_data_line + offset + i, msg),
        false => Error::new(path, msg),
    };

    let mut used = vec![0, 1, 2];
    if layout.normals {
        used.extend(NX..NX + 3);
    }
    if layout.uvs {
        used.extend([U, V]);
    }
    for (i, v) in vertices.iter().enumerate() {
        if let Some(&s) = used.iter().find(|&&s| !v.attrs[s].is_finite()) {
            let what = ["x", "y", "z", "nx", "ny", "nz", "u", "v"][s];
            let msg = format!("vertex {i}: {what} = {} is not finite", v.attrs[s]);
            return Err(at(layout.vertex_offset, i, msg));
        }
    }

    let mut g = Geometry::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut corners = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let n = face.indices.len();
        if n < 3 {
            let msg = format!("face {f} has {n} vertices; a face needs at least 3");
            return Err(at(layout.face_offset, f, msg));
        }
        corners.clear();
        for k in 0..n {
            let idx = face.indices.get(k);
            match u32::try_from(idx) {
                Ok(i) if (i as usize) < vertices.len() => corners.push(i),
                _ => {
                    let msg = format!(
                        "face {f}: vertex index {idx} is out of range (the file has {} vertices)",
                        vertices.len()
                    );
                    return Err(at(layout.face_offset, f, msg));
                }
            }
        }
        for tri in fan(&corners) {
            let vs = tri.map(|i| &vertices[i as usize].attrs);
            g.triangles
                .push(vs.map(|a| Vec3::new(a[X], a[X + 1], a[X + 2])));
            if layout.normals {
                normals.push(vs.map(|a| Vec3::new(a[NX], a[NX + 1], a[NX + 2])));
            }
            if layout.uvs {
                uvs.push(vs.map(|a| Vec2::new(a[U], a[V])));
            }
        }
    }
    if g.triangles.is_empty() {
        return Err(Error::new(path, "the mesh has no triangles (no faces)"));
    }
    g.normals = layout.normals.then_some(normals);
    g.uvs = layout.uvs.then_some(uvs);
    Ok(g)
}

/// Refuses headers without the properties we need, before any payload is read.
fn check_header(path: &Path, header: &Header, line_after_header: usize) -> Result<Layout> {
    let mut offsets = (None, None);
    let mut offset = 0usize;
    for (name, el) in &header.elements {
        match name.as_str() {
            "vertex" => offsets.0 = Some(offset),
            "face" => offsets.1 = Some(offset),
            _ => {}
        }
        offset = offset.saturating_add(el.count);
    }
    let (Some(vertex_offset), Some(face_offset)) = offsets else {
        return Err(Error::new(
            path,
            "the header must declare a `vertex` and a `face` element",
        ));
    };
    let vertex = &header.elements["vertex"];
    let face = &header.elements["face"];
    for p in ["x", "y", "z"] {
        if !has_scalar(vertex, &[p]) {
            let msg = format!("the vertex element has no scalar property `{p}`");
            return Err(Error::new(path, msg));
        }
    }
    let index_type = face
        .properties
        .values()
        .find(|p| is_index_list(&p.name))
        .map(|p| &p.data_type);
    match index_type {
        Some(PropertyType::List(_, t)) if !matches!(t, ScalarType::Float | ScalarType::Double) => {}
        Some(_) => {
            let msg = "the face's vertex_indices must be a list of an integer type";
            return Err(Error::new(path, msg));
        }
        None => {
            let msg = "the face element has no `vertex_indices` or `vertex_index` list";
            return Err(Error::new(path, msg));
        }
    }
    Ok(Layout {
        ascii: header.encoding == Encoding::Ascii,
        first_data_line: line_after_header,
        vertex_offset,
        face_offset,
        normals: ["nx", "ny", "nz"].iter().all(|p| has_scalar(vertex, &[p])),
        uvs: has_scalar(vertex, &["u", "s", "texture_u", "texture_s"])
            && has_scalar(vertex, &["v", "t", "texture_v", "texture_t"]),
    })
}

fn has_scalar(el: &ElementDef, names: &[&str]) -> bool {
    names
        .iter()
        .any(|n| matches!(el.properties.get(*n), Some(p) if matches!(p.data_type, PropertyType::Scalar(_))))
}

/// The parser's error as ours: its line where the file is text at that point, and its message
/// on one line, without repeats or the grammar's internal state, of bounded length (it quotes the
/// offending input line).
fn parse_error(path: &Path, e: &ParseError, text: bool) -> Error {
    let full = e.to_string();
    let body = match e.line() {
        Some(line) => full
            .strip_prefix(&format!("Line {line}: "))
            .unwrap_or(&full),
        None => &full,
    };
    let mut parts: Vec<String> = Vec::new();
    for part in body.split("\n\t") {
        let part = part.replace(['\r', '\n'], "");
        if !part.starts_with("Error: ParseError {") && !parts.contains(&part) {
            parts.push(part);
        }
    }
    let mut msg = format!("invalid PLY: {}", parts.join("; "));
    if let Some((cut, _)) = msg.char_indices().nth(240) {
        msg.truncate(cut);
        msg.push('…');
    }
    match e.line() {
        Some(line) if text => Error::at_line(path, line, msg),
        _ => Error::new(path, msg),
    }
}
