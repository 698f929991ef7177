//! `kdray merge`'s EXR reading (`kdray::image::decode_exr`) on arbitrary bytes: it must return,
//! never panic, hang or allocate past a bound set by the input (a part may claim at most
//! `EXR_MAX_RATIO` pixels per byte of its file, and `MAX_PIXELS` in all, before anything is
//! allocated for them). A part it accepts must be what `merge` needs: whole rows of an image
//! within the pixel cap, every row set once; it must merge alone exactly when it is the whole
//! image; and it must survive being written as kdray writes parts and read back bit for bit.
//!
//! Run: `cargo +nightly fuzz run exr fuzz/corpus/exr fuzz/seeds/exr` (from the repository root),
//! or `bash fuzz/run.sh SECONDS exr`; seeds: `fuzz/seeds/exr` (`render --tile` parts, one whole
//! image, and the issue-20 findings: a window of 2³¹ pixels, a chunk table with a repeated
//! entry).
#![no_main]

use kdray::image::{MAX_PIXELS, decode_exr, encode_exr, merge};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.exr");
    let Ok(band) = decode_exr(path, data) else {
        return;
    };
    let (w, h) = (band.width as u64, band.height as u64);
    assert!(w * h <= MAX_PIXELS, "{w}x{h} accepted past the cap");
    assert!(
        w > 0 && (band.pixels.len() as u64).is_multiple_of(w),
        "partial rows"
    );
    let rows = band.pixels.len() as u64 / w;
    assert!(u64::from(band.first_row) + rows <= h, "rows past the image");
    assert!(
        band.pixels.len() as u64 <= kdray::image::EXR_MAX_RATIO * data.len() as u64,
        "more pixels than the bytes can hold"
    );
    let alone = merge(&[(path, band.clone())]);
    assert_eq!(
        alone.is_ok(),
        band.is_whole(),
        "a lone part merges iff whole"
    );
    if rows == 0 {
        return;
    }
    let mut bytes = std::io::Cursor::new(Vec::new());
    encode_exr(&band, &mut bytes).expect("an accepted part can be written");
    let again = decode_exr(path, bytes.get_ref()).expect("a written part reads back");
    let bits = |b: &kdray::image::Band| -> Vec<u32> {
        b.pixels.iter().flatten().map(|v| v.to_bits()).collect()
    };
    assert_eq!(
        (again.width, again.height, again.first_row),
        (band.width, band.height, band.first_row)
    );
    assert_eq!(bits(&again), bits(&band), "pixels change in a round trip");
});
