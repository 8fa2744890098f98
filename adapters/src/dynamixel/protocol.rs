//! DYNAMIXEL Protocol 2.0 codec: pure functions over bytes.
//!
//! Packet layout (ROBOTIS e-Manual, "Protocol 2.0", Instruction Packet / Status Packet):
//!
//! ```text
//! FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAM ... | CRC_L CRC_H
//! ```
//!
//! * `LEN` counts instruction + (stuffed) parameters + the two CRC bytes.
//! * Byte stuffing: inside the instruction..parameter range every `FF FF FD` gets an extra
//!   `FD` (`FF FF FD FD`); length and CRC are computed over the stuffed bytes.
//! * CRC: CRC-16 with polynomial 0x8005, init 0, no reflection, no final xor, over everything
//!   from the first header byte to the last parameter byte. That is the catalogued
//!   CRC-16/UMTS (a.k.a. CRC-16/BUYPASS, CRC-16/VERIFONE) from the `crc` crate; the fixtures in
//!   `tests` prove it against the e-Manual's worked examples.
//! * A status packet carries instruction 0x55 and an error byte before its parameters:
//!   bit 7 = alert (read Hardware Error Status for the cause), bits 0..6 = error number.
//! * Fast Sync Read (0x8A, e-Manual "Fast Sync Read"; DynamixelSDK 4.1.0's
//!   `fastSyncReadRx`): the addressed devices answer with ONE status packet from the broadcast
//!   id, `FF FF FD 00 FE LEN 55 | ERR1 ID1 DATA1 CRC1 | ERR2 ID2 DATA2 CRC2 | ... | ERRn IDn
//!   DATAn CRC`, each device appending its part; the last CRC is the packet's. The reply is
//!   not byte-stuffed (the SDK unstuffs every status but the fast ones), so the decoder takes
//!   a status from the broadcast id as it is ([`fast_sync_entries`], [`encode_fast_sync_reply`]).

use std::fmt;

use crc::{Crc, CRC_16_UMTS};

/// The four bytes every packet starts with (three header bytes and the reserved 0x00).
pub const HEADER: [u8; 4] = [0xFF, 0xFF, 0xFD, 0x00];
/// Broadcast id: every device executes the packet (sync read/write use it).
pub const BROADCAST_ID: u8 = 0xFE;
/// Highest id a device may have (253 = 0xFD and 255 = 0xFF would collide with the header).
pub const MAX_DEVICE_ID: u8 = 252;
/// Header (4) + id (1) + length (2).
const PREFIX_LEN: usize = 7;
/// Largest LEN field the decoder accepts. Real packets here are far below this; a bigger
/// value means we locked onto garbage, so the decoder resynchronises instead of waiting.
pub const MAX_LENGTH_FIELD: usize = 1024;

const DXL_CRC: Crc<u16> = Crc::<u16>::new(&CRC_16_UMTS);

/// The DYNAMIXEL CRC-16 over `bytes`.
pub fn crc16(bytes: &[u8]) -> u16 {
    DXL_CRC.checksum(bytes)
}

/// Instruction byte values (e-Manual, Protocol 2.0, "Instruction").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Instruction {
    Ping = 0x01,
    Read = 0x02,
    Write = 0x03,
    RegWrite = 0x04,
    Action = 0x05,
    FactoryReset = 0x06,
    Reboot = 0x08,
    Clear = 0x10,
    Status = 0x55,
    SyncRead = 0x82,
    SyncWrite = 0x83,
    FastSyncRead = 0x8A,
    BulkRead = 0x92,
    BulkWrite = 0x93,
}

impl Instruction {
    pub fn from_byte(b: u8) -> Option<Self> {
        use Instruction::*;
        Some(match b {
            0x01 => Ping,
            0x02 => Read,
            0x03 => Write,
            0x04 => RegWrite,
            0x05 => Action,
            0x06 => FactoryReset,
            0x08 => Reboot,
            0x10 => Clear,
            0x55 => Status,
            0x82 => SyncRead,
            0x83 => SyncWrite,
            0x8A => FastSyncRead,
            0x92 => BulkRead,
            0x93 => BulkWrite,
            _ => return None,
        })
    }
}

/// A device id on the bus (0..=252). Broadcast is not a device id; see [`BROADCAST_ID`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub struct ServoId(u8);

