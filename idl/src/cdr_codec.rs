//! Plain CDR (XCDR1) encoding with the 4-byte encapsulation header, as CycloneDDS puts it on
//! the wire. Used for golden-byte tests, fuzzing and anything that needs the bytes without a
//! DDS participant. cyclonedds-rs itself writes big-endian; the SDKs write little-endian;
//! readers accept both.

use serde::{de::DeserializeOwned, Serialize};

/// Failure to encode or decode a CDR buffer.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    #[error("CDR encode failed: {0}")]
    Encode(String),
    #[error("CDR decode failed: {0}")]
    Decode(String),
}

/// Largest sample handgate will decode; HandState_ with 7 motors and 9 pads is ~1 KiB.
pub const MAX_DECODE_BYTES: u64 = 1 << 20;

/// Little-endian CDR with encapsulation header `00 01 00 00` (what unitree_sdk2 and
/// unitree_sdk2py send).
pub fn to_cdr_le<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    cdr::serialize::<_, _, cdr::CdrLe>(value, cdr::Infinite).map_err(|e| CdrError::Encode(e.to_string()))
}

/// Big-endian CDR with encapsulation header `00 00 00 00` (what cyclonedds-rs sends).
pub fn to_cdr_be<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    cdr::serialize::<_, _, cdr::CdrBe>(value, cdr::Infinite).map_err(|e| CdrError::Encode(e.to_string()))
}

/// Decodes a CDR buffer of either endianness (read from its encapsulation header). Never
/// panics; sequences longer than the buffer allows are rejected by the size bound.
pub fn from_cdr<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    let bound = (bytes.len() as u64).min(MAX_DECODE_BYTES);
    cdr::deserialize_from::<_, T, _>(bytes, cdr::Bounded(bound)).map_err(|e| CdrError::Decode(e.to_string()))
}

/// `body`, a sample's bytes after its encapsulation header (a raw reader's, which does not keep
/// the header), decoded as `T` in each byte order it decodes in: little-endian first (what the
/// SDKs write), then big-endian.
pub fn from_cdr_body<T: DeserializeOwned>(body: &[u8]) -> impl Iterator<Item = T> + '_ {
    [[0u8, 1, 0, 0], [0, 0, 0, 0]].into_iter().filter_map(move |header| {
        let mut buf = Vec::with_capacity(body.len() + 4);
        buf.extend_from_slice(&header);
        buf.extend_from_slice(body);
        from_cdr::<T>(&buf).ok()
    })
}

/// CDR strings decoded without trusting their length prefix.
///
/// The `cdr` crate (0.2.4, also what cyclonedds-rs decodes every received sample with)
/// allocates and zero-fills a buffer of the announced string length *before* checking it
/// against the bytes that exist, so one malformed sample announcing a 4 GiB string costs 4 GiB
/// of memory (found by `fuzz/` cdr_decode; docs/reliability.md). Every `String` field of the
/// wire types decodes through [`cdr_string::deserialize`] instead: the same bytes (u32 length
/// including the terminating NUL, then the bytes), read one element at a time so the size
/// bound stops a lying length after the bytes that are actually there.
pub mod cdr_string {
    use std::fmt;

    use serde::de::{self, DeserializeSeed, Deserializer, SeqAccess, Visitor};

    /// Largest string kept (bytes); longer ones are a decode error. Joint and device names
    /// are tens of bytes.
    pub const MAX_STRING: usize = 64 * 1024;

    struct StrVisitor;

    impl<'de> Visitor<'de> for StrVisitor {
        type Value = String;

        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a CDR string (u32 length, bytes)")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<String, A::Error> {
            let len: u32 = seq
                .next_element()?
                .ok_or_else(|| de::Error::custom("string length missing"))?;
            let len = len as usize;
            if len > MAX_STRING {
                return Err(de::Error::custom(format!("string of {len} bytes (max {MAX_STRING})")));
            }
            let mut buf = Vec::with_capacity(len.min(256));
            for _ in 0..len {
                let b: u8 = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::custom("string truncated"))?;
                buf.push(b);
            }
            // The length counts the terminating NUL (as the cdr crate: drop the last byte).
            buf.pop();
            String::from_utf8(buf).map_err(de::Error::custom)
        }
    }

    /// `#[serde(deserialize_with = "cdr_string::deserialize")]` for a `String` field.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
        // A tuple reads nothing up front: the visitor pulls the length, then the bytes.
        d.deserialize_tuple(usize::MAX, StrVisitor)
    }

    struct StrSeed;

    impl<'de> DeserializeSeed<'de> for StrSeed {
        type Value = String;
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<String, D::Error> {
            deserialize(d)
        }
    }

    struct VecVisitor;

    impl<'de> Visitor<'de> for VecVisitor {
        type Value = Vec<String>;

        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a CDR sequence of strings")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<String>, A::Error> {
            let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(256));
            while let Some(s) = seq.next_element_seed(StrSeed)? {
                out.push(s);
            }
            Ok(out)
        }
    }

    /// `#[serde(deserialize_with = "cdr_string::deserialize_vec")]` for a `Vec<String>` field.
    pub fn deserialize_vec<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<String>, D::Error> {
        d.deserialize_seq(VecVisitor)
    }
}

