//! The `.tri` triangle soup (docs/FORMATS.md): little-endian `u32 n`, then `n × 9 f32`
//! (`v0 v1 v2` of each triangle), no header, nothing after.

use glam::Vec3;

/// Bytes per triangle: nine `f32`.
const TRI_BYTES: usize = 36;

/// Decodes `.tri` bytes into triangles.
///
/// The count is checked against the byte length before anything is allocated from it, so a
/// corrupt count cannot ask for more memory than the input already occupies.
///
/// # Errors
/// A message (without a file name) when the input is shorter than its 4-byte count, its length is
/// not `4 + 36·n`, its count disagrees with its length, a coordinate is not finite, or `n` is 0.
pub fn decode_tri(bytes: &[u8]) -> core::result::Result<Vec<[Vec3; 3]>, String> {
    let Some((head, body)) = bytes.split_first_chunk::<4>() else {
        return Err(format!(
            "truncated: {} bytes, but a .tri file starts with a 4-byte triangle count",
            bytes.len()
        ));
    };
    let n = u32::from_le_bytes(*head) as usize;
    if body.len() % TRI_BYTES != 0 {
        return Err(format!(
            "{} bytes after the count is not a whole number of 36-byte triangles",
            body.len()
        ));
    }
    let in_file = body.len() / TRI_BYTES;
    if n != in_file {
        return Err(format!(
            "the header counts {n} triangles but the file holds {in_file} \
             (a .tri file is exactly 4 + 36·n bytes)"
        ));
    }
    if n == 0 {
        return Err("the mesh has no triangles".into());
    }
    let mut triangles = Vec::with_capacity(n);
    for (i, chunk) in body.chunks_exact(TRI_BYTES).enumerate() {
        let mut f = [0.0f32; 9];
        for (dst, src) in f.iter_mut().zip(chunk.chunks_exact(4)) {
            *dst = f32::from_le_bytes([src[0], src[1], src[2], src[3]]);
        }
        if let Some(k) = f.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "triangle {i}: coordinate {k} is {} (not finite)",
                f[k]
            ));
        }
        triangles.push([
            Vec3::new(f[0], f[1], f[2]),
            Vec3::new(f[3], f[4], f[5]),
            Vec3::new(f[6], f[7], f[8]),
        ]);
    }
    Ok(triangles)
}

/// Encodes triangles as `.tri` bytes (the inverse of [`decode_tri`]).
///
/// # Panics
/// If there are more than `u32::MAX` triangles, which the format cannot count.
pub fn encode_tri(triangles: &[[Vec3; 3]]) -> Vec<u8> {
    let n = u32::try_from(triangles.len()).expect(".tri counts triangles in a u32");
    let mut out = Vec::with_capacity(4 + TRI_BYTES * triangles.len());
    out.extend_from_slice(&n.to_le_bytes());
    for v in triangles.iter().flatten() {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tris() -> Vec<[Vec3; 3]> {
        vec![
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [
                Vec3::new(-1.5, 2.0, 1e-30),
                Vec3::splat(3.0),
                Vec3::new(0.0, -0.0, 7.25),
            ],
        ]
    }

    #[test]
    fn round_trip_is_exact() {
        let bytes = encode_tri(&tris());
        assert_eq!(bytes.len(), 4 + 2 * 36);
        assert_eq!(&bytes[..4], &2u32.to_le_bytes());
        assert_eq!(decode_tri(&bytes).unwrap(), tris());
    }

    #[test]
    fn wrong_lengths_are_refused() {
        let bytes = encode_tri(&tris());
        for len in [0, 3, 4, 5, 39, bytes.len() - 1] {
            assert!(decode_tri(&bytes[..len]).is_err(), "len {len}");
        }
        let mut trailing = bytes.clone();
        trailing.push(0);
        assert!(decode_tri(&trailing).is_err());
        let mut extra_tri = bytes.clone();
        extra_tri.extend_from_slice(&[0; 36]);
        assert!(decode_tri(&extra_tri).unwrap_err().contains("counts 2"));
    }

    #[test]
    fn huge_count_is_refused_without_allocating() {
        let mut bytes = u32::MAX.to_le_bytes().to_vec();
        bytes.extend_from_slice(&[0; 36]);
        assert!(decode_tri(&bytes).unwrap_err().contains("holds 1"));
    }

    #[test]
    fn non_finite_and_empty_are_refused() {
        let mut t = tris();
        t[1][2].y = f32::NAN;
        assert!(
            decode_tri(&encode_tri(&t))
                .unwrap_err()
                .contains("triangle 1")
        );
        t[1][2].y = f32::INFINITY;
        assert!(decode_tri(&encode_tri(&t)).is_err());
        assert!(
            decode_tri(&encode_tri(&[]))
                .unwrap_err()
                .contains("no triangles")
        );
    }
}
