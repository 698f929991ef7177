//! Hostile input, round three (issue 29), the CLI's part: outputs that are special files, files
//! larger than memory, scenes that amplify a small mesh, radiance past f32's range, and the
//! smaller findings (mesh paths that are not meshes, long and impossible output names, `hits
//! --first` past the end, `info` on groups, a build over a mesh its scene includes). Each test
//! failed on the code before the fix.

use flate2::Compression;
use flate2::write::GzEncoder;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{dir, kdray, s};

/// Runs `kdray args` under a 2,000,000 KiB address-space limit (the issue's `ulimit -v`).
fn kdray_limited(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2000000; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts exit code `code`, no panic, and a message containing each of `words`.
#[track_caller]
fn fails(out: &Output, code: i32, words: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for w in words {
        assert!(err.contains(w), "should say {w:?}: {err}");
    }
}

#[track_caller]
fn succeeds(out: &Output) -> String {
    assert!(out.status.success(), "{}", stderr(out));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// One triangle as a `.tri` file.
fn tri_file(d: &Path, name: &str) -> PathBuf {
    tri_copies(d, name, 1)
}

/// `n` copies of one triangle as a `.tri` file (one leaf: a group, with `--leaves groups`).
fn tri_copies(d: &Path, name: &str, n: u32) -> PathBuf {
    let mut b = n.to_le_bytes().to_vec();
    for _ in 0..n {
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let p = d.join(name);
    std::fs::write(&p, b).unwrap();
    p
}

/// A rays file: one ray from above the `tri_file` triangle, straight down.
fn rays_file(d: &Path) -> PathBuf {
    let mut b = Vec::new();
    for v in [0.2f32, 0.2, 1.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let p = d.join("r.bin");
    std::fs::write(&p, b).unwrap();
    p
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

#[cfg(unix)]
fn is_fifo(path: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_fifo())
}

/// An output that is a FIFO or a device is refused, exit 1, and stays what it was (it used to be
/// replaced by a regular file, exit 0). `/dev/null` is tried for real only where replacing it is
/// impossible anyway (not root); as root, a device node with `/dev/null`'s numbers made in the
/// scratch folder stands in for it.
#[cfg(unix)]
#[test]
fn special_outputs_are_never_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let d = dir("special-outputs");
    let mesh = tri_file(&d, "m.tri");
    let rays = rays_file(&d);
    let fifo = d.join("out.fifo");
    let fifo_png = d.join("out.png");
    mkfifo(&fifo);
    mkfifo(&fifo_png);
    let runs: [Vec<&str>; 4] = [
        vec!["trace", s(&mesh), "--rays", s(&rays), "--out", s(&fifo)],
        vec!["build", s(&mesh), "-o", s(&fifo)],
        vec!["rays", s(&mesh), "--size", "4x4", "-o", s(&fifo)],
        vec!["render", "--size", "4x4", "--spp", "1", "-o", s(&fifo_png)],
    ];
    for args in &runs {
        fails(&kdray(args), 1, &["not a regular file"]);
    }
    assert!(is_fifo(&fifo) && is_fifo(&fifo_png), "the FIFOs are kept");

    let root = std::fs::metadata("/proc/self")
        .map(|m| std::os::unix::fs::MetadataExt::uid(&m) == 0)
        .unwrap_or(true);
    let null = if root {
        let node = d.join("null");
        let made = Command::new("mknod")
            .args([s(&node), "c", "1", "3"])
            .status()
            .is_ok_and(|st| st.success());
        if !made {
            eprintln!("skipped the device part: mknod failed");
            return;
        }
        node
    } else {
        PathBuf::from("/dev/null")
    };
    let out = kdray(&["trace", s(&mesh), "--rays", s(&rays), "--out", s(&null)]);
    fails(&out, 1, &["not a regular file"]);
    let kind = std::fs::symlink_metadata(&null).unwrap().file_type();
    assert!(
        kind.is_char_device(),
        "{} is still a device",
        null.display()
    );
}

/// `-o file.tri/x.kdt` says the parent is not a directory (it said "does not exist"); an output
/// name of 250 characters is written (its temporary's name was too long).
#[test]
fn output_names_the_file_system_allows_work_and_others_say_why_not() {
    let d = dir("output-names");
    let mesh = tri_file(&d, "m.tri");
    let under_file = mesh.join("x.kdt");
    fails(
        &kdray(&["build", s(&mesh), "-o", s(&under_file)]),
        1,
        &["is not a directory"],
    );
    let long = d.join(format!("{}.kdt", "a".repeat(246)));
    assert_eq!(long.file_name().unwrap().len(), 250);
    succeeds(&kdray(&["build", s(&mesh), "-o", s(&long)]));
    assert!(long.is_file());
}

/// `hits --first` at or past the end is an error naming the count (it printed nothing, exit 0).
#[test]
fn hits_first_past_the_end_is_an_error() {
    let d = dir("hits-first");
    let mesh = tri_file(&d, "m.tri");
    let rays = rays_file(&d);
    let hits = d.join("h.bin");
    succeeds(&kdray(&[
        "trace",
        s(&mesh),
        "--rays",
        s(&rays),
        "--out",
        s(&hits),
    ]));
    let listed = succeeds(&kdray(&["hits", s(&hits), "--first", "0"]));
    assert!(listed.starts_with("0 t=1 prim=0"), "{listed}");
    for first in ["1", "7"] {
        fails(
            &kdray(&["hits", s(&hits), "--first", first]),
            1,
            &["h.bin", "holds 1 hits", "past its end"],
        );
    }
}

/// `info` says what a tree's leaves hold: groups or index lists.
#[test]
fn info_says_whether_leaves_hold_groups() {
    let d = dir("info-groups");
    let mesh = tri_copies(&d, "m.tri", 8);
    for (leaves, words) in [
        ("list", "leaves hold     lists"),
        ("groups", "leaves hold     groups (2 groups"),
    ] {
        let kdt = d.join(format!("{leaves}.kdt"));
        succeeds(&kdray(&[
            "build",
            s(&mesh),
            "-o",
            s(&kdt),
            "--leaves",
            leaves,
        ]));
        let info = succeeds(&kdray(&["info", s(&kdt)]));
        assert!(info.contains(words), "{info}");
    }
}

/// A scene's camera, six lines.
const CAMERA: &str = "[camera]\nkind = \"pinhole\"\neye = [0, 0, 3]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nvfov = 40\n";

/// A scene file naming `mesh` as its one mesh, at line 8.
fn scene_with_mesh(d: &Path, name: &str, mesh: &str) -> PathBuf {
    let text = format!("{CAMERA}\n[[mesh]]\npath = \"{mesh}\"\n");
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `build s.toml -o one.tri`, `trace s.toml --out one.tri`, where the scene includes `one.tri`:
/// refused, the mesh kept (it was overwritten, as documented).
#[test]
fn outputs_never_overwrite_a_mesh_the_scene_includes() {
    let d = dir("scene-mesh-output");
    let mesh = tri_file(&d, "one.tri");
    let before = std::fs::read(&mesh).unwrap();
    let scene = scene_with_mesh(&d, "s.toml", "one.tri");
    let rays = rays_file(&d);
    let words = ["one.tri", "must not overwrite an input"];
    fails(&kdray(&["build", s(&scene), "-o", s(&mesh)]), 1, &words);
    let desc = d.join("s.desc");
    let with_desc = [
        "build",
        s(&scene),
        "-o",
        s(&mesh),
        "--description",
        s(&desc),
    ];
    fails(&kdray(&with_desc), 1, &words);
    let trace = ["trace", s(&scene), "--rays", s(&rays), "--out", s(&mesh)];
    fails(&kdray(&trace), 1, &words);
    assert_eq!(std::fs::read(&mesh).unwrap(), before, "the mesh is kept");
}

/// A mesh path that is a directory (`.`), a FIFO or a file of no mesh format fails naming the
/// scene file and the entry's line (they named only the mesh, or nothing).
#[cfg(unix)]
#[test]
fn mesh_paths_that_are_not_meshes_name_the_scene_and_line() {
    let d = dir("scene-mesh-paths");
    mkfifo(&d.join("pipe.ply"));
    std::fs::write(d.join("notes.txt"), "not a mesh\n").unwrap();
    std::fs::write(d.join("bad.ply"), "ply\nformat nonsense\n").unwrap();
    let out = d.join("o.kdt");
    for (mesh, words) in [
        (".", "a directory"),
        ("pipe.ply", "not a regular file"),
        ("notes.txt", "unknown mesh format"),
        ("bad.ply", "bad.ply"),
    ] {
        let scene = scene_with_mesh(&d, "s.toml", mesh);
        let run = kdray(&["build", s(&scene), "-o", s(&out)]);
        fails(&run, 1, &["s.toml:8:", words]);
    }
}

/// A small scene naming one small `.ply.gz` many times: refused before loading them all, naming
/// the entry where the meshes together pass the cap (it held gigabytes first).
#[test]
fn scenes_amplifying_a_small_mesh_are_refused_before_loading() {
    let d = dir("amplify");
    // One triangle, repeated as 300,000 faces: 3.9 MB inflated from a few KB.
    let faces = 300_000;
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
         property float y\nproperty float z\nelement face {faces}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        ply.extend_from_slice(&v.to_le_bytes());
    }
    let mut face = vec![3u8];
    for i in 0..3i32 {
        face.extend_from_slice(&i.to_le_bytes());
    }
    ply.extend(face.repeat(faces));
    let mut gz = GzEncoder::new(Vec::new(), Compression::best());
    gz.write_all(&ply).unwrap();
    std::fs::write(d.join("small.ply.gz"), gz.finish().unwrap()).unwrap();
    let mut scene = String::from(CAMERA);
    for _ in 0..200 {
        scene.push_str("\n[[mesh]]\npath = \"small.ply.gz\"\n");
    }
    let path = d.join("many.toml");
    std::fs::write(&path, scene).unwrap();
    let out = d.join("o.kdt");
    let run = kdray_limited(&["build", s(&path), "-o", s(&out)]);
    fails(&run, 1, &["many.toml:", "512 MiB", "in all"]);
    assert!(!out.exists());
}

/// Emission or background near f32's maximum is refused at load, naming the key and the cap
/// (renders never stopped with `--noise`, wrote `inf` pixels, printed `relative 0.0000`, and
/// `converge` printed `slope=NaN`, all with exit 0).
#[test]
fn radiance_that_can_overflow_is_refused_at_load() {
    let d = dir("radiance");
    let light = format!(
        "{CAMERA}\n\
         [[material]]\nname = \"sun\"\nkind = \"emissive\"\nemission = [3e38, 3e38, 3e38]\n\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"sun\"\n"
    );
    let sky = format!(
        "{CAMERA}\n\
         [render]\nbackground = [1e30, 0, 0]\n\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n"
    );
    for (name, text, key) in [
        ("light.toml", light, "emission"),
        ("sky.toml", sky, "background"),
    ] {
        let scene = d.join(name);
        std::fs::write(&scene, text).unwrap();
        let png = d.join("o.png");
        let exr = d.join("o.exr");
        let csv = d.join("c.csv");
        for args in [
            vec![
                "render",
                s(&scene),
                "--size",
                "8x8",
                "--noise",
                "0.1",
                "-o",
                s(&png),
            ],
            vec![
                "render",
                s(&scene),
                "--size",
                "8x8",
                "--spp",
                "8",
                "-o",
                s(&exr),
            ],
            vec![
                "converge",
                s(&scene),
                "--size",
                "8x8",
                "--seconds",
                "0.01",
                "-o",
                s(&csv),
            ],
        ] {
            let run = kdray(&args);
            fails(&run, 1, &[name, key, "at most 1e10"]);
            let out = String::from_utf8_lossy(&run.stdout);
            assert!(!out.contains("NaN") && !out.contains("inf"), "{out}");
        }
        assert!(!png.exists() && !exr.exists() && !csv.exists());
    }
}

/// A sparse file of `bytes` zero bytes.
fn sparse(path: &Path, bytes: u64) {
    std::fs::File::create(path).unwrap().set_len(bytes).unwrap();
}

/// `trace` with a 1 GiB rays file and `hits` of a 1 GiB hits file, under a 2 GB address-space
/// limit: they read the whole file and decoded a second copy, and died with SIGABRT. Now `hits`
/// reads only what it prints, and `trace` reads the rays into one allocation, checking each.
#[test]
fn files_larger_than_half_of_memory_are_streamed() {
    let d = dir("large-files");
    let mesh = tri_file(&d, "m.tri");
    let hits = d.join("h.bin");
    sparse(&hits, 1 << 30);
    let run = kdray_limited(&["hits", s(&hits), "--count", "1"]);
    assert_eq!(succeeds(&run), "0 t=0 prim=0 u=0 v=0\n");
    let run = kdray_limited(&["hits", s(&hits), "--first", "67108863"]);
    assert_eq!(succeeds(&run), "67108863 t=0 prim=0 u=0 v=0\n");

    // Zero rays: the first is refused (a direction of length 0), before the rest is read.
    let rays = d.join("r.bin");
    sparse(&rays, 1 << 30);
    let out = d.join("o.bin");
    let run = kdray_limited(&["trace", s(&mesh), "--rays", s(&rays), "--out", s(&out)]);
    fails(&run, 1, &["r.bin", "ray 0"]);
    // Two of them do not fit together with their hits: exit 1 naming the memory.
    let rays2 = d.join("r2.bin");
    sparse(&rays2, 3 << 29);
    let run = kdray_limited(&["trace", s(&mesh), "--rays", s(&rays2), "--out", s(&out)]);
    assert!(matches!(run.status.code(), Some(1)), "{}", stderr(&run));
    assert!(!stderr(&run).contains("panicked"));
    assert!(!out.exists());
}

/// The triangle `(−k, −k, 0), (k, −k, 0), (0, k, 0)` as a `.tri` file.
fn big_triangle(d: &Path, name: &str, k: f32) -> PathBuf {
    let mut b = 1u32.to_le_bytes().to_vec();
    for v in [-k, -k, 0.0, k, -k, 0.0, 0.0, k, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let p = d.join(name);
    std::fs::write(&p, b).unwrap();
    p
}

/// Triangles far from the ray origin: the (±3e12, …) triangle, which `build` accepted
/// and the rays of `kdray rays` all missed (f32 products past 3.4e38), is refused naming the
/// triangle and the bound; at ±1e12 the same rays hit in both modes; a ±1e9 triangle is hit from
/// 1e18 away and a ray from 1e20 is refused naming the ray (it missed).
#[test]
fn far_triangles_are_hit_or_refused() {
    let d = dir("far-triangles");
    let huge = big_triangle(&d, "huge.tri", 3e12);
    let kdt = d.join("huge.kdt");
    let run = kdray(&["build", s(&huge), "-o", s(&kdt)]);
    fails(
        &run,
        1,
        &["huge.tri", "triangle 0", "twice the scene's diagonal"],
    );

    let big = big_triangle(&d, "big.tri", 1e12);
    let rays = d.join("big.rays");
    succeeds(&kdray(&[
        "rays",
        s(&big),
        "--size",
        "64x64",
        "-o",
        s(&rays),
    ]));
    let hits = d.join("big.hits");
    for mode in [None, Some("--watertight")] {
        let mut args = vec!["trace", s(&big), "--rays", s(&rays), "--out", s(&hits)];
        args.extend(mode);
        let out = succeeds(&kdray(&args));
        // The triangle covers 882 of the framing camera's 4,096 pixels at every scale that
        // does not overflow (1e9, 1e11: the figure).
        assert!(out.contains("hits=882 "), "{mode:?}: {out}");
    }

    let small = big_triangle(&d, "small.tri", 1e9);
    let ray = |z: f32| {
        let mut b = Vec::new();
        for v in [0.0f32, 0.0, z, 0.0, 0.0, -1.0, 0.0, f32::INFINITY] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    };
    let near = d.join("near.rays");
    std::fs::write(&near, ray(1e18)).unwrap();
    let out = succeeds(&kdray(&[
        "trace",
        s(&small),
        "--rays",
        s(&near),
        "--out",
        s(&hits),
        "--watertight",
    ]));
    assert!(out.contains("hits=1 "), "{out}");
    let far = d.join("far.rays");
    std::fs::write(&far, ray(1e20)).unwrap();
    let run = kdray(&["trace", s(&small), "--rays", s(&far), "--out", s(&hits)]);
    fails(&run, 1, &["far.rays", "ray 0", "overflow"]);
}
