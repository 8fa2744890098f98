//! The Dex3-1 USB CRC.
//!
//! The user manual gives a table-driven routine that walks `u32` words and feeds each word's
//! bytes most-significant first into a non-reflected CRC-32 with polynomial 0x04C11DB7, initial
//! value 0xFFFFFFFF and no final xor. That is exactly CRC-32/MPEG-2 (docs/sources.md §3; the same
//! result as `crc32_core` in unitreerobotics/dex1_1_service) over the byte stream in which every
//! little-endian word is byte-reversed. We run the `crc` crate's CRC-32/MPEG-2 over that stream.
//!
//! Every covered region is a whole number of words; the words start at arbitrary byte offsets
//! (the structures are packed), so they are read as little-endian `u32` from the bytes.

use crc::{Crc, Table, CRC_32_MPEG_2};

const MPEG2: Crc<u32, Table<16>> = Crc::<u32, Table<16>>::new(&CRC_32_MPEG_2);

/// CRC-32/MPEG-2 of a plain byte stream (for the standard check value).
pub fn crc32_mpeg2(bytes: &[u8]) -> u32 {
    MPEG2.checksum(bytes)
}

/// The manual's word-wise CRC over `words.len() / 4` little-endian words starting at
/// `words[0]`. Trailing bytes that do not fill a word are ignored, as the C routine (which takes
/// a word count) would never see them.
pub fn crc32_words(words: &[u8]) -> u32 {
    let mut digest = MPEG2.digest();
    // Byte-reverse each word into a small stack buffer and feed it in blocks.
    let mut buf = [0u8; 256];
    for block in words.chunks(256) {
        let n = block.len() / 4 * 4;
        for (dst, src) in buf[..n].chunks_exact_mut(4).zip(block[..n].chunks_exact(4)) {
            dst[0] = src[3];
            dst[1] = src[2];
            dst[2] = src[1];
            dst[3] = src[0];
        }
        digest.update(&buf[..n]);
        if n < block.len() {
            break;
        }
    }
    digest.finalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// An independent restatement of the manual's routine ("CRC32 Function Calculation
    /// Method"): a 256-entry MSB-first table for poly 0x04C11DB7 and a loop over u32 words
    /// taking bytes from bit 24 down. Written from the manual's description, not shared with
    /// the implementation above.
    fn manual_table() -> [u32; 256] {
        let mut t = [0u32; 256];
        for (i, slot) in t.iter_mut().enumerate() {
            let mut c = (i as u32) << 24;
            for _ in 0..8 {
                c = if c & 0x8000_0000 != 0 {
                    (c << 1) ^ 0x04C1_1DB7
                } else {
                    c << 1
                };
            }
            *slot = c;
        }
        t
    }

    fn manual_crc(words: &[u32]) -> u32 {
        let table = manual_table();
        let mut crc = 0xFFFF_FFFFu32;
        for &data in words {
            for j in 0..4 {
                let idx = ((crc >> 24) ^ (data >> (24 - j * 8))) & 0xFF;
                crc = (crc << 8) ^ table[idx as usize];
            }
        }
        crc
    }

    #[test]
    fn standard_check_value() {
        assert_eq!(crc32_mpeg2(b"123456789"), 0x0376_E6E7);
    }

    #[test]
    fn empty_is_initial_value() {
        assert_eq!(crc32_words(&[]), 0xFFFF_FFFF);
        assert_eq!(manual_crc(&[]), 0xFFFF_FFFF);
    }

    #[test]
    fn one_word_fixture() {
        // Word 0x34333231 is bytes "1234" little-endian; MSB first the stream is "4321".
        assert_eq!(crc32_words(b"1234"), crc32_mpeg2(b"4321"));
        assert_eq!(crc32_words(b"1234"), manual_crc(&[0x3433_3231]));
    }

    proptest! {
        #[test]
        fn equals_manual_routine(words in proptest::collection::vec(any::<u32>(), 0..400)) {
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            prop_assert_eq!(crc32_words(&bytes), manual_crc(&words));
        }

        #[test]
        fn ignores_partial_trailing_word(words in proptest::collection::vec(any::<u32>(), 0..80), tail in proptest::collection::vec(any::<u8>(), 0..4)) {
            let mut bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            let whole = crc32_words(&bytes);
            bytes.extend_from_slice(&tail);
            prop_assert_eq!(crc32_words(&bytes), whole);
        }
    }
}
