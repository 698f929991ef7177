//! The `kdray` binary's contract: exit codes, messages that name the file, the `trace` line,
//! and hits that agree with the library.

use std::path::Path;
use std::process::Output;

mod common;
use common::{dir, kdray, s};

fn tri_file(path: &Path, tris: &[[f32; 9]]) {
    let mut b = (tris.len() as u32).to_le_bytes().to_vec();
    for t in tris {
        for v in t {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, b).unwrap();
}

fn ray_bytes(rays: &[[f32; 8]]) -> Vec<u8> {
    rays.iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

#[test]
fn build_info_trace_round_trip() {
    let d = dir("roundtrip");
    let mesh = d.join("two.tri");
    // Two triangles in the planes z = 0 and z = -1, both covering the origin's column.
    tri_file(
        &mesh,
        &[
            [-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 0.0, 1.0, 0.0],
            [-1.0, -1.0, -1.0, 1.0, -1.0, -1.0, 0.0, 1.0, -1.0],
        ],
    );
    let kdt = d.join("two.kdt");
    let out = kdray(&["build", s(&mesh), "-o", s(&kdt)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info = kdray(&["info", s(&kdt)]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(info.status.success());
    for key in [
        "nodes",
        "leaves",
        "empty leaves",
        "prims per leaf",
        "depth",
        "sah cost",
        "bytes per prim",
        "build ms",
    ] {
        assert!(text.contains(key), "info lacks '{key}':\n{text}");
    }
    let rays = d.join("rays.bin");
    std::fs::write(
        &rays,
        ray_bytes(&[
            [0.0, 0.0, 5.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY], // hits triangle 0 at t = 5
            [0.0, 0.0, 5.0, 0.0, 0.0, -1.0, 5.5, f32::INFINITY], // skips it: triangle 1 at t = 6
            [5.0, 5.0, 5.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY], // misses
            // tmin = tmax at triangle 0: an empty interval, a miss (a NaN ray is refused,
            // `hostile.rs`).
            [0.0, 0.0, 5.0, 0.0, 0.0, -1.0, 5.0, 5.0],
        ]),
    )
    .unwrap();
    let hits = d.join("hits.bin");
    // Every input kind, packet width and mode gives the same hits (4 rays: one partial packet of
    // 8).
    // Also through the stream API.
    for (input, packet, mode, how) in [&kdt, &mesh]
        .into_iter()
        .flat_map(|i| ["1", "4", "8"].map(|p| (i, p)))
        .flat_map(|(i, p)| ["fast", "watertight"].map(|m| (i, p, m)))
        .flat_map(|(i, p, m)| [&[][..], &["--stream"]].map(|h| (i, p, m, h)))
    {
        let mut args = vec![
            "trace",
            s(input),
            "--rays",
            s(&rays),
            "--out",
            s(&hits),
            "--repeat",
            "2",
            "--threads",
            "1",
            "--packet",
            packet,
        ];
        if mode == "watertight" {
            args.push("--watertight");
        }
        args.extend(how);
        let out = kdray(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let line = String::from_utf8_lossy(&out.stdout);
        let packet_key = format!("packet={packet}");
        let mode_key = format!("mode={mode}");
        for key in [
            "build_ms=",
            "trace_ms=",
            "mrays_s=",
            "rays=4",
            "hits=2",
            &packet_key,
            "isa=",
            &mode_key,
        ] {
            assert!(line.contains(key), "trace line lacks {key}: {line}");
        }
        let b = std::fs::read(&hits).unwrap();
        assert_eq!(b.len(), 4 * 16);
        let f = |i: usize| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        let u = |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!((f(0), u(1)), (5.0, 0));
        assert_eq!((f(4), u(5)), (6.0, 1));
        assert_eq!((f(8), u(9)), (f32::INFINITY, u32::MAX));
        assert_eq!((f(12), u(13)), (f32::INFINITY, u32::MAX));
    }
}

/// `build --layout wide` writes a wide section that `info` reports and `trace` walks, to the
/// same hits file as the nodes-only layout (single rays, the stream and packets, both modes); the
/// retired `--layout blocked` and `--in-flight` are usage errors that say what replaces them.
#[test]
fn wide_layout_round_trip() {
    let d = dir("wide");
    let mesh = d.join("scatter.tri");
    let tris: Vec<[f32; 9]> = (0..400)
        .map(|i| {
            let p = [
                (i * 7 % 13) as f32,
                (i * 11 % 17) as f32,
                (i * 5 % 19) as f32,
            ];
            [
                p[0],
                p[1],
                p[2],
                p[0] + 1.5,
                p[1],
                p[2] + 0.2,
                p[0],
                p[1] + 1.2,
                p[2] - 0.3,
            ]
        })
        .collect();
    tri_file(&mesh, &tris);
    let rays = d.join("rays.bin");
    let ray_set: Vec<[f32; 8]> = (0..500)
        .map(|i| {
            let a = i as f32 * 0.61;
            let dir = [a.cos() * 0.6, a.sin() * 0.6, -0.8];
            [6.0, 8.0, 30.0, dir[0], dir[1], dir[2], 0.0, f32::INFINITY]
        })
        .collect();
    std::fs::write(&rays, ray_bytes(&ray_set)).unwrap();
    let kdt = |layout: &str| {
        let kdt = d.join(format!("{layout}.kdt"));
        let out = kdray(&["build", s(&mesh), "-o", s(&kdt), "--layout", layout]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        kdt
    };
    let (nodes, wide) = (kdt("nodes"), kdt("wide"));
    let info = String::from_utf8_lossy(&kdray(&["info", s(&wide)]).stdout).into_owned();
    assert!(info.contains("layout          wide ("), "{info}");
    let info = String::from_utf8_lossy(&kdray(&["info", s(&nodes)]).stdout).into_owned();
    assert!(info.contains("layout          nodes ("), "{info}");
    for (packet, stream) in [("1", false), ("1", true), ("8", false)] {
        for watertight in [false, true] {
            let trace = |kdt: &Path, name: &str| {
                let hits = d.join(name);
                let mut args = vec!["trace", s(kdt), "--rays", s(&rays), "--out", s(&hits)];
                args.extend(["--packet", packet, "--threads", "1"]);
                if stream {
                    args.push("--stream");
                }
                if watertight {
                    args.push("--watertight");
                }
                let out = kdray(&args);
                assert!(
                    out.status.success(),
                    "{}",
                    String::from_utf8_lossy(&out.stderr)
                );
                (
                    String::from_utf8_lossy(&out.stdout).into_owned(),
                    std::fs::read(hits).unwrap(),
                )
            };
            let (line_n, hits_n) = trace(&nodes, "nodes.hits");
            let (line_w, hits_w) = trace(&wide, "wide.hits");
            assert!(line_n.contains("layout=nodes"), "{line_n}");
            assert!(line_w.contains("layout=wide"), "{line_w}");
            assert!(
                line_w.contains("hits=") && !line_w.contains("hits=0 "),
                "{line_w}"
            );
            assert!(
                hits_n == hits_w,
                "packet {packet}, stream {stream}, watertight {watertight}"
            );
        }
    }
    let retired: [&[&str]; 2] = [
        &["build", s(&mesh), "-o", "x.kdt", "--layout", "blocked"],
        &[
            "trace",
            s(&wide),
            "--rays",
            s(&rays),
            "--out",
            "h",
            "--in-flight",
            "16",
        ],
    ];
    for args in retired {
        let out = kdray(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("retired") && err.contains("wide"),
            "{args:?}: {err}"
        );
    }
}

/// The builder stores triangles in leaf order; hits must still name them by their input index,
/// with barycentrics relative to their input vertices.
#[test]
fn hits_report_input_order() {
    let d = dir("order");
    let mesh = d.join("row.tri");
    let n = 64;
    // Triangle i sits at x = slot(i), a scrambled position, so leaf order differs from input
    // order; vertex order alternates so that (u, v) depends on it.
    let slot = |i: usize| ((i * 37) % n) as f32 * 3.0;
    let tris: Vec<[f32; 9]> = (0..n)
        .map(|i| {
            let x = slot(i);
            let (a, b, c) = ([x, 0.0, 0.0], [x + 2.0, 0.0, 0.0], [x, 2.0, 0.0]);
            let [p, q, r] = if i % 2 == 0 { [a, b, c] } else { [b, c, a] };
            [p[0], p[1], p[2], q[0], q[1], q[2], r[0], r[1], r[2]]
        })
        .collect();
    tri_file(&mesh, &tris);
    let kdt = d.join("row.kdt");
    assert!(kdray(&["build", s(&mesh), "-o", s(&kdt)]).status.success());
    // One ray per triangle, in input order, at the point with barycentrics (0.25, 0.5).
    let rays: Vec<[f32; 8]> = tris
        .iter()
        .map(|t| {
            let at = |k: usize| t[k] + 0.25 * (t[3 + k] - t[k]) + 0.5 * (t[6 + k] - t[k]);
            [at(0), at(1), 4.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY]
        })
        .collect();
    let rays_file = d.join("rays.bin");
    std::fs::write(&rays_file, ray_bytes(&rays)).unwrap();
    let hits = d.join("hits.bin");
    // The stream reorders rays internally: its hits too must come back in input order.
    let hows: [&[&str]; 2] = [&[], &["--stream"]];
    for (packet, how) in ["1", "4", "8"]
        .into_iter()
        .flat_map(|p| hows.map(|h| (p, h)))
    {
        let mut args = vec![
            "trace",
            s(&kdt),
            "--rays",
            s(&rays_file),
            "--out",
            s(&hits),
            "--packet",
            packet,
        ];
        args.extend(how);
        let out = kdray(&args);
        assert!(out.status.success());
        let b = std::fs::read(&hits).unwrap();
        let f = |i: usize| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        let u = |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        for i in 0..n {
            assert_eq!(u(4 * i + 1), i as u32, "packet {packet} {how:?}: ray {i}");
            assert_eq!(f(4 * i), 4.0);
            assert!((f(4 * i + 2) - 0.25).abs() < 1e-5 && (f(4 * i + 3) - 0.5).abs() < 1e-5);
        }
    }
}

/// Asserts exit code 1 and a message naming `path`.
fn assert_input_error(out: &Output, path: &Path) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {err}");
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(err.contains(name), "message does not name {name}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_inputs_exit_1_and_name_the_file() {
    let d = dir("bad");
    let kdt = d.join("out.kdt");
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated.tri", vec![5, 0, 0, 0, 1, 2, 3]),
        ("empty.tri", 0u32.to_le_bytes().to_vec()),
        (
            "nan.obj",
            b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n".to_vec(),
        ),
        (
            "range.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(),
        ),
        (
            "broken.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n".to_vec(),
        ),
        ("bad.toml", b"[camera\nkind = 1".to_vec()),
        ("unknown.xyz", b"hello".to_vec()),
    ];
    for (name, bytes) in cases {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        assert_input_error(&kdray(&["build", s(&p), "-o", s(&kdt)]), &p);
    }
    let missing = d.join("missing.ply");
    assert_input_error(&kdray(&["build", s(&missing), "-o", s(&kdt)]), &missing);
    // A corrupt .kdt and a rays file that is not a whole number of rays.
    let bad_kdt = d.join("bad.kdt");
    std::fs::write(&bad_kdt, [0u8; 200]).unwrap();
    assert_input_error(&kdray(&["info", s(&bad_kdt)]), &bad_kdt);
    let mesh = d.join("ok.tri");
    tri_file(&mesh, &[[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]]);
    let rays = d.join("short.bin");
    std::fs::write(&rays, [0u8; 33]).unwrap();
    let hits = d.join("hits.bin");
    assert_input_error(
        &kdray(&["trace", s(&mesh), "--rays", s(&rays), "--out", s(&hits)]),
        &rays,
    );
}

#[test]
fn both_build_qualities_write_trees_and_report_the_peak_memory() {
    let d = dir("quality");
    let mesh = d.join("grid.tri");
    // A 20 x 20 grid of unit triangles in z = 0, and the same one at z = 1.
    let tris: Vec<[f32; 9]> = (0..800)
        .map(|i| {
            let (x, y, z) = ((i % 20) as f32, ((i / 20) % 20) as f32, (i / 400) as f32);
            [x, y, z, x + 1.0, y, z, x, y + 1.0, z]
        })
        .collect();
    tri_file(&mesh, &tris);
    for quality in ["high", "fast"] {
        let kdt = d.join(format!("{quality}.kdt"));
        let out = kdray(&["build", s(&mesh), "-o", s(&kdt), "--quality", quality]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("800 triangles"), "{text}");
        if cfg!(target_os = "linux") {
            assert!(text.contains("peak_mib="), "{text}");
            // The build's CPU time, a whole number of ms (ticks of 10 ms).
            let cpu = text
                .split("cpu_ms=")
                .nth(1)
                .and_then(|t| t.split(',').next());
            assert!(cpu.is_some_and(|ms| ms.parse::<u64>().is_ok()), "{text}");
        }
        assert!(kdray(&["info", s(&kdt)]).status.success());
    }
    let out = kdray(&["build", s(&mesh), "-o", "x.kdt", "--quality", "medium"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("medium") && err.contains("fast"), "{err}");
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(kdray(&[]).status.code(), Some(2));
    assert_eq!(kdray(&["build"]).status.code(), Some(2));
    assert_eq!(
        kdray(&[
            "trace", "x.tri", "--rays", "r", "--out", "h", "--packet", "3"
        ])
        .status
        .code(),
        Some(2)
    );
    assert_eq!(
        kdray(&[
            "trace", "x.tri", "--rays", "r", "--out", "h", "--repeat", "0"
        ])
        .status
        .code(),
        Some(2)
    );
    assert_eq!(
        kdray(&[
            "trace", "x.tri", "--rays", "r", "--out", "h", "--layout", "tiles"
        ])
        .status
        .code(),
        Some(2)
    );
}

/// Decodes an 8-bit RGB PNG: (width, height, bytes).
fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn render_draws_the_default_scene_the_right_way_round() {
    let d = dir("render-default");
    let out = d.join("room.png");
    let o = kdray(&["render", "-o", s(&out), "--size", "32x32", "--spp", "4"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let line = String::from_utf8_lossy(&o.stdout);
    assert!(
        line.starts_with("wrote ") && line.contains("32x32, 4 spp"),
        "{line}"
    );
    let (w, h, px) = read_png(&out);
    assert_eq!((w, h), (32, 32));
    // The red wall is on the left, the green one on the right (x = -1 and x = +1, seen from +z).
    let mean = |x0: usize, x1: usize, c: usize| {
        let mut sum = 0.0;
        for y in 0..h as usize {
            for x in x0..x1 {
                sum += f64::from(px[(y * w as usize + x) * 3 + c]);
            }
        }
        sum / ((x1 - x0) * h as usize) as f64
    };
    let (left_r, left_g) = (mean(1, 4, 0), mean(1, 4, 1));
    let (right_r, right_g) = (mean(28, 31, 0), mean(28, 31, 1));
    assert!(left_r > 1.3 * left_g, "left wall r {left_r} g {left_g}");
    assert!(
        right_g > 1.3 * right_r,
        "right wall r {right_r} g {right_g}"
    );
}

#[test]
fn render_is_the_same_on_one_thread_and_two_and_with_single_ray_or_stream_bounces() {
    let d = dir("render-threads");
    let (a, b, c) = (d.join("a.png"), d.join("b.png"), d.join("c.png"));
    let e = d.join("e.png");
    let runs = [
        (&a, &["--threads", "1"][..]),
        (&b, &["--threads", "2"]),
        (&c, &["--bounces", "single"]),
        (&e, &["--bounces", "stream", "--threads", "2"]),
    ];
    for (out, extra) in runs {
        let args = ["render", "-o", s(out), "--size", "16x16", "--spp", "2"];
        let o = kdray(&[&args[..], extra].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(read_png(&a), read_png(&b));
    assert_eq!(read_png(&a), read_png(&c));
    assert_eq!(read_png(&a), read_png(&e));
}

#[test]
fn render_errors_name_the_file_and_usage_errors_exit_2() {
    let d = dir("render-errors");
    let fails = |args: &[&str], needle: &str| {
        let o = kdray(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    };
    let jpg = d.join("out.jpg");
    fails(&["render", "-o", s(&jpg)], "out.jpg");
    let missing = d.join("missing.toml");
    fails(
        &["render", s(&missing), "-o", s(&d.join("m.png"))],
        "missing.toml",
    );
    let deep = d.join("deep.toml");
    std::fs::write(
        &deep,
        "[camera]\nkind = \"pinhole\"\neye = [0, 0, 3]\ntarget = [0, 0, 0]\n\
         [render]\nmax_depth = 5000\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n",
    )
    .unwrap();
    fails(
        &["render", s(&deep), "-o", s(&d.join("deep.png"))],
        "deep.toml",
    );
    for args in [
        &["render", "--spp", "0"][..],
        &["render", "--size", "0x4"],
        &["render", "--size", "big"],
    ] {
        assert_eq!(kdray(args).status.code(), Some(2), "{args:?}");
    }
}

#[test]
fn build_writes_a_render_description_for_scene_files_only() {
    let d = dir("description");
    let (kdt, kdr) = (d.join("room.kdt"), d.join("room.kdr"));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/default.toml");
    let o = kdray(&["build", scene, "-o", s(&kdt), "--description", s(&kdr)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("render description"), "{stdout}");
    let words = |p: &Path| -> Vec<u32> {
        let bytes = std::fs::read(p).unwrap();
        bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    let (scene_words, desc_words) = (words(&kdt), words(&kdr));
    let scene = kdray_core::Scene::from_words(&scene_words).unwrap();
    let desc = kdray_core::description::Description::from_words(&desc_words, &scene, &scene_words)
        .unwrap();
    assert_eq!(desc.settings().spp, 64);
    // `render --checksum` prints the pixels' checksum, the same on one thread and two.
    let sums: Vec<String> = ["1", "2"]
        .iter()
        .map(|threads| {
            let png = d.join(format!("room-{threads}.png"));
            let args = ["render", "-o", s(&png), "--size", "8x8", "--spp", "1"];
            let o = kdray(&[&args[..], &["--checksum", "--threads", threads]].concat());
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let line = String::from_utf8_lossy(&o.stdout).to_string();
            let sum = line
                .split("checksum=")
                .nth(1)
                .expect("a checksum")
                .trim()
                .to_string();
            assert_eq!(sum.len(), 8, "{line}");
            sum
        })
        .collect();
    assert_eq!(sums[0], sums[1]);
    // A mesh has no camera or materials to describe: a usage error.
    let mesh = d.join("one.tri");
    tri_file(&mesh, &[[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]]);
    let o = kdray(&["build", s(&mesh), "-o", s(&kdt), "--description", s(&kdr)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--description"));
}

/// `kdray build --quality fast --leaves list` builds the tree the npm and Python packages build
/// by default (`fast`, the SAH priced in groups of four whatever the leaves, index lists, wide
/// nodes): the same words but for the header's build time and checksum.
#[test]
fn build_fast_with_lists_is_the_packages_default_tree() {
    use kdray::build::{BuildParams, Quality, build};
    use kdray::flat::{Layout, Leaves, read_kdt, serialize_as};
    use kdray_core::format::{header, seal};
    let d = dir("packages-tree");
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/bunny.ply.gz");
    let kdt = d.join("fast.kdt");
    let out = kdray(&[
        "build",
        s(&mesh),
        "-o",
        s(&kdt),
        "--quality",
        "fast",
        "--leaves",
        "list",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let geom = kdray::load::load_mesh(&mesh).unwrap();
    let params = BuildParams::grouped().with_quality(Quality::Fast);
    let tree = build(&geom, &params, None).unwrap();
    let mut packages = serialize_as(&tree, &geom, 0.0, Layout::Wide, Leaves::List).unwrap();
    let mut cli = read_kdt(&kdt).unwrap();
    for words in [&mut packages, &mut cli] {
        words[header::BUILD_MS] = 0;
        seal(words);
    }
    assert_eq!(cli.len(), packages.len());
    assert!(cli == packages, "the CLI's fast tree is not the packages'");
}