impl ServoId {
    pub fn new(id: u8) -> Result<Self, CodecError> {
        if id <= MAX_DEVICE_ID {
            Ok(Self(id))
        } else {
            Err(CodecError::BadId(id))
        }
    }
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl TryFrom<u8> for ServoId {
    type Error = CodecError;
    fn try_from(v: u8) -> Result<Self, CodecError> {
        ServoId::new(v)
    }
}

impl From<ServoId> for u8 {
    fn from(v: ServoId) -> u8 {
        v.0
    }
}

impl fmt::Display for ServoId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Errors of building or interpreting packets.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CodecError {
    #[error("servo id {0} is outside 0..=252")]
    BadId(u8),
    #[error("packet too long: {0} stuffed bytes (max {MAX_LENGTH_FIELD})")]
    TooLong(usize),
    #[error("sync write entry for id {id} has {got} bytes, expected {expected}")]
    SyncWriteLength { id: u8, got: usize, expected: usize },
    #[error("instruction 0x{0:02X} is not a known Protocol 2.0 instruction")]
    UnknownInstruction(u8),
    #[error("{instruction:?} packet has {got} parameter bytes, which does not fit its layout")]
    BadParams { instruction: Instruction, got: usize },
    #[error("packet is not a status packet (instruction 0x{0:02X})")]
    NotStatus(u8),
}

/// Whether `out` ends with an `FF FF FD` at or after `from`.
fn ends_with_header(out: &[u8], from: usize) -> bool {
    out.len() >= from + 3 && out.ends_with(&[0xFF, 0xFF, 0xFD])
}

/// Pushes `b` onto `out`, stuffing the body that starts at `body`: an `FF FF FD` there gets
/// an extra `FD`.
fn push_stuffed(out: &mut Vec<u8>, body: usize, b: u8) {
    out.push(b);
    if ends_with_header(out, body) {
        out.push(0xFD);
    }
}

/// Adds byte stuffing: every `FF FF FD` gets an extra `FD`.
pub fn stuff(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + data.len() / 3);
    for &b in data {
        push_stuffed(&mut out, 0, b);
    }
    out
}

/// Removes byte stuffing: `FF FF FD FD` becomes `FF FF FD`. `None` when `data` has an
/// `FF FF FD` without its stuffing byte: a sender must stuff every one (Protocol 2.0), so such
/// a body is malformed (and would not re-encode to the same length).
pub fn unstuff(data: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(data.len());
    unstuff_into(data, &mut out).then_some(out)
}

/// [`unstuff`] into `out` (cleared; its buffer reused); `false` for a malformed body.
pub fn unstuff_into(data: &[u8], out: &mut Vec<u8>) -> bool {
    out.clear();
    let mut i = 0;
    while i < data.len() {
        out.push(data[i]);
        if ends_with_header(out, 0) {
            if data.get(i + 1) != Some(&0xFD) {
                return false;
            }
            i += 1; // skip the stuffing byte
        }
        i += 1;
    }
    true
}

/// A decoded packet with its parameters unstuffed. For a status packet `params[0]` is the
/// error byte; use [`Status::from_packet`] to interpret it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packet {
    pub id: u8,
    pub instruction: u8,
    pub params: Vec<u8>,
}

/// A packet with its parameters borrowed (from [`Decoder::next_frame_ref`]'s buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PacketRef<'a> {
    pub id: u8,
    pub instruction: u8,
    pub params: &'a [u8],
}

impl PacketRef<'_> {
    pub fn to_packet(&self) -> Packet {
        Packet {
            id: self.id,
            instruction: self.instruction,
            params: self.params.to_vec(),
        }
    }
}

impl<'a> From<&'a Packet> for PacketRef<'a> {
    fn from(p: &'a Packet) -> Self {
        PacketRef {
            id: p.id,
            instruction: p.instruction,
            params: &p.params,
        }
    }
}

/// Writes one packet into a buffer: the header, then the instruction and parameters stuffed
/// as they come, then length and CRC ([`Self::finish`]).
struct PacketWriter<'a> {
    out: &'a mut Vec<u8>,
    /// Where this packet starts in `out` (0 unless appended after others).
    base: usize,
}

impl<'a> PacketWriter<'a> {
    /// Starts a packet in `out` (cleared; its buffer reused).
    fn start(out: &'a mut Vec<u8>, id: u8, instruction: u8) -> Self {
        out.clear();
        Self::append(out, id, instruction)
    }

