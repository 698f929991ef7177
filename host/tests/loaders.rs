//! The mesh loaders on small files written to a temporary folder: every format and its
//! triangulation, then malformed input, which must give an error naming the file (and the line,
//! for ASCII PLY and OBJ) and never a panic.

use core::sync::atomic::{AtomicUsize, Ordering};
use glam::{Vec2, Vec3};
use kdray::load::{encode_tri, load_mesh};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file in the system's temporary folder, removed on drop.
struct TempFile(PathBuf);

impl TempFile {
    /// Writes `bytes` to a fresh file whose name ends in `name`.
    fn new(name: &str, bytes: &[u8]) -> Self {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!("kdray-loaders-{}-{n}-{name}", std::process::id()));
        std::fs::write(&path, bytes).unwrap();
        Self(path)
    }

    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Loads `bytes` as a file called `name` and returns the error's text, asserting that it names
/// the file, and the line when `line` is given.
fn error_of(name: &str, bytes: &[u8], line: Option<usize>) -> String {
    let file = TempFile::new(name, bytes);
    let err = load_mesh(file.path()).expect_err("the loader accepted bad input");
    let text = err.to_string();
    assert!(text.contains(name), "error does not name {name}: {text}");
    assert_eq!(err.line, line, "wrong line in: {text}");
    if let Some(line) = line {
        assert!(text.contains(&format!("{name}:{line}: ")), "{text}");
    }
    text
}

const ASCII_PLY: &str = "ply
format ascii 1.0
comment a unit square (quad) and one triangle
element vertex 5
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float u
property float v
element face 2
property list uchar int vertex_indices
end_header
0 0 0 0 0 1 0 0
1 0 0 0 0 1 1 0
1 1 0 0 0 1 1 1
0 1 0 0 0 1 0 1
0 0 1 0 1 0 0.5 0.5
4 0 1 2 3
3 0 4 1
";

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

#[test]
fn ascii_ply_quad_is_fan_triangulated_with_normals_and_uvs() {
    let file = TempFile::new("mesh.ply", ASCII_PLY.as_bytes());
    let g = load_mesh(file.path()).unwrap();
    let (p0, p1, p2, p3, p4) = (
        v(0., 0., 0.),
        v(1., 0., 0.),
        v(1., 1., 0.),
        v(0., 1., 0.),
        v(0., 0., 1.),
    );
    assert_eq!(g.triangles, vec![[p0, p1, p2], [p0, p2, p3], [p0, p4, p1]]);
    let normals = g.normals.unwrap();
    assert_eq!(normals[0], [Vec3::Z; 3]);
    assert_eq!(normals[2], [Vec3::Z, Vec3::Y, Vec3::Z]);
    assert_eq!(g.uvs.unwrap()[1], [Vec2::ZERO, Vec2::ONE, Vec2::Y]);
    assert!(g.spheres.is_empty());
}

#[test]
fn ply_variants_load_alike() {
    let plain = TempFile::new("mesh.ply", ASCII_PLY.as_bytes());
    let want = load_mesh(plain.path()).unwrap();
    let variants = [
        ASCII_PLY.replace(
            "list uchar int vertex_indices",
            "list uchar ushort vertex_index",
        ),
        ASCII_PLY.replace("list uchar int", "list int uchar"),
        ASCII_PLY.replace('\n', "\r\n"),
        ASCII_PLY.replace(
            "property float u\nproperty float v",
            "property float s\nproperty float t",
        ),
        ASCII_PLY.replace("property float x", "property double x"),
    ];
    for text in &variants {
        let file = TempFile::new("variant.ply", text.as_bytes());
        assert_eq!(load_mesh(file.path()).unwrap(), want, "{text}");
    }
}

#[test]
fn gzipped_ply_loads_like_the_plain_file() {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(ASCII_PLY.as_bytes()).unwrap();
    let gz = TempFile::new("mesh.ply.gz", &enc.finish().unwrap());
    let plain = TempFile::new("mesh.ply", ASCII_PLY.as_bytes());
    assert_eq!(
        load_mesh(gz.path()).unwrap(),
        load_mesh(plain.path()).unwrap()
    );
    // Not gzip at all.
    error_of("notgz.ply.gz", ASCII_PLY.as_bytes(), None);
}

