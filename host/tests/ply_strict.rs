//! The PLY loader where `ply-rs-bw` alone is lenient (issue 12's probe): each case is refused
//! with the file's name and, where the file is text at that point, the line; and header counts
//! the payload cannot hold are refused before anything is allocated for them.

use flate2::Compression;
use flate2::write::GzEncoder;
use kdray::load::{MAX_INFLATED, MeshFormat, decode_mesh};
use std::io::Write;
use std::path::Path;

/// A quad (two faces): vertices on lines 10 to 13, faces on lines 14 and 15.
const GOOD: &str = "ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
element face 2
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
3 0 1 2
3 0 2 3
";

/// Decodes `text` as `name` (by its extension) and returns the error, asserting it names the file
/// and, when given, the line.
#[track_caller]
fn refused(name: &str, bytes: &[u8], line: Option<usize>, words: &str) -> String {
    let format = MeshFormat::from_path(Path::new(name)).unwrap();
    let err = decode_mesh(format, Path::new(name), bytes).expect_err("accepted");
    let text = err.to_string();
    assert!(text.starts_with(name), "{text}");
    assert_eq!(err.line, line, "line of: {text}");
    assert!(text.contains(words), "should say {words:?}: {text}");
    text
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[test]
fn the_good_file_loads_plain_and_gzipped() {
    let plain = decode_mesh(MeshFormat::Ply, Path::new("q.ply"), GOOD.as_bytes()).unwrap();
    assert_eq!(plain.triangles.len(), 2);
    let gz = decode_mesh(
        MeshFormat::PlyGz,
        Path::new("q.ply.gz"),
        &gzip(GOOD.as_bytes()),
    );
    assert_eq!(gz.unwrap(), plain);
    // Trailing blank lines after an ASCII payload are whitespace, not data.
    let padded = format!("{GOOD}\n\n  \r\n");
    assert!(decode_mesh(MeshFormat::Ply, Path::new("q.ply"), padded.as_bytes()).is_ok());
}

#[test]
fn an_undercounted_element_or_trailing_data_is_refused_at_its_line() {
    // The header says one face; the second face's line is left over.
    let under = GOOD.replace("element face 2", "element face 1");
    refused(
        "under.ply",
        under.as_bytes(),
        Some(15),
        "after the last element",
    );
    let trailing = format!("{GOOD}3 0 1 3\n");
    refused(
        "trail.ply",
        trailing.as_bytes(),
        Some(16),
        "after the last element",
    );
    // Binary: one byte after the last face.
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nelement face 1\n\
                    property list uchar int vertex_indices\nend_header\n"
        .to_vec();
    bin.extend_from_slice(&[0u8; 36]);
    bin.push(3);
    for i in [0i32, 1, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    // (A degenerate triangle of zeros loads: the check here is about the layout.)
    assert!(decode_mesh(MeshFormat::Ply, Path::new("b.ply"), &bin).is_ok());
    bin.push(0);
    refused("b.ply", &bin, None, "1 bytes of data after");
}

#[test]
fn duplicate_declarations_are_refused_at_their_line() {
    let dup = GOOD.replace("property float z\n", "property float z\nproperty float y\n");
    refused(
        "dup.ply",
        dup.as_bytes(),
        Some(7),
        "property `y` is declared twice",
    );
    let dup_el = GOOD.replace(
        "end_header",
        "element vertex 1\nproperty float q\nend_header",
    );
    refused(
        "dupel.ply",
        dup_el.as_bytes(),
        Some(9),
        "element `vertex` is declared twice",
    );
}

#[test]
fn a_list_count_past_its_type_is_refused_at_its_line() {
    let indices: Vec<String> = (0..300).map(|i| (i % 4).to_string()).collect();
    let long = GOOD.replace("3 0 2 3\n", &format!("300 {}\n", indices.join(" ")));
    refused(
        "long.ply",
        long.as_bytes(),
        Some(15),
        "does not fit the header's count type",
    );
    // The same face under a ushort count type is fine as far as counts go (its fan repeats
    // vertices, which is allowed).
    let ushort = long.replace("list uchar int", "list ushort int");
    assert!(decode_mesh(MeshFormat::Ply, Path::new("u.ply"), ushort.as_bytes()).is_ok());
}

#[test]
fn only_version_1_0_is_read() {
    let v2 = GOOD.replace("ascii 1.0", "ascii 2.0");
    refused("v2.ply", v2.as_bytes(), Some(2), "version 2.0");
    let bad_magic = GOOD.replacen("ply", "plx", 1);
    refused("magic.ply", bad_magic.as_bytes(), Some(1), "does not start");
}

#[test]
fn damaged_gzip_is_refused() {
    let gz = gzip(GOOD.as_bytes());
    // The CRC-32 is the trailer's first 4 bytes.
    let mut bad_crc = gz.clone();
    let at = bad_crc.len() - 8;
    bad_crc[at] ^= 0xff;
    refused("crc.ply.gz", &bad_crc, None, "invalid gzip data");
    refused("cut.ply.gz", &gz[..gz.len() - 8], None, "invalid gzip data");
    refused(
        "half.ply.gz",
        &gz[..gz.len() / 2],
        None,
        "invalid gzip data",
    );
    let mut junk = gz.clone();
    junk.extend_from_slice(b"junk after the member");
    refused("junk.ply.gz", &junk, None, "invalid gzip data");
}

#[test]
fn counts_the_payload_cannot_hold_are_refused_before_reading() {
    // The probe's element with no properties and 4 billion items.
    let none = GOOD.replace(
        "element face 2",
        "element nothing 4000000000\nelement face 2",
    );
    refused(
        "none.ply",
        none.as_bytes(),
        Some(7),
        "items but no properties",
    );
    // Counts past what the bytes after the header can hold (3 × 2 bytes a vertex, 8 a face).
    let verts = GOOD.replace("element vertex 4", "element vertex 4000000000");
    refused(
        "v.ply",
        verts.as_bytes(),
        Some(16),
        "declares 4000000000 items",
    );
    let faces = GOOD.replace("element face 2", "element face 7");
    refused(
        "f.ply",
        faces.as_bytes(),
        Some(16),
        "element `face` declares 7 items",
    );
    // A gzip bomb past the cap: a header, then zeros, as concatenated members.
    let mut bomb = gzip(GOOD.as_bytes());
    let zeros = gzip(&vec![0u8; 1 << 20]);
    for _ in 0..(MAX_INFLATED >> 20) + 1 {
        bomb.extend_from_slice(&zeros);
    }
    refused("bomb.ply.gz", &bomb, None, "inflates to more than 512 MiB");
}
