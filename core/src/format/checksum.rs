//! The checksum in the header: what catches damage (see "Corruption" in [`super`]).

use super::{HEADER_WORDS, header};

/// FNV-1a's 64-bit offset basis and prime (Fowler, Noll, Vo; IETF draft-eastlake-fnv).
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// The checksum stored in the header's CHECKSUM words: 64-bit FNV-1a over `words` taken whole
/// (not byte by byte), in four interleaved lanes so that the multiplies do not wait on each other,
/// with the CHECKSUM words themselves counted as 0; then the length and the four lanes folded in.
/// See "Corruption" in the module doc for what it detects.
pub fn checksum(words: &[u32]) -> u64 {
    let mut head = [0u32; HEADER_WORDS];
    let n = words.len().min(HEADER_WORDS);
    head[..n].copy_from_slice(&words[..n]);
    head[header::CHECKSUM] = 0;
    head[header::CHECKSUM + 1] = 0;
    let mut lanes = [0u64, 1, 2, 3].map(|k| FNV_OFFSET ^ k);
    let mut feed = |chunk: &[u32]| {
        for (h, &w) in lanes.iter_mut().zip(chunk) {
            *h = (*h ^ u64::from(w)).wrapping_mul(FNV_PRIME);
        }
    };
    head[..n].chunks(4).for_each(&mut feed);
    // Whole chunks as arrays, so that the four lanes stay in registers with no bounds checks
    // (slices of unknown length cost twice the instructions per word), then the rest.
    let (whole, rest) = words[n..].as_chunks::<4>();
    for chunk in whole {
        feed(chunk);
    }
    feed(rest);
    let step = |h: u64, w: u64| (h ^ w).wrapping_mul(FNV_PRIME);
    lanes
        .into_iter()
        .fold(step(FNV_OFFSET, words.len() as u64), step)
}

/// Stores `words`' [`checksum`] in its header (the writer's last step). Does nothing to an
/// array shorter than the header.
pub fn seal(words: &mut [u32]) {
    if words.len() >= HEADER_WORDS {
        let sum = checksum(words);
        words[header::CHECKSUM] = sum as u32;
        words[header::CHECKSUM + 1] = (sum >> 32) as u32;
    }
}
