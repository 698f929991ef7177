//! Image files: 8-bit sRGB PNG (the default) and linear f32 OpenEXR, and the row bands that
//! `kdray render --tile K/N` writes and `kdray merge` reassembles.
//!
//! A band is an ordinary EXR whose display window is the whole image and whose data window is the
//! band's rows (OpenEXR's own way of storing part of an image), so any EXR viewer places it right.

use crate::error::{Error, Result};
use exr::prelude::{
    Encoding, Image, IntegerBounds, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage,
};
use kdray_core::color::srgb8;
use std::path::Path;

/// The image formats `kdray` writes, chosen by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

impl Format {
    /// The format named by `path`'s extension (`.png` or `.exr`, any case).
    ///
    /// # Errors
    /// Any other extension, naming the file.
    pub fn of(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("png") => Ok(Self::Png),
            Some(e) if e.eq_ignore_ascii_case("exr") => Ok(Self::Exr),
            _ => Err(Error::new(
                path,
                "the output image must be a .png (8-bit sRGB) or .exr (linear) file",
            )),
        }
    }
}

/// Rows `rows` of a `width × height` linear RGB image, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    pub width: u32,
    pub height: u32,
    pub first_row: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl Band {
    /// The number of rows held.
    pub fn rows(&self) -> u32 {
        (self.pixels.len() / self.width.max(1) as usize) as u32
    }

    /// Whether this is the whole image.
    pub fn is_whole(&self) -> bool {
        self.first_row == 0 && self.rows() == self.height
    }
}

/// Writes `band` to `path` in the format its extension names; a PNG must be the whole image.
///
/// # Errors
/// I/O and encoder errors, naming the file.
pub fn write(path: &Path, band: &Band) -> Result<()> {
    match Format::of(path)? {
        Format::Png if band.is_whole() => write_png(path, &band.pixels, band.width, band.height),
        Format::Png => Err(Error::new(
            path,
            "a band of rows can only be written as .exr",
        )),
        Format::Exr => write_exr(path, band),
    }
}

/// Writes linear RGB pixels as an 8-bit sRGB PNG.
fn write_png(path: &Path, pixels: &[[f32; 3]], width: u32, height: u32) -> Result<()> {
    let bytes: Vec<u8> = pixels.iter().flatten().map(|&c| srgb8(c)).collect();
    write_png_bytes(path, &bytes, width, height, true)
}

/// Writes 8-bit RGB bytes as a PNG (tagged sRGB if `srgb`).
pub fn write_png_bytes(path: &Path, rgb: &[u8], width: u32, height: u32, srgb: bool) -> Result<()> {
    crate::files::write_atomic_with(path, |out| {
        let mut encoder = png::Encoder::new(out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        if srgb {
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        }
        let mut writer = encoder.write_header()?;
        writer.write_image_data(rgb)?;
        writer.finish()?;
        Ok(())
    })
}

/// Writes `band` as a linear f32 RGB EXR (lossless ZIP), its rows placed in the whole image.
fn write_exr(path: &Path, band: &Band) -> Result<()> {
    crate::files::write_atomic_with(path, |out| encode_exr(band, out))
}

/// Encodes `band` as [`write()`] stores it in an `.exr` (the `exr` fuzz target encodes to memory).
///
/// # Errors
/// The encoder's or `out`'s.
pub fn encode_exr(band: &Band, out: impl std::io::Write + std::io::Seek) -> std::io::Result<()> {
    let (w, rows) = (band.width as usize, band.rows() as usize);
    let mut attributes = LayerAttributes::named("rgb");
    attributes.layer_position = Vec2(0, band.first_row as i32);
    attributes.software_name = Some("kdray".into());
    let layer = Layer::new(
        (w, rows),
        attributes,
        Encoding::SMALL_LOSSLESS,
        SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let [r, g, b] = band.pixels[y * w + x];
            (r, g, b)
        }),
    );
    let mut image = Image::from_layer(layer);
    image.attributes.display_window =
        IntegerBounds::new((0, 0), (band.width as usize, band.height as usize));
    image
        .write()
        .to_buffered(out)
        .map_err(|e| std::io::Error::other(format!("cannot write EXR: {e}")))
}

