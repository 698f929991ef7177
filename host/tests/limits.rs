//! Bounded work and loose checks (issue 20): sizes the caps admit but memory cannot hold exit 1
//! naming the cap instead of aborting (each run under a 2 GB address-space limit, the issue's
//! `ulimit -v 2000000`), counts that would loop for ever are usage errors (exit 2), thread
//! limits are usage errors in every command, and error texts blame the key at fault.

use flate2::Compression;
use flate2::write::GzEncoder;
use std::io::Write;
use std::process::{Command, Output};

mod common;
use common::{dir, s};

/// Runs `kdray args` under a 2,000,000 KiB address-space limit.
fn kdray(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2000000; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

#[track_caller]
fn fails(out: &Output, code: i32, words: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for w in words {
        assert!(err.contains(w), "should say {w:?}: {err}");
    }
}

fn tri_file(d: &std::path::Path) -> std::path::PathBuf {
    let mut b = 1u32.to_le_bytes().to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let p = d.join("m.tri");
    std::fs::write(&p, b).unwrap();
    p
}

#[test]
fn a_render_larger_than_memory_exits_1_naming_the_cap() {
    let d = dir("limits-render");
    let out = d.join("big.png");
    let run = kdray(&["render", "--size", "8192x8192", "--spp", "1", "-o", s(&out)]);
    fails(&run, 1, &["big.png", "8192x8192", "67108864 pixels"]);
    assert!(!out.exists());
}

#[test]
fn a_ray_set_larger_than_memory_exits_1_naming_the_cap() {
    let d = dir("limits-rays");
    let mesh = tri_file(&d);
    let out = d.join("big.rays");
    let run = kdray(&["rays", s(&mesh), "--size", "8192x8192", "-o", s(&out)]);
    fails(&run, 1, &["big.rays", "8192x8192", "67108864 rays"]);
    assert!(!out.exists());
}

/// The 99 KB `.ply.gz`: 24,500 faces of 255 corners (6.2 million fan triangles from a
/// 25 MB payload), whose build needs more than 2 GB.
#[test]
fn a_small_ply_gz_of_large_fans_exits_1() {
    let d = dir("limits-fans");
    let (nv, nf) = (256usize, 24_500usize);
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {nv}\nproperty float x\n\
         property float y\nproperty float z\nelement face {nf}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for i in 0..nv {
        let a = i as f32 * 0.02;
        for v in [a.cos(), a.sin(), 0.001 * i as f32] {
            ply.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut face = vec![255u8];
    for i in 0..255i32 {
        face.extend_from_slice(&i.to_le_bytes());
    }
    for _ in 0..nf {
        ply.extend_from_slice(&face);
    }
    let mut gz = GzEncoder::new(Vec::new(), Compression::fast());
    gz.write_all(&ply).unwrap();
    let path = d.join("fans.ply.gz");
    std::fs::write(&path, gz.finish().unwrap()).unwrap();
    let run = kdray(&["build", s(&path), "-o", s(&d.join("f.kdt"))]);
    fails(&run, 1, &["fans.ply.gz", "6198500 triangles", "memory"]);
}

#[test]
fn trace_repeat_is_capped() {
    let d = dir("limits-repeat");
    let mesh = tri_file(&d);
    let rays = d.join("empty.rays");
    std::fs::write(&rays, b"").unwrap();
    let out = d.join("h.hits");
    let args = [
        "trace",
        s(&mesh),
        "--rays",
        s(&rays),
        "--out",
        s(&out),
        "--repeat",
    ];
    let run = kdray(&[&args[..], &["4294967295"]].concat());
    fails(&run, 2, &["--repeat", "1000"]);
    let run = common::kdray(&[&args[..], &["3"]].concat());
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn thread_counts_are_usage_errors_in_every_command() {
    let d = dir("limits-threads");
    let csv = s(&d.join("c.csv")).to_string();
    let png = s(&d.join("r.png")).to_string();
    for n in ["0", "5000"] {
        fails(
            &kdray(&["converge", "-o", &csv, "--threads", n]),
            2,
            &["threads"],
        );
        fails(
            &kdray(&["render", "-o", &png, "--threads", n]),
            2,
            &["threads"],
        );
    }
}

#[test]
fn ascii_ply_face_with_more_indices_than_its_count_is_refused() {
    let d = dir("limits-ply-extra");
    let p = d.join("extra.ply");
    std::fs::write(
        &p,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2 3\n",
    )
    .unwrap();
    let run = kdray(&["build", s(&p), "-o", s(&d.join("e.kdt"))]);
    fails(&run, 1, &["extra.ply:14:", "face 0"]);
}

#[test]
fn a_thick_lens_of_absurd_ior_blames_the_ior() {
    let d = dir("limits-lens");
    let scene = d.join("lens.toml");
    std::fs::write(
        &scene,
        "[camera]\nkind = \"thick_lens\"\neye = [0, 0.45, 3]\ntarget = [0, 0.3, 0]\n\
         vfov = 30.0\nr1 = 1.0\nr2 = 0.11\nl1 = 0.01\nl2 = 0.01\nior = 1e30\naperture = 0.03\n\
         focus = 3.0\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n",
    )
    .unwrap();
    let run = kdray(&[
        "render",
        s(&scene),
        "--size",
        "8x8",
        "--spp",
        "1",
        "-o",
        s(&d.join("l.png")),
    ]);
    fails(
        &run,
        1,
        &["lens.toml", "ior = 1000000000000000000000000000000"],
    );
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !err.contains("vfov"),
        "the field of view is not at fault: {err}"
    );
}

/// Adaptive sampling places each band's samples by that band's variance alone, so merged bands
/// would not be the whole render: the combination is refused as a usage error.
#[test]
fn adaptive_with_tile_is_a_usage_error() {
    let d = dir("limits-adaptive-tile");
    let out = d.join("p.exr");
    let run = kdray(&[
        "render",
        "--adaptive",
        "--tile",
        "1/2",
        "--spp",
        "4",
        "-o",
        s(&out),
    ]);
    fails(&run, 2, &["--adaptive", "--tile"]);
    assert!(!out.exists());
}