/// IDL bounded sequences (`sequence<T, N>`) as `Vec<T>` fields:
/// `#[serde(serialize_with = "bounded_seq::serialize::<N, _, _>",
/// deserialize_with = "bounded_seq::deserialize::<N, _, _>")]`.
///
/// Same bytes as an unbounded sequence (u32 count, then the elements); the bound is what
/// CycloneDDS enforces: encoding more than `N` elements is an error (its `write_bound_exceeded`),
/// and so is decoding a count above `N`, checked against the announced count before any
/// element is read or any memory is reserved for it.
pub mod bounded_seq {
    use std::fmt;
    use std::marker::PhantomData;

    use serde::de::{self, Deserialize, Deserializer, SeqAccess, Visitor};
    use serde::ser::{self, Serialize, SerializeSeq, Serializer};

    /// Serialises `v` as a sequence, or fails if it holds more than `N` elements.
    #[allow(clippy::ptr_arg)] // serde's serialize_with passes `&Vec<T>`
    pub fn serialize<const N: usize, T: Serialize, S: Serializer>(v: &Vec<T>, s: S) -> Result<S::Ok, S::Error> {
        if v.len() > N {
            return Err(ser::Error::custom(format!(
                "bounded sequence of {} elements (bound {N})",
                v.len()
            )));
        }
        let mut seq = s.serialize_seq(Some(v.len()))?;
        for x in v {
            seq.serialize_element(x)?;
        }
        seq.end()
    }

    struct BoundedVisitor<const N: usize, T>(PhantomData<T>);

    impl<'de, const N: usize, T: Deserialize<'de>> Visitor<'de> for BoundedVisitor<N, T> {
        type Value = Vec<T>;

        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "a sequence of at most {N} elements")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            // The cdr crate reports the announced count here, before reading any element.
            if let Some(n) = seq.size_hint() {
                if n > N {
                    return Err(de::Error::custom(format!(
                        "bounded sequence of {n} elements (bound {N})"
                    )));
                }
            }
            let mut out = Vec::with_capacity(N.min(seq.size_hint().unwrap_or(0)));
            while let Some(x) = seq.next_element()? {
                if out.len() == N {
                    return Err(de::Error::custom(format!("bounded sequence longer than {N}")));
                }
                out.push(x);
            }
            Ok(out)
        }
    }

    /// Deserialises a sequence of at most `N` elements.
    pub fn deserialize<'de, const N: usize, T: Deserialize<'de>, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Vec<T>, D::Error> {
        d.deserialize_seq(BoundedVisitor::<N, T>(PhantomData))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{handgate as hg, ros2};

    /// Regression (fuzz/ cdr_decode, out-of-memory): a string announcing ~4 GiB must fail
    /// fast, not allocate it.
    #[test]
    fn lying_string_length_is_an_error_not_an_allocation() {
        let mut ok = hg::HandCmd_::default();
        ok.joints.push(hg::JointCmd_ {
            name: "index_0".into(),
            ..Default::default()
        });
        for enc in [to_cdr_le::<hg::HandCmd_>, to_cdr_be::<hg::HandCmd_>] {
            let bytes = enc(&ok).unwrap();
            assert_eq!(from_cdr::<hg::HandCmd_>(&bytes).unwrap(), ok);
            // The name's length word sits after seq(8) mode(1)+pad(3) closure(4) stiffness(4)
            // count(4), after the 4-byte encapsulation header.
            let at = 4 + 8 + 4 + 4 + 4 + 4;
            for len in [0xFFFF_FFF0u32, 0x8000_0000, MAX_DECODE_BYTES as u32 + 1, 100] {
                let mut bad = bytes.clone();
                let word = if bytes[1] == 1 {
                    len.to_le_bytes()
                } else {
                    len.to_be_bytes()
                };
                bad[at..at + 4].copy_from_slice(&word);
                assert!(from_cdr::<hg::HandCmd_>(&bad).is_err(), "length {len:#x}");
            }
        }
        // The fuzzer's input: a ros2 JointState_ whose name sequence lies the same way.
        let js = ros2::JointState_ {
            name: vec!["a".into(), "bc".into()],
            ..Default::default()
        };
        let bytes = to_cdr_le(&js).unwrap();
        assert_eq!(from_cdr::<ros2::JointState_>(&bytes).unwrap(), js);
        let mut bad = bytes.clone();
        let n = bad.len();
        bad.truncate(n - 12);
        assert!(from_cdr::<ros2::JointState_>(&bad).is_err());
    }

    #[test]
    fn empty_and_long_strings_round_trip() {
        for name in [String::new(), "x".repeat(1000)] {
            let v = hg::JointCmd_ {
                name,
                ..Default::default()
            };
            assert_eq!(from_cdr::<hg::JointCmd_>(&to_cdr_le(&v).unwrap()).unwrap(), v);
            assert_eq!(from_cdr::<hg::JointCmd_>(&to_cdr_be(&v).unwrap()).unwrap(), v);
        }
        let v = hg::JointCmd_ {
            name: "y".repeat(cdr_string::MAX_STRING + 1),
            ..Default::default()
        };
        assert!(from_cdr::<hg::JointCmd_>(&to_cdr_le(&v).unwrap()).is_err());
    }
}