/// The most pixels an image may have: `render --size`, a scene's `[render]` size and every part
/// `kdray merge` reads (2²⁶, 8192 × 8192: 768 MiB of f32 RGB). The same number bounds the render
/// descriptions of `kdray_core::description`.
pub const MAX_PIXELS: u64 = kdray_core::description::MAX_PIXELS;

/// How many uncompressed bytes one byte of an EXR file can honestly stand for: deflate's largest
/// ratio (a 258-byte match in one ~2-bit code, RFC 1951 §3.2.5: 1032:1), which ZIP and PXR24
/// chunks cannot exceed; RLE (at most 128 bytes from 2), B44 (fixed ratios) and PIZ (Huffman runs of
/// at most 255 16-bit values in 9+ bits) stay far below it. A pixel is at least 6 bytes (three
/// f16 channels), so `pixels ≤ EXR_MAX_RATIO × file size` holds for every readable file with a
/// margin of 6.
pub const EXR_MAX_RATIO: u64 = 1032;

/// Reads an EXR's first RGB(A) layer as a band of the image its display window describes.
///
/// # Errors
/// As [`decode_exr`], or the file cannot be read (a directory or other non-regular file is
/// refused as such).
pub fn read_exr(path: &Path) -> Result<Band> {
    decode_exr(path, &crate::files::read(path)?)
}

/// The pixels of the layer being read, and how many pixels of each of its rows were set: a
/// chunk table that points two chunks at one (or leaves one out) sets some rows twice and others
/// never, and must not pass as an image with black rows.
struct Reading {
    width: usize,
    pixels: Vec<[f32; 3]>,
    row_sets: Vec<u32>,
}