/// A binary PLY: double coordinates, a quad and a triangle, indices as `list uchar uint` (little
/// endian) or `list uchar int` (big endian), an extra ignored property and element.
fn binary_ply(little: bool) -> Vec<u8> {
    let (format, list) = match little {
        true => ("binary_little_endian", "uint"),
        false => ("binary_big_endian", "int"),
    };
    let header = format!(
        "ply\nformat {format} 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
         property double z\nproperty uchar red\nelement face 2\n\
         property list uchar {list} vertex_indices\nelement extra 1\nproperty short w\nend_header\n"
    );
    let mut b = header.into_bytes();
    let f64b = |x: f64| {
        if little {
            x.to_le_bytes()
        } else {
            x.to_be_bytes()
        }
    };
    let u32b = |x: u32| {
        if little {
            x.to_le_bytes()
        } else {
            x.to_be_bytes()
        }
    };
    for p in [
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 2.0, 0.0],
        [0.0, 2.0, 0.5],
    ] {
        for c in p {
            b.extend_from_slice(&f64b(c));
        }
        b.push(255);
    }
    b.push(4);
    for i in [0, 1, 2, 3] {
        b.extend_from_slice(&u32b(i));
    }
    b.push(3);
    for i in [3, 2, 1] {
        b.extend_from_slice(&u32b(i));
    }
    b.extend_from_slice(&[0, 7]);
    b
}

#[test]
fn binary_ply_both_endians() {
    let expect = vec![
        [v(0., 0., 0.), v(2., 0., 0.), v(2., 2., 0.)],
        [v(0., 0., 0.), v(2., 2., 0.), v(0., 2., 0.5)],
        [v(0., 2., 0.5), v(2., 2., 0.), v(2., 0., 0.)],
    ];
    for little in [true, false] {
        let file = TempFile::new("bin.ply", &binary_ply(little));
        let g = load_mesh(file.path()).unwrap();
        assert_eq!(g.triangles, expect, "little endian: {little}");
        assert_eq!((g.normals, g.uvs), (None, None));
    }
}