    /// Starts a packet after what `out` holds.
    fn append(out: &'a mut Vec<u8>, id: u8, instruction: u8) -> Self {
        let base = out.len();
        out.extend_from_slice(&HEADER);
        out.push(id);
        out.extend_from_slice(&[0, 0]); // the length, set by finish
        push_stuffed(out, base + PREFIX_LEN, instruction);
        Self { out, base }
    }

    fn extend(&mut self, params: &[u8]) {
        for &b in params {
            push_stuffed(self.out, self.base + PREFIX_LEN, b);
        }
    }

    /// The length field (stuffed body + CRC) and the CRC.
    fn finish(self) -> Result<(), CodecError> {
        let b = self.base;
        let len = self.out.len() - b - PREFIX_LEN + 2;
        if len > MAX_LENGTH_FIELD {
            self.out.truncate(b);
            return Err(CodecError::TooLong(len));
        }
        self.out[b + 5..b + PREFIX_LEN].copy_from_slice(&(len as u16).to_le_bytes());
        let crc = crc16(&self.out[b..]);
        self.out.extend_from_slice(&crc.to_le_bytes());
        Ok(())
    }
}

/// Appends one status packet (`error`, then `params`) to `out`, after what it holds: a
/// servo's reply built without allocating once `out` has grown (the emulators and the
/// virtual bus front answer every cycle).
pub fn append_status(out: &mut Vec<u8>, id: u8, error: StatusError, params: &[u8]) -> Result<(), CodecError> {
    let mut w = PacketWriter::append(out, id, Instruction::Status as u8);
    w.extend(&[error.to_byte()]);
    w.extend(params);
    w.finish()
}

/// Encodes one packet: stuffing, length and CRC.
pub fn encode_packet(id: u8, instruction: u8, params: &[u8]) -> Result<Vec<u8>, CodecError> {
    let mut out = Vec::with_capacity(PREFIX_LEN + params.len() + 4);
    let mut w = PacketWriter::start(&mut out, id, instruction);
    w.extend(params);
    w.finish()?;
    Ok(out)
}

/// Error number of a status packet (bits 0..6 of its error byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorNumber {
    None,
    ResultFail,
    InstructionError,
    CrcError,
    DataRangeError,
    DataLengthError,
    DataLimitError,
    AccessError,
    Other(u8),
}

impl ErrorNumber {
    pub fn from_bits(v: u8) -> Self {
        match v & 0x7F {
            0 => Self::None,
            1 => Self::ResultFail,
            2 => Self::InstructionError,
            3 => Self::CrcError,
            4 => Self::DataRangeError,
            5 => Self::DataLengthError,
            6 => Self::DataLimitError,
            7 => Self::AccessError,
            n => Self::Other(n),
        }
    }
    pub fn bits(self) -> u8 {
        match self {
            Self::None => 0,
            Self::ResultFail => 1,
            Self::InstructionError => 2,
            Self::CrcError => 3,
            Self::DataRangeError => 4,
            Self::DataLengthError => 5,
            Self::DataLimitError => 6,
            Self::AccessError => 7,
            Self::Other(n) => n & 0x7F,
        }
    }
}

/// The error byte of a status packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StatusError {
    /// Bit 7: the device has a hardware error; read Hardware Error Status for the cause.
    pub alert: bool,
    pub number: ErrorNumber,
}

impl StatusError {
    pub const OK: StatusError = StatusError {
        alert: false,
        number: ErrorNumber::None,
    };
    pub fn from_byte(b: u8) -> Self {
        Self {
            alert: b & 0x80 != 0,
            number: ErrorNumber::from_bits(b),
        }
    }
    pub fn to_byte(self) -> u8 {
        (if self.alert { 0x80 } else { 0 }) | self.number.bits()
    }
}

/// A status (return) packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Status {
    pub id: u8,
    pub error: StatusError,
    pub params: Vec<u8>,
}

/// A status packet with its parameters borrowed (see [`Status`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StatusRef<'a> {
    pub id: u8,
    pub error: StatusError,
    pub params: &'a [u8],
}