/// [`read_exr`] on the bytes of a file (`path` only names it in errors); what the `exr` fuzz
/// target calls.
///
/// Memory is bounded by the input before anything is allocated: every layer's data window must
/// hold at most [`MAX_PIXELS`] pixels and at most [`EXR_MAX_RATIO`] per byte of the file, and its
/// chunk table (8 bytes a chunk) must fit in the file.
///
/// # Errors
/// A malformed file, a layer past those bounds, a row its chunks do not set exactly once, or a
/// data window that is not whole rows of the display window, naming the file.
pub fn decode_exr(path: &Path, bytes: &[u8]) -> Result<Band> {
    let bad = |e: exr::error::Error| Error::new(path, format!("not a readable RGB EXR: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(bytes, false).map_err(bad)?;
    let len = bytes.len() as u64;
    let mut total = 0u64;
    for header in &meta.headers {
        let size = header.layer_size;
        let pixels = (size.0 as u64).saturating_mul(size.1 as u64);
        total = total.saturating_add(pixels);
        let msg = if total > MAX_PIXELS {
            format!(
                "its data window ({}x{}) holds more than {MAX_PIXELS} pixels, the limit of an image",
                size.0, size.1
            )
        } else if total > EXR_MAX_RATIO.saturating_mul(len) || header.chunk_count as u64 > len / 8 {
            format!(
                "its data window ({}x{}) claims more pixels than a {len}-byte EXR can hold \
                 (at most {EXR_MAX_RATIO} per byte, and 8 bytes of chunk table a chunk)",
                size.0, size.1
            )
        } else {
            continue;
        };
        return Err(Error::new(path, msg));
    }
    use exr::prelude::traits::*;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size: Vec2<usize>, _: &exr::prelude::RgbaChannels| Reading {
                width: size.0,
                pixels: vec![[0.0f32; 3]; size.0 * size.1],
                row_sets: vec![0; size.1],
            },
            |r: &mut Reading, Vec2(x, y), (red, g, b, _a): (f32, f32, f32, f32)| {
                r.pixels[y * r.width + x] = [red, g, b];
                r.row_sets[y] = r.row_sets[y].saturating_add(1);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(bad)?;
    let display = image.attributes.display_window;
    let layer = &image.layer_data;
    let (position, size) = (layer.attributes.layer_position, layer.size);
    let reading = &layer.channel_data.pixels;
    if let Some(row) = reading.row_sets.iter().position(|&n| n as usize != size.0) {
        let msg = format!(
            "row {} of its data window is stored {} times, not once (a broken chunk table?)",
            i64::from(position.1) + row as i64,
            reading.row_sets[row] as usize / size.0.max(1)
        );
        return Err(Error::new(path, msg));
    }
    let whole_rows = display.position == Vec2(0, 0)
        && position.0 == 0
        && size.0 == display.size.0
        && position.1 >= 0
        && position.1 as usize + size.1 <= display.size.1;
    if !whole_rows {
        return Err(Error::new(
            path,
            format!(
                "its pixels ({}x{} at {},{}) are not whole rows of its {}x{} image",
                size.0, size.1, position.0, position.1, display.size.0, display.size.1
            ),
        ));
    }
    let too_big = |v: usize| u32::try_from(v).ok();
    let (Some(width), Some(height)) = (too_big(display.size.0), too_big(display.size.1)) else {
        return Err(Error::new(path, "image too large"));
    };
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        let msg = format!(
            "its display window ({width}x{height}) holds more than {MAX_PIXELS} pixels, the limit of an image"
        );
        return Err(Error::new(path, msg));
    }
    Ok(Band {
        width,
        height,
        first_row: position.1 as u32,
        pixels: image.layer_data.channel_data.pixels.pixels,
    })
}

/// Assembles bands of one image, each given with the file it came from.
///
/// # Errors
/// No bands, bands of different image sizes, overlapping bands, or rows that no band covers; the
/// error names the file at fault (for a gap, the band after it, or the last one).
pub fn merge(parts: &[(&Path, Band)]) -> Result<Band> {
    let Some((first_path, first)) = parts.first() else {
        return Err(Error::new("merge", "no parts given"));
    };
    let (w, h) = (first.width, first.height);
    if let Some((p, b)) = parts.iter().find(|(_, b)| (b.width, b.height) != (w, h)) {
        let msg = format!(
            "a band of a {}x{} image, but {} is of a {w}x{h} image",
            b.width,
            b.height,
            first_path.display()
        );
        return Err(Error::new(p, msg));
    }
    let mut sorted: Vec<&(&Path, Band)> = parts.iter().collect();
    sorted.sort_by_key(|(_, b)| b.first_row);
    let mut next_row = 0u32;
    let mut prev: Option<&Path> = None;
    for (path, band) in &sorted {
        let rows = band.first_row..band.first_row + band.rows();
        if rows.start > next_row {
            let msg = format!(
                "rows {next_row}..{} of the {w}x{h} image are in no part (a band is missing before this one)",
                rows.start
            );
            return Err(Error::new(path, msg));
        }
        if rows.start < next_row {
            let other = prev.map_or(String::new(), |p| p.display().to_string());
            let msg = format!(
                "its rows {}..{} overlap {other}, which covers rows up to {next_row}",
                rows.start, rows.end
            );
            return Err(Error::new(path, msg));
        }
        next_row = rows.end;
        prev = Some(path);
    }
    if next_row < h {
        let msg = format!(
            "rows {next_row}..{h} of the {w}x{h} image are in no part (a band is missing after this one)"
        );
        return Err(Error::new(prev.unwrap_or(first_path), msg));
    }
    // Allocated once the parts are known to cover the image exactly: their pixels, no more.
    let mut pixels = Vec::with_capacity(w as usize * h as usize);
    for (_, band) in &sorted {
        pixels.extend_from_slice(&band.pixels);
    }
    Ok(Band {
        width: w,
        height: h,
        first_row: 0,
        pixels,
    })
}
