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
///
/// The device loop and the emulator run it over a whole command and a whole state frame every
/// cycle (about 2.5 kB each way): on x86-64 CPUs with carry-less multiplication, runs of at
/// least [`FOLD_MIN`] bytes are folded 64 and 16 bytes at a time ([`fold`]), the rest goes through the
/// table, with the same result (tested against the manual's routine).
pub fn crc32_words(words: &[u8]) -> u32 {
    let words = &words[..words.len() / 4 * 4];
    #[cfg(target_arch = "x86_64")]
    if words.len() >= FOLD_MIN && fold::available() {
        // SAFETY: the CPU has the instructions `fold::crc32_words` is compiled for (checked
        // just above), and `words` is a whole number of words of at least 16 bytes.
        return unsafe { fold::crc32_words(words) };
    }
    table_words(MPEG2.digest(), words)
}

/// Shorter runs (the 20- to 44-byte packets) go through the table: folding pays off on frames.
pub const FOLD_MIN: usize = 64;

/// Feeds whole little-endian words to `digest` most-significant byte first and returns the CRC.
fn table_words(mut digest: crc::Digest<'_, u32, Table<16>>, words: &[u8]) -> u32 {
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
    }
    digest.finalize()
}

/// The CRC by folding with carry-less multiplication (as in Intel's white paper "Fast CRC
/// Computation for Generic Polynomials Using PCLMULQDQ Instruction", here for the non-reflected
/// polynomial and without its Barrett step).
///
/// The word stream is a polynomial over GF(2), the first bit the highest power. Sixteen bytes
/// are four words; loaded as one 128-bit value with the first word in the top 32 bits, bit `i`
/// of the value is the coefficient of `x^i`, as carry-less multiplication counts them. A running
/// value `X = H·x^64 + L` that stands for everything before the next block `D` becomes
/// `H·(x^192 mod P) + L·(x^128 mod P) + D`, congruent to `X·x^128 + D` modulo `P`, and still
/// under 128 bits. The initial value is XOR-ed into the first word (which is what a register
/// preset does to a CRC without reflection). What is left, the last 128-bit value followed by
/// the words after the last whole block, goes through the table from a zero register: a CRC is
/// the message times `x^32` modulo `P`, and the value is congruent to the message it stands for.
#[cfg(target_arch = "x86_64")]
mod fold {
    use super::{table_words, MPEG2};
    use std::arch::x86_64::{
        __m128i, _mm_clmulepi64_si128, _mm_loadu_si128, _mm_set_epi32, _mm_set_epi64x, _mm_shuffle_epi32,
        _mm_storeu_si128, _mm_xor_si128,
    };

    /// `x^n mod P` for the CRC-32/MPEG-2 polynomial `P = x^32 + 0x04C11DB7`.
    const fn x_pow_mod(n: u32) -> u64 {
        let mut r: u64 = 1;
        let mut i = 0;
        while i < n {
            r <<= 1;
            if r & (1 << 32) != 0 {
                r ^= 0x1_04C1_1DB7;
            }
            i += 1;
        }
        r
    }

    /// The constants that move a 128-bit value `n` bits further down the stream: its high 64
    /// bits are multiplied by `x^(n+64) mod P`, its low ones by `x^n mod P` (high lane, low lane).
    const fn by(n: u32) -> (u64, u64) {
        (x_pow_mod(n + 64), x_pow_mod(n))
    }
    const BY_128: (u64, u64) = by(128);
    const BY_256: (u64, u64) = by(256);
    const BY_384: (u64, u64) = by(384);
    const BY_512: (u64, u64) = by(512);

