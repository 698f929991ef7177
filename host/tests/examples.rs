//! Every example in the docs runs as written: each scene in `host/scenes/` renders (small) through
//! the `kdray` binary, every scene the README and `docs/SCENE.md` name exists, and every complete
//! scene printed in `docs/SCENE.md` is one of those files, word for word.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace's root (this crate is `host/`).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The example scenes: `host/scenes/*.toml`, with their text.
fn scenes() -> Vec<(PathBuf, String)> {
    let mut out: Vec<(PathBuf, String)> = std::fs::read_dir(root().join("host/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p, text)
        })
        .collect();
    out.sort();
    assert!(out.len() >= 7, "the example scenes: {out:?}");
    out
}

/// Scenes that need files the README's setup does not make: `dragon.toml` reads
/// `data/dragon.ply`, which `scripts/fetch-meshes.sh` fetches (README, "Getting started").
fn needs_benchmark_data(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n == "dragon.toml") && !root().join("data/dragon.ply").exists()
}

#[test]
fn every_example_scene_renders() {
    let out_dir = std::env::temp_dir().join(format!("kdray-examples-{}", std::process::id()));
    std::fs::create_dir_all(&out_dir).unwrap();
    for (path, _) in scenes() {
        if needs_benchmark_data(&path) {
            eprintln!("skipped {} (run scripts/fetch-meshes.sh)", path.display());
            continue;
        }
        let png = out_dir.join(path.with_extension("png").file_name().unwrap());
        let out = Command::new(env!("CARGO_BIN_EXE_kdray"))
            .args([
                "render",
                path.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
            ])
            .args(["--size", "24x16", "--spp", "2"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let size = std::fs::metadata(&png).map(|m| m.len()).unwrap_or(0);
        assert!(size > 0, "{} wrote no picture", path.display());
    }
    let _ = std::fs::remove_dir_all(&out_dir);
}

/// A scene that reads a mesh from `data/` names the script that puts it there, as the README and
/// the loader's error do (`scripts/fetch-meshes.sh`, not the benchmark set-up, which also installs
/// Embree).
#[test]
fn scenes_that_need_fetched_meshes_name_the_fetch_script() {
    let mut needing = 0;
    for (path, text) in scenes() {
        let reads_data = text
            .lines()
            .any(|l| l.trim_start().starts_with("path") && l.contains("data/"));
        if reads_data {
            needing += 1;
            assert!(
                text.contains("scripts/fetch-meshes.sh"),
                "{} reads data/ but does not name scripts/fetch-meshes.sh",
                path.display()
            );
        }
    }
    assert!(needing >= 1, "dragon.toml reads data/dragon.ply");
}

#[test]
fn the_docs_name_only_scenes_that_exist_and_print_them_as_they_are() {
    let files = scenes();
    for doc in ["README.md", "docs/SCENE.md"] {
        let text = std::fs::read_to_string(root().join(doc)).unwrap();
        for (i, _) in text.match_indices("host/scenes/") {
            let name: String = text[i..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "/_-.".contains(*c))
                .collect();
            let name = name.trim_end_matches('.');
            if name.ends_with(".toml") {
                assert!(
                    root().join(name).exists(),
                    "{doc} names {name}, which is missing"
                );
            }
        }
    }
    let doc = std::fs::read_to_string(root().join("docs/SCENE.md")).unwrap();
    let mut printed = 0;
    for block in doc.split("```toml\n").skip(1) {
        let block = &block[..block.find("```").expect("a closed block")];
        if block.contains("[camera]") {
            assert!(
                files.iter().any(|(_, text)| text == block),
                "docs/SCENE.md prints a scene that is not a file of host/scenes/:\n{block}"
            );
            printed += 1;
        }
    }
    assert!(printed >= 1, "docs/SCENE.md prints its example scene");
}
