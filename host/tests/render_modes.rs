//! `kdray render`'s stopping rules, EXR output, `--tile K/N` and `kdray merge`: exit codes,
//! messages that name the file, and bands that merge into the whole render bit for bit.

use std::path::Path;

mod common;
use common::{dir, kdray, s};

/// Runs kdray, asserts success, returns stdout.
fn ok(args: &[&str]) -> String {
    let o = kdray(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{args:?}: {err}");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Asserts exit code 1 and a message that contains `needle` (a file name) and no panic.
fn fails(args: &[&str], needle: &str) {
    let o = kdray(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?} does not name {needle}: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// An EXR's size, data-window origin and f32 RGB pixels.
type ExrBand = ((usize, usize), (i32, i32), Vec<[f32; 3]>);

/// Reads an EXR band with the `exr` crate directly.
fn read_exr(path: &Path) -> ExrBand {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.0, vec![[0.0f32; 3]; size.0 * size.1]),
        |(w, px): &mut (usize, Vec<[f32; 3]>),
         exr::prelude::Vec2(x, y),
         (r, g, b, _a): (f32, f32, f32, f32)| px[y * *w + x] = [r, g, b],
    )
    .unwrap();
    let layer = &image.layer_data;
    let pos = layer.attributes.layer_position;
    (
        (layer.size.0, layer.size.1),
        (pos.0, pos.1),
        layer.channel_data.pixels.1.clone(),
    )
}

/// Bands rendered alone and merged are the whole render, bit for bit, in EXR and in PNG; the
/// bands' own files hold their rows at the right place. 10 rows in 3 bands: 3, 3 and 4 rows.
#[test]
fn tiles_merge_into_the_whole_render_bit_for_bit() {
    let d = dir("tiles");
    let common = ["--size", "12x10", "--spp", "11", "--seed", "5"];
    let whole = d.join("whole.exr");
    ok(&[&["render", "-o", s(&whole)][..], &common].concat());
    let mut parts = Vec::new();
    for k in 1..=3 {
        let part = d.join(format!("part{k}.exr"));
        let tile = format!("{k}/3");
        let line = ok(&[&["render", "-o", s(&part), "--tile", &tile][..], &common].concat());
        assert!(line.contains(&format!("tile {k}/3")), "{line}");
        parts.push(part);
    }
    let (size, origin, _) = read_exr(&parts[2]);
    assert_eq!(
        (size, origin),
        ((12, 4), (0, 6)),
        "band 3 of 3 is rows 6..10"
    );
    // Given out of order: merge sorts them.
    let merged = d.join("merged.exr");
    ok(&[
        "merge",
        s(&parts[2]),
        s(&parts[0]),
        s(&parts[1]),
        "-o",
        s(&merged),
    ]);
    let (w, m) = (read_exr(&whole), read_exr(&merged));
    assert_eq!(w.0, (12, 10));
    assert!(
        w.2.iter().any(|p| p[0] > 0.0),
        "a black image proves nothing"
    );
    let bits = |px: &[[f32; 3]]| -> Vec<u32> { px.iter().flatten().map(|v| v.to_bits()).collect() };
    assert_eq!(bits(&w.2), bits(&m.2));
    let (whole_png, merged_png) = (d.join("whole.png"), d.join("merged.png"));
    ok(&[&["render", "-o", s(&whole_png)][..], &common].concat());
    ok(&[
        "merge",
        s(&parts[0]),
        s(&parts[1]),
        s(&parts[2]),
        "-o",
        s(&merged_png),
    ]);
    assert_eq!(
        std::fs::read(&whole_png).unwrap(),
        std::fs::read(&merged_png).unwrap()
    );
}

/// `merge` refuses overlapping and missing bands, and files that are not EXR bands, naming the
/// file; a band of another image size too.
#[test]
fn merge_refuses_overlaps_gaps_and_bad_parts() {
    let d = dir("merge-bad");
    let band = |k: u32, n: u32, size: &str| {
        let p = d.join(format!("b{k}of{n}-{size}.exr"));
        let tile = format!("{k}/{n}");
        ok(&[
            "render",
            "-o",
            s(&p),
            "--tile",
            &tile,
            "--size",
            size,
            "--spp",
            "1",
        ]);
        p
    };
    let (a, b, c) = (band(1, 3, "8x9"), band(2, 3, "8x9"), band(3, 3, "8x9"));
    let out = d.join("out.exr");
    fails(&["merge", s(&a), s(&c), "-o", s(&out)], "b3of3-8x9.exr");
    fails(&["merge", s(&a), s(&b), "-o", s(&out)], "b2of3-8x9.exr");
    fails(
        &["merge", s(&a), s(&b), s(&b), s(&c), "-o", s(&out)],
        "b2of3-8x9.exr",
    );
    let half = band(1, 2, "8x9");
    fails(&["merge", s(&half), s(&b), s(&c), "-o", s(&out)], "overlap");
    let other = band(2, 3, "8x6");
    fails(
        &["merge", s(&a), s(&other), s(&c), "-o", s(&out)],
        "b2of3-8x6.exr",
    );
    let junk = d.join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    fails(&["merge", s(&junk), "-o", s(&out)], "junk.exr");
    let missing = d.join("missing.exr");
    fails(&["merge", s(&missing), "-o", s(&out)], "missing.exr");
    fails(
        &["merge", s(&a), s(&b), s(&c), "-o", s(&d.join("out.tif"))],
        "out.tif",
    );
    assert!(!out.exists(), "nothing is written on a refusal");
    assert_eq!(kdray(&["merge", "-o", s(&out)]).status.code(), Some(2));
}

/// The EXR is linear and unclamped: a scene that shows only its background gives the background
/// exactly, 2.5 included.
#[test]
fn exr_output_holds_linear_radiance_above_one() {
    let d = dir("exr");
    let scene = d.join("sky.toml");
    std::fs::write(
        &scene,
        "[camera]\nkind = \"pinhole\"\neye = [0, 0, 0]\ntarget = [0, 0, -1]\n\
         [render]\nbackground = [2.5, 0.5, 0.125]\nmax_depth = 4\n\
         [[sphere]]\ncenter = [0, 0, 5]\nradius = 1\n",
    )
    .unwrap();
    let out = d.join("sky.exr");
    let line = ok(&[
        "render",
        s(&scene),
        "-o",
        s(&out),
        "--size",
        "6x4",
        "--spp",
        "3",
    ]);
    assert!(line.contains("6x4, 3 spp"), "{line}");
    let (size, origin, px) = read_exr(&out);
    assert_eq!((size, origin), ((6, 4), (0, 0)));
    assert!(px.iter().all(|p| *p == [2.5, 0.5, 0.125]), "{px:?}");
}

/// The summary line accounts for the run's time: loading the scene, making the tree, rendering
/// and writing the image, which add up to the total (to within what happens between them:
/// checking arguments and outputs).
#[test]
fn the_summary_line_times_add_up() {
    let d = dir("times");
    let out = d.join("t.png");
    let line = ok(&["render", "-o", s(&out), "--size", "16x16", "--spp", "8"]);
    let ms = |key: &str| -> f64 {
        let v = line
            .split(&format!(" {key}="))
            .nth(1)
            .unwrap_or_else(|| panic!("no {key} in {line}"));
        v.split_whitespace().next().unwrap().parse().unwrap()
    };
    let parts = ["load_ms", "build_ms", "render_ms", "write_ms"].map(ms);
    let (sum, total) = (parts.iter().sum::<f64>(), ms("total_ms"));
    assert!(parts.iter().all(|&p| p >= 0.0), "{line}");
    assert!(
        sum <= total + 0.5 && total - sum < 100.0 + 0.1 * total,
        "{sum} of {total}: {line}"
    );
}

/// `--seconds` and `--noise` stop the render and the summary line says how far it got.
#[test]
fn seconds_and_noise_stop_the_render_and_report_it() {
    let d = dir("stops");
    let out = d.join("t.png");
    let run =
        |extra: &[&str]| ok(&[&["render", "-o", s(&out), "--size", "8x8"][..], extra].concat());
    let line = run(&["--seconds", "0.2"]);
    for key in ["8x8, ", " spp, ", " s, ", "Mrays/s", "est. RMSE", "passes="] {
        assert!(line.contains(key), "no '{key}' in {line}");
    }
    // A noise level every image meets stops after the first pass of 8 samples.
    let line = run(&["--noise", "1000"]);
    let stopped = |spp: &str, passes: &str| line.contains(spp) && line.contains(passes);
    assert!(stopped("8x8, 8 spp", "passes=1 "), "{line}");
    // --spp caps a noise target that is never met.
    let line = run(&["--noise", "1e-9", "--spp", "24"]);
    assert!(
        line.contains("8x8, 24 spp") && line.contains("passes=3 "),
        "{line}"
    );
    let line = run(&["--spp", "40", "--adaptive"]);
    let spp: f64 = line
        .split(", ")
        .find_map(|f| f.strip_suffix(" spp")?.parse().ok())
        .unwrap_or_else(|| panic!("no spp in {line}"));
    assert!(
        (40.0..48.0).contains(&spp),
        "adaptive: {spp} spp for a budget of 40"
    );
}

#[test]
fn render_usage_errors_exit_2() {
    for args in [
        &["render", "--tile", "0/3"][..],
        &["render", "--tile", "4/3"],
        &["render", "--tile", "3"],
        &["render", "--tile", "a/b"],
        &["render", "--seconds", "0"],
        &["render", "--seconds", "-1"],
        &["render", "--seconds", "inf"],
        &["render", "--noise", "NaN"],
        &["render", "--noise", "x"],
    ] {
        let o = kdray(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
}

/// Output problems are found before the work starts: they are reported even when the scene
/// given is missing (which would be the first thing the work reads).
#[test]
fn output_problems_are_found_first_and_name_the_file() {
    let d = dir("out-first");
    let missing_scene = d.join("nothere.toml");
    let png_tile = d.join("band.png");
    fails(
        &[
            "render",
            s(&missing_scene),
            "--tile",
            "1/2",
            "-o",
            s(&png_tile),
        ],
        "band.png",
    );
    let no_dir = d.join("no").join("such").join("dir.exr");
    fails(&["render", s(&missing_scene), "-o", s(&no_dir)], "dir.exr");
    fails(&["render", s(&missing_scene), "-o", s(&d)], s(&d));
    // More bands than rows is the scene's problem: it names the image's size.
    fails(
        &[
            "render",
            "--size",
            "4x3",
            "--tile",
            "4/4",
            "-o",
            s(&d.join("x.exr")),
        ],
        "only 3 rows",
    );
}

/// `converge` writes its CSV (and the plot, where the labels' font is installed) and prints a
/// slope; its usage errors exit 2, bad outputs and scenes exit 1 naming the file.
#[test]
fn converge_writes_its_report_and_refuses_bad_arguments() {
    let d = dir("converge");
    let csv = d.join("furnace.csv");
    let args = ["converge", "-o", s(&csv), "--size", "8x8", "--repeats", "2"];
    let out = ok(&[&args[..], &["--seconds", "0.2", "--adaptive"]].concat());
    assert!(
        out.contains("slope=") && out.contains("mode=adaptive"),
        "{out}"
    );
    assert!(out.contains("analytic"), "{out}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("mode,spp,seconds,rmse,seconds_min,seconds_max,rmse_min,rmse_max,repeats")
    );
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!((first[0], first[1], first[8]), ("uniform", "2", "2"));
    let rmse: f64 = first[3].parse().unwrap();
    assert!(
        rmse > 0.0 && rmse < 1.0,
        "RMSE {rmse} of a furnace of radiance ~1"
    );
    if Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").exists() {
        let png = std::fs::read(d.join("furnace.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
    for bad in [
        &["converge", "-o", "r.csv", "--seconds", "0"][..],
        &["converge", "-o", "r.csv", "--repeats", "0"],
        &["converge"],
    ] {
        assert_eq!(kdray(bad).status.code(), Some(2), "{bad:?}");
    }
    fails(&["converge", "-o", s(&d.join("report.txt"))], "report.txt");
    let missing = d.join("absent.toml");
    fails(&["converge", s(&missing), "-o", s(&csv)], "absent.toml");
    let no_dir = d.join("nodir").join("r.csv");
    fails(&["converge", s(&missing), "-o", s(&no_dir)], "r.csv");
}
