//! The RH56's own serial protocol (RH56 user manual V1.09 §2; the frames pyrh56 0.4.0 builds
//! and checks): pure, allocation-free on reused buffers, fuzzed.
//!
//! ```text
//! request  EB 90  id  len  cmd  addr_lo addr_hi  payload...  sum
//! reply    90 EB  id  len  cmd  addr_lo addr_hi  payload...  sum
//! ```
//! `len` counts `cmd` and everything after it up to the checksum; `sum` is the low 8 bits of
//! the sum of every byte after the two header bytes (id through the last payload byte).
//! - read (0x11): request payload = one byte, the number of data bytes to read (9-byte frame);
//!   reply payload = those bytes (`len` = count + 3).
//! - write (0x12): request payload = the bytes to write (16-bit values little-endian); reply
//!   payload = one byte, 1 = written (`len` = 4, 9-byte frame).

/// Request header (host → hand).
pub const REQUEST_HEADER: [u8; 2] = [0xEB, 0x90];
/// Reply header (hand → host).
pub const REPLY_HEADER: [u8; 2] = [0x90, 0xEB];
/// Read registers.
pub const CMD_READ: u8 = 0x11;
/// Write registers.
pub const CMD_WRITE: u8 = 0x12;
/// Header, id, len before `cmd`; the checksum after.
pub const OVERHEAD: usize = 5;
/// Largest data a read reply carries (`len` = count + 3 must fit a byte).
pub const MAX_READ: usize = 252;
/// Largest data a write request carries (`len` = data + 3).
pub const MAX_WRITE: usize = 252;
/// A read request's and a write acknowledgement's length.
pub const SHORT_FRAME: usize = 9;

/// Why bytes are not a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// A frame may start here but `need` more bytes are missing.
    #[error("incomplete frame: {need} more byte(s) needed")]
    Incomplete { need: usize },
    #[error("no frame header at the start")]
    BadHeader,
    #[error("checksum mismatch: computed {computed:#04x}, received {received:#04x}")]
    BadChecksum { computed: u8, received: u8 },
    /// A complete frame whose fields do not fit together (its length field, its command).
    #[error("malformed frame: {0}")]
    Malformed(&'static str),
}

impl FrameError {
    /// The counter key of a refusal (`bad_checksum`, `garbage`, `malformed`).
    pub fn reason(&self) -> &'static str {
        match self {
            FrameError::Incomplete { .. } => "incomplete",
            FrameError::BadHeader => "garbage",
            FrameError::BadChecksum { .. } => "bad_checksum",
            FrameError::Malformed(_) => "malformed",
        }
    }
}

/// What cannot be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    #[error("{0} data bytes do not fit one frame (at most 252)")]
    TooLong(usize),
    #[error("a read or write of 0 bytes")]
    Empty,
}

/// The low 8 bits of the sum of `bytes`.
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |s, b| s.wrapping_add(*b))
}

fn frame(header: [u8; 2], id: u8, cmd: u8, addr: u16, payload: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(&header);
    let [lo, hi] = addr.to_le_bytes();
    out.extend_from_slice(&[id, (payload.len() + 3) as u8, cmd, lo, hi]);
    out.extend_from_slice(payload);
    let sum = checksum(&out[2..]);
    out.push(sum);
}

/// A read request of `count` data bytes from `addr` into `out` (cleared first).
pub fn encode_read(id: u8, addr: u16, count: usize, out: &mut Vec<u8>) -> Result<(), EncodeError> {
    match count {
        0 => Err(EncodeError::Empty),
        n if n > MAX_READ => Err(EncodeError::TooLong(n)),
        n => {
            frame(REQUEST_HEADER, id, CMD_READ, addr, &[n as u8], out);
            Ok(())
        }
    }
}

/// A write request of `data` at `addr` into `out` (cleared first).
pub fn encode_write(id: u8, addr: u16, data: &[u8], out: &mut Vec<u8>) -> Result<(), EncodeError> {
    match data.len() {
        0 => Err(EncodeError::Empty),
        n if n > MAX_WRITE => Err(EncodeError::TooLong(n)),
        _ => {
            frame(REQUEST_HEADER, id, CMD_WRITE, addr, data, out);
            Ok(())
        }
    }
}

/// A read reply carrying `data` (what the hand sends; the front and the emulator use it).
pub fn encode_read_reply(id: u8, addr: u16, data: &[u8], out: &mut Vec<u8>) -> Result<(), EncodeError> {
    if data.len() > MAX_READ {
        return Err(EncodeError::TooLong(data.len()));
    }
    frame(REPLY_HEADER, id, CMD_READ, addr, data, out);
    Ok(())
}

/// A write acknowledgement (`ok`: result byte 1, else 0).
pub fn encode_write_ack(id: u8, addr: u16, ok: bool, out: &mut Vec<u8>) {
    frame(REPLY_HEADER, id, CMD_WRITE, addr, &[u8::from(ok)], out);
}

