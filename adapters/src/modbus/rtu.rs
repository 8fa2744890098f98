//! Modbus RTU framing: `slave(1) PDU CRC(2)`, the CRC-16/MODBUS of slave + PDU sent low byte
//! first (Modbus over Serial Line V1.02, 2.5.1). Pure functions over bytes.
//!
//! On a serial line a frame ends with 3.5 character times of silence ([`frame_gap`]). The
//! decoders here do not need the silence: a frame's length follows from its function code
//! and byte count, so a request or response can be cut out of a byte stream (a pty, RTU over
//! TCP) as soon as its last byte is in. The silence is still used by the callers: a master
//! waits [`frame_gap`] before it transmits, and a server discards a partial frame after it
//! (front::stream's `Session::gap`). For a function code whose length the decoder does not
//! know, the frame ends at the first position where the CRC matches (what a slave that
//! delimits by silence would see), so such a request is answered with exception 1 instead of
//! stalling the line.

use std::time::Duration;

use crc::{Crc, CRC_16_MODBUS};

use super::pdu::EXCEPTION_BIT;

/// Largest RTU frame (spec 2.5.1.1): slave + 253-byte PDU + CRC.
pub const MAX_ADU: usize = 256;
/// Slave address 0 is a broadcast: every slave executes a write and none answers.
pub const BROADCAST: u8 = 0;
/// Highest unicast slave address.
pub const MAX_SLAVE: u8 = 247;
/// Bits per character the spec's timing assumes: start, 8 data, parity (or a second stop
/// bit), stop. An 8N1 line (the Robotiq's, the RH56's) sends 10 bits per byte; the gaps
/// computed from 11 bits are the spec's and err on the long side.
pub const BITS_PER_CHAR: u32 = 11;

const MODBUS_CRC: Crc<u16> = Crc::<u16>::new(&CRC_16_MODBUS);

/// CRC-16/MODBUS (poly 0x8005 reflected, init 0xFFFF) of `bytes`; sent as `crc.to_le_bytes()`.
pub fn crc16(bytes: &[u8]) -> u16 {
    MODBUS_CRC.checksum(bytes)
}

/// One character time at `baud` ([`BITS_PER_CHAR`] bits).
pub fn char_time(baud: u32) -> Duration {
    Duration::from_nanos(BITS_PER_CHAR as u64 * 1_000_000_000 / baud.max(1) as u64)
}

/// The silence that ends a frame: 3.5 character times, fixed at 1.75 ms above 19200 baud
/// (spec 2.5.1.1).
pub fn frame_gap(baud: u32) -> Duration {
    if baud > 19_200 {
        Duration::from_micros(1750)
    } else {
        Duration::from_nanos(7 * BITS_PER_CHAR as u64 * 1_000_000_000 / (2 * baud.max(1) as u64))
    }
}

/// Appends `slave`, `pdu` and the CRC to `out`.
pub fn encode(slave: u8, pdu: &[u8], out: &mut Vec<u8>) {
    let start = begin(out, slave);
    out.extend_from_slice(pdu);
    finish(out, start);
}

/// Starts a frame in `out` (pushes the slave address); write the PDU after it, then call
/// [`finish`] with the returned start. Saves a copy when the PDU is encoded in place.
pub fn begin(out: &mut Vec<u8>, slave: u8) -> usize {
    let start = out.len();
    out.push(slave);
    start
}

/// Appends the CRC of `out[start..]`.
pub fn finish(out: &mut Vec<u8>, start: usize) {
    let crc = crc16(&out[start..]);
    out.extend_from_slice(&crc.to_le_bytes());
}

/// A frame cut from the front of a buffer, CRC checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    pub slave: u8,
    /// Function code and data (no slave, no CRC).
    pub pdu: &'a [u8],
    /// Bytes the frame took from the buffer.
    pub len: usize,
}

/// Why no frame could be cut from the front of a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RtuError {
    /// The frame is not complete: at least `need` more bytes.
    #[error("incomplete frame: {need} more bytes needed")]
    Incomplete { need: usize },
    /// A frame of `len` bytes whose CRC does not match: drop `len` bytes (or wait for the
    /// gap and drop everything).
    #[error("bad CRC in a {len}-byte frame: received {received:04X}, computed {computed:04X}")]
    BadCrc { len: usize, received: u16, computed: u16 },
    /// Not a frame this decoder can delimit (a response of another function, a length past
    /// [`MAX_ADU`]): drop the buffer.
    #[error("malformed frame: {reason}")]
    Malformed { reason: &'static str },
}

impl RtuError {
    /// A short key for counters and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            RtuError::Incomplete { .. } => "incomplete",
            RtuError::BadCrc { .. } => "bad_crc",
            RtuError::Malformed { .. } => "malformed",
        }
    }
}

