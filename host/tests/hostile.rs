//! Bad input everywhere (issue 12, item 6): every subcommand, given an empty, truncated,
//! oversized-count, NaN, gzip-bomb or binary-garbage file, exits 1 with a message naming that
//! file, never panics, and stays inside a memory limit far below what the input claims (each run
//! here is under `ulimit -v` of 1.5 GiB, where the 4-billion-item headers and the bombs of the
//! probe grew past 4 GB). Then one test per probe finding: the `kdray rays` overflow, overflowing
//! `.tri` edges, short ray directions, flipped `.kdt` bits, argument validation, non-regular
//! inputs and outputs checked before the work.

use flate2::Compression;
use flate2::write::GzEncoder;
use std::io::Write;
use std::process::{Command, Output};

mod common;
use common::{dir, s};

/// Virtual memory limit of every run, in KiB (1.5 GiB: threads and allocator arenas included).
const MEM_LIMIT_KIB: u64 = 1536 * 1024;

/// Runs `kdray args` under the memory limit.
fn kdray(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {MEM_LIMIT_KIB}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts exit code `code` and a message naming `file` (and containing `words`, if given).
#[track_caller]
fn assert_fails(out: &Output, code: i32, file: &str, words: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(file), "message should name {file}: {err}");
    assert!(err.contains(words), "message should say {words:?}: {err}");
}

fn tri_bytes(tris: &[[f32; 9]]) -> Vec<u8> {
    let mut b = (tris.len() as u32).to_le_bytes().to_vec();
    for v in tris.iter().flatten() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::best());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// A gzip file of `members` members, each `chunk` zero bytes, after one member holding `head`:
/// inflates to `head.len() + members · chunk` bytes from a few hundred bytes a member.
fn zero_bomb(head: &[u8], chunk: usize, members: usize) -> Vec<u8> {
    let mut out = gzip(head);
    let zeros = gzip(&vec![0u8; chunk]);
    for _ in 0..members {
        out.extend_from_slice(&zeros);
    }
    out
}

const GOOD_TRI: [[f32; 9]; 1] = [[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]];

fn ray_bytes(rays: &[[f32; 8]]) -> Vec<u8> {
    rays.iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// The bad files, by class: (class, file name, bytes).
fn bad_meshes() -> Vec<(&'static str, &'static str, Vec<u8>)> {
    let ply_head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nelement face 1\n\
                    property list uchar int vertex_indices\nend_header\n";
    let mut good_ply = ply_head.as_bytes().to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        good_ply.extend_from_slice(&v.to_le_bytes());
    }
    good_ply.push(3);
    for i in [0i32, 1, 2] {
        good_ply.extend_from_slice(&i.to_le_bytes());
    }
    let mut garbage = Vec::new();
    let mut x = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..4096 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        garbage.push(x as u8);
    }
    // The probe's 242-byte PLY: an element without properties counted 4 billion times.
    let no_props = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nelement nothing 4000000000\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let huge_faces = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                      property float y\nproperty float z\nelement face 1073741824\n\
                      property list uchar int vertex_indices\nend_header\n";
    let huge_verts = "ply\nformat binary_little_endian 1.0\nelement vertex 536870912\n\
                      property float x\nproperty float y\nproperty float z\nelement face 1\n\
                      property list uchar int vertex_indices\nend_header\n";
    let mut tri_huge_count = u32::MAX.to_le_bytes().to_vec();
    tri_huge_count.extend_from_slice(&tri_bytes(&GOOD_TRI)[4..]);
    let nan_tri = [[0.0, f32::NAN, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]];
    let no_trailer = {
        let g = gzip(&good_ply);
        g[..g.len() - 8].to_vec()
    };
    vec![
        ("empty", "e.ply", vec![]),
        ("empty", "e.ply.gz", vec![]),
        ("empty", "e.obj", vec![]),
        ("empty", "e.tri", vec![]),
        ("empty", "e.toml", vec![]),
        (
            "truncated",
            "t.ply",
            good_ply[..good_ply.len() - 5].to_vec(),
        ),
        ("truncated", "t.ply.gz", no_trailer),
        ("truncated", "t.tri", tri_bytes(&GOOD_TRI)[..30].to_vec()),
        (
            "truncated",
            "t.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2".to_vec(),
        ),
        ("oversized count", "props.ply", no_props.as_bytes().to_vec()),
        (
            "oversized count",
            "faces.ply",
            huge_faces.as_bytes().to_vec(),
        ),
        (
            "oversized count",
            "verts.ply",
            huge_verts.as_bytes().to_vec(),
        ),
        ("oversized count", "count.tri", tri_huge_count),
        (
            "oversized count",
            "idx.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4000000000\n".to_vec(),
        ),
        (
            "nan",
            "n.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
              property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
              end_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"
                .to_vec(),
        ),
        (
            "nan",
            "n.obj",
            b"v 0 0 0\nv NaN 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
        ),
        ("nan", "n.tri", tri_bytes(&nan_tri)),
        (
            "nan",
            "n.toml",
            b"[[sphere]]\ncenter = [0.0, nan, 0.0]\nradius = 1.0\n".to_vec(),
        ),
        // 1 MiB of zeros a member, 600 members: 600 MiB inflated from under 1 MiB.
        (
            "gzip bomb",
            "b.ply.gz",
            zero_bomb(ply_head.as_bytes(), 1 << 20, 600),
        ),
        // The probe's bombs: 2^30 empty faces, 2^29 zero vertices (header and payload gzipped).
        (
            "gzip bomb",
            "faces.ply.gz",
            zero_bomb(huge_faces.as_bytes(), 1 << 20, 1024),
        ),
        (
            "gzip bomb",
            "verts.ply.gz",
            zero_bomb(huge_verts.as_bytes(), 1 << 20, 700),
        ),
        ("garbage", "g.ply", garbage.clone()),
        ("garbage", "g.ply.gz", garbage.clone()),
        ("garbage", "g.obj", garbage.clone()),
        ("garbage", "g.tri", garbage.clone()),
        ("garbage", "g.toml", garbage),
    ]
}

