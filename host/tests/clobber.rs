//! Outputs that must never clobber (issue 20): an output that is one of the command's inputs
//! (the same file by device and inode, under any name), two outputs that are one file, a
//! temporary opened through a planted symbolic link, a failed command leaving an output behind,
//! and an unwritable folder found only after the work. Each refusal is exit 1 naming the output,
//! with every input byte for byte as it was.

use std::path::Path;
use std::process::Output;

mod common;
use common::{dir, kdray, s};

/// One small triangle as a `.tri`.
fn tri_bytes() -> Vec<u8> {
    let mut b = 1u32.to_le_bytes().to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

/// A tiny scene: one sphere, 8x8 pixels, 1 spp.
const SCENE: &str = "[camera]\nkind = \"pinhole\"\neye = [0, 0, 3]\ntarget = [0, 0, 0]\n\
                     [render]\nwidth = 8\nheight = 8\nspp = 1\n\
                     [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n";

#[track_caller]
fn refused(out: &Output, names: &str, words: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {err}");
    assert!(err.contains(names), "should name {names}: {err}");
    assert!(err.contains(words), "should say {words:?}: {err}");
}

#[track_caller]
fn unchanged(path: &Path, bytes: &[u8]) {
    assert_eq!(
        std::fs::read(path).unwrap(),
        bytes,
        "{} was overwritten",
        path.display()
    );
}

/// No file but `keep` in `d` (no temporary, no partial output).
#[track_caller]
fn only(d: &Path, keep: &[&str]) {
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want: Vec<String> = keep.iter().map(|k| k.to_string()).collect();
    want.sort();
    assert_eq!(names, want, "files left in {}", d.display());
}

#[test]
fn build_onto_its_own_input_is_refused() {
    let d = dir("clobber-build");
    let mesh = d.join("m.tri");
    std::fs::write(&mesh, tri_bytes()).unwrap();
    let out = kdray(&["build", s(&mesh), "-o", s(&mesh)]);
    refused(&out, "m.tri", "input");
    unchanged(&mesh, &tri_bytes());
    // The same file under another name: a hard link and a symbolic link.
    let hard = d.join("hard.kdt");
    std::fs::hard_link(&mesh, &hard).unwrap();
    refused(
        &kdray(&["build", s(&mesh), "-o", s(&hard)]),
        "hard.kdt",
        "input",
    );
    let soft = d.join("soft.kdt");
    std::os::unix::fs::symlink(&mesh, &soft).unwrap();
    refused(
        &kdray(&["build", s(&mesh), "-o", s(&soft)]),
        "soft.kdt",
        "input",
    );
    unchanged(&mesh, &tri_bytes());
    only(&d, &["m.tri", "hard.kdt", "soft.kdt"]);
}

#[test]
fn description_onto_the_scene_or_the_tree_is_refused() {
    let d = dir("clobber-desc");
    let scene = d.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let kdt = d.join("s.kdt");
    let out = kdray(&[
        "build",
        s(&scene),
        "-o",
        s(&kdt),
        "--description",
        s(&scene),
    ]);
    refused(&out, "s.toml", "input");
    unchanged(&scene, SCENE.as_bytes());
    // Two outputs that are one file, neither existing yet (the second spelled differently).
    let other = d.join(".").join("s.kdt");
    let out = kdray(&[
        "build",
        s(&scene),
        "-o",
        s(&kdt),
        "--description",
        s(&other),
    ]);
    refused(&out, "s.kdt", "two outputs");
    only(&d, &["s.toml"]);
}

#[test]
fn a_failed_description_leaves_no_tree() {
    let d = dir("clobber-desc-fails");
    // 65 materials: more than a render description holds (64), which the tree does not mind.
    let mut text = String::from(SCENE);
    for k in 0..65 {
        text += &format!("[[material]]\nname = \"m{k}\"\nkind = \"diffuse\"\n");
    }
    let scene = d.join("s.toml");
    std::fs::write(&scene, &text).unwrap();
    let (kdt, kdr) = (d.join("s.kdt"), d.join("s.kdr"));
    let out = kdray(&["build", s(&scene), "-o", s(&kdt), "--description", s(&kdr)]);
    refused(&out, "s.toml", "materials");
    only(&d, &["s.toml"]);
}

#[test]
fn trace_onto_its_rays_is_refused() {
    let d = dir("clobber-trace");
    let mesh = d.join("m.tri");
    std::fs::write(&mesh, tri_bytes()).unwrap();
    let rays = d.join("r.rays");
    let ray: Vec<u8> = [0.2f32, 0.2, 1.0, 0.0, 0.0, -1.0, 0.0, 10.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(&rays, &ray).unwrap();
    let out = kdray(&["trace", s(&mesh), "--rays", s(&rays), "--out", s(&rays)]);
    refused(&out, "r.rays", "input");
    unchanged(&rays, &ray);
    let out = kdray(&["trace", s(&mesh), "--rays", s(&rays), "--out", s(&mesh)]);
    refused(&out, "m.tri", "input");
    unchanged(&mesh, &tri_bytes());
    only(&d, &["m.tri", "r.rays"]);
}

#[test]
fn merge_onto_a_part_is_refused() {
    let d = dir("clobber-merge");
    let scene = d.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let parts = [d.join("part1.exr"), d.join("part2.exr")];
    for (k, part) in parts.iter().enumerate() {
        let tile = format!("{}/2", k + 1);
        let out = kdray(&["render", s(&scene), "--tile", &tile, "-o", s(part)]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let before = std::fs::read(&parts[0]).unwrap();
    let out = kdray(&["merge", s(&parts[0]), s(&parts[1]), "-o", s(&parts[0])]);
    refused(&out, "part1.exr", "input");
    unchanged(&parts[0], &before);
}

#[test]
fn accuracy_csv_and_plot_cannot_be_one_file() {
    let d = dir("clobber-accuracy");
    let out = kdray(&["accuracy", "-o", s(&d.join("a.png")), "--rounds", "1"]);
    refused(&out, "a.png", "two outputs");
    only(&d, &[]);
}

/// A symbolic link planted where the old scheme put its temporary (`.NAME.PID.tmp`, this
/// process's id) is not followed: the file it points to keeps its bytes, the output is written.
#[test]
fn a_planted_symlink_at_the_temporary_is_not_followed() {
    let d = dir("clobber-symlink");
    let victim = d.join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let out = d.join("image.bin");
    let planted = d.join(format!(".image.bin.{}.tmp", std::process::id()));
    std::os::unix::fs::symlink(&victim, &planted).unwrap();
    kdray::files::write_atomic(&out, b"output").unwrap();
    unchanged(&victim, b"precious");
    unchanged(&out, b"output");
    assert!(planted.symlink_metadata().unwrap().file_type().is_symlink());
}

/// Outputs are made ordinary files (0666 less the umask), not private temporaries.
#[test]
fn outputs_keep_ordinary_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let d = dir("clobber-mode");
    let out = d.join("x.bin");
    kdray::files::write_atomic(&out, b"x").unwrap();
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
    assert_ne!(
        mode & 0o044,
        0,
        "readable by others as File::create makes it: {mode:o}"
    );
}

/// An output folder where no file can be created is found before the work: the error names
/// the output although the scene (read after the check) is missing too. `/proc` refuses new
/// files even to root, for whom permission bits do not count.
#[test]
fn an_unwritable_output_folder_is_found_before_the_work() {
    if !Path::new("/proc/self").exists() {
        return; // not Linux: no always-unwritable folder to try
    }
    let d = dir("clobber-unwritable");
    let missing = d.join("missing.toml");
    let out = kdray(&["render", s(&missing), "-o", "/proc/kdray-test.png"]);
    refused(&out, "/proc/kdray-test.png", "cannot write");
    let mesh = d.join("m.tri");
    std::fs::write(&mesh, tri_bytes()).unwrap();
    let out = kdray(&["build", s(&mesh), "-o", "/proc/kdray-test.kdt"]);
    refused(&out, "/proc/kdray-test.kdt", "cannot write");
}
