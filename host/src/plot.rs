//! Plots as PNG files (`plotters`), for the reports: log-log lines (`kdray converge`) and
//! labelled scatter panels (`kdray accuracy`).
//!
//! `plotters` draws into an RGB buffer and the `png` crate encodes it, so no image crate and no
//! system font library is linked; the labels' font is DejaVu Sans, read at run time from the
//! usual system folders (Debian package `fonts-dejavu-core`, present on the project's machines)
//! and registered with `plotters::style::register_font`.

mod labels;

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

/// One labelled point of a scatter plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: String,
}

/// One chart of a figure: a title and its series (a name and its points; one colour each).
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub title: String,
    pub series: Vec<(String, Vec<Point>)>,
}

/// Scatter plots side by side, one per panel, on a linear `x` and a logarithmic `y` axis, every
/// point labelled, written to `path` as a PNG of `size` pixels. Points with `y` below `y_floor`
/// (e.g. exact zeros) are drawn on the floor.
///
/// # Errors
/// An error naming `path` when the chart cannot be drawn or written.
pub fn scatter_log_y(
    path: &Path,
    title: &str,
    axes: (&str, &str),
    panels: &[Panel],
    y_floor: f64,
    size: (u32, u32),
) -> Result<()> {
    font().map_err(|msg| Error::new(path, msg))?;
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    draw(&mut rgb, title, axes, panels, y_floor, size)
        .map_err(|e| Error::new(path, format!("cannot draw the chart: {e}")))?;
    crate::image::write_png_bytes(path, &rgb, size.0, size.1, false)
}

type DrawResult = core::result::Result<(), Box<dyn core::error::Error>>;

/// Draws the figure of [`scatter_log_y`] into an RGB8 buffer of `size` pixels.
fn draw(
    rgb: &mut [u8],
    title: &str,
    axes: (&str, &str),
    panels: &[Panel],
    y_floor: f64,
    size: (u32, u32),
) -> DrawResult {
    let root = BitMapBackend::with_buffer(rgb, size).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let areas = root.split_evenly((1, panels.len().max(1)));
    for (area, panel) in areas.iter().zip(panels) {
        draw_panel(area, panel, axes, y_floor)?;
    }
    root.present()?;
    Ok(())
}

/// One panel of [`draw`].
fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    panel: &Panel,
    (x_desc, y_desc): (&str, &str),
    y_floor: f64,
) -> DrawResult {
    let all = || panel.series.iter().flat_map(|(_, p)| p.iter());
    let x_max = all().map(|p| p.x).fold(0.0f64, f64::max) * 1.25 + 1e-9;
    let y_of = |p: &Point| p.y.max(y_floor);
    let y_max = all().map(y_of).fold(y_floor * 10.0, f64::max) * 30.0;
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 17))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(62)
        .build_cartesian_2d(0.0..x_max, (y_floor..y_max).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()?;
    for (k, (name, points)) in panel.series.iter().enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        chart
            .draw_series(
                points
                    .iter()
                    .map(|p| Circle::new((p.x, y_of(p)), 5, colour.filled())),
            )?
            .label(name.as_str())
            .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;

    // The labels, in their series' colour, each placed clear of every point and every other
    // label (`labels::place`); one moved away from its point gets a leader line to it.
    let font: TextStyle = ("sans-serif", 13).into();
    let mut pixels = Vec::new();
    let mut sizes = Vec::new();
    let mut owners = Vec::new();
    for (k, (_, points)) in panel.series.iter().enumerate() {
        for p in points {
            pixels.push(chart.backend_coord(&(p.x, y_of(p))));
            sizes.push(area.estimate_text_size(&p.label, &font)?);
            owners.push((k, p.label.as_str()));
        }
    }
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let bounds = labels::Rect {
        left: xs.start,
        top: ys.start,
        right: xs.end,
        bottom: ys.end,
    };
    // The legend (upper right, drawn above): one line per series, about 20 pixels each.
    let legend_w = panel
        .series
        .iter()
        .map(|(name, _)| area.estimate_text_size(name, &font).map_or(0, |(w, _)| w))
        .max()
        .unwrap_or(0) as i32
        + 40;
    let legend = labels::Rect {
        left: bounds.right - legend_w - 10,
        top: bounds.top,
        right: bounds.right,
        bottom: bounds.top + 20 * panel.series.len() as i32 + 20,
    };
    let (bx, by) = area.get_base_pixel();
    let placed = labels::place(&pixels, &sizes, bounds, &[legend]);
    for (((&(px, py), &(w, h)), place), (k, text)) in
        pixels.iter().zip(&sizes).zip(&placed).zip(owners)
    {
        let colour = Palette99::pick(k).to_rgba();
        if place.leader {
            // From the point to the nearest point of the label's box.
            let tx = px.clamp(place.x, place.x + w as i32);
            let ty = py.clamp(place.y, place.y + h as i32);
            area.draw(&PathElement::new(
                vec![(px - bx, py - by), (tx - bx, ty - by)],
                colour.stroke_width(1),
            ))?;
        }
        let style = font.color(&colour);
        area.draw(&Text::new(
            text.to_string(),
            (place.x - bx, place.y - by),
            style,
        ))?;
    }
    Ok(())
}