impl<'a> StatusRef<'a> {
    pub fn from_packet(p: PacketRef<'a>) -> Result<Self, CodecError> {
        if p.instruction != Instruction::Status as u8 {
            return Err(CodecError::NotStatus(p.instruction));
        }
        let Some((&err, params)) = p.params.split_first() else {
            return Err(CodecError::BadParams {
                instruction: Instruction::Status,
                got: 0,
            });
        };
        Ok(Self {
            id: p.id,
            error: StatusError::from_byte(err),
            params,
        })
    }

    pub fn to_status(&self) -> Status {
        Status {
            id: self.id,
            error: self.error,
            params: self.params.to_vec(),
        }
    }
}

impl Status {
    pub fn from_packet(p: &Packet) -> Result<Self, CodecError> {
        StatusRef::from_packet(p.into()).map(|s| s.to_status())
    }

    pub fn encode(&self) -> Result<Vec<u8>, CodecError> {
        let mut params = Vec::with_capacity(self.params.len() + 1);
        params.push(self.error.to_byte());
        params.extend_from_slice(&self.params);
        encode_packet(self.id, Instruction::Status as u8, &params)
    }
}

/// A typed instruction packet (the ones handgate sends, plus what the emulator must parse).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    Ping {
        id: u8,
    },
    Read {
        id: u8,
        addr: u16,
        len: u16,
    },
    Write {
        id: u8,
        addr: u16,
        data: Vec<u8>,
    },
    Reboot {
        id: u8,
    },
    /// Same address and length from several devices; each answers with its own status, in
    /// the order of `ids`.
    SyncRead {
        addr: u16,
        len: u16,
        ids: Vec<u8>,
    },
    /// As [`Request::SyncRead`], answered by one status packet for all `ids` (in their
    /// order): see [`fast_sync_entries`].
    FastSyncRead {
        addr: u16,
        len: u16,
        ids: Vec<u8>,
    },
    /// Same address and length to several devices; no status is returned.
    SyncWrite {
        addr: u16,
        len: u16,
        entries: Vec<(u8, Vec<u8>)>,
    },
}

impl Request {
    /// The id in the packet header.
    pub fn packet_id(&self) -> u8 {
        match self {
            Request::Ping { id } | Request::Read { id, .. } | Request::Write { id, .. } | Request::Reboot { id } => *id,
            Request::SyncRead { .. } | Request::FastSyncRead { .. } | Request::SyncWrite { .. } => BROADCAST_ID,
        }
    }

    pub fn instruction(&self) -> Instruction {
        match self {
            Request::Ping { .. } => Instruction::Ping,
            Request::Read { .. } => Instruction::Read,
            Request::Write { .. } => Instruction::Write,
            Request::Reboot { .. } => Instruction::Reboot,
            Request::SyncRead { .. } => Instruction::SyncRead,
            Request::FastSyncRead { .. } => Instruction::FastSyncRead,
            Request::SyncWrite { .. } => Instruction::SyncWrite,
        }
    }

    /// Encodes the request to wire bytes.
    pub fn encode(&self) -> Result<Vec<u8>, CodecError> {
        let mut out = Vec::new();
        self.encode_into(&mut out)?;
        Ok(out)
    }

    /// [`Self::encode`] into `out` (cleared; its buffer reused: the bus round encodes every
    /// round without allocating).
    pub fn encode_into(&self, out: &mut Vec<u8>) -> Result<(), CodecError> {
        let id = self.packet_id();
        if id != BROADCAST_ID {
            check_id(id)?;
        }
        let mut p = PacketWriter::start(out, id, self.instruction() as u8);
        match self {
            Request::Ping { .. } | Request::Reboot { .. } => {}
            Request::Read { addr, len, .. } => {
                p.extend(&addr.to_le_bytes());
                p.extend(&len.to_le_bytes());
            }
            Request::Write { addr, data, .. } => {
                p.extend(&addr.to_le_bytes());
                p.extend(data);
            }
            Request::SyncRead { addr, len, ids } | Request::FastSyncRead { addr, len, ids } => {
                p.extend(&addr.to_le_bytes());
                p.extend(&len.to_le_bytes());
                for &id in ids {
                    check_id(id)?;
                    p.extend(&[id]);
                }
            }
            Request::SyncWrite { addr, len, entries } => {
                p.extend(&addr.to_le_bytes());
                p.extend(&len.to_le_bytes());
                for (id, data) in entries {
                    check_id(*id)?;
                    if data.len() != *len as usize {
                        return Err(CodecError::SyncWriteLength {
                            id: *id,
                            got: data.len(),
                            expected: *len as usize,
                        });
                    }
                    p.extend(&[*id]);
                    p.extend(data);
                }
            }
        }
        p.finish()
    }

