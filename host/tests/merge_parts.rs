//! `kdray merge` on hostile parts (issue 20): a few hundred bytes claiming 2³¹ pixels, or more
//! pixels than its size can hold, is refused before anything is allocated for them (each run is
//! under a 1.5 GiB address-space limit; the first asked for 24 GB and aborted); a chunk table
//! pointing two entries at one chunk is refused instead of merged with black rows and exit 0; a
//! directory is called a directory. The parts are a real `render --tile` output with its header
//! or chunk table patched.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{dir, s};

/// Runs `kdray args` under a 1.5 GiB address-space limit.
fn kdray(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1572864; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

#[track_caller]
fn refused(out: &Output, names: &str, words: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {err}");
    assert!(err.contains(names), "should name {names}: {err}");
    assert!(err.contains(words), "should say {words:?}: {err}");
}

/// A 16x32 image rendered as one part (two chunks of 16 rows: ZIP), its bytes.
fn part(d: &Path) -> Vec<u8> {
    let scene = d.join("s.toml");
    std::fs::write(
        &scene,
        "[camera]\nkind = \"pinhole\"\neye = [0, 0, 3]\ntarget = [0, 0, 0]\n\
         [render]\nspp = 1\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n",
    )
    .unwrap();
    let out = d.join("whole.exr");
    let run = common::kdray(&[
        "render",
        s(&scene),
        "--size",
        "16x32",
        "--tile",
        "1/1",
        "-o",
        s(&out),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    std::fs::read(&out).unwrap()
}

/// Sets the last row (`ymax`) of the `box2i` attribute `name` (e.g. `dataWindow`).
fn set_ymax(bytes: &mut [u8], name: &str, ymax: i32) {
    let key = format!("{name}\0box2i\0");
    let at = bytes
        .windows(key.len())
        .position(|w| w == key.as_bytes())
        .expect("attribute present")
        + key.len()
        + 4; // the attribute's size
    bytes[at + 12..at + 16].copy_from_slice(&ymax.to_le_bytes());
}

/// The offset of the chunk table: the first place whose u64 points 16 bytes on (two chunks).
fn chunk_table(bytes: &[u8]) -> usize {
    (0..bytes.len() - 16)
        .find(|&p| u64::from_le_bytes(bytes[p..p + 8].try_into().unwrap()) == p as u64 + 16)
        .expect("a two-entry chunk table")
}

fn write(d: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn an_honest_part_merges() {
    let d = dir("parts-honest");
    let bytes = part(&d);
    let p = write(&d, "p.exr", &bytes);
    let out = kdray(&["merge", s(&p), "-o", s(&d.join("m.png"))]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_data_window_of_two_billion_pixels_is_refused_without_allocating() {
    let d = dir("parts-huge");
    let mut bytes = part(&d);
    // 16 x 2^27 rows: what the 441-byte file claimed (24 GB of f32 RGB).
    set_ymax(&mut bytes, "dataWindow", (1 << 27) - 1);
    set_ymax(&mut bytes, "displayWindow", (1 << 27) - 1);
    let p = write(&d, "huge.exr", &bytes);
    let out = kdray(&["merge", s(&p), "-o", s(&d.join("m.exr"))]);
    refused(&out, "huge.exr", "67108864 pixels");
    assert!(!d.join("m.exr").exists());
}

#[test]
fn a_part_claiming_more_than_its_size_can_hold_is_refused() {
    let d = dir("parts-dishonest");
    let mut bytes = part(&d);
    // 16 x 2^21 rows = 2^25 pixels: under the image cap, but ~6,000 per byte of this file.
    set_ymax(&mut bytes, "dataWindow", (1 << 21) - 1);
    set_ymax(&mut bytes, "displayWindow", (1 << 21) - 1);
    let p = write(&d, "tall.exr", &bytes);
    let out = kdray(&["merge", s(&p), "-o", s(&d.join("m.exr"))]);
    refused(&out, "tall.exr", "can hold");
}

#[test]
fn two_rows_of_the_chunk_table_at_one_chunk_is_an_error() {
    let d = dir("parts-dup-chunk");
    let mut bytes = part(&d);
    let t = chunk_table(&bytes);
    let first: [u8; 8] = bytes[t..t + 8].try_into().unwrap();
    bytes[t + 8..t + 16].copy_from_slice(&first);
    let p = write(&d, "dup.exr", &bytes);
    let out = kdray(&["merge", s(&p), "-o", s(&d.join("m.png"))]);
    refused(&out, "dup.exr", "stored");
    assert!(!d.join("m.png").exists());
}

#[test]
fn a_directory_part_is_called_a_directory() {
    let d = dir("parts-dir");
    let sub = d.join("sub.exr");
    std::fs::create_dir_all(&sub).unwrap();
    let out = kdray(&["merge", s(&sub), "-o", s(&d.join("m.png"))]);
    refused(&out, "sub.exr", "a directory");
}
