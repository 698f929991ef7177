//! `kdray accuracy`: the report's rows hold what the kernels do (references exact, packets equal
//! to scalar, Möller–Trumbore losing seam rays that a sphere never loses), its CSV and PNG are
//! well formed, and a bad output path fails before any work.

use kdray::accuracy::{self, CSV_HEADER, Row, Settings, sets};
use kdray::plot::{self, Panel, Point};
use std::process::Command;

/// Small sets, one timing round: the error columns do not depend on the timing.
fn rows() -> Vec<Row> {
    let settings = Settings {
        rounds: 1,
        min_measure_ms: 0.0,
    };
    let mut rows = accuracy::measure(&sets::random(256), &settings);
    rows.extend(accuracy::measure(&sets::seams(3), &settings));
    rows
}

fn find<'a>(rows: &'a [Row], set: &str, kernel: &str) -> &'a Row {
    rows.iter()
        .find(|r| r.set == set && r.kernel == kernel)
        .unwrap_or_else(|| panic!("no row {set} / {kernel}"))
}

/// The references have no error and no false verdicts by definition; the 4- and 8-wide kernels
/// round exactly like the scalar ones, so every error column is identical to the scalar row's;
/// every row has a finite time (0 is possible here: one pass is shorter than the CPU clock's tick)
/// and counts all rays.
#[test]
fn references_are_exact_and_packets_equal_scalar() {
    let rows = rows();
    assert_eq!(rows.len(), 2 * accuracy::Variant::ALL.len());
    for r in &rows {
        assert!(r.ns_per_test >= 0.0 && r.ns_per_test.is_finite(), "{r:?}");
        assert_eq!(r.rays % 8, 0);
        if r.kernel.ends_with("(reference)") {
            assert_eq!(
                (r.mean_rel_err, r.max_rel_err, r.false_misses, r.false_hits),
                (0.0, 0.0, 0, 0),
                "{r:?}"
            );
        }
    }
    for set in ["random", "seams"] {
        for (scalar, packets) in [
            ("mt scalar", ["mt x4", "mt x8"]),
            ("wt scalar", ["wt x4", "wt x8"]),
            ("sphere scalar", ["sphere x4", "sphere x8"]),
        ] {
            let s = find(&rows, set, scalar);
            for p in packets {
                let p = find(&rows, set, p);
                assert_eq!(
                    (p.mean_rel_err, p.max_rel_err, p.false_misses, p.false_hits),
                    (s.mean_rel_err, s.max_rel_err, s.false_misses, s.false_hits),
                    "{set}: {} differs from {}",
                    p.kernel,
                    s.kernel
                );
            }
        }
    }
}

/// On the seam rays (from inside a closed icosphere, aimed exactly at its vertices and edges)
/// f32 Möller–Trumbore loses rays that the f64 reference hits — the case is stiff — and hits
/// nothing the reference misses; the sphere around the same points loses none. Rays that hit
/// agree with f64 to within a few ulps of `t ≈ 1`.
#[test]
fn seam_rays_are_lost_by_moller_trumbore_not_by_the_sphere() {
    let rows = rows();
    let mt = find(&rows, "seams", "mt scalar");
    assert!(mt.false_misses > 0, "{mt:?}");
    assert_eq!(mt.false_hits, 0, "{mt:?}");
    assert!(mt.max_rel_err < 1e-6, "{mt:?}");
    let sphere = find(&rows, "seams", "sphere scalar");
    assert_eq!(
        (sphere.false_misses, sphere.false_hits),
        (0, 0),
        "{sphere:?}"
    );
}

/// The CSV has the header and one line per row with as many fields; the Markdown table one line
/// per row after its two header lines.
#[test]
fn csv_and_markdown_have_a_line_per_row() {
    let rows = rows();
    let csv = accuracy::csv(&rows);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), rows.len() + 1);
    let fields = CSV_HEADER.split(',').count();
    assert!(
        lines.iter().all(|l| l.split(',').count() == fields),
        "{csv}"
    );
    assert!(
        lines[1].starts_with("random,mt scalar,2048,"),
        "{}",
        lines[1]
    );
    assert_eq!(accuracy::markdown(&rows).lines().count(), rows.len() + 2);
}

/// The scatter plot is a PNG of the requested size with something drawn on it (not all white).
#[test]
fn scatter_plot_is_a_png() {
    let path = std::env::temp_dir().join(format!("kdray-plot-{}.png", std::process::id()));
    let points = vec![
        Point {
            x: 1.0,
            y: 1e-7,
            label: "a".into(),
        },
        Point {
            x: 3.0,
            y: 0.0,
            label: "exact".into(),
        },
    ];
    let panel = Panel {
        title: "p".into(),
        series: vec![("s".into(), points)],
    };
    plot::scatter_log_y(
        &path,
        "t",
        ("x", "y"),
        &[panel.clone(), panel],
        1e-12,
        (320, 200),
    )
    .unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (320, 200));
    assert!(
        buf[..info.buffer_size()].iter().any(|&b| b < 128),
        "a blank chart"
    );
    std::fs::remove_file(&path).unwrap();
}

/// An output in a folder that does not exist is refused at once, naming the file, exit 1.
#[test]
fn missing_output_folder_fails_before_any_work() {
    let start = std::time::Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(["accuracy", "-o", "/nonexistent-kdray-dir/report.csv"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent-kdray-dir/report.csv"), "{err}");
    assert!(start.elapsed().as_secs() < 5, "it did the work first");
}

/// The watertight kernel (Woop, Benthin & Wald 2013) loses none of the seam rays that f32
/// Möller–Trumbore loses, at any packet width, and hits nothing the f64 reference misses.
#[test]
fn watertight_loses_no_seam_ray() {
    let rows = rows();
    for kernel in ["wt scalar", "wt x4", "wt x8"] {
        let wt = find(&rows, "seams", kernel);
        assert_eq!((wt.false_misses, wt.false_hits), (0, 0), "{wt:?}");
        assert!(wt.max_rel_err < 1e-6, "{wt:?}");
    }
    assert!(find(&rows, "seams", "mt scalar").false_misses > 0);
}
