//! The PLY loader (`kdray::load::decode_mesh`, ASCII and binary) on arbitrary bytes: it must
//! return, never panic, hang or allocate past a bound set by the input's size. The same bytes,
//! gzipped, must load as `.ply.gz` to the same result (the inflate path adds nothing but its own
//! checks), and every mesh it accepts must build into a scene that validates
//! ([`kdray_fuzz::build_and_validate`]).
//!
//! Run: `cargo +nightly fuzz run ply fuzz/corpus/ply` (from `fuzz/`); seeds: `fuzz/corpus/ply`.
#![no_main]

use flate2::Compression;
use flate2::write::GzEncoder;
use kdray::load::{MeshFormat, decode_mesh};
use libfuzzer_sys::fuzz_target;
use std::io::Write;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let plain = decode_mesh(MeshFormat::Ply, Path::new("fuzz.ply"), data);
    let mut gz = GzEncoder::new(Vec::new(), Compression::fast());
    gz.write_all(data).unwrap();
    let gz = gz.finish().unwrap();
    let zipped = decode_mesh(MeshFormat::PlyGz, Path::new("fuzz.ply.gz"), &gz);
    match (&plain, &zipped) {
        (Ok(a), Ok(b)) => assert_eq!(a, b, "plain and gzipped loads differ"),
        (Err(a), Err(b)) => assert_eq!(a.message, b.message, "plain and gzipped errors differ"),
        _ => panic!("plain {:?} but gzipped {:?}", plain.is_ok(), zipped.is_ok()),
    }
    if let Ok(geom) = plain {
        kdray_fuzz::build_and_validate("ply", &geom);
    }
    // And the raw bytes as a .ply.gz: a gzip decoder on garbage.
    let _ = decode_mesh(MeshFormat::PlyGz, Path::new("raw.ply.gz"), data);
});
