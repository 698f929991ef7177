//! What the fuzz targets found, replayed: every `fuzz/seeds/*/regression-*` file (kept there so the
//! fuzzers start from it too) goes through the loader its name's extension picks and, when
//! accepted, the builder, the serializer and `Scene::from_words`, as the `ply` and `obj` targets
//! do. None may panic; each accepted mesh must give a scene that validates.
//!
//! - `obj/regression-clip-overflow.tri`: two triangles with coordinates from 1e-44 to 7e32. The
//!   builder's exact f64 clip (Sutherland–Hodgman) produced more than the 9 vertices a clipped
//!   triangle can have in exact arithmetic and indexed past its buffer (a panic in
//!   `build::clip::clip_triangle`); it now falls back to the triangle's box.

use kdray::build::{BuildParams, build};
use kdray::flat::serialize;
use kdray::load::{MeshFormat, decode_mesh};
use kdray_core::Scene;
use std::path::Path;

#[test]
fn fuzz_regressions_build_into_valid_scenes() {
    let seeds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds");
    let mut replayed = 0;
    for dir in std::fs::read_dir(&seeds).unwrap() {
        for file in std::fs::read_dir(dir.unwrap().path()).unwrap() {
            let path = file.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let Some(format) =
                MeshFormat::from_path(&path).filter(|_| name.starts_with("regression-"))
            else {
                continue;
            };
            replayed += 1;
            let bytes = std::fs::read(&path).unwrap();
            let Ok(geom) = decode_mesh(format, &path, &bytes) else {
                continue;
            };
            let params = BuildParams {
                parallel: false,
                ..BuildParams::default()
            };
            let tree = build(&geom, &params, None).unwrap();
            let words = serialize(&tree, &geom, 0.0).unwrap();
            if let Err(e) = Scene::from_words(&words) {
                panic!("{name}: the built scene does not validate: {e}");
            }
        }
    }
    assert!(
        replayed >= 1,
        "no regression files found under {}",
        seeds.display()
    );
}
