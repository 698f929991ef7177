//! What a newcomer meets first: the default output's name, `kdray hits`, the hint that names
//! scripts/fetch-meshes.sh, help texts that describe every argument, a source build at the
//! machine's instruction set (`kdray --version` says which), and a `trace` line that says whether
//! it built the tree.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{dir, kdray, s};

/// Runs `kdray` with `args` in the folder `cwd`.
fn kdray_in(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run kdray")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `DIR/one.tri`: one triangle in the plane z = 0 covering the origin's column.
fn one_triangle(d: &Path) -> PathBuf {
    let mesh = d.join("one.tri");
    let mut b = 1u32.to_le_bytes().to_vec();
    for v in [-1.0f32, -1.0, 0.0, 1.0, -1.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&mesh, b).unwrap();
    mesh
}

/// A small scene: one diffuse sphere under the background light.
const SMALL_SCENE: &str = r#"
[camera]
kind = "pinhole"
eye = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
vfov = 40.0

[render]
width = 8
height = 6
spp = 1

[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
"#;

#[test]
fn render_names_its_default_output_after_the_scene() {
    let d = dir("default-name");
    let scene = d.join("little_ball.toml");
    std::fs::write(&scene, SMALL_SCENE).unwrap();
    let out = kdray_in(&d, &["render", "little_ball.toml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(d.join("little_ball.png").is_file());
    assert!(!d.join("render.png").exists());
    let line = String::from_utf8_lossy(&out.stdout);
    assert!(line.starts_with("wrote little_ball.png: 8x6"), "{line}");
    // A band of rows gets its number and the .exr it needs.
    let out = kdray_in(&d, &["render", s(&scene), "--tile", "2/3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(d.join("little_ball-2.exr").is_file());
    // An explicit -o is kept as given.
    let out = kdray_in(&d, &["render", s(&scene), "-o", "other.png"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(d.join("other.png").is_file());
}

#[test]
fn a_missing_benchmark_mesh_names_the_script_that_fetches_it() {
    let d = dir("missing-mesh");
    let scene = d.join("needs_data.toml");
    std::fs::write(
        &scene,
        format!("{SMALL_SCENE}\n[[mesh]]\npath = \"data/not-fetched-yet.ply\"\n"),
    )
    .unwrap();
    let out = kdray(&["render", s(&scene), "-o", s(&d.join("x.png"))]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let msg = stderr(&out);
    assert!(msg.contains(s(&scene)), "{msg}");
    assert!(msg.contains("scripts/fetch-meshes.sh"), "{msg}");
    assert!(!d.join("x.png").exists());
    // A mesh elsewhere is just missing: no hint about the benchmark meshes.
    std::fs::write(
        &scene,
        format!("{SMALL_SCENE}\n[[mesh]]\npath = \"mine.ply\"\n"),
    )
    .unwrap();
    let msg = stderr(&kdray(&["build", s(&scene), "-o", s(&d.join("x.kdt"))]));
    assert!(
        msg.contains("mine.ply") && !msg.contains("fetch-meshes"),
        "{msg}"
    );
}

/// The hits of `kdray trace` on a known scene, as text.
#[test]
fn hits_prints_a_hits_file_as_text() {
    let d = dir("hits-text");
    let mesh = one_triangle(&d);
    // Two rays down -z: one through the triangle (t = 2), one beside it.
    let rays: [[f32; 8]; 2] = [
        [0.0, 0.0, 2.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY],
        [5.0, 5.0, 2.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY],
    ];
    let rays_file = d.join("rays.bin");
    let bytes: Vec<u8> = rays
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(&rays_file, bytes).unwrap();
    let hits = d.join("hits.bin");
    let out = kdray(&[
        "trace",
        s(&mesh),
        "--rays",
        s(&rays_file),
        "--out",
        s(&hits),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = kdray(&["hits", s(&hits)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{text}");
    assert!(lines[0].starts_with("0 t=2 prim=0 u="), "{text}");
    assert_eq!(lines[1], "1 miss");
    let out = kdray(&["hits", s(&hits), "--first", "1", "--count", "5"]);
    assert_eq!(String::from_utf8_lossy(&out.stdout), "1 miss\n");
    // Not a hits file: exit 1, naming it.
    let bad = d.join("bad.bin");
    std::fs::write(&bad, [0u8; 17]).unwrap();
    let out = kdray(&["hits", s(&bad)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains(s(&bad)));
}

#[test]
fn help_describes_every_argument_the_issue_named() {
    for (sub, needles) in [
        (
            "build",
            &["<INPUT>", "The mesh", "--out <OUT.kdt>", "flat format"][..],
        ),
        ("info", &["<FILE.kdt>", "written by `kdray build`"]),
        ("merge", &["--out <OUT>", "The whole image"]),
        (
            "rays",
            &["framing camera", "1,048,576 rays", "--seed", "--kind"],
        ),
        ("trace", &["t = inf", "prim = 0xFFFFFFFF"]),
        ("render", &["thick_lens.png", "13 %"]),
        ("hits", &["miss"]),
    ] {
        let out = kdray(&[sub, "--help"]);
        assert!(out.status.success());
        let text = String::from_utf8_lossy(&out.stdout);
        for n in needles {
            assert!(text.contains(n), "kdray {sub} --help lacks `{n}`:\n{text}");
        }
    }
}

/// `kdray --version` names the instruction set the build uses and the CPU's own (run-time
/// detection), so that a user can see whether the build leaves speed unused.
#[test]
fn version_names_the_builds_isa_and_the_cpus() {
    let out = kdray(&["--version"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let line = String::from_utf8_lossy(&out.stdout);
    assert!(line.starts_with("kdray "), "{line}");
    let build = format!("isa={} (this CPU: ", kdray_core::isa::name());
    assert!(line.contains(&build), "--version lacks `{build}`: {line}");
    let cpu = format!(", {}", kdray::cpu::isa());
    assert!(
        line.contains(&cpu),
        "--version lacks the CPU's isa `{cpu}`: {line}"
    );
}

/// The default source build (`cargo build`, `cargo run`, `cargo install --path host` from the
/// repository: `.cargo/config.toml` sets `target-cpu=native` on x86-64) compiles for the CPU that
/// builds it, so its SIMD is the CPU's best on `kdray_core::isa`'s ladder (AVX2 + FMA on an AVX2
/// or AVX-512 machine, not two SSE2 halves). A build with RUSTFLAGS for another CPU (a portable
/// build, `-C target-cpu=x86-64`) fails this by design.
#[test]
fn a_default_source_build_uses_the_cpus_isa() {
    assert_eq!(
        kdray_core::isa::name(),
        kdray::cpu::isa(),
        "this build's SIMD is not this CPU's best: is RUSTFLAGS set (it replaces \
         .cargo/config.toml's target-cpu=native), or was it built elsewhere?"
    );
}

/// `trace` on a `.kdt` builds nothing: `build_ms=0.000 prebuilt=1`, with the time stored in the
/// file under its own key; on a mesh it reports the build it made (`prebuilt=0`).
#[test]
fn trace_says_whether_it_built_the_tree() {
    let d = dir("prebuilt");
    let mesh = one_triangle(&d);
    let kdt = d.join("one.kdt");
    let out = kdray(&["build", s(&mesh), "-o", s(&kdt)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let rays = d.join("rays.bin");
    let ray = [0.0f32, 0.0, 2.0, 0.0, 0.0, -1.0, 0.0, f32::INFINITY];
    std::fs::write(&rays, ray.map(f32::to_le_bytes).concat()).unwrap();
    let hits = d.join("hits.bin");
    let trace = |input: &Path| {
        let out = kdray(&["trace", s(input), "--rays", s(&rays), "--out", s(&hits)]);
        assert!(out.status.success(), "{}", stderr(&out));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let line = trace(&kdt);
    assert!(
        line.starts_with("build_ms=0.000 prebuilt=1 stored_build_ms="),
        "{line}"
    );
    assert!(line.contains(" hits=1 "), "{line}");
    let line = trace(&mesh);
    assert!(line.starts_with("build_ms="), "{line}");
    assert!(line.contains(" prebuilt=0 "), "{line}");
    assert!(!line.contains("stored_build_ms"), "{line}");
}
