//! PLY meshes through `ply-rs-bw`: ASCII, binary little- and big-endian, optionally gzipped.
//!
//! Read from the `vertex` element: `x y z` (any scalar type, usually float or double), optional
//! normals `nx ny nz` and texture coordinates (`u v`, `s t` or `texture_u texture_v`). From the
//! `face` element: `vertex_indices` or `vertex_index`, a list of any integer type. Other elements
//! and properties are read past and ignored (into a zero-sized record: they cost no memory).
//!
//! Strict where the parser is lenient, with the file and the line: the version must be `1.0`, an
//! element or property may not be declared twice, an element with items must have properties, the
//! payload must end exactly where the header's counts say (nothing but whitespace after an ASCII
//! payload, nothing after a binary one: an undercounted element shows up here), an ASCII face's
//! list count must fit its declared count type, and a `.ply.gz` must inflate whole — CRC and
//! length trailer checked — to at most [`MAX_INFLATED`] bytes.
//!
//! Memory: before any payload is read, each element's count is checked against the bytes left
//! after the header, at the fewest bytes one item can take (a face counted with its three
//! indices, since fewer are refused), so a header claiming billions of items allocates nothing for
//! them, and what is kept (64 bytes a vertex, 64 bytes plus its indices a face, nothing for
//! other elements) stays within about 11 times the payload.
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
use std::io::Read;
use std::path::Path;

/// The most bytes a `.ply.gz` may inflate to (512 MiB: a binary PLY of about 20 million
/// triangles). Past it the file is refused, whatever its header says.
pub const MAX_INFLATED: usize = 512 << 20;

/// The longest header read (1 MiB).
const MAX_HEADER: usize = 1 << 20;

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

/// Any element other than `vertex` and `face`: read past, nothing kept.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Self
    }

    fn set_property(&mut self, _: &str, _: Property) -> PropertyAccessResult {
        PropertyAccessResult::Ignored
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
    /// The largest list count the face index list's count type holds.
    max_face_len: u64,
}

/// Refuses an ASCII payload line holding more values than its element's properties take (e.g.
/// `3 0 1 2 3`: a face of count 3 with four indices), which the parser reads past: the extra
/// values are most likely a miscounted list, and the mesh would silently lose them. Each element
/// is one line (the parser has read them all already, so every count parses); lines are counted
/// from `first_line`, the payload's first.
fn check_ascii_values(path: &Path, data: &[u8], header: &Header, first_line: usize) -> Result<()> {
    let mut lines = data
        .split(|&b| b == b'\n')
        .skip(first_line - 1)
        .zip(first_line..);
    for (name, el) in &header.elements {
        for item in 0..el.count {
            let Some((line, number)) = lines.next() else {
                return Ok(());
            };
            let text = String::from_utf8_lossy(line);
            let mut tokens = text.split_ascii_whitespace();
            for prop in el.properties.values() {
                let count = match prop.data_type {
                    PropertyType::Scalar(_) => 0,
                    PropertyType::List(..) => tokens
                        .next()
                        .and_then(|t| t.parse::<usize>().ok())
                        .unwrap_or(0),
                };
                let take = if matches!(prop.data_type, PropertyType::Scalar(_)) {
                    1
                } else {
                    count
                };
                if tokens.by_ref().take(take).count() < take {
                    return Ok(()); // the parser refuses short lines itself
                }
            }
            let extra = tokens.count();
            if extra > 0 {
                let msg = format!(
                    "{name} {item}: {extra} more value(s) than its properties take (a list count too small?)"
                );
                return Err(Error::at_line(path, number, msg));
            }
        }
    }
    Ok(())
}

/// Decodes PLY bytes (gzip-compressed when `gz`); `path` names the file in errors.
pub(super) fn decode(path: &Path, bytes: &[u8], gz: bool) -> Result<Geometry> {
    if gz {
        parse(path, &inflate(path, bytes)?)
    } else {
        parse(path, bytes)
    }
}

/// Inflates a whole gzip file (every member; each member's CRC-32 and length trailer checked by
/// `flate2`), refusing one that inflates past [`MAX_INFLATED`]. A first pass only counts (and
/// checks) the inflated bytes, so a bomb is refused holding nothing, and an accepted file is
/// inflated into a buffer of exactly its size.
fn inflate(path: &Path, bytes: &[u8]) -> Result<Vec<u8>> {
    let gz_error = |e: std::io::Error| Error::new(path, format!("invalid gzip data: {e}"));
    let size = inflated_size(path, bytes)?;
    let mut out = Vec::with_capacity(size.min(MAX_INFLATED as u64) as usize);
    if size <= MAX_INFLATED as u64 {
        MultiGzDecoder::new(bytes)
            .read_to_end(&mut out)
            .map_err(gz_error)?;
    }
    if size > MAX_INFLATED as u64 {
        let msg = format!(
            "inflates to more than {} MiB, the limit for a .ply.gz (a decompression bomb?)",
            MAX_INFLATED >> 20
        );
        return Err(Error::new(path, msg));
    }
    Ok(out)
}