    /// Interprets a decoded instruction packet (the emulator's side).
    pub fn from_packet(pk: &Packet) -> Result<Self, CodecError> {
        let inst = Instruction::from_byte(pk.instruction).ok_or(CodecError::UnknownInstruction(pk.instruction))?;
        let p = &pk.params;
        let bad = || CodecError::BadParams {
            instruction: inst,
            got: p.len(),
        };
        let u16_at = |i: usize| u16::from_le_bytes([p[i], p[i + 1]]);
        Ok(match inst {
            Instruction::Ping if p.is_empty() => Request::Ping { id: pk.id },
            Instruction::Reboot if p.is_empty() => Request::Reboot { id: pk.id },
            Instruction::Read if p.len() == 4 => Request::Read {
                id: pk.id,
                addr: u16_at(0),
                len: u16_at(2),
            },
            Instruction::Write if p.len() >= 3 => Request::Write {
                id: pk.id,
                addr: u16_at(0),
                data: p[2..].to_vec(),
            },
            Instruction::SyncRead if p.len() >= 4 => Request::SyncRead {
                addr: u16_at(0),
                len: u16_at(2),
                ids: p[4..].to_vec(),
            },
            Instruction::FastSyncRead if p.len() >= 4 => Request::FastSyncRead {
                addr: u16_at(0),
                len: u16_at(2),
                ids: p[4..].to_vec(),
            },
            Instruction::SyncWrite if p.len() >= 4 => {
                let len = u16_at(2);
                let chunk = len as usize + 1;
                let rest = &p[4..];
                if len == 0 || rest.len() % chunk != 0 {
                    return Err(bad());
                }
                Request::SyncWrite {
                    addr: u16_at(0),
                    len,
                    entries: rest.chunks(chunk).map(|c| (c[0], c[1..].to_vec())).collect(),
                }
            }
            Instruction::Ping
            | Instruction::Reboot
            | Instruction::Read
            | Instruction::Write
            | Instruction::SyncRead
            | Instruction::FastSyncRead
            | Instruction::SyncWrite => return Err(bad()),
            other => {
                return Err(CodecError::BadParams {
                    instruction: other,
                    got: p.len(),
                })
            }
        })
    }
}

fn check_id(id: u8) -> Result<(), CodecError> {
    if id <= MAX_DEVICE_ID {
        Ok(())
    } else {
        Err(CodecError::BadId(id))
    }
}

/// Something the stream decoder rejected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FrameError {
    /// A complete frame whose CRC did not match.
    BadCrc { id: u8, expected: u16, got: u16 },
    /// A header whose length field is impossible (< 3 or > [`MAX_LENGTH_FIELD`]).
    BadLength { id: u8, len: usize },
    /// A frame with a good CRC whose body has an `FF FF FD` without its stuffing byte.
    Unstuffed { id: u8 },
}

/// Counters kept by [`Decoder`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    pub packets: u64,
    pub bad_crc: u64,
    pub bad_length: u64,
    /// Frames with a good CRC and an unstuffed `FF FF FD` in their body.
    pub unstuffed: u64,
    /// Partial frames dropped by [`Decoder::reset`] (the sender stopped mid-packet).
    pub truncated: u64,
    /// Bytes skipped while looking for a header.
    pub garbage_bytes: u64,
}

/// Streaming decoder: feed it bytes as they arrive, take packets out. Never panics on any
/// input; resynchronises on the next header after garbage or a bad frame.
#[derive(Debug, Default)]
pub struct Decoder {
    buf: Vec<u8>,
    /// The unstuffed body of the packet [`Self::next_frame_ref`] returned last.
    body: Vec<u8>,
    stats: DecoderStats,
}