#[test]
fn non_finite_binary_ply_names_the_vertex() {
    let mut bytes = binary_ply(true);
    let header = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    // Vertex 1's y: after vertex 0 (3 doubles + a byte) and vertex 1's x.
    let at = header + 25 + 8;
    bytes[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let t = error_of("nan.ply", &bytes, None);
    assert!(t.contains("vertex 1: y = NaN"), "{t}");
    // A double too large for f32 is refused too.
    bytes[at..at + 8].copy_from_slice(&1e300f64.to_le_bytes());
    error_of("big.ply", &bytes, None);
}

#[test]
fn truncated_binary_ply_is_an_error() {
    let full = binary_ply(true);
    let header = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    for cut in [header, header + 30, header + 100, full.len() - 1] {
        error_of("short.ply", &full[..cut], None);
    }
    // A huge count in the header and no payload: an error, not a huge allocation.
    let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n\
                property float y\nproperty float z\nelement face 1\n\
                property list uchar int vertex_indices\nend_header\n";
    error_of("huge.ply", huge.as_bytes(), None);
    // Cut inside the header, which is text: the line is known.
    error_of("short.ply", &full[..10], Some(2));
}

/// `ASCII_PLY` with line `line` (1-based) replaced.
fn ascii_with(line: usize, text: &str) -> String {
    let mut lines: Vec<&str> = ASCII_PLY.lines().collect();
    lines[line - 1] = text;
    lines.join("\n") + "\n"
}

#[test]
fn malformed_ascii_ply_errors_give_lines() {
    // Lines 16 to 20 hold vertices 0 to 4, lines 21 and 22 the faces.
    error_of(
        "nan.ply",
        ascii_with(17, "1 nan 0 0 0 1 1 0").as_bytes(),
        Some(17),
    );
    error_of(
        "inf.ply",
        ascii_with(20, "0 0 1 0 1 0 inf 0.5").as_bytes(),
        Some(20),
    );
    let t = error_of("range.ply", ascii_with(22, "3 0 5 1").as_bytes(), Some(22));
    assert!(t.contains("out of range"), "{t}");
    error_of("neg.ply", ascii_with(21, "4 0 1 -2 3").as_bytes(), Some(21));
    let t = error_of("two.ply", ascii_with(22, "2 0 4").as_bytes(), Some(22));
    assert!(t.contains("at least 3"), "{t}");
    // The parser's own errors: a word that is not a number, a short line.
    error_of(
        "word.ply",
        ascii_with(18, "1 one 0 0 0 1 1 1").as_bytes(),
        Some(18),
    );
    error_of("few.ply", ascii_with(19, "0 1 0").as_bytes(), Some(19));
    error_of(
        "hdr.ply",
        ascii_with(5, "property flaot x").as_bytes(),
        Some(5),
    );
    // Cut after vertex 2: the payload ends early.
    let cut: String = ASCII_PLY
        .lines()
        .take(18)
        .map(|l| format!("{l}\n"))
        .collect();
    error_of("cut.ply", cut.as_bytes(), Some(19));
}

#[test]
fn ply_without_triangles_or_positions_is_an_error() {
    let empty = ASCII_PLY
        .replace("element face 2", "element face 0")
        .replace("4 0 1 2 3\n3 0 4 1\n", "");
    let t = error_of("empty.ply", empty.as_bytes(), None);
    assert!(t.contains("no triangles"), "{t}");
    let no_z = ASCII_PLY.replace("property float z\n", "property float w\n");
    error_of("noz.ply", no_z.as_bytes(), None);
    let no_faces = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
    error_of("points.ply", no_faces.as_bytes(), None);
    let float_idx = ASCII_PLY.replace("list uchar int", "list uchar float");
    error_of("fidx.ply", float_idx.as_bytes(), None);
    error_of("zero.ply", b"", None);
}

const OBJ: &str =
    "# a quad with normals and texture coordinates, then a triangle by relative indices
o square
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
usemtl whatever
f 1/1/1 2/2/1 3/3/1 4/4/1
g tail
f -4/1/1 -2/3/1 -1/4/1
";

#[test]
fn obj_quad_is_fan_triangulated_with_attributes() {
    let file = TempFile::new("quad.obj", OBJ.as_bytes());
    let g = load_mesh(file.path()).unwrap();
    let (p0, p1, p2, p3) = (v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.));
    assert_eq!(g.triangles, vec![[p0, p1, p2], [p0, p2, p3], [p0, p2, p3]]);
    assert_eq!(g.normals.unwrap(), vec![[Vec3::Z; 3]; 3]);
    assert_eq!(g.uvs.unwrap()[1], [Vec2::ZERO, Vec2::ONE, Vec2::Y]);
}

#[test]
fn obj_attributes_are_dropped_unless_every_face_has_them() {
    let text = OBJ.replace("f -4/1/1 -2/3/1 -1/4/1", "f 1 3 4");
    let file = TempFile::new("mixed.obj", text.as_bytes());
    let g = load_mesh(file.path()).unwrap();
    assert_eq!(g.triangles.len(), 3);
    assert_eq!((g.normals, g.uvs), (None, None));
    // A position weight divides; a polygon of 5 gives 3 triangles.
    let text = "v 2 4 6 2\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4 5\n";
    let file = TempFile::new("w.obj", text.as_bytes());
    let g = load_mesh(file.path()).unwrap();
    assert_eq!(g.triangles.len(), 3);
    assert_eq!(g.triangles[0][0], v(1., 2., 3.));
    assert_eq!(
        g.triangles[2],
        [v(1., 2., 3.), v(0., 1., 0.), v(0., 0., 1.)]
    );
}