/// How many bytes the gzip file `bytes` inflates to, counted without keeping them, up to one
/// past [`MAX_INFLATED`] (a larger file counts as `MAX_INFLATED + 1`).
///
/// # Errors
/// Invalid gzip data.
pub fn inflated_size(path: &Path, bytes: &[u8]) -> Result<u64> {
    std::io::copy(
        &mut MultiGzDecoder::new(bytes).take(MAX_INFLATED as u64 + 1),
        &mut std::io::sink(),
    )
    .map_err(|e| Error::new(path, format!("invalid gzip data: {e}")))
}

fn parse(path: &Path, data: &[u8]) -> Result<Geometry> {
    scan_header(path, data)?;
    let mut reader = Reader::new(data);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| parse_error(path, &e, true))?;
    let payload_bytes = reader.get_ref().len();
    let layout = check_header(path, data, &header, reader.line(), payload_bytes)?;
    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    let payload_error = |e: ParseError| parse_error(path, &e, layout.ascii);
    for (name, el) in &header.elements {
        match name.as_str() {
            "vertex" => {
                vertices = Parser::<Elem>::new()
                    .read_payload_for_element(&mut reader, el, &header)
                    .map_err(payload_error)?;
            }
            "face" => {
                faces = Parser::<Elem>::new()
                    .read_payload_for_element(&mut reader, el, &header)
                    .map_err(payload_error)?;
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, el, &header)
                    .map_err(payload_error)?;
            }
        }
    }
    let rest = reader.get_ref();
    let trailing = if layout.ascii {
        rest.iter().any(|b| !b.is_ascii_whitespace())
    } else {
        !rest.is_empty()
    };
    if trailing {
        let msg = format!(
            "{} bytes of data after the last element the header declares (does it undercount?)",
            rest.len()
        );
        let at_end = data.len() - rest.len();
        return Err(match layout.ascii {
            true => Error::at_line(path, super::line_of_offset(data, at_end), msg),
            false => Error::new(path, msg),
        });
    }
    if layout.ascii {
        check_ascii_values(path, data, &header, layout.first_data_line)?;
    }
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
    // The fans' triangles, reserved at once and fallibly: faces of many corners make up to 35
    // bytes of triangles per byte of payload (253 triangles from a 256-byte face of one-byte
    // indices), so a small file may ask for more than there is, and must be refused, not abort.
    let tris: u64 = faces
        .iter()
        .map(|f| f.indices.len().saturating_sub(2) as u64)
        .sum();
    let reserve = |n: u64, per: u64| -> Result<()> {
        let bytes = n.saturating_mul(per);
        crate::memory::ensure(
            path,
            bytes,
            &format!("its {n} triangles (and their build)"),
            &format!(
                "a .ply.gz inflates to at most {} MiB, and a triangle takes about {} bytes to \
                 hold and build",
                MAX_INFLATED >> 20,
                per
            ),
        )
    };
    let extra = 36 + if layout.normals { 36 } else { 0 } + if layout.uvs { 24 } else { 0 };
    reserve(tris, extra + crate::memory::BUILD_BYTES_PER_PRIM)?;
    g.triangles.reserve_exact(tris as usize);
    normals.reserve_exact(if layout.normals { tris as usize } else { 0 });
    uvs.reserve_exact(if layout.uvs { tris as usize } else { 0 });
    let mut corners = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let n = face.indices.len();
        if n as u64 > layout.max_face_len {
            let msg = format!(
                "face {f}: list count {n} does not fit the header's count type (at most {})",
                layout.max_face_len
            );
            return Err(at(layout.face_offset, f, msg));
        }
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