    /// Whether this CPU has what [`crc32_words`] needs (checked once, then cached by std).
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("pclmulqdq") && std::arch::is_x86_feature_detected!("sse2")
    }

    /// Sixteen bytes of the stream as a 128-bit value, the first word in the top lane.
    ///
    /// # Safety
    /// `b` holds at least 16 bytes and the CPU has SSE2.
    #[target_feature(enable = "sse2")]
    #[allow(unused_unsafe)] // the intrinsics are unsafe to call before Rust 1.87 (MSRV 1.80)
    unsafe fn load(b: &[u8]) -> __m128i {
        debug_assert!(b.len() >= 16);
        // SAFETY: 16 readable bytes (the caller's contract); unaligned load.
        let v = unsafe { _mm_loadu_si128(b.as_ptr().cast()) };
        // Lanes [w0, w1, w2, w3] (lowest first) to [w3, w2, w1, w0].
        unsafe { _mm_shuffle_epi32::<0x1B>(v) }
    }

    /// `x` moved `n` bits down the stream (`k` = [`by`]`(n)` in a register), modulo `P`.
    ///
    /// # Safety
    /// The CPU has PCLMULQDQ and SSE2.
    #[target_feature(enable = "pclmulqdq,sse2")]
    #[allow(unused_unsafe)] // the intrinsics are unsafe to call before Rust 1.87 (MSRV 1.80)
    unsafe fn fold(x: __m128i, k: __m128i) -> __m128i {
        // SAFETY: the caller's contract.
        unsafe { _mm_xor_si128(_mm_clmulepi64_si128::<0x11>(x, k), _mm_clmulepi64_si128::<0x00>(x, k)) }
    }

    /// The constants of [`by`] in a register.
    ///
    /// # Safety
    /// The CPU has SSE2.
    #[target_feature(enable = "sse2")]
    #[allow(unused_unsafe)] // the intrinsics are unsafe to call before Rust 1.87 (MSRV 1.80)
    unsafe fn constants((high, low): (u64, u64)) -> __m128i {
        // SAFETY: the caller's contract.
        unsafe { _mm_set_epi64x(high as i64, low as i64) }
    }

    /// The CRC of a whole number of words, at least 16 bytes. Four running values fold 64
    /// bytes at a time (four independent chains of multiplications keep the multiplier busy),
    /// then join into one, which folds the whole 16-byte blocks left.
    ///
    /// # Safety
    /// The CPU has PCLMULQDQ and SSE2 ([`available`]); `words.len()` is a multiple of 4 and at
    /// least 16.
    #[target_feature(enable = "pclmulqdq,sse2")]
    #[allow(unused_unsafe)] // the intrinsics are unsafe to call before Rust 1.87 (MSRV 1.80)
    pub(super) unsafe fn crc32_words(words: &[u8]) -> u32 {
        debug_assert!(words.len() >= 16 && words.len() % 4 == 0);
        // SAFETY (every block below): SSE2 and PCLMULQDQ are present (the caller's contract);
        // each load reads 16 bytes inside `words`.
        let preset = unsafe { _mm_set_epi32(-1, 0, 0, 0) };
        let mut at;
        let mut x = if words.len() >= 64 {
            let k = unsafe { constants(BY_512) };
            let mut v = unsafe {
                [
                    _mm_xor_si128(load(&words[..16]), preset),
                    load(&words[16..32]),
                    load(&words[32..48]),
                    load(&words[48..64]),
                ]
            };
            at = 64;
            while words.len() - at >= 64 {
                for (i, x) in v.iter_mut().enumerate() {
                    *x = unsafe { _mm_xor_si128(fold(*x, k), load(&words[at + 16 * i..])) };
                }
                at += 64;
            }
            unsafe {
                let joined = _mm_xor_si128(fold(v[0], constants(BY_384)), fold(v[1], constants(BY_256)));
                _mm_xor_si128(_mm_xor_si128(joined, fold(v[2], constants(BY_128))), v[3])
            }
        } else {
            at = 16;
            unsafe { _mm_xor_si128(load(&words[..16]), preset) }
        };
        let k = unsafe { constants(BY_128) };
        while words.len() - at >= 16 {
            x = unsafe { _mm_xor_si128(fold(x, k), load(&words[at..])) };
            at += 16;
        }
        let mut lanes = [0u32; 4];
        unsafe { _mm_storeu_si128(lanes.as_mut_ptr().cast(), x) };
        // The value's bytes, most significant first, are the words of the top lane first.
        let mut bytes = [0u8; 16];
        for (dst, lane) in bytes.chunks_exact_mut(4).zip(lanes.iter().rev()) {
            dst.copy_from_slice(&lane.to_le_bytes());
        }
        // From a zero register: `bytes` and the tail are words (little-endian), as
        // `table_words` takes them.
        let digest = MPEG2.digest_with_initial(0);
        let tail = &words[at..];
        let mut rest = [0u8; 32];
        rest[..16].copy_from_slice(&bytes);
        rest[16..16 + tail.len()].copy_from_slice(tail);
        table_words(digest, &rest[..16 + tail.len()])
    }
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

    /// The folded CRC equals the table's at every length from one block up to past a state
    /// frame, on bytes that are not all alike.
    #[test]
    fn folding_equals_table() {
        let mut state = 0x9E37_79B9u32;
        let bytes: Vec<u8> = (0..1400)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                state as u8
            })
            .collect();
        for len in (0..=bytes.len()).step_by(4) {
            let w = &bytes[..len];
            let table = table_words(MPEG2.digest(), w);
            assert_eq!(crc32_words(w), table, "len {len}");
            #[cfg(target_arch = "x86_64")]
            if len >= 16 && fold::available() {
                // SAFETY: checked available; whole words, at least 16 bytes.
                assert_eq!(unsafe { fold::crc32_words(w) }, table, "len {len}");
            }
        }
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
