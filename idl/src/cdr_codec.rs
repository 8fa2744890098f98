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