/// The header's text checks that `ply-rs-bw` does not make, with the line of each problem: the
/// first line is `ply`, the version is `1.0`, no element or property is declared twice (the
/// parser would keep only the last), and no element with items lacks properties (such items take
/// no bytes, so a count of billions would be read, and kept, from nothing).
fn scan_header(path: &Path, data: &[u8]) -> Result<()> {
    if data.is_empty() {
        return Err(Error::new(path, "invalid PLY: the file is empty"));
    }
    let mut elements: Vec<String> = Vec::new();
    let mut properties: Vec<String> = Vec::new();
    // The current element: its line and whether it has items.
    let mut current: Option<(usize, bool)> = None;
    let close = |current: Option<(usize, bool)>, n_props: usize| match current {
        Some((line, true)) if n_props == 0 => Err(Error::at_line(
            path,
            line,
            "invalid PLY: an element with items but no properties",
        )),
        _ => Ok(()),
    };
    let mut offset = 0;
    for (i, raw) in data.split(|&b| b == b'\n').enumerate() {
        let line = i + 1;
        offset += raw.len() + 1;
        if offset > MAX_HEADER {
            let msg = format!("invalid PLY: no end_header in the first {MAX_HEADER} bytes");
            return Err(Error::new(path, msg));
        }
        let text = String::from_utf8_lossy(raw);
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        let at = |msg: String| Error::at_line(path, line, format!("invalid PLY: {msg}"));
        if line == 1 {
            if words != ["ply"] {
                return Err(at("the file does not start with a `ply` line".into()));
            }
            continue;
        }
        match words.as_slice() {
            ["format", _, version] if *version != "1.0" => {
                return Err(at(format!("format version {version}; only 1.0 is read")));
            }
            ["element", name, count, ..] => {
                close(current, properties.len())?;
                if elements.iter().any(|e| e == name) {
                    return Err(at(format!("element `{name}` is declared twice")));
                }
                elements.push(name.to_string());
                properties.clear();
                current = Some((line, *count != "0"));
            }
            ["property", .., name] => {
                if properties.iter().any(|p| p == name) {
                    return Err(at(format!("property `{name}` is declared twice")));
                }
                properties.push(name.to_string());
            }
            ["end_header"] => return close(current, properties.len()),
            _ => {}
        }
    }
    Ok(()) // no end_header: the parser reports it
}

/// Refuses headers without the properties we need, or whose counts the payload cannot hold,
/// before any payload is read. `payload_bytes` of `data` follow the header.
fn check_header(
    path: &Path,
    data: &[u8],
    header: &Header,
    line_after_header: usize,
    payload_bytes: usize,
) -> Result<Layout> {
    if (header.version.major, header.version.minor) != (1, 0) {
        return Err(Error::new(path, "invalid PLY: only version 1.0 is read"));
    }
    let ascii = header.encoding == Encoding::Ascii;
    // An ASCII file too short for its counts is reported at the line where it ends.
    let last_line = super::line_of_offset(data, data.len());
    let mut offsets = (None, None);
    let mut offset = 0usize;
    for (name, el) in &header.elements {
        match name.as_str() {
            "vertex" => offsets.0 = Some(offset),
            "face" => offsets.1 = Some(offset),
            _ => {}
        }
        offset = offset.saturating_add(el.count);
        let need = el.count.checked_mul(min_item_bytes(el, ascii));
        if need.is_none_or(|n| n > payload_bytes) {
            let msg = format!(
                "invalid PLY: element `{name}` declares {} items, more than the {payload_bytes} \
                 bytes after the header can hold",
                el.count
            );
            return Err(match ascii {
                true => Error::at_line(path, last_line, msg),
                false => Error::new(path, msg),
            });
        }
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
    let max_face_len = match index_type {
        Some(PropertyType::List(count, t))
            if !matches!(t, ScalarType::Float | ScalarType::Double) =>
        {
            scalar_max(count)
        }
        Some(_) => {
            let msg = "the face's vertex_indices must be a list of an integer type";
            return Err(Error::new(path, msg));
        }
        None => {
            let msg = "the face element has no `vertex_indices` or `vertex_index` list";
            return Err(Error::new(path, msg));
        }
    };
    Ok(Layout {
        ascii,
        first_data_line: line_after_header,
        vertex_offset,
        face_offset,
        normals: ["nx", "ny", "nz"].iter().all(|p| has_scalar(vertex, &[p])),
        uvs: has_scalar(vertex, &["u", "s", "texture_u", "texture_s"])
            && has_scalar(vertex, &["v", "t", "texture_v", "texture_t"]),
        max_face_len,
    })
}

/// The fewest payload bytes one item of `el` can take: in binary, each scalar's size and each
/// list's count; in ASCII, two characters a value (a digit and a separator). A face's index list
/// is counted with three entries, as a face with fewer is refused anyway.
fn min_item_bytes(el: &ElementDef, ascii: bool) -> usize {
    let size = |t: &ScalarType| if ascii { 2 } else { scalar_size(t) };
    el.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) => size(t),
            PropertyType::List(count, item) if el.name == "face" && is_index_list(&p.name) => {
                size(count) + 3 * size(item)
            }
            PropertyType::List(count, _) => size(count),
        })
        .sum()
}

fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The largest value of an integer scalar type (as a list count).
fn scalar_max(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char => i8::MAX as u64,
        ScalarType::UChar => u8::MAX.into(),
        ScalarType::Short => i16::MAX as u64,
        ScalarType::UShort => u16::MAX.into(),
        ScalarType::Int => i32::MAX as u64,
        ScalarType::UInt | ScalarType::Float | ScalarType::Double => u32::MAX.into(),
    }
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