/// `build`, `trace` and `rays` on every bad mesh or scene; `render` on every bad scene and on a
/// scene that loads each bad mesh: exit 1, the bad file named, memory bounded.
#[test]
fn every_subcommand_refuses_every_bad_input_class() {
    let d = dir("classes");
    let rays = d.join("ok.rays");
    std::fs::write(
        &rays,
        ray_bytes(&[[0.2, 0.2, 1.0, 0.0, 0.0, -1.0, 0.0, 1e30]]),
    )
    .unwrap();
    let (kdt, hits, out_rays, png) = (
        d.join("o.kdt"),
        d.join("o.hits"),
        d.join("o.rays"),
        d.join("o.png"),
    );
    for (class, name, bytes) in bad_meshes() {
        let file = d.join(name);
        std::fs::write(&file, &bytes).unwrap();
        let f = s(&file);
        let mut runs: Vec<Vec<&str>> = vec![vec!["build", f, "-o", s(&kdt)]];
        // The bombs take seconds each to inflate in a debug build; every subcommand loads
        // through the same function, so `build` (and `render` below) stand for the rest there.
        if class != "gzip bomb" {
            runs.push(vec!["trace", f, "--rays", s(&rays), "--out", s(&hits)]);
            runs.push(vec!["rays", f, "-o", s(&out_rays)]);
        }
        for args in &runs {
            let out = kdray(args);
            assert_eq!(
                out.status.code(),
                Some(1),
                "{class} {name} {args:?}: {}",
                stderr(&out)
            );
            assert_fails(&out, 1, name, "");
        }
        assert!(
            !kdt.exists() && !hits.exists() && !out_rays.exists(),
            "{class} {name}"
        );
        // Render sees meshes through a scene file, and scenes directly.
        if class == "gzip bomb" && name != "b.ply.gz" {
            continue;
        }
        let scene = if name.ends_with(".toml") {
            file.clone()
        } else {
            let scene = d.join(format!("uses-{name}.toml"));
            std::fs::write(&scene, format!("[[mesh]]\npath = \"{name}\"\n")).unwrap();
            scene
        };
        let out = kdray(&[
            "render",
            s(&scene),
            "-o",
            s(&png),
            "--size",
            "4x4",
            "--spp",
            "1",
        ]);
        assert_fails(&out, 1, name, "");
        assert!(!png.exists(), "{class} {name}");
    }
    // The .kdt and rays inputs: empty, truncated, oversized count, NaN, garbage.
    std::fs::write(d.join("one.tri"), tri_bytes(&GOOD_TRI)).unwrap();
    assert!(
        kdray(&["build", s(&d.join("one.tri")), "-o", s(&kdt)])
            .status
            .success()
    );
    let good = std::fs::read(&kdt).unwrap();
    let mut huge = good.clone();
    huge[5 * 4..6 * 4].copy_from_slice(&u32::MAX.to_le_bytes()); // TRI_COUNT
    let mut nan_bounds = good.clone();
    nan_bounds[9 * 4..10 * 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let bad_kdts = [
        ("e.kdt", vec![]),
        ("t.kdt", good[..good.len() - 4].to_vec()),
        ("odd.kdt", good[..good.len() - 1].to_vec()),
        ("c.kdt", huge),
        ("n.kdt", nan_bounds),
        ("g.kdt", vec![0xA5; 4096]),
    ];
    for (name, bytes) in bad_kdts {
        let file = d.join(name);
        std::fs::write(&file, bytes).unwrap();
        assert_fails(&kdray(&["info", s(&file)]), 1, name, "");
        let out = kdray(&["trace", s(&file), "--rays", s(&rays), "--out", s(&hits)]);
        assert_fails(&out, 1, name, "");
        assert_fails(&kdray(&["rays", s(&file), "-o", s(&out_rays)]), 1, name, "");
    }
    for (name, bytes) in [
        ("e.rays", vec![]),
        ("t.rays", vec![0u8; 33]),
        (
            "n.rays",
            ray_bytes(&[[0.0, 0.0, 1.0, f32::NAN, 0.0, 1e-9, 0.0, 1.0]]),
        ),
        ("g.rays", vec![0x7f; 320]),
    ] {
        let file = d.join(name);
        std::fs::write(&file, bytes).unwrap();
        let out = kdray(&["trace", s(&kdt), "--rays", s(&file), "--out", s(&hits)]);
        // An empty rays file is zero rays (a valid, empty hits file); a NaN ray is refused
        // (`rays_that_ask_another_question_are_refused`).
        if name == "e.rays" {
            assert!(out.status.success(), "{name}: {}", stderr(&out));
        } else {
            assert_fails(&out, 1, name, "");
        }
    }
}

/// `kdray rays` panicked (exit 101) framing a triangle with coordinates 1e19: now a refusal
/// naming the input (the builder refuses it first: too large for f32 arithmetic, and so does it
/// 1e18, which framed but was never hit in fast mode); 1e12 still frames.
#[test]
fn rays_refuses_a_scene_too_large_to_frame() {
    let d = dir("frame");
    let big = d.join("big.tri");
    std::fs::write(
        &big,
        tri_bytes(&[[0.0, 0.0, 0.0, 1e19, 0.0, 0.0, 0.0, 1e19, 0.0]]),
    )
    .unwrap();
    let out = kdray(&["rays", s(&big), "-o", s(&d.join("r.bin")), "--size", "4x4"]);
    assert_fails(&out, 1, "big.tri", "too large");
    let big = d.join("big18.tri");
    std::fs::write(
        &big,
        tri_bytes(&[[0.0, 0.0, 0.0, 1e18, 0.0, 0.0, 0.0, 1e18, 0.0]]),
    )
    .unwrap();
    let out = kdray(&["rays", s(&big), "-o", s(&d.join("r.bin")), "--size", "4x4"]);
    assert_fails(&out, 1, "big18.tri", "too large for f32");
    let ok = d.join("ok.tri");
    std::fs::write(
        &ok,
        tri_bytes(&[[0.0, 0.0, 0.0, 1e12, 0.0, 0.0, 0.0, 1e12, 0.0]]),
    )
    .unwrap();
    let out = kdray(&["rays", s(&ok), "-o", s(&d.join("r.bin")), "--size", "4x4"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Finite vertices ±3e38 apart overflow the stored edges: the error names the input `.tri`, and
/// no `.kdt` (nor a temporary) is left behind.
#[test]
fn overflowing_edges_name_the_input_and_leave_no_output() {
    let d = dir("edges");
    let tri = d.join("far.tri");
    std::fs::write(
        &tri,
        tri_bytes(&[[-3e38, 0.0, 0.0, 3e38, 0.0, 0.0, 0.0, 1.0, 0.0]]),
    )
    .unwrap();
    let kdt = d.join("far.kdt");
    let out = kdray(&["build", s(&tri), "-o", s(&kdt)]);
    assert_fails(&out, 1, "far.tri", "overflow");
    assert!(!stderr(&out).contains("far.kdt"), "{}", stderr(&out));
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 1, "only the input is there: {left:?}");
}

/// Directions must be normalized (docs/FORMATS.md's rays file): one of length 1e-7, which every packet
/// width used to let miss a triangle straight ahead, is refused with its index.
#[test]
fn trace_refuses_unnormalized_directions_by_index() {
    let d = dir("dirs");
    let tri = d.join("one.tri");
    std::fs::write(&tri, tri_bytes(&GOOD_TRI)).unwrap();
    let rays = d.join("r.bin");
    let ok = [0.2, 0.2, 1.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY];
    let short = [0.2, 0.2, 1.0, 0.0, 0.0, -1e-7, 0.0, f32::INFINITY];
    std::fs::write(&rays, ray_bytes(&[ok, ok, short])).unwrap();
    for packet in ["1", "8"] {
        let out = kdray(&[
            "trace",
            s(&tri),
            "--rays",
            s(&rays),
            "--out",
            s(&d.join("h.bin")),
            "--packet",
            packet,
        ]);
        assert_fails(&out, 1, "r.bin", "ray 2");
        assert!(stderr(&out).contains("normalized"), "{}", stderr(&out));
    }
    // Within the tolerance (a writer's rounding): accepted, and hit.
    let near = [0.2, 0.2, 1.0, 0.0, 0.0, -1.0005, 0.0, f32::INFINITY];
    std::fs::write(&rays, ray_bytes(&[ok, near])).unwrap();
    let hits = d.join("h.bin");
    let out = kdray(&["trace", s(&tri), "--rays", s(&rays), "--out", s(&hits)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("hits=2"));
}

/// A flipped bit anywhere in a `.kdt` is refused by `info`, `trace` and `rays` (exit 1, naming the
/// file); the version-4 header of an old file asks for a rebuild.
#[test]
fn flipped_kdt_bits_are_refused() {
    let d = dir("flips");
    let tri = d.join("one.tri");
    std::fs::write(&tri, tri_bytes(&GOOD_TRI)).unwrap();
    let kdt = d.join("one.kdt");
    assert!(
        common::kdray(&["build", s(&tri), "-o", s(&kdt)])
            .status
            .success()
    );
    let good = std::fs::read(&kdt).unwrap();
    let flipped = d.join("flipped.kdt");
    // A bit in every 16th byte (the CLI runs are slow; the core test flips every bit).
    for at in (0..good.len()).step_by(16) {
        let mut b = good.clone();
        b[at] ^= 1 << (at % 8);
        std::fs::write(&flipped, &b).unwrap();
        assert_fails(&kdray(&["info", s(&flipped)]), 1, "flipped.kdt", "");
    }
    let mut b = good.clone();
    b[100] ^= 4;
    std::fs::write(&flipped, &b).unwrap();
    assert_fails(&kdray(&["info", s(&flipped)]), 1, "flipped.kdt", "checksum");
    b = good.clone();
    b[4..8].copy_from_slice(&4u32.to_le_bytes());
    std::fs::write(&flipped, &b).unwrap();
    assert_fails(&kdray(&["info", s(&flipped)]), 1, "flipped.kdt", "rebuild");
}

/// Argument values that build nonsense or stall are usage errors (exit 2), before any input is
/// read (the input here does not even exist).
#[test]
fn nonsense_arguments_are_usage_errors() {
    let d = dir("args");
    let (input, out) = (d.join("missing.tri"), d.join("o.kdt"));
    for arg in [
        "--empty-bonus=nan",
        "--empty-bonus=2",
        "--empty-bonus=1",
        "--empty-bonus=-0.5",
        "--isect-cost=-5",
        "--isect-cost=0",
        "--trav-cost=inf",
        "--trav-cost=nan",
    ] {
        let out = kdray(&["build", s(&input), "-o", s(&out), arg]);
        assert_eq!(out.status.code(), Some(2), "{arg}: {}", stderr(&out));
    }
    let rays = d.join("r.bin");
    for threads in ["0", "100000", "-1", "x"] {
        let out = kdray(&[
            "trace",
            s(&input),
            "--rays",
            s(&rays),
            "--out",
            s(&out),
            &format!("--threads={threads}"),
        ]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "--threads {threads}: {}",
            stderr(&out)
        );
        assert!(stderr(&out).contains("threads"), "{}", stderr(&out));
        let out = kdray(&["render", &format!("--threads={threads}")]);
        assert_eq!(out.status.code(), Some(2), "render --threads {threads}");
    }
}

/// A FIFO (or any non-regular file) as an input is refused at once instead of blocking forever.
#[test]
fn non_regular_inputs_are_refused() {
    let d = dir("fifo");
    for name in ["pipe.ply", "pipe.obj", "pipe.toml", "pipe.kdt"] {
        let fifo = d.join(name);
        let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
        assert!(made.success());
        if name != "pipe.kdt" {
            let out = kdray(&["build", s(&fifo), "-o", s(&d.join("o.kdt"))]);
            assert_fails(&out, 1, name, "not a regular file");
        }
    }
    let out = kdray(&["info", s(&d.join("pipe.kdt"))]);
    assert_fails(&out, 1, "pipe.kdt", "not a regular file");
    let tri = d.join("one.tri");
    std::fs::write(&tri, tri_bytes(&GOOD_TRI)).unwrap();
    let out = kdray(&[
        "trace",
        s(&tri),
        "--rays",
        s(&d.join("pipe.ply")),
        "--out",
        s(&d.join("h")),
    ]);
    assert_fails(&out, 1, "pipe.ply", "not a regular file");
    let folder = d.join("folder.ply");
    std::fs::create_dir_all(&folder).unwrap();
    let out = kdray(&["build", s(&folder), "-o", s(&d.join("o.kdt"))]);
    assert_fails(&out, 1, "folder.ply", "directory");
}

/// Outputs are checked before the work: the error names the output even when the input is bad
/// too (so nothing was loaded, built or rendered first).
#[test]
fn outputs_are_checked_before_the_work() {
    let d = dir("outputs");
    let missing_scene = d.join("nope.toml");
    let out = kdray(&["render", s(&missing_scene), "-o", "/missing-dir/x.png"]);
    assert_fails(&out, 1, "x.png", "does not exist");
    let out = kdray(&["render", "-o", "/missing-dir/x.png"]);
    assert_fails(&out, 1, "x.png", "does not exist");
    let out = kdray(&["build", s(&d.join("nope.tri")), "-o", s(&d)]);
    assert_fails(&out, 1, s(&d), "is a directory");
    let out = kdray(&["build", s(&d.join("nope.tri")), "-o", "/tmp"]);
    assert_fails(&out, 1, "/tmp", "is a directory");
    let rays = d.join("nope.rays");
    let out = kdray(&[
        "trace",
        s(&missing_scene),
        "--rays",
        s(&rays),
        "--out",
        "/missing-dir/h",
    ]);
    assert_fails(&out, 1, "/missing-dir/h", "does not exist");
    let out = kdray(&["rays", s(&missing_scene), "-o", s(&d)]);
    assert_fails(&out, 1, s(&d), "is a directory");
}

/// Issue 20: a ray with `tmin = −inf` was traced (as the whole line behind its origin) and its
/// "hit" written out, exit 0; NaN and infinite rays were written out as misses. Each such ray is
/// now refused by index, naming the rays file, and no hits file is written; `tmin = tmax` (an
/// empty interval) and `tmax = +inf` stay valid.
#[test]
fn rays_that_ask_another_question_are_refused() {
    let d = dir("bad-rays");
    let (kdt, hits) = (d.join("one.kdt"), d.join("hits.bin"));
    std::fs::write(d.join("one.tri"), tri_bytes(&GOOD_TRI)).unwrap();
    let built = kdray(&["build", s(&d.join("one.tri")), "-o", s(&kdt)]);
    assert!(built.status.success(), "{}", stderr(&built));
    let good = [0.25, 0.25, 1.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY];
    let with = |k: usize, v: f32| {
        let mut r = good;
        r[k] = v;
        r
    };
    let bad = [
        (
            "tmin -inf",
            with(6, f32::NEG_INFINITY),
            "tmin must be finite",
        ),
        ("tmin +inf", with(6, f32::INFINITY), "tmin must be finite"),
        ("tmin NaN", with(6, f32::NAN), "tmin must be finite"),
        ("tmax NaN", with(7, f32::NAN), "tmax finite or +inf"),
        (
            "tmax -inf",
            with(7, f32::NEG_INFINITY),
            "tmax finite or +inf",
        ),
        ("tmin > tmax", with(7, -1.0), "tmin is above tmax"),
        ("origin inf", with(0, f32::INFINITY), "not finite"),
        ("direction NaN", with(3, f32::NAN), "not finite"),
    ];
    for (what, ray, words) in bad {
        let file = d.join("bad.rays");
        std::fs::write(&file, ray_bytes(&[good, good, ray])).unwrap();
        let out = kdray(&["trace", s(&kdt), "--rays", s(&file), "--out", s(&hits)]);
        assert_fails(&out, 1, "bad.rays", "ray 2");
        assert!(stderr(&out).contains(words), "{what}: {}", stderr(&out));
        assert!(!hits.exists(), "{what}");
    }
    let empty = with(7, 0.0); // tmin = tmax = 0: nothing can lie in between
    let file = d.join("ok.rays");
    std::fs::write(&file, ray_bytes(&[good, empty])).unwrap();
    let out = kdray(&["trace", s(&kdt), "--rays", s(&file), "--out", s(&hits)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = std::fs::read(&hits).unwrap();
    let t = |i: usize| f32::from_le_bytes(bytes[16 * i..16 * i + 4].try_into().unwrap());
    assert_eq!((t(0), t(1)), (1.0, f32::INFINITY));
}
