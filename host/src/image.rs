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
    crate::files::write_atomic_with(path, |out| {
        image
            .write()
            .to_buffered(out)
            .map_err(|e| std::io::Error::other(format!("cannot write EXR: {e}")))
    })
}

/// Reads an EXR's first RGB(A) layer as a band of the image its display window describes.
///
/// # Errors
/// An unreadable or malformed file, or a data window that is not whole rows of the display
/// window, naming the file.
pub fn read_exr(path: &Path) -> Result<Band> {
    if !path.is_file() {
        return Err(Error::new(path, "no such file"));
    }
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.0, vec![[0.0f32; 3]; size.0 * size.1]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), Vec2(x, y), (r, g, b, _a): (f32, f32, f32, f32)| {
            px[y * *w + x] = [r, g, b];
        },
    )
    .map_err(|e| Error::new(path, format!("not a readable RGB EXR: {e}")))?;
    let display = image.attributes.display_window;
    let layer = &image.layer_data;
    let (position, size) = (layer.attributes.layer_position, layer.size);
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
    Ok(Band {
        width,
        height,
        first_row: position.1 as u32,
        pixels: layer.channel_data.pixels.1.clone(),
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
    let mut pixels = Vec::with_capacity(w as usize * h as usize);
    let mut next_row = 0u32;
    let mut prev: Option<&Path> = None;
    for (path, band) in sorted {
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
        pixels.extend_from_slice(&band.pixels);
        next_row = rows.end;
        prev = Some(path);
    }
    if next_row < h {
        let msg = format!(
            "rows {next_row}..{h} of the {w}x{h} image are in no part (a band is missing after this one)"
        );
        return Err(Error::new(prev.unwrap_or(first_path), msg));
    }
    Ok(Band {
        width: w,
        height: h,
        first_row: 0,
        pixels,
    })
}