impl Decoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// A decoder whose buffers hold `bytes` before they grow: a device loop sizes them for
    /// its largest read (plus one read's worth), so no cycle allocates.
    pub fn with_capacity(bytes: usize) -> Self {
        Self {
            buf: Vec::with_capacity(bytes),
            body: Vec::with_capacity(bytes),
            stats: DecoderStats::default(),
        }
    }

    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes held that are not yet a complete packet.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Drops buffered bytes (e.g. after a timeout); a partial frame counts as truncated.
    pub fn reset(&mut self) {
        if self.buf.len() >= HEADER.len() && self.buf.starts_with(&HEADER) {
            self.stats.truncated += 1;
        } else {
            self.stats.garbage_bytes += self.buf.len() as u64;
        }
        self.buf.clear();
    }

    /// The next complete packet or rejected frame; `None` when more bytes are needed.
    pub fn next_frame(&mut self) -> Option<Result<Packet, FrameError>> {
        self.next_frame_ref().map(|f| f.map(|p| p.to_packet()))
    }

    /// [`Self::next_frame`] with the packet's parameters borrowed from the decoder (no
    /// allocation once its buffers have grown).
    pub fn next_frame_ref(&mut self) -> Option<Result<PacketRef<'_>, FrameError>> {
        let id = match self.next_body()? {
            Ok(id) => id,
            Err(e) => return Some(Err(e)),
        };
        let (&instruction, params) = self.body.split_first()?;
        Some(Ok(PacketRef {
            id,
            instruction,
            params,
        }))
    }

    /// Finds the next complete packet and unstuffs its body (instruction first, never empty)
    /// into `self.body`: its id, or the rejected frame; `None` when more bytes are needed.
    fn next_body(&mut self) -> Option<Result<u8, FrameError>> {
        loop {
            // Find a header.
            let start = find_header(&self.buf);
            match start {
                Some(0) => {}
                Some(n) => {
                    self.stats.garbage_bytes += n as u64;
                    self.buf.drain(..n);
                }
                None => {
                    // Keep a possible header prefix at the end of the buffer.
                    let keep = header_prefix_suffix(&self.buf);
                    let drop = self.buf.len() - keep;
                    self.stats.garbage_bytes += drop as u64;
                    self.buf.drain(..drop);
                    return None;
                }
            }
            if self.buf.len() < PREFIX_LEN {
                return None;
            }
            let id = self.buf[4];
            let len = u16::from_le_bytes([self.buf[5], self.buf[6]]) as usize;
            if !(3..=MAX_LENGTH_FIELD).contains(&len) {
                self.stats.bad_length += 1;
                self.buf.drain(..1);
                return Some(Err(FrameError::BadLength { id, len }));
            }
            let total = PREFIX_LEN + len;
            if self.buf.len() < total {
                return None;
            }
            let got = u16::from_le_bytes([self.buf[total - 2], self.buf[total - 1]]);
            let expected = crc16(&self.buf[..total - 2]);
            if got != expected {
                self.stats.bad_crc += 1;
                // Skip only the header: a real packet may start inside the bad frame.
                self.buf.drain(..1);
                return Some(Err(FrameError::BadCrc { id, expected, got }));
            }
            let body = &self.buf[PREFIX_LEN..total - 2];
            if is_fast_reply(id, body[0]) {
                // A Fast Sync Read reply: sent unstuffed (module docs).
                self.body.clear();
                self.body.extend_from_slice(body);
            } else if !unstuff_into(body, &mut self.body) {
                self.stats.unstuffed += 1;
                // As for a bad CRC: a real packet may start inside it (at that FF FF FD).
                self.buf.drain(..1);
                return Some(Err(FrameError::Unstuffed { id }));
            }
            self.buf.drain(..total);
            if self.body.is_empty() {
                continue;
            }
            self.stats.packets += 1;
            return Some(Ok(id));
        }
    }
}

fn find_header(buf: &[u8]) -> Option<usize> {
    buf.windows(HEADER.len()).position(|w| w == HEADER)
}

/// Length of the longest suffix of `buf` that is a proper prefix of [`HEADER`].
fn header_prefix_suffix(buf: &[u8]) -> usize {
    (1..HEADER.len())
        .rev()
        .find(|&k| buf.len() >= k && buf[buf.len() - k..] == HEADER[..k])
        .unwrap_or(0)
}

/// Decodes every packet in `bytes` (convenience for tests and one-shot parsing).
pub fn decode_all(bytes: &[u8]) -> Vec<Result<Packet, FrameError>> {
    let mut d = Decoder::new();
    d.push(bytes);
    std::iter::from_fn(|| d.next_frame()).collect()
}

/// Little-endian helpers for control-table values.
pub fn le_u16(b: &[u8]) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(..2)?.try_into().ok()?))
}

