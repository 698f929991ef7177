//! Links Embree 3 (`libembree3`) when the `embree` feature is on; the default build needs nothing.
//!
//! `EMBREE_DIR` points at a non-system install (its `lib/` is searched, its
//! `include/embree3/rtcore_config.h` checked). The hand-written declarations in
//! `src/peer_embree/ffi.rs` assume the library was configured with `RTC_MAX_INSTANCE_LEVEL_COUNT 1`
//! and `RTC_MIN_WIDTH 0` (Debian's `libembree-dev` 3.13.5 is); both change the layout of
//! `RTCHit` and `RTCIntersectContext`, so a header that says otherwise stops the build here
//! rather than corrupting memory at run time.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    if env::var_os("CARGO_FEATURE_EMBREE").is_none() {
        return;
    }
    let dir = env::var_os("EMBREE_DIR").map(PathBuf::from);
    if let Some(dir) = &dir {
        println!(
            "cargo:rustc-link-search=native={}",
            dir.join("lib").display()
        );
    }
    println!("cargo:rustc-link-lib=dylib=embree3");

    let candidates: Vec<PathBuf> = dir
        .iter()
        .map(|d| d.join("include"))
        .chain(["/usr/include", "/usr/local/include"].map(PathBuf::from))
        .map(|d| d.join("embree3/rtcore_config.h"))
        .collect();
    let Some(config) = candidates.iter().find(|p| p.is_file()) else {
        println!(
            "cargo:warning=embree3/rtcore_config.h not found (looked in {candidates:?}); \
             cannot check that the FFI layout matches the installed Embree"
        );
        return;
    };
    println!("cargo:rerun-if-changed={}", config.display());
    let text = fs::read_to_string(config).expect("read rtcore_config.h");
    for (name, want) in [
        ("RTC_VERSION_MAJOR", "3"),
        ("RTC_MAX_INSTANCE_LEVEL_COUNT", "1"),
        ("EMBREE_MIN_WIDTH", "0"),
    ] {
        let found = text.lines().find_map(|l| {
            let mut w = l.split_whitespace();
            (w.next() == Some("#define") && w.next() == Some(name)).then(|| w.next())
        });
        match found.flatten() {
            Some(v) if v == want => {}
            other => panic!(
                "{}: {name} is {other:?}, but src/peer_embree/ffi.rs assumes {want}",
                config.display()
            ),
        }
    }
}