/// The length of a frame given its header: `Ok(Some(len))` known, `Ok(None)` unknown function
/// (delimit by CRC), `Err(need)` more header bytes needed.
type LenRule = Result<Option<usize>, usize>;

/// `fixed + buf[count_at]` once `count_at` is in.
fn counted(buf: &[u8], count_at: usize, fixed: usize) -> LenRule {
    match buf.get(count_at) {
        Some(&n) => Ok(Some(fixed + n as usize)),
        None => Err(count_at + 1 - buf.len()),
    }
}

fn request_len(buf: &[u8]) -> LenRule {
    if buf.len() < 2 {
        return Err(2 - buf.len());
    }
    match buf[1] {
        // Reads of coils, discrete inputs, registers; single writes; diagnostics (08):
        // slave fc a a b b crc crc.
        0x01..=0x06 | 0x08 => Ok(Some(8)),
        // Exception status, comm event counter / log, report server id: slave fc crc crc.
        0x07 | 0x0B | 0x0C | 0x11 => Ok(Some(4)),
        // Write multiple coils / registers: slave fc addr(2) qty(2) n data(n) crc.
        0x0F | 0x10 => counted(buf, 6, 9),
        // Mask write register: slave fc addr and mask(2) or mask(2) crc.
        0x16 => Ok(Some(10)),
        // Read/write multiple: slave fc raddr rqty waddr wqty n data(n) crc.
        0x17 => counted(buf, 10, 13),
        _ => Ok(None),
    }
}

fn response_len(buf: &[u8], expected_function: u8) -> Result<LenRule, RtuError> {
    if buf.len() < 2 {
        return Ok(Err(2 - buf.len()));
    }
    let f = buf[1];
    if f == expected_function | EXCEPTION_BIT {
        return Ok(Ok(Some(5)));
    }
    if f != expected_function {
        return Err(RtuError::Malformed {
            reason: "function code does not answer the request",
        });
    }
    Ok(match f {
        // slave fc n data(n) crc.
        0x01..=0x04 | 0x0C | 0x17 => counted(buf, 2, 5),
        // Echo of address and value/quantity.
        0x05 | 0x06 | 0x0F | 0x10 => Ok(Some(8)),
        0x16 => Ok(Some(10)),
        0x07 => Ok(Some(5)),
        _ => Ok(None),
    })
}

fn cut(buf: &[u8], rule: LenRule) -> Result<Frame<'_>, RtuError> {
    let len = match rule {
        Err(need) => return Err(RtuError::Incomplete { need }),
        Ok(None) => return cut_by_crc(buf),
        Ok(Some(len)) => len,
    };
    if len > MAX_ADU {
        return Err(RtuError::Malformed {
            reason: "byte count makes the frame longer than 256 bytes",
        });
    }
    if buf.len() < len {
        return Err(RtuError::Incomplete { need: len - buf.len() });
    }
    let computed = crc16(&buf[..len - 2]);
    let received = u16::from_le_bytes([buf[len - 2], buf[len - 1]]);
    if computed != received {
        return Err(RtuError::BadCrc {
            len,
            received,
            computed,
        });
    }
    Ok(Frame {
        slave: buf[0],
        pdu: &buf[1..len - 2],
        len,
    })
}

/// A frame of unknown length ends where the CRC of what precedes matches the next two bytes.
fn cut_by_crc(buf: &[u8]) -> Result<Frame<'_>, RtuError> {
    let mut digest = MODBUS_CRC.digest();
    let limit = buf.len().min(MAX_ADU);
    // Shortest frame: slave, function, CRC.
    digest.update(&buf[..2]);
    for len in 4..=limit {
        let computed = digest.clone().finalize();
        if u16::from_le_bytes([buf[len - 2], buf[len - 1]]) == computed {
            return Ok(Frame {
                slave: buf[0],
                pdu: &buf[1..len - 2],
                len,
            });
        }
        digest.update(&buf[len - 2..len - 1]);
    }
    if buf.len() >= MAX_ADU {
        Err(RtuError::Malformed {
            reason: "no CRC match within 256 bytes",
        })
    } else {
        Err(RtuError::Incomplete { need: 1 })
    }
}

/// Cuts the request frame at the front of `buf` (a server's view).
pub fn decode_request(buf: &[u8]) -> Result<Frame<'_>, RtuError> {
    cut(buf, request_len(buf))
}

/// Cuts the response to a request of `expected_function` at the front of `buf` (a master's
/// view): the function must be `expected_function` or its exception.
pub fn decode_response(buf: &[u8], expected_function: u8) -> Result<Frame<'_>, RtuError> {
    let rule = response_len(buf, expected_function)?;
    cut(buf, rule)
}
