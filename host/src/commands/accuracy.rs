//! `kdray accuracy`: the kernel accuracy-against-time report (table, CSV, PNG).

use core::fmt::Write as _;
use kdray::accuracy::{self, Row, Settings, sets};
use kdray::error::Result;
use kdray::files;
use kdray::plot::{self, Panel, Point};
use std::path::PathBuf;

/// `kdray accuracy`'s arguments.
#[derive(clap::Args, Debug)]
pub struct AccuracyArgs {
    /// The CSV report to write; the scatter plot (error against ns per test) goes next to it, with
    /// the extension `.png`.
    #[arg(short, long, default_value = "accuracy.csv")]
    pub out: PathBuf,
    /// Alternating timing rounds per ray set; each figure is the median.
    #[arg(long, default_value_t = 15, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub rounds: u32,
}

/// Random cases (eight rays each) of the `random` set.
const RANDOM_CASES: usize = 4096;
/// Subdivisions of the icosphere of the `seams` set: 5,120 triangles.
const ICOSPHERE_LEVELS: u32 = 4;

/// Runs the report: prints the table, writes the CSV and the PNG.
pub fn accuracy(args: &AccuracyArgs) -> Result<()> {
    let png = args.out.with_extension("png");
    // `-o a.png` would put the CSV and the plot in one file: refused as two outputs in one.
    files::check_outputs(&[], &[&args.out, &png])?;
    let settings = Settings {
        rounds: args.rounds as usize,
        ..Settings::default()
    };
    let mut rows = Vec::new();
    // One step per timing round of each set; drawn between measurements, on this thread.
    let bar = indicatif::ProgressBar::new(2 * u64::from(args.rounds));
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {pos}/{len} rounds {elapsed} (eta {eta})",
        )
        .expect("valid template"),
    );
    for set in [sets::random(RANDOM_CASES), sets::seams(ICOSPHERE_LEVELS)] {
        bar.set_message(format!("accuracy: timing the kernels on `{}`", set.name));
        rows.extend(accuracy::measure_with(&set, &settings, &mut |_| bar.inc(1)));
    }
    bar.finish_and_clear();
    println!(
        "kdray accuracy: isa={} rounds={} clock={} (ns per test: median of the rounds)",
        kdray_core::isa::name(),
        args.rounds,
        accuracy::clock_name()
    );
    print!("{}", accuracy::markdown(&rows));
    files::write_atomic(&args.out, accuracy::csv(&rows).as_bytes())?;
    plot::scatter_log_y(
        &png,
        &format!(
            "kdray kernels: error of t against time ({})",
            kdray_core::isa::name()
        ),
        ("ns per ray test", "mean relative error of t against f64"),
        &panels(&rows),
        1e-12,
        (1400, 620),
    )?;
    println!("wrote {} and {}", args.out.display(), png.display());
    Ok(())
}

/// The plot: one panel per ray set, one series per primitive (Möller–Trumbore, sphere), each
/// kernel a labelled point; the references, whose error is 0 by definition, sit on the floor.
fn panels(rows: &[Row]) -> Vec<Panel> {
    let mut panels: Vec<Panel> = Vec::new();
    for r in rows {
        let (family, width) = r.kernel.split_once(' ').unwrap_or((r.kernel, ""));
        let mut label = width.replace(" (reference)", "");
        if r.false_miss_rate > 0.0 {
            let _ = write!(label, ", {:.2}% lost", 100.0 * r.false_miss_rate);
        }
        let point = Point {
            x: r.ns_per_test,
            y: r.mean_rel_err,
            label,
        };
        let name = format!("{} ({} rays)", r.set, r.rays);
        if panels.last().is_none_or(|p| p.title != name) {
            panels.push(Panel {
                title: name,
                series: Vec::new(),
            });
        }
        let Some(panel) = panels.last_mut() else {
            continue;
        };
        let family = match family {
            "mt" => "Möller–Trumbore",
            "wt" => "watertight",
            other => other,
        };
        match panel.series.iter_mut().find(|(n, _)| n == family) {
            Some((_, points)) => points.push(point),
            None => panel.series.push((family.to_string(), vec![point])),
        }
    }
    panels
}
