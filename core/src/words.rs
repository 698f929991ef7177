//! Bytes as words, without `unsafe` in the caller: the way from `include_bytes!`, a flash region
//! or a fetched buffer to the `&[u32]` that [`Scene::from_words`](crate::Scene::from_words) and
//! [`Description::from_words`](crate::description::Description::from_words) take.
//!
//! The flat formats are little-endian words; on a little-endian target (every target kdray is
//! built for: x86-64, aarch64, thumbv7em, wasm32) a 4-byte-aligned byte slice already *is* that
//! word array, so [`from_bytes`] views it in place through `bytemuck` (no copy). A misaligned or
//! odd-length slice is an error, never a panic.
//!
//! `include_bytes!` gives no alignment guarantee; [`include_words!`](crate::include_words) wraps
//! the bytes in [`Aligned`] so that they start on a 4-byte boundary:
//! ```
//! # // The doc test views bytes built in place of a file.
//! use kdray_core::words::{Aligned, from_bytes};
//! static BYTES: &Aligned<[u8]> = &Aligned([1, 0, 0, 0, 2, 0, 0, 0]);
//! assert_eq!(from_bytes(&BYTES.0), Ok(&[1u32, 2][..]));
//! ```

/// Why bytes are not a word array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WordsError {
    /// The bytes do not start on a 4-byte boundary.
    Misaligned,
    /// The length is not a multiple of 4.
    OddLength { bytes: usize },
    /// The target is big-endian: the words would need swapping, which a view cannot do.
    BigEndian,
}

impl core::fmt::Display for WordsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Misaligned => write!(f, "the bytes do not start on a 4-byte boundary"),
            Self::OddLength { bytes } => {
                write!(f, "{bytes} bytes is not a whole number of 32-bit words")
            }
            Self::BigEndian => write!(f, "little-endian words cannot be viewed in place here"),
        }
    }
}

/// `bytes` viewed as little-endian `u32` words, in place.
///
/// # Errors
/// [`WordsError`] when `bytes` is misaligned, not a multiple of 4 long, or the target is
/// big-endian.
pub fn from_bytes(bytes: &[u8]) -> Result<&[u32], WordsError> {
    if cfg!(target_endian = "big") {
        return Err(WordsError::BigEndian);
    }
    if !bytes.len().is_multiple_of(4) {
        return Err(WordsError::OddLength { bytes: bytes.len() });
    }
    bytemuck::try_cast_slice(bytes).map_err(|_| WordsError::Misaligned)
}

/// A value placed on a 4-byte boundary: `Aligned([u8; N])` holds bytes that [`from_bytes`]
/// accepts. Used through [`include_words!`](crate::include_words).
#[repr(C, align(4))]
pub struct Aligned<T: ?Sized>(pub T);

/// Embeds a file (as `include_bytes!` does, path relative to the calling file) on a 4-byte
/// boundary and evaluates to a `&'static [u8]` that [`words::from_bytes`](from_bytes) accepts.
///
/// ```ignore
/// let words = kdray_core::words::from_bytes(kdray_core::include_words!("scene.kdt"))?;
/// ```
#[macro_export]
macro_rules! include_words {
    ($path:expr) => {{
        static ALIGNED: &$crate::words::Aligned<[u8]> =
            &$crate::words::Aligned(*include_bytes!($path));
        &ALIGNED.0
    }};
}

/// FNV-1a, 32-bit (Fowler, Noll, Vo; the parameters of draft-eastlake-fnv), over words as their
/// little-endian bytes: the scene hash of a render description and the pixel checksum that the
/// firmware and the host print.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a(pub u32);

impl Default for Fnv1a {
    fn default() -> Self {
        Self(0x811c_9dc5)
    }
}

impl Fnv1a {
    /// Adds one word's four bytes, low byte first.
    #[inline]
    pub fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
    }

    /// Adds the bits of pixels of linear RGB, row-major, red first: the checksum of an image.
    pub fn pixels(&mut self, pixels: &[[f32; 3]]) {
        for c in pixels.iter().flatten() {
            self.word(c.to_bits());
        }
    }
}
