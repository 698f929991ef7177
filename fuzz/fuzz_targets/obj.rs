//! The OBJ loader (`kdray::load::decode_mesh`) on arbitrary bytes: it must return, never panic or
//! hang, and every mesh it accepts must build into a scene that validates
//! ([`kdray_fuzz::build_and_validate`]). The same loader's `.tri` path gets the same bytes.
//!
//! Run: `cargo +nightly fuzz run obj fuzz/corpus/obj` (from `fuzz/`); seeds: `fuzz/corpus/obj`.
#![no_main]

use kdray::load::{MeshFormat, decode_mesh};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(geom) = decode_mesh(MeshFormat::Obj, Path::new("fuzz.obj"), data) {
        kdray_fuzz::build_and_validate("obj", &geom);
    }
    if let Ok(geom) = decode_mesh(MeshFormat::Tri, Path::new("fuzz.tri"), data) {
        kdray_fuzz::build_and_validate("tri", &geom);
    }
});