pub fn le_i16(b: &[u8]) -> Option<i16> {
    Some(i16::from_le_bytes(b.get(..2)?.try_into().ok()?))
}

pub fn le_i32(b: &[u8]) -> Option<i32> {
    Some(i32::from_le_bytes(b.get(..4)?.try_into().ok()?))
}

/// Wire time of `bytes` bytes at `baud` with 8N1 framing (10 bits per byte).
pub fn wire_time(bytes: usize, baud: u32) -> std::time::Duration {
    std::time::Duration::from_nanos(bytes as u64 * 10 * 1_000_000_000 / baud.max(1) as u64)
}

/// Whether a packet with this id and instruction is a Fast Sync Read reply (a status from the
/// broadcast id), which travels unstuffed.
pub fn is_fast_reply(id: u8, instruction: u8) -> bool {
    id == BROADCAST_ID && instruction == Instruction::Status as u8
}

/// One device's part of a Fast Sync Read reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FastEntry<'a> {
    pub id: u8,
    pub error: StatusError,
    pub data: &'a [u8],
}

/// The entries of a Fast Sync Read reply, in line order (see [`fast_sync_entries`]).
#[derive(Debug, Clone)]
pub struct FastEntries<'a> {
    params: &'a [u8],
    len: usize,
    at: usize,
}

impl<'a> Iterator for FastEntries<'a> {
    type Item = FastEntry<'a>;
    fn next(&mut self) -> Option<FastEntry<'a>> {
        let rest = self.params.get(self.at..)?;
        if rest.len() < self.len + 2 {
            return None;
        }
        let e = FastEntry {
            error: StatusError::from_byte(rest[0]),
            id: rest[1],
            data: &rest[2..2 + self.len],
        };
        // The next entry starts after this one's CRC.
        self.at += self.len + 4;
        Some(e)
    }
}

/// The entries of a Fast Sync Read reply whose devices each returned `len` bytes: `params`
/// are the parameters of the status packet from [`BROADCAST_ID`] (a [`PacketRef`]'s, the first
/// device's error byte first). Its length must be `n * (len + 4) - 2` for some `n >= 1`
/// (each entry is error, id, data, CRC; the last entry's CRC is the packet's).
pub fn fast_sync_entries(params: &[u8], len: usize) -> Result<FastEntries<'_>, CodecError> {
    let chunk = len + 4;
    if params.len() < chunk - 2 || (params.len() + 2) % chunk != 0 {
        return Err(CodecError::BadParams {
            instruction: Instruction::FastSyncRead,
            got: params.len(),
        });
    }
    Ok(FastEntries { params, len, at: 0 })
}

/// How many devices a Fast Sync Read reply with `params` carries for `len` bytes each
/// (`None`: not a well-formed reply).
pub fn fast_sync_count(params: &[u8], len: usize) -> Option<usize> {
    fast_sync_entries(params, len)
        .ok()
        .map(|_| (params.len() + 2) / (len + 4))
}

/// Encodes a Fast Sync Read reply into `out` (cleared; its buffer reused): `n` entries of
/// `len` data bytes each, produced by `entry(i, data)` which fills `data` (exactly `len`
/// bytes) and returns the device's id and error. Each inner CRC is the CRC of the packet
/// up to it, as a device computes it when it appends its part to the stream (the e-Manual's
/// layout; DynamixelSDK checks only the last). Not byte-stuffed (module docs).
pub fn encode_fast_sync_reply(
    n: usize,
    len: usize,
    out: &mut Vec<u8>,
    mut entry: impl FnMut(usize, &mut [u8]) -> (u8, StatusError),
) -> Result<(), CodecError> {
    let length = 1 + n * (len + 4);
    if n == 0 || length > MAX_LENGTH_FIELD {
        return Err(CodecError::TooLong(length));
    }
    out.clear();
    out.extend_from_slice(&HEADER);
    out.push(BROADCAST_ID);
    out.extend_from_slice(&(length as u16).to_le_bytes());
    out.push(Instruction::Status as u8);
    for i in 0..n {
        if i > 0 {
            let crc = crc16(out);
            out.extend_from_slice(&crc.to_le_bytes());
        }
        let at = out.len();
        out.resize(at + 2 + len, 0);
        let (id, error) = entry(i, &mut out[at + 2..]);
        check_id(id)?;
        out[at] = error.to_byte();
        out[at + 1] = id;
    }
    let crc = crc16(out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(())
}