/// One decoded frame, borrowing its payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame<'a> {
    pub id: u8,
    pub cmd: u8,
    pub addr: u16,
    /// The bytes between the address and the checksum.
    pub payload: &'a [u8],
}

/// The frame at the start of `buf` with header `header`, and its length.
fn decode(header: [u8; 2], buf: &[u8]) -> Result<(Frame<'_>, usize), FrameError> {
    for (i, h) in header.iter().enumerate() {
        match buf.get(i) {
            None => return Err(FrameError::Incomplete { need: 4 - buf.len() }),
            Some(b) if b != h => return Err(FrameError::BadHeader),
            Some(_) => {}
        }
    }
    let Some(&len) = buf.get(3) else {
        return Err(FrameError::Incomplete { need: 4 - buf.len() });
    };
    let total = OVERHEAD + len as usize;
    if buf.len() < total {
        // A length below cmd + address is malformed whatever follows: say so now rather
        // than wait for bytes that cannot make it a frame.
        if len < 3 {
            return Err(FrameError::Malformed("length field below 3 (command and address)"));
        }
        return Err(FrameError::Incomplete {
            need: total - buf.len(),
        });
    }
    if len < 3 {
        return Err(FrameError::Malformed("length field below 3 (command and address)"));
    }
    let computed = checksum(&buf[2..total - 1]);
    let received = buf[total - 1];
    if computed != received {
        return Err(FrameError::BadChecksum { computed, received });
    }
    Ok((
        Frame {
            id: buf[2],
            cmd: buf[4],
            addr: u16::from_le_bytes([buf[5], buf[6]]),
            payload: &buf[7..total - 1],
        },
        total,
    ))
}

/// A request a hand (or a front) receives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request<'a> {
    Read { id: u8, addr: u16, count: u8 },
    Write { id: u8, addr: u16, data: &'a [u8] },
}

impl Request<'_> {
    pub fn id(&self) -> u8 {
        match self {
            Request::Read { id, .. } | Request::Write { id, .. } => *id,
        }
    }
}

/// The request at the start of `buf` and the bytes it takes.
pub fn decode_request(buf: &[u8]) -> Result<(Request<'_>, usize), FrameError> {
    let (f, n) = decode(REQUEST_HEADER, buf)?;
    let req = match (f.cmd, f.payload.len()) {
        (CMD_READ, 1) if f.payload[0] > 0 && f.payload[0] as usize <= MAX_READ => Request::Read {
            id: f.id,
            addr: f.addr,
            count: f.payload[0],
        },
        (CMD_READ, 1) => return Err(FrameError::Malformed("read of 0 or more than 252 bytes")),
        (CMD_READ, _) => return Err(FrameError::Malformed("read request without exactly one count byte")),
        (CMD_WRITE, 0) => return Err(FrameError::Malformed("write request without data")),
        (CMD_WRITE, _) => Request::Write {
            id: f.id,
            addr: f.addr,
            data: f.payload,
        },
        _ => return Err(FrameError::Malformed("unknown command (not 0x11 read or 0x12 write)")),
    };
    Ok((req, n))
}

/// A reply the host receives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply<'a> {
    Read { id: u8, addr: u16, data: &'a [u8] },
    WriteAck { id: u8, addr: u16, ok: bool },
}

/// The reply at the start of `buf` and the bytes it takes.
pub fn decode_reply(buf: &[u8]) -> Result<(Reply<'_>, usize), FrameError> {
    let (f, n) = decode(REPLY_HEADER, buf)?;
    let reply = match (f.cmd, f.payload.len()) {
        (CMD_READ, _) => Reply::Read {
            id: f.id,
            addr: f.addr,
            data: f.payload,
        },
        (CMD_WRITE, 1) => Reply::WriteAck {
            id: f.id,
            addr: f.addr,
            ok: f.payload[0] == 1,
        },
        (CMD_WRITE, _) => return Err(FrameError::Malformed("write acknowledgement without one result byte")),
        _ => return Err(FrameError::Malformed("unknown command (not 0x11 read or 0x12 write)")),
    };
    Ok((reply, n))
}