#[test]
fn malformed_obj_errors_give_lines() {
    let with = |line: usize, text: &str| {
        let mut lines: Vec<&str> = OBJ.lines().collect();
        lines[line - 1] = text;
        lines.join("\n")
    };
    error_of("nan.obj", with(4, "v 1 NaN 0").as_bytes(), Some(4));
    error_of("inf.obj", with(5, "v 1 1 inf").as_bytes(), Some(5));
    error_of("word.obj", with(6, "v 0 one 0").as_bytes(), Some(6));
    error_of("short.obj", with(6, "v 0 1").as_bytes(), Some(6));
    let t = error_of(
        "range.obj",
        with(13, "f 1/1/1 2/2/1 9/3/1").as_bytes(),
        Some(13),
    );
    assert!(t.contains("out of range"), "{t}");
    error_of(
        "vtrange.obj",
        with(13, "f 1/1/1 2/5/1 3/3/1").as_bytes(),
        Some(13),
    );
    error_of(
        "vnrange.obj",
        with(15, "f 1//2 2//1 3//1").as_bytes(),
        Some(15),
    );
    error_of("zero.obj", with(13, "f 0 1 2").as_bytes(), Some(13));
    error_of("rel.obj", with(15, "f -5 -1 -2").as_bytes(), Some(15));
    let t = error_of("two.obj", with(15, "f 1 2").as_bytes(), Some(15));
    assert!(t.contains("at least 3"), "{t}");
    error_of(
        "slashes.obj",
        with(15, "f 1/1/1/1 2 3").as_bytes(),
        Some(15),
    );
    error_of("utf8.obj", b"v 0 0 0\nv 1 0 0\n\xff\xfe\n", Some(3));
    let t = error_of("empty.obj", b"# nothing\nv 0 0 0\n", None);
    assert!(t.contains("no triangles"), "{t}");
}

#[test]
fn tri_round_trip_and_errors() {
    let tris = vec![
        [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)],
        [v(-1., 2., 3.), v(4., -5., 6.), v(7., 8., -9.5)],
    ];
    let bytes = encode_tri(&tris);
    let file = TempFile::new("soup.tri", &bytes);
    assert_eq!(load_mesh(file.path()).unwrap().triangles, tris);
    error_of("short.tri", &bytes[..bytes.len() - 1], None);
    error_of("long.tri", &[&bytes[..], &[0]].concat(), None);
    error_of("count.tri", &[&[3, 0, 0, 0], &bytes[4..]].concat(), None);
    error_of("empty.tri", &0u32.to_le_bytes(), None);
    let mut nan = tris.clone();
    nan[0][1].z = f32::NAN;
    error_of("nan.tri", &encode_tri(&nan), None);
}

#[test]
fn missing_file_and_unknown_extension() {
    let missing = std::env::temp_dir().join("kdray-loaders-does-not-exist.ply");
    assert!(
        load_mesh(&missing)
            .unwrap_err()
            .to_string()
            .contains("does-not-exist.ply")
    );
    error_of("mesh.stl", b"solid", None);
}

mod never_panic {
    use super::*;
    use proptest::prelude::*;

    const HEADER: &str = "ply\nformat FORMAT 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                          property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";

    fn load(name: &str, bytes: &[u8]) {
        let file = TempFile::new(name, bytes);
        if let Err(e) = load_mesh(file.path()) {
            assert!(e.to_string().contains(name));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(scaled_cases(200)))]

        #[test]
        fn random_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            for name in ["r.ply", "r.ply.gz", "r.obj", "r.tri"] {
                load(name, &bytes);
            }
        }

        #[test]
        fn random_ply_payloads(
            bytes in proptest::collection::vec(any::<u8>(), 0..200),
            format in prop_oneof!["ascii", "binary_little_endian", "binary_big_endian"],
        ) {
            let mut file = HEADER.replace("FORMAT", &format).into_bytes();
            file.extend_from_slice(&bytes);
            load("p.ply", &file);
        }

        #[test]
        fn random_text_payloads(words in proptest::collection::vec(
            prop_oneof!["v", "vt", "vn", "f", "-1", "0", "1", "2", "3", "4", "1/1", "1//1",
                        "2/2/2", "/", "nan", "inf", "1e39", "-3", "0.5", "\n", "\n", "g"],
            0..80,
        )) {
            let text = words.join(" ");
            load("t.obj", text.as_bytes());
            let mut ply = HEADER.replace("FORMAT", "ascii");
            ply.push_str(&text);
            load("t.ply", ply.as_bytes());
        }
    }
}

/// `n` times `KDRAY_PROPTEST_SCALE` (default 1), as `kdray_tests::cases` does for the other
/// suites (this crate cannot depend on `kdray-tests`, which depends on it).
fn scaled_cases(n: u32) -> u32 {
    std::env::var("KDRAY_PROPTEST_SCALE").map_or(n, |v| {
        let k: u32 = v
            .trim()
            .parse()
            .expect("KDRAY_PROPTEST_SCALE: a positive whole number");
        n.saturating_mul(k.max(1))
    })
}
