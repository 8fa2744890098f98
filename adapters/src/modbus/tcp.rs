//! Modbus TCP framing: the 7-byte MBAP header, then the PDU (Modbus Messaging on TCP/IP
//! Implementation Guide V1.0b, 3.1.3):
//!
//! ```text
//! transaction(2) protocol(2) = 0 length(2) = 1 + PDU bytes  unit(1)  PDU
//! ```
//!
//! All big-endian. No CRC: TCP checks the bytes. Pure functions over bytes.

use super::pdu::MAX_PDU;

/// MBAP header bytes.
pub const MBAP_LEN: usize = 7;
/// Largest Modbus TCP frame: header + 253-byte PDU.
pub const MAX_ADU: usize = MBAP_LEN + MAX_PDU;
/// The protocol identifier of Modbus.
pub const PROTOCOL_MODBUS: u16 = 0;

/// The MBAP header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mbap {
    /// Chosen by the client, echoed by the server.
    pub transaction: u16,
    /// 0 for Modbus.
    pub protocol: u16,
    /// Bytes that follow the length field: unit + PDU.
    pub length: u16,
    /// The unit (slave) id; a gateway routes by it, a plain server echoes it.
    pub unit: u8,
}

/// Why no frame could be cut from the front of a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TcpError {
    /// Need at least `need` more bytes.
    #[error("incomplete frame: {need} more bytes needed")]
    Incomplete { need: usize },
    /// Not Modbus: the stream is garbage (close it or drop the buffer).
    #[error("protocol identifier {0}, not 0 (Modbus)")]
    Protocol(u16),
    /// A length field that cannot hold a unit id and a PDU of 1..=253 bytes.
    #[error("MBAP length {0} outside 2..=254")]
    Length(u16),
}

impl TcpError {
    /// A short key for counters and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            TcpError::Incomplete { .. } => "incomplete",
            TcpError::Protocol(_) => "bad_protocol",
            TcpError::Length(_) => "bad_length",
        }
    }
}

impl Mbap {
    /// Decodes and checks the header at the front of `buf`.
    pub fn decode(buf: &[u8]) -> Result<Self, TcpError> {
        if buf.len() < MBAP_LEN {
            return Err(TcpError::Incomplete {
                need: MBAP_LEN - buf.len(),
            });
        }
        let h = Mbap {
            transaction: u16::from_be_bytes([buf[0], buf[1]]),
            protocol: u16::from_be_bytes([buf[2], buf[3]]),
            length: u16::from_be_bytes([buf[4], buf[5]]),
            unit: buf[6],
        };
        if h.protocol != PROTOCOL_MODBUS {
            return Err(TcpError::Protocol(h.protocol));
        }
        if !(2..=1 + MAX_PDU as u16).contains(&h.length) {
            return Err(TcpError::Length(h.length));
        }
        Ok(h)
    }

    /// Appends the header.
    pub fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.transaction.to_be_bytes());
        out.extend_from_slice(&self.protocol.to_be_bytes());
        out.extend_from_slice(&self.length.to_be_bytes());
        out.push(self.unit);
    }

    /// The whole frame's length (header + PDU).
    pub fn frame_len(&self) -> usize {
        MBAP_LEN - 1 + self.length as usize
    }
}

/// A frame cut from the front of a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Adu<'a> {
    pub header: Mbap,
    pub pdu: &'a [u8],
    /// Bytes the frame took from the buffer.
    pub len: usize,
}

/// Cuts the frame at the front of `buf`.
pub fn decode(buf: &[u8]) -> Result<Adu<'_>, TcpError> {
    let header = Mbap::decode(buf)?;
    let len = header.frame_len();
    if buf.len() < len {
        return Err(TcpError::Incomplete { need: len - buf.len() });
    }
    Ok(Adu {
        header,
        pdu: &buf[MBAP_LEN..len],
        len,
    })
}

/// Appends a frame with `pdu`.
pub fn encode(transaction: u16, unit: u8, pdu: &[u8], out: &mut Vec<u8>) {
    let start = begin(out, transaction, unit);
    out.extend_from_slice(pdu);
    finish(out, start);
}

/// Starts a frame in `out` (a header with the length left 0); write the PDU after it, then
/// call [`finish`] with the returned start.
pub fn begin(out: &mut Vec<u8>, transaction: u16, unit: u8) -> usize {
    let start = out.len();
    Mbap {
        transaction,
        protocol: PROTOCOL_MODBUS,
        length: 0,
        unit,
    }
    .encode(out);
    start
}

/// Fills in the length field of the frame started at `start`.
pub fn finish(out: &mut [u8], start: usize) {
    let length = (out.len() - start - (MBAP_LEN - 1)) as u16;
    out[start + 4..start + 6].copy_from_slice(&length.to_be_bytes());
}
