//! Log-log line plots as PNG files (`plotters`), for the reports (`kdray converge`).
//!
//! `plotters` draws into an RGB buffer and the `png` crate encodes it, so no image crate and no
//! system font library is linked; the labels' font is DejaVu Sans, read at run time from the
//! usual system folders (Debian package `fonts-dejavu-core`, present on the project's machines)
//! and registered with `plotters::style::register_font`.

use crate::error::{Error, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::OnceLock;

/// Where the labels' font is looked for, in order.
const FONTS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

/// One line of points `(x, y)`, both > 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// A log-log plot.
#[derive(Clone, Debug, PartialEq)]
pub struct LogLog<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [Series],
    /// A dashed guide line of this slope through the first series' first point.
    pub guide_slope: Option<f64>,
}

/// Registers the labels' font once; `Err` says which files were tried.
fn font() -> core::result::Result<(), String> {
    static REGISTERED: OnceLock<core::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            let bytes = FONTS
                .iter()
                .find_map(|p| std::fs::read(p).ok())
                .ok_or_else(|| {
                    format!(
                        "no font for the labels (install fonts-dejavu-core; tried {})",
                        FONTS.join(", ")
                    )
                })?;
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
                .map_err(|_| "the DejaVu Sans file is not a usable font".to_string())
        })
        .clone()
}

/// Draws `plot` into a `width × height` PNG at `path`.
///
/// # Errors
/// No points, no font, or a file that cannot be written, naming the file.
pub fn log_log(path: &Path, plot: &LogLog, (width, height): (u32, u32)) -> Result<()> {
    let all: Vec<(f64, f64)> = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    if all.is_empty() {
        return Err(Error::new(
            path,
            "nothing to plot: no positive, finite points",
        ));
    }
    font().map_err(|msg| Error::new(path, msg))?;
    let span = |f: fn(&(f64, f64)) -> f64| {
        let lo = all.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = all.iter().map(f).fold(0.0, f64::max);
        // A margin of a fifth of a decade each side (and a decade at least overall).
        let (lo, hi) = (lo / 1.6, hi * 1.6);
        if hi / lo < 10.0 {
            let mid = (lo * hi).sqrt();
            (mid / 10f64.sqrt(), mid * 10f64.sqrt())
        } else {
            (lo, hi)
        }
    };
    let ((x0, x1), (y0, y1)) = (span(|p| p.0), span(|p| p.1));
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    let draw_error = |e: String| Error::new(path, format!("cannot draw the plot: {e}"));
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(plot.title, ("sans-serif", 22))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| draw_error(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(plot.x_label)
            .y_desc(plot.y_label)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        let colors = [
            RGBColor(31, 119, 180),
            RGBColor(214, 39, 40),
            RGBColor(44, 160, 44),
        ];
        for (i, s) in plot.series.iter().enumerate() {
            let color = colors[i % colors.len()];
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(|e| draw_error(e.to_string()))?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(s.points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(|e| draw_error(e.to_string()))?;
        }
        if let (Some(slope), Some(&(px, py))) = (
            plot.guide_slope,
            plot.series.first().and_then(|s| s.points.first()),
        ) {
            let at = |x: f64| py * (x / px).powf(slope);
            let dashes = DashedLineSeries::new(
                [(x0, at(x0)), (x1, at(x1))],
                8,
                6,
                BLACK.mix(0.5).stroke_width(1),
            );
            chart
                .draw_series(dashes)
                .map_err(|e| draw_error(e.to_string()))?
                .label(format!("slope {slope}"))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.mix(0.5)));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 15))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        root.present().map_err(|e| draw_error(e.to_string()))?;
    }
    crate::image::write_png_bytes(path, &rgb, width, height, false)
}