/// Where the next request header may start in `buf` after garbage (index of the next 0xEB, or
/// the end): what a reader skips to resynchronise.
pub fn resync(buf: &[u8]) -> usize {
    buf.iter()
        .skip(1)
        .position(|b| *b == REQUEST_HEADER[0])
        .map_or(buf.len(), |p| p + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixtures: the frames pyrh56 0.4.0 builds (`build_read_reg16(1, 1546, 12)`,
    /// `build_reg16_frame(1, 1486, [1000, 1000, 1000, 1000, 1000, 900])`,
    /// `build_write_bytes_frame(1, 1004, b"\x01")`), computed by it, byte for byte.
    const READ_ANGLE_ACT: [u8; 9] = [0xEB, 0x90, 0x01, 0x04, 0x11, 0x0A, 0x06, 0x0C, 0x32];
    const WRITE_OPEN: [u8; 20] = [
        0xEB, 0x90, 0x01, 0x0F, 0x12, 0xCE, 0x05, 0xE8, 0x03, 0xE8, 0x03, 0xE8, 0x03, 0xE8, 0x03, 0xE8, 0x03, 0x84,
        0x03, 0x13,
    ];
    const CLEAR_ERROR: [u8; 9] = [0xEB, 0x90, 0x01, 0x04, 0x12, 0xEC, 0x03, 0x01, 0x07];

    #[test]
    fn requests_match_pyrh56_byte_for_byte() {
        let mut out = Vec::new();
        encode_read(1, 1546, 12, &mut out).unwrap();
        assert_eq!(out, READ_ANGLE_ACT);
        let mut data = Vec::new();
        for v in [1000u16, 1000, 1000, 1000, 1000, 900] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        encode_write(1, 1486, &data, &mut out).unwrap();
        assert_eq!(out, WRITE_OPEN);
        encode_write(1, 1004, &[1], &mut out).unwrap();
        assert_eq!(out, CLEAR_ERROR);
    }

    #[test]
    fn requests_decode_back() {
        assert_eq!(
            decode_request(&READ_ANGLE_ACT),
            Ok((
                Request::Read {
                    id: 1,
                    addr: 1546,
                    count: 12
                },
                9
            ))
        );
        let (r, n) = decode_request(&WRITE_OPEN).unwrap();
        assert_eq!(n, 20);
        match r {
            Request::Write {
                id: 1,
                addr: 1486,
                data,
            } => assert_eq!(&data[10..], &[0x84, 0x03]),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn replies_as_pyrh56_checks_them() {
        // parse_read_response: length count + 8, len field count + 3, address echoed, sum of
        // bytes 2..-1.
        let mut out = Vec::new();
        encode_read_reply(2, 1546, &[1, 2, 3, 4], &mut out).unwrap();
        assert_eq!(out.len(), 4 + 8);
        assert_eq!(&out[..5], &[0x90, 0xEB, 2, 7, 0x11]);
        assert_eq!(out[11], checksum(&out[2..11]));
        assert_eq!(
            decode_reply(&out),
            Ok((
                Reply::Read {
                    id: 2,
                    addr: 1546,
                    data: &[1, 2, 3, 4]
                },
                12
            ))
        );
        // parse_write_ack: 90 EB id 04 12 addr 01 sum.
        encode_write_ack(1, 1486, true, &mut out);
        assert_eq!(out, [0x90, 0xEB, 0x01, 0x04, 0x12, 0xCE, 0x05, 0x01, 0xEB]);
        assert_eq!(
            decode_reply(&out),
            Ok((
                Reply::WriteAck {
                    id: 1,
                    addr: 1486,
                    ok: true
                },
                9
            ))
        );
    }

    #[test]
    fn bad_frames_say_why() {
        let mut bad = READ_ANGLE_ACT;
        bad[8] ^= 1;
        assert_eq!(
            decode_request(&bad),
            Err(FrameError::BadChecksum {
                computed: 0x32,
                received: 0x33
            })
        );
        assert_eq!(
            decode_request(&READ_ANGLE_ACT[..5]),
            Err(FrameError::Incomplete { need: 4 })
        );
        assert_eq!(decode_request(&[0xEB]), Err(FrameError::Incomplete { need: 3 }));
        assert_eq!(decode_request(&[0x00, 0x90]), Err(FrameError::BadHeader));
        assert_eq!(decode_request(&[0xEB, 0x91]), Err(FrameError::BadHeader));
        // A reply header is not a request.
        assert_eq!(decode_request(&[0x90, 0xEB, 1, 4]), Err(FrameError::BadHeader));
        assert!(matches!(
            decode_request(&[0xEB, 0x90, 1, 2, 0x11, 0, 0x14]),
            Err(FrameError::Malformed(_))
        ));
        let mut out = Vec::new();
        frame(REQUEST_HEADER, 1, 0x13, 1486, &[1], &mut out);
        assert!(matches!(decode_request(&out), Err(FrameError::Malformed(_))));
        frame(REQUEST_HEADER, 1, CMD_READ, 1486, &[0], &mut out);
        assert!(matches!(decode_request(&out), Err(FrameError::Malformed(_))));
        assert_eq!(encode_read(1, 0, 0, &mut out), Err(EncodeError::Empty));
        assert_eq!(encode_read(1, 0, 253, &mut out), Err(EncodeError::TooLong(253)));
        assert_eq!(encode_write(1, 0, &[0; 253], &mut out), Err(EncodeError::TooLong(253)));
    }

    #[test]
    fn resync_skips_to_the_next_header_byte() {
        assert_eq!(resync(&[0x00, 0x01, 0xEB, 0x90]), 2);
        assert_eq!(resync(&[0xEB, 0x00, 0x01]), 3);
        assert_eq!(resync(&[]), 0);
    }

    #[test]
    fn every_prefix_of_a_frame_is_incomplete_and_never_an_error() {
        for n in 0..WRITE_OPEN.len() {
            assert!(
                matches!(decode_request(&WRITE_OPEN[..n]), Err(FrameError::Incomplete { .. })),
                "{n}"
            );
        }
    }
}
