//! Byte codec of the Dex3-1 USB bulk protocol (user manual, "Introduction to Send and Receive
//! Structures"; sizes and CRC coverage settled in docs/sources.md §3). Pure functions over bytes:
//! every structure is packed (1-byte aligned) and little-endian.
//!
//! | structure | size | head | CRC coverage |
//! |---|---|---|---|
//! | `LinuxToMcuCmd_t` | 1234 | not public (we send [`CMD_FRAME_HEAD`], an assumption) | words from byte 2 up to `crc` (307 words) |
//! | `McuToLinuxState_t` | 1270 | FC FD (manual) | words from byte 2 up to `crc` (316 words) |
//! | `MotorCmd_t` | 20 | FE EE | 4 words, bytes 0..16 (head included, manual) |
//! | `MotorState_t` | 26 | FC EE | 5 words, bytes 2..22 (head excluded, manual and motor_msg_HG.h) |
//! | `SensorState_t` | 44 | 7E E7 | 10 words, bytes 0..40 (head included: INFERENCE from "Participate in CRC check") |

use super::crc::crc32_words;
use std::fmt;
use thiserror::Error;

/// Buses ("fingers") in the frames (`SUPPORTED_FINGER_NUM`).
pub const BUS_COUNT: usize = 5;
/// Per-bus buffer size in BOTH directions. The manual's header says 140 for the send buffer
/// ([`HEADER_SEND_BUFFER_SIZE`]) but then `LinuxToMcuCmd_t` would be 734 bytes, not the 1234 the
/// manual's specifications state; 240 fits both stated sizes (docs/sources.md §3).
pub const BUS_BUFFER_SIZE: usize = 240;
/// The manual header's `SUPPORTED_SEND_BUFFER_SIZE`; documented only, it does NOT match 1234.
pub const HEADER_SEND_BUFFER_SIZE: usize = 140;
/// `LinuxToMcuCmd_t`: 2 + 4 + 5·4 + 5·B + 4 + 4.
pub const CMD_FRAME_LEN: usize = 2 + 4 + 4 * BUS_COUNT + BUS_COUNT * BUS_BUFFER_SIZE + 4 + 4;
/// `McuToLinuxState_t`: 2 + 2 + 2 + 5·4 + 5·B + 4·2 + 6·2 + 4 + 16 + 4.
pub const STATE_FRAME_LEN: usize = 2 + 2 + 2 + 4 * BUS_COUNT + BUS_COUNT * BUS_BUFFER_SIZE + 8 + 12 + 4 + 16 + 4;
/// `MotorCmd_t` length.
pub const MOTOR_CMD_LEN: usize = 20;
/// `MotorState_t` length.
pub const MOTOR_FB_LEN: usize = 26;
/// `SensorState_t` length.
pub const SENSOR_LEN: usize = 44;

/// `MotorCmd_t.head` (manual).
pub const MOTOR_CMD_HEAD: [u8; 2] = [0xFE, 0xEE];
/// `MotorState_t.head` (manual, motor_msg_HG.h).
pub const MOTOR_FB_HEAD: [u8; 2] = [0xFC, 0xEE];
/// `SensorState_t.head` (manual).
pub const SENSOR_HEAD: [u8; 2] = [0x7E, 0xE7];
/// `McuToLinuxState_t.head` (manual comment "0xFC 0xFD").
pub const STATE_FRAME_HEAD: [u8; 2] = [0xFC, 0xFD];
/// `LinuxToMcuCmd_t.head`: NOT PUBLIC. ASSUMPTION by analogy with the other heads (FE = to
/// device, FD = frame). Outside the frame CRC; our emulator does not check it.
pub const CMD_FRAME_HEAD: [u8; 2] = [0xFE, 0xFD];
/// Device id 15 addresses every motor of a bus; motors do not answer it (manual).
pub const BROADCAST_ID: u8 = 15;

const CMD_CMD_SIZE_OFF: usize = 6;
const CMD_BUSES_OFF: usize = 26;
const CMD_RESERVE_OFF: usize = CMD_BUSES_OFF + BUS_COUNT * BUS_BUFFER_SIZE;
const CMD_CRC_OFF: usize = CMD_RESERVE_OFF + 4;
const ST_STATE_SIZE_OFF: usize = 6;
const ST_BUSES_OFF: usize = 26;
const ST_PIN_V_OFF: usize = ST_BUSES_OFF + BUS_COUNT * BUS_BUFFER_SIZE;
const ST_IMU_OFF: usize = ST_PIN_V_OFF + 8;
const ST_ERROR_OFF: usize = ST_IMU_OFF + 12;
const ST_RESERVE_OFF: usize = ST_ERROR_OFF + 4;
const ST_CRC_OFF: usize = ST_RESERVE_OFF + 16;

const _: () = assert!(CMD_FRAME_LEN == 1234);
const _: () = assert!(STATE_FRAME_LEN == 1270);
const _: () = assert!(CMD_CRC_OFF + 4 == CMD_FRAME_LEN);
const _: () = assert!(ST_CRC_OFF + 4 == STATE_FRAME_LEN);
const _: () = assert!((CMD_CRC_OFF - 2) % 4 == 0 && (ST_CRC_OFF - 2) % 4 == 0);

/// A bus index, `0..BUS_COUNT`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub struct BusId(u8);

impl BusId {
    pub const ALL: [BusId; BUS_COUNT] = [BusId(0), BusId(1), BusId(2), BusId(3), BusId(4)];
    pub fn new(b: u8) -> Result<Self, IdError> {
        if (b as usize) < BUS_COUNT {
            Ok(Self(b))
        } else {
            Err(IdError::Bus(b))
        }
    }
    pub fn get(self) -> u8 {
        self.0
    }
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl TryFrom<u8> for BusId {
    type Error = IdError;
    fn try_from(b: u8) -> Result<Self, IdError> {
        Self::new(b)
    }
}
impl From<BusId> for u8 {
    fn from(b: BusId) -> u8 {
        b.0
    }
}
impl fmt::Display for BusId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "bus {}", self.0)
    }
}

/// A motor or sensor id on a bus, `0..=14` (15 is broadcast and never a device).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub struct DeviceId(u8);

impl DeviceId {
    pub fn new(id: u8) -> Result<Self, IdError> {
        if id < BROADCAST_ID {
            Ok(Self(id))
        } else {
            Err(IdError::Device(id))
        }
    }
    pub fn get(self) -> u8 {
        self.0
    }
}
impl TryFrom<u8> for DeviceId {
    type Error = IdError;
    fn try_from(b: u8) -> Result<Self, IdError> {
        Self::new(b)
    }
}
impl From<DeviceId> for u8 {
    fn from(b: DeviceId) -> u8 {
        b.0
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum IdError {
    #[error("bus {0} out of range (0..{BUS_COUNT})")]
    Bus(u8),
    #[error("device id {0} out of range (0..=14; 15 is broadcast)")]
    Device(u8),
}

/// Decoding errors of whole frames and sub-frames.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CodecError {
    #[error("wrong length: expected {expected} bytes, got {got}")]
    Length { expected: usize, got: usize },
    #[error("bad CRC: frame says {stored:#010x}, computed {computed:#010x}")]
    Crc { stored: u32, computed: u32 },
    #[error("bad head {got:02X?}, expected {expected:02X?}")]
    Head { expected: [u8; 2], got: [u8; 2] },
    #[error("bus {bus} payload of {len} bytes exceeds the {BUS_BUFFER_SIZE}-byte buffer")]
    BusOverflow { bus: usize, len: usize },
}

pub use crate::dex3::{MotorStatus, RisMode};

fn rd_u16(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn rd_i16(b: &[u8], o: usize) -> i16 {
    i16::from_le_bytes([b[o], b[o + 1]])
}
fn rd_u32(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
fn rd_i32(b: &[u8], o: usize) -> i32 {
    i32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
fn wr(b: &mut [u8], o: usize, v: &[u8]) {
    b[o..o + v.len()].copy_from_slice(v);
}

fn check_len(bytes: &[u8], expected: usize) -> Result<(), CodecError> {
    if bytes.len() != expected {
        return Err(CodecError::Length {
            expected,
            got: bytes.len(),
        });
    }
    Ok(())
}

fn check_crc(bytes: &[u8], covered: std::ops::Range<usize>, crc_at: usize) -> Result<(), CodecError> {
    let stored = rd_u32(bytes, crc_at);
    let computed = crc32_words(&bytes[covered]);
    if stored != computed {
        return Err(CodecError::Crc { stored, computed });
    }
    Ok(())
}

fn check_head(bytes: &[u8], expected: [u8; 2]) -> Result<(), CodecError> {
    let got = [bytes[0], bytes[1]];
    if got != expected {
        return Err(CodecError::Head { expected, got });
    }
    Ok(())
}

/// `MotorCmd_t`, 20 bytes: head FE EE, mode, res, tor_des i16, spd_des i16, pos_des i32,
/// k_pos u16, k_spd u16 (u16 per motor_msg_HG.h; the manual says int16), CRC32 over bytes 0..16.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotorCmdFrame {
    pub mode: RisMode,
    pub res: u8,
    pub tor_des: i16,
    pub spd_des: i16,
    pub pos_des: i32,
    pub k_pos: u16,
    pub k_spd: u16,
}

impl MotorCmdFrame {
    pub fn encode(&self) -> [u8; MOTOR_CMD_LEN] {
        let mut b = [0u8; MOTOR_CMD_LEN];
        wr(&mut b, 0, &MOTOR_CMD_HEAD);
        b[2] = self.mode.encode();
        b[3] = self.res;
        wr(&mut b, 4, &self.tor_des.to_le_bytes());
        wr(&mut b, 6, &self.spd_des.to_le_bytes());
        wr(&mut b, 8, &self.pos_des.to_le_bytes());
        wr(&mut b, 12, &self.k_pos.to_le_bytes());
        wr(&mut b, 14, &self.k_spd.to_le_bytes());
        let crc = crc32_words(&b[0..16]);
        wr(&mut b, 16, &crc.to_le_bytes());
        b
    }

    pub fn decode(b: &[u8]) -> Result<Self, CodecError> {
        check_len(b, MOTOR_CMD_LEN)?;
        check_head(b, MOTOR_CMD_HEAD)?;
        check_crc(b, 0..16, 16)?;
        Ok(Self {
            mode: RisMode::decode(b[2]),
            res: b[3],
            tor_des: rd_i16(b, 4),
            spd_des: rd_i16(b, 6),
            pos_des: rd_i32(b, 8),
            k_pos: rd_u16(b, 12),
            k_spd: rd_u16(b, 14),
        })
    }
}

/// `MotorState_t`, 26 bytes: head FC EE, mode, temp i8 (case), sensor u8 (winding), vol u8,
/// torque i16, speed i16, pos i32, MError u32, ExSensor1 u16, ExSensor2 u16, CRC32 over bytes
/// 2..22 (head excluded).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotorFeedbackFrame {
    pub mode: RisMode,
    pub temp_case: i8,
    pub temp_winding: u8,
    pub vol: u8,
    pub torque: i16,
    pub speed: i16,
    pub pos: i32,
    pub error: u32,
    pub ex_sensor: [u16; 2],
}

impl MotorFeedbackFrame {
    pub fn encode(&self) -> [u8; MOTOR_FB_LEN] {
        let mut b = [0u8; MOTOR_FB_LEN];
        wr(&mut b, 0, &MOTOR_FB_HEAD);
        b[2] = self.mode.encode();
        b[3] = self.temp_case as u8;
        b[4] = self.temp_winding;
        b[5] = self.vol;
        wr(&mut b, 6, &self.torque.to_le_bytes());
        wr(&mut b, 8, &self.speed.to_le_bytes());
        wr(&mut b, 10, &self.pos.to_le_bytes());
        wr(&mut b, 14, &self.error.to_le_bytes());
        wr(&mut b, 18, &self.ex_sensor[0].to_le_bytes());
        wr(&mut b, 20, &self.ex_sensor[1].to_le_bytes());
        let crc = crc32_words(&b[2..22]);
        wr(&mut b, 22, &crc.to_le_bytes());
        b
    }

    pub fn decode(b: &[u8]) -> Result<Self, CodecError> {
        check_len(b, MOTOR_FB_LEN)?;
        check_head(b, MOTOR_FB_HEAD)?;
        check_crc(b, 2..22, 22)?;
        Ok(Self {
            mode: RisMode::decode(b[2]),
            temp_case: b[3] as i8,
            temp_winding: b[4],
            vol: b[5],
            torque: rd_i16(b, 6),
            speed: rd_i16(b, 8),
            pos: rd_i32(b, 10),
            error: rd_u32(b, 14),
            ex_sensor: [rd_u16(b, 18), rd_u16(b, 20)],
        })
    }
}

/// `SensorState_t`, 44 bytes: head 7E E7, id:4 | status:4, reserved, pressure `u16[12]`,
/// temperature `i8[12]`, CRC32 over bytes 0..40 (head included: inference).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SensorFrame {
    id: u8,
    status: u8,
    pub reserved: u8,
    /// Raw pressure counts (manual: 1 count = 8 Pa).
    pub pressure: [u16; 12],
    /// °C.
    pub temperature: [i8; 12],
}

impl SensorFrame {
    /// `id` and `status` are masked to 4 bits each.
    pub fn new(id: u8, status: u8, pressure: [u16; 12], temperature: [i8; 12]) -> Self {
        Self {
            id: id & 0x0F,
            status: status & 0x0F,
            reserved: 0,
            pressure,
            temperature,
        }
    }
    pub fn id(&self) -> u8 {
        self.id
    }
    pub fn status(&self) -> u8 {
        self.status
    }

    pub fn encode(&self) -> [u8; SENSOR_LEN] {
        let mut b = [0u8; SENSOR_LEN];
        wr(&mut b, 0, &SENSOR_HEAD);
        b[2] = self.id | (self.status << 4);
        b[3] = self.reserved;
        for (i, p) in self.pressure.iter().enumerate() {
            wr(&mut b, 4 + 2 * i, &p.to_le_bytes());
        }
        for (i, t) in self.temperature.iter().enumerate() {
            b[28 + i] = *t as u8;
        }
        let crc = crc32_words(&b[0..40]);
        wr(&mut b, 40, &crc.to_le_bytes());
        b
    }

    pub fn decode(b: &[u8]) -> Result<Self, CodecError> {
        check_len(b, SENSOR_LEN)?;
        check_head(b, SENSOR_HEAD)?;
        check_crc(b, 0..40, 40)?;
        let mut pressure = [0u16; 12];
        let mut temperature = [0i8; 12];
        for i in 0..12 {
            pressure[i] = rd_u16(b, 4 + 2 * i);
            temperature[i] = b[28 + i] as i8;
        }
        Ok(Self {
            id: b[2] & 0x0F,
            status: b[2] >> 4,
            reserved: b[3],
            pressure,
            temperature,
        })
    }
}

/// One bus's payload: up to [`BUS_BUFFER_SIZE`] bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct BusPayload {
    len: usize,
    buf: [u8; BUS_BUFFER_SIZE],
}

impl Default for BusPayload {
    fn default() -> Self {
        Self {
            len: 0,
            buf: [0; BUS_BUFFER_SIZE],
        }
    }
}

impl fmt::Debug for BusPayload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "BusPayload({:02X?})", self.bytes())
    }
}

impl BusPayload {
    pub fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    pub fn clear(&mut self) {
        self.len = 0;
        self.buf = [0; BUS_BUFFER_SIZE];
    }
    /// Appends bytes; fails (leaving the payload unchanged) if they do not fit.
    pub fn push(&mut self, bytes: &[u8], bus: usize) -> Result<(), CodecError> {
        let end = self.len + bytes.len();
        if end > BUS_BUFFER_SIZE {
            return Err(CodecError::BusOverflow { bus, len: end });
        }
        self.buf[self.len..end].copy_from_slice(bytes);
        self.len = end;
        Ok(())
    }
    /// Raw buffer (all 240 bytes, including what lies past `len`).
    pub fn raw(&self) -> &[u8; BUS_BUFFER_SIZE] {
        &self.buf
    }
}

/// `LinuxToMcuCmd_t`, 1234 bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinuxToMcuCmd {
    pub head: [u8; 2],
    /// Meaning not public; we send zeros.
    pub mode: [u8; 4],
    /// `cmd_size[bus]` as sent. [`LinuxToMcuCmd::encode`] writes each bus's payload length
    /// (ASSUMPTION: "total data size of each finger bus" = used bytes).
    pub buses: [BusPayload; BUS_COUNT],
    pub reserve: u32,
}

impl Default for LinuxToMcuCmd {
    fn default() -> Self {
        Self {
            head: CMD_FRAME_HEAD,
            mode: [0; 4],
            buses: Default::default(),
            reserve: 0,
        }
    }
}

impl LinuxToMcuCmd {
    /// Writes the frame and its CRC into `out`.
    pub fn encode_into(&self, out: &mut [u8; CMD_FRAME_LEN]) {
        wr(out, 0, &self.head);
        wr(out, 2, &self.mode);
        for (i, bus) in self.buses.iter().enumerate() {
            wr(out, CMD_CMD_SIZE_OFF + 4 * i, &(bus.len() as u32).to_le_bytes());
            wr(out, CMD_BUSES_OFF + BUS_BUFFER_SIZE * i, bus.raw());
        }
        wr(out, CMD_RESERVE_OFF, &self.reserve.to_le_bytes());
        let crc = crc32_words(&out[2..CMD_CRC_OFF]);
        wr(out, CMD_CRC_OFF, &crc.to_le_bytes());
    }

    pub fn encode(&self) -> [u8; CMD_FRAME_LEN] {
        let mut out = [0u8; CMD_FRAME_LEN];
        self.encode_into(&mut out);
        out
    }

    /// Decodes and verifies the frame CRC. A `cmd_size` larger than the buffer is clamped to
    /// it (the bytes beyond do not exist).
    pub fn decode(b: &[u8]) -> Result<Self, CodecError> {
        check_len(b, CMD_FRAME_LEN)?;
        check_crc(b, 2..CMD_CRC_OFF, CMD_CRC_OFF)?;
        let mut buses: [BusPayload; BUS_COUNT] = Default::default();
        for (i, bus) in buses.iter_mut().enumerate() {
            let size = (rd_u32(b, CMD_CMD_SIZE_OFF + 4 * i) as usize).min(BUS_BUFFER_SIZE);
            let off = CMD_BUSES_OFF + BUS_BUFFER_SIZE * i;
            bus.buf.copy_from_slice(&b[off..off + BUS_BUFFER_SIZE]);
            bus.len = size;
        }
        Ok(Self {
            head: [b[0], b[1]],
            mode: [b[2], b[3], b[4], b[5]],
            buses,
            reserve: rd_u32(b, CMD_RESERVE_OFF),
        })
    }
}

/// `McuToLinuxState_t`, 1270 bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McuToLinuxState {
    pub head: [u8; 2],
    /// `mode[0]` model of the hand, `mode[1]` timeout protection (manual).
    pub mode: [u8; 2],
    pub fans: [u8; 2],
    /// `state_size[bus]` exactly as received (may exceed the buffer on a broken frame).
    pub state_size: [u32; BUS_COUNT],
    /// The full 240-byte bus buffers.
    pub state: [[u8; BUS_BUFFER_SIZE]; BUS_COUNT],
    pub pin_v: u16,
    pub vin_v: u16,
    pub vm_v: u16,
    pub pin_a: u16,
    /// ax ay az gx gy gz, raw.
    pub imu: [i16; 6],
    pub error: u32,
    pub reserve: [u32; 4],
}

impl Default for McuToLinuxState {
    fn default() -> Self {
        Self {
            head: STATE_FRAME_HEAD,
            mode: [0; 2],
            fans: [0; 2],
            state_size: [0; BUS_COUNT],
            state: [[0; BUS_BUFFER_SIZE]; BUS_COUNT],
            pin_v: 0,
            vin_v: 0,
            vm_v: 0,
            pin_a: 0,
            imu: [0; 6],
            error: 0,
            reserve: [0; 4],
        }
    }
}

impl McuToLinuxState {
    /// Copies a bus payload in and sets its `state_size`.
    pub fn set_bus(&mut self, bus: usize, payload: &BusPayload) {
        self.state[bus] = *payload.raw();
        self.state_size[bus] = payload.len() as u32;
    }

    pub fn encode_into(&self, out: &mut [u8; STATE_FRAME_LEN]) {
        wr(out, 0, &self.head);
        wr(out, 2, &self.mode);
        wr(out, 4, &self.fans);
        for i in 0..BUS_COUNT {
            wr(out, ST_STATE_SIZE_OFF + 4 * i, &self.state_size[i].to_le_bytes());
            wr(out, ST_BUSES_OFF + BUS_BUFFER_SIZE * i, &self.state[i]);
        }
        wr(out, ST_PIN_V_OFF, &self.pin_v.to_le_bytes());
        wr(out, ST_PIN_V_OFF + 2, &self.vin_v.to_le_bytes());
        wr(out, ST_PIN_V_OFF + 4, &self.vm_v.to_le_bytes());
        wr(out, ST_PIN_V_OFF + 6, &self.pin_a.to_le_bytes());
        for (i, v) in self.imu.iter().enumerate() {
            wr(out, ST_IMU_OFF + 2 * i, &v.to_le_bytes());
        }
        wr(out, ST_ERROR_OFF, &self.error.to_le_bytes());
        for (i, v) in self.reserve.iter().enumerate() {
            wr(out, ST_RESERVE_OFF + 4 * i, &v.to_le_bytes());
        }
        let crc = crc32_words(&out[2..ST_CRC_OFF]);
        wr(out, ST_CRC_OFF, &crc.to_le_bytes());
    }

    pub fn encode(&self) -> [u8; STATE_FRAME_LEN] {
        let mut out = [0u8; STATE_FRAME_LEN];
        self.encode_into(&mut out);
        out
    }

    /// Decodes and verifies the frame CRC. The head is reported, not checked (it is outside
    /// the CRC and not confirmed on hardware).
    pub fn decode(b: &[u8]) -> Result<Self, CodecError> {
        check_len(b, STATE_FRAME_LEN)?;
        check_crc(b, 2..ST_CRC_OFF, ST_CRC_OFF)?;
        let mut s = Self {
            head: [b[0], b[1]],
            mode: [b[2], b[3]],
            fans: [b[4], b[5]],
            pin_v: rd_u16(b, ST_PIN_V_OFF),
            vin_v: rd_u16(b, ST_PIN_V_OFF + 2),
            vm_v: rd_u16(b, ST_PIN_V_OFF + 4),
            pin_a: rd_u16(b, ST_PIN_V_OFF + 6),
            error: rd_u32(b, ST_ERROR_OFF),
            ..Self::default()
        };
        for i in 0..BUS_COUNT {
            s.state_size[i] = rd_u32(b, ST_STATE_SIZE_OFF + 4 * i);
            let off = ST_BUSES_OFF + BUS_BUFFER_SIZE * i;
            s.state[i].copy_from_slice(&b[off..off + BUS_BUFFER_SIZE]);
        }
        for i in 0..6 {
            s.imu[i] = rd_i16(b, ST_IMU_OFF + 2 * i);
        }
        for i in 0..4 {
            s.reserve[i] = rd_u32(b, ST_RESERVE_OFF + 4 * i);
        }
        Ok(s)
    }
}

/// Readings parsed from the buses of one state frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParsedFeedback {
    pub motors: Vec<(BusId, MotorFeedbackFrame)>,
    pub sensors: Vec<(BusId, SensorFrame)>,
    pub counters: ParseCounters,
}

/// Problems met while walking the bus buffers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ParseCounters {
    /// Packets with a known head whose CRC did not match (skipped by their length).
    pub bad_crc: u32,
    /// Positions where no known head was found (the rest of that bus is skipped).
    pub unknown_header: u32,
    /// A known head whose packet runs past the bus's `state_size`.
    pub truncated: u32,
    /// `state_size` larger than the bus buffer (clamped).
    pub oversize: u32,
}

impl ParseCounters {
    pub fn total(&self) -> u32 {
        self.bad_crc + self.unknown_header + self.truncated + self.oversize
    }
}

/// One CRC-checked packet from a bus.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feedback {
    Motor(MotorFeedbackFrame),
    Sensor(SensorFrame),
}

/// Walks one bus buffer's first `state_size` bytes packet by packet (head FC EE → 26-byte
/// motor feedback, head 7E E7 → 44-byte sensor state), checking every packet's CRC, and hands
/// each good packet to `each`; problems go to `counters`. Never panics, never allocates.
pub fn walk_bus(
    bus: BusId,
    buf: &[u8],
    state_size: u32,
    counters: &mut ParseCounters,
    mut each: impl FnMut(BusId, Feedback),
) {
    let mut size = state_size as usize;
    if size > buf.len() {
        counters.oversize += 1;
        size = buf.len();
    }
    let data = &buf[..size];
    let mut pos = 0;
    while pos < data.len() {
        let rest = &data[pos..];
        if rest.len() < 2 {
            counters.truncated += 1;
            return;
        }
        let head = [rest[0], rest[1]];
        let len = if head == MOTOR_FB_HEAD {
            MOTOR_FB_LEN
        } else if head == SENSOR_HEAD {
            SENSOR_LEN
        } else {
            counters.unknown_header += 1;
            return;
        };
        if rest.len() < len {
            counters.truncated += 1;
            return;
        }
        let pkt = &rest[..len];
        let packet = if head == MOTOR_FB_HEAD {
            MotorFeedbackFrame::decode(pkt).map(Feedback::Motor)
        } else {
            SensorFrame::decode(pkt).map(Feedback::Sensor)
        };
        match packet {
            Ok(f) => each(bus, f),
            Err(_) => counters.bad_crc += 1,
        }
        pos += len;
    }
}

impl ParsedFeedback {
    fn add(&mut self, bus: BusId, f: Feedback) {
        match f {
            Feedback::Motor(m) => self.motors.push((bus, m)),
            Feedback::Sensor(s) => self.sensors.push((bus, s)),
        }
    }
}

/// [`walk_bus`], collecting the packets into `out`.
pub fn parse_bus(bus: BusId, buf: &[u8], state_size: u32, out: &mut ParsedFeedback) {
    let mut counters = out.counters;
    walk_bus(bus, buf, state_size, &mut counters, |bus, f| out.add(bus, f));
    out.counters = counters;
}

/// [`walk_bus`] over every bus of a decoded state frame; returns the problems met.
pub fn for_each_feedback(state: &McuToLinuxState, mut each: impl FnMut(BusId, Feedback)) -> ParseCounters {
    let mut counters = ParseCounters::default();
    for bus in BusId::ALL {
        walk_bus(
            bus,
            &state.state[bus.index()],
            state.state_size[bus.index()],
            &mut counters,
            &mut each,
        );
    }
    counters
}

/// Parses every bus of a decoded state frame.
pub fn parse_feedback(state: &McuToLinuxState) -> ParsedFeedback {
    let mut out = ParsedFeedback {
        motors: Vec::with_capacity(16),
        sensors: Vec::with_capacity(16),
        counters: ParseCounters::default(),
    };
    out.counters = for_each_feedback(state, |bus, f| out.add(bus, f));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn sizes_follow_facts() {
        assert_eq!(CMD_FRAME_LEN, 1234);
        assert_eq!(STATE_FRAME_LEN, 1270);
        // The header's 140 would give 734 (docs/sources.md §3).
        assert_eq!(2 + 4 + 4 * BUS_COUNT + BUS_COUNT * HEADER_SEND_BUFFER_SIZE + 4 + 4, 734);
    }

    #[test]
    fn ris_mode_bits() {
        let m = RisMode::new(3, MotorStatus::Foc, true);
        assert_eq!(m.encode(), 0x93);
        assert_eq!(RisMode::decode(0x10 | 6), RisMode::new(6, MotorStatus::Foc, false));
        assert_eq!(RisMode::new(0xFF, MotorStatus::from_raw(0xFF), false).encode(), 0x7F);
        for b in 0..=255u8 {
            assert_eq!(RisMode::decode(b).encode(), b);
        }
    }

    /// Hand-built fixture: every byte written out, CRC computed by the manual's routine on the
    /// words (independent of our encoder's layout code).
    #[test]
    fn motor_cmd_fixture() {
        let f = MotorCmdFrame {
            mode: RisMode::new(2, MotorStatus::Foc, true),
            res: 0,
            tor_des: 0x0102,
            spd_des: -2,
            pos_des: 0x0A0B0C0D,
            k_pos: 0xC000,
            k_spd: 0x0CCD,
        };
        let b = f.encode();
        let body = [
            0xFE, 0xEE, 0x92, 0x00, 0x02, 0x01, 0xFE, 0xFF, 0x0D, 0x0C, 0x0B, 0x0A, 0x00, 0xC0, 0xCD, 0x0C,
        ];
        assert_eq!(&b[..16], &body);
        assert_eq!(&b[16..], &crc32_words(&body).to_le_bytes());
        // The CRC as the manual computes it on the four words:
        let words = [0x0092EEFEu32, 0xFFFE0102, 0x0A0B0C0D, 0x0CCDC000];
        assert_eq!(rd_u32(&b, 16), manual_crc(&words));
        assert_eq!(MotorCmdFrame::decode(&b), Ok(f));
    }

    #[test]
    fn motor_feedback_fixture() {
        let f = MotorFeedbackFrame {
            mode: RisMode::new(1, MotorStatus::Foc, false),
            temp_case: -5,
            temp_winding: 40,
            vol: 48,
            torque: 256,
            speed: -41,
            pos: -5215,
            error: 0,
            ex_sensor: [1, 2],
        };
        let b = f.encode();
        assert_eq!(&b[..2], &[0xFC, 0xEE]);
        assert_eq!(b[2], 0x11);
        assert_eq!(b[3], 0xFB);
        // Head excluded from the CRC: changing it changes nothing but the head check.
        let words: Vec<u32> = b[2..22].chunks(4).map(|c| rd_u32(c, 0)).collect();
        assert_eq!(rd_u32(&b, 22), manual_crc(&words));
        assert_eq!(MotorFeedbackFrame::decode(&b), Ok(f));
        let mut bad = b;
        bad[10] ^= 1;
        assert!(matches!(MotorFeedbackFrame::decode(&bad), Err(CodecError::Crc { .. })));
        let mut head = b;
        head[1] = 0xEF;
        assert!(matches!(
            MotorFeedbackFrame::decode(&head),
            Err(CodecError::Head { .. })
        ));
    }

    #[test]
    fn sensor_fixture() {
        let mut p = [0u16; 12];
        p[0] = 30000;
        p[11] = 0xBEEF;
        let mut t = [25i8; 12];
        t[3] = -12;
        let f = SensorFrame::new(4, 0, p, t);
        let b = f.encode();
        assert_eq!(&b[..4], &[0x7E, 0xE7, 0x04, 0x00]);
        assert_eq!(&b[4..6], &30000u16.to_le_bytes());
        assert_eq!(&b[26..28], &[0xEF, 0xBE]);
        assert_eq!(b[31], (-12i8) as u8);
        let words: Vec<u32> = b[0..40].chunks(4).map(|c| rd_u32(c, 0)).collect();
        assert_eq!(rd_u32(&b, 40), manual_crc(&words));
        assert_eq!(SensorFrame::decode(&b), Ok(f));
    }

    #[test]
    fn cmd_frame_fixture_and_roundtrip() {
        let mut cmd = LinuxToMcuCmd::default();
        let m = MotorCmdFrame {
            mode: RisMode::new(0, MotorStatus::Foc, true),
            ..Default::default()
        };
        cmd.buses[1].push(&m.encode(), 1).unwrap();
        cmd.reserve = 7;
        let b = cmd.encode();
        assert_eq!(&b[0..2], &CMD_FRAME_HEAD);
        assert_eq!(&b[6..10], &0u32.to_le_bytes());
        assert_eq!(&b[10..14], &20u32.to_le_bytes());
        assert_eq!(&b[26 + 240..26 + 240 + 20], &m.encode());
        assert_eq!(&b[1226..1230], &7u32.to_le_bytes());
        // Frame CRC: words from byte 2 up to the crc field, as the manual's
        // crc32((uint32_t*)&cmd.mode[0], sizeof/4 - 1) = 307 words.
        let words: Vec<u32> = b[2..1230].chunks(4).map(|c| rd_u32(c, 0)).collect();
        assert_eq!(words.len(), CMD_FRAME_LEN / 4 - 1);
        assert_eq!(rd_u32(&b, 1230), manual_crc(&words));
        let back = LinuxToMcuCmd::decode(&b).unwrap();
        assert_eq!(back, cmd);
        let mut bad = b;
        bad[700] ^= 0x40;
        assert!(matches!(LinuxToMcuCmd::decode(&bad), Err(CodecError::Crc { .. })));
        // The head is outside the CRC.
        let mut head = b;
        head[0] = 0;
        assert!(LinuxToMcuCmd::decode(&head).is_ok());
        assert!(matches!(
            LinuxToMcuCmd::decode(&b[..1233]),
            Err(CodecError::Length {
                expected: 1234,
                got: 1233
            })
        ));
    }

    #[test]
    fn bus_overflow_is_an_error() {
        let mut p = BusPayload::default();
        for _ in 0..12 {
            p.push(&[0; 20], 0).unwrap();
        }
        assert_eq!(p.len(), 240);
        assert!(matches!(p.push(&[0; 1], 0), Err(CodecError::BusOverflow { .. })));
        assert_eq!(p.len(), 240);
    }

    fn sample_state() -> McuToLinuxState {
        let mut s = McuToLinuxState {
            mode: [3, 1],
            fans: [0, 9],
            pin_v: 22697,
            vin_v: 1,
            vm_v: 2,
            pin_a: 3,
            imu: [1, -2, 981, 4, -5, 6],
            error: 0xDEAD,
            reserve: [1, 2, 3, 4],
            ..Default::default()
        };
        let mut bus0 = BusPayload::default();
        for id in 0..3 {
            let f = MotorFeedbackFrame {
                mode: RisMode::new(id, MotorStatus::Foc, id == 2),
                pos: 1000 * id as i32,
                ..Default::default()
            };
            bus0.push(&f.encode(), 0).unwrap();
        }
        bus0.push(&SensorFrame::new(1, 0, [9; 12], [30; 12]).encode(), 0)
            .unwrap();
        s.set_bus(0, &bus0);
        let mut bus4 = BusPayload::default();
        bus4.push(&SensorFrame::new(0, 0, [7; 12], [31; 12]).encode(), 4)
            .unwrap();
        s.set_bus(4, &bus4);
        s
    }

    #[test]
    fn state_frame_layout_and_roundtrip() {
        let s = sample_state();
        let b = s.encode();
        assert_eq!(&b[0..2], &STATE_FRAME_HEAD);
        assert_eq!(&b[2..6], &[3, 1, 0, 9]);
        assert_eq!(rd_u32(&b, 6), 3 * 26 + 44);
        assert_eq!(rd_u32(&b, 6 + 16), 44);
        assert_eq!(rd_u16(&b, 1226), 22697);
        assert_eq!(rd_i16(&b, 1234 + 4), 981);
        assert_eq!(rd_u32(&b, 1246), 0xDEAD);
        let words: Vec<u32> = b[2..1266].chunks(4).map(|c| rd_u32(c, 0)).collect();
        assert_eq!(words.len(), 316);
        assert_eq!(rd_u32(&b, 1266), manual_crc(&words));
        assert_eq!(McuToLinuxState::decode(&b).unwrap(), s);
    }

    #[test]
    fn parser_finds_every_packet() {
        let p = parse_feedback(&sample_state());
        assert_eq!(p.counters, ParseCounters::default());
        assert_eq!(p.motors.len(), 3);
        assert_eq!(p.sensors.len(), 2);
        assert_eq!(p.motors[2].1.mode, RisMode::new(2, MotorStatus::Foc, true));
        assert_eq!(p.sensors[1].0, BusId::new(4).unwrap());
        assert_eq!(p.sensors[1].1.pressure, [7; 12]);
    }

    #[test]
    fn parser_counts_problems() {
        let mut s = sample_state();
        s.state[0][26 + 10] ^= 0xFF; // second motor packet's payload
        s.state_size[4] = 40; // sensor packet cut short
        s.state_size[2] = 4; // garbage head (zeros)
        s.state_size[3] = 999; // larger than the buffer, zeros inside
        let p = parse_feedback(&s);
        assert_eq!(p.motors.len(), 2);
        assert_eq!(p.sensors.len(), 1);
        assert_eq!(
            p.counters,
            ParseCounters {
                bad_crc: 1,
                unknown_header: 2,
                truncated: 1,
                oversize: 1
            }
        );
    }

    /// The manual's routine, restated (see crc.rs tests).
    fn manual_crc(words: &[u32]) -> u32 {
        let mut crc = 0xFFFF_FFFFu32;
        for &w in words {
            for j in 0..4 {
                let mut c = ((crc >> 24) ^ (w >> (24 - j * 8))) & 0xFF;
                c <<= 24;
                for _ in 0..8 {
                    c = if c & 0x8000_0000 != 0 {
                        (c << 1) ^ 0x04C1_1DB7
                    } else {
                        c << 1
                    };
                }
                crc = (crc << 8) ^ c;
            }
        }
        crc
    }

    fn arb_motor() -> impl Strategy<Value = MotorCmdFrame> {
        (
            any::<u8>(),
            any::<u8>(),
            any::<i16>(),
            any::<i16>(),
            any::<i32>(),
            any::<u16>(),
            any::<u16>(),
        )
            .prop_map(|(m, res, t, s, p, kp, kd)| MotorCmdFrame {
                mode: RisMode::decode(m),
                res,
                tor_des: t,
                spd_des: s,
                pos_des: p,
                k_pos: kp,
                k_spd: kd,
            })
    }

    proptest! {
        #[test]
        fn motor_cmd_roundtrip(f in arb_motor()) {
            prop_assert_eq!(MotorCmdFrame::decode(&f.encode()), Ok(f));
        }

        #[test]
        fn motor_fb_roundtrip(m in any::<u8>(), tc in any::<i8>(), tw in any::<u8>(), v in any::<u8>(),
                               t in any::<i16>(), s in any::<i16>(), p in any::<i32>(), e in any::<u32>(), x in any::<[u16; 2]>()) {
            let f = MotorFeedbackFrame { mode: RisMode::decode(m), temp_case: tc, temp_winding: tw, vol: v,
                                         torque: t, speed: s, pos: p, error: e, ex_sensor: x };
            prop_assert_eq!(MotorFeedbackFrame::decode(&f.encode()), Ok(f));
        }

        #[test]
        fn sensor_roundtrip(id in 0u8..16, st in 0u8..16, p in any::<[u16; 12]>(), t in any::<[i8; 12]>()) {
            let f = SensorFrame::new(id, st, p, t);
            prop_assert_eq!(SensorFrame::decode(&f.encode()), Ok(f));
        }

        #[test]
        fn cmd_frame_roundtrip(frames in proptest::collection::vec((0usize..5, arb_motor()), 0..30), mode in any::<[u8; 4]>()) {
            let mut cmd = LinuxToMcuCmd { mode, ..Default::default() };
            for (bus, f) in frames {
                let _ = cmd.buses[bus].push(&f.encode(), bus);
            }
            prop_assert_eq!(LinuxToMcuCmd::decode(&cmd.encode()), Ok(cmd));
        }

        #[test]
        fn any_single_bit_flip_in_cmd_frame_is_caught(byte in 2usize..CMD_FRAME_LEN, bit in 0u8..8) {
            let mut b = LinuxToMcuCmd::default().encode();
            b[byte] ^= 1 << bit;
            prop_assert!(LinuxToMcuCmd::decode(&b).is_err());
        }

        /// The parser never panics, whatever the bytes and sizes.
        #[test]
        fn parser_never_panics(buf in proptest::collection::vec(any::<u8>(), 0..300), size in any::<u32>()) {
            let mut out = ParsedFeedback::default();
            parse_bus(BusId::new(0).unwrap(), &buf, size, &mut out);
            prop_assert!(out.motors.len() * MOTOR_FB_LEN + out.sensors.len() * SENSOR_LEN <= buf.len());
        }

        /// Arbitrary bytes laid out as packets with random heads: never panics, and every
        /// well-formed packet is found.
        #[test]
        fn parser_on_mixed_packets(kinds in proptest::collection::vec(0u8..4, 0..8), noise in any::<u64>()) {
            let mut bus = Vec::new();
            let mut good = 0;
            for (i, k) in kinds.iter().enumerate() {
                match k {
                    0 => { bus.extend_from_slice(&MotorFeedbackFrame { pos: i as i32, ..Default::default() }.encode()); good += 1; }
                    1 => { bus.extend_from_slice(&SensorFrame::new(i as u8, 0, [i as u16; 12], [0; 12]).encode()); good += 1; }
                    2 => { let mut b = MotorFeedbackFrame::default().encode(); b[5] ^= (noise as u8) | 1; bus.extend_from_slice(&b); }
                    _ => { let mut b = SensorFrame::default().encode(); b[6] ^= ((noise >> 8) as u8) | 1; bus.extend_from_slice(&b); }
                }
            }
            let mut out = ParsedFeedback::default();
            parse_bus(BusId::new(1).unwrap(), &bus, bus.len() as u32, &mut out);
            prop_assert_eq!(out.motors.len() + out.sensors.len(), good);
            prop_assert_eq!(out.counters.bad_crc as usize, kinds.len() - good);
        }

        /// Arbitrary 1270-byte state frames given a valid frame CRC: every one decodes, the
        /// bus parser runs on the arbitrary bus contents and sizes (never finding more than the
        /// buffers hold), and the frame re-encodes to the same bytes. Any other length is refused.
        #[test]
        fn state_decode_never_panics(
            mut bytes in proptest::collection::vec(any::<u8>(), STATE_FRAME_LEN),
            other_len in 0usize..1400,
        ) {
            let crc = crc32_words(&bytes[2..ST_CRC_OFF]);
            bytes[ST_CRC_OFF..ST_CRC_OFF + 4].copy_from_slice(&crc.to_le_bytes());
            let s = McuToLinuxState::decode(&bytes);
            prop_assert!(s.is_ok(), "{:?}", s.err());
            let s = s.unwrap();
            let out = parse_feedback(&s);
            let room: usize = s.state_size.iter().map(|n| (*n as usize).min(BUS_BUFFER_SIZE)).sum();
            prop_assert!(out.motors.len() * MOTOR_FB_LEN + out.sensors.len() * SENSOR_LEN <= room);
            prop_assert_eq!(&s.encode()[..], &bytes[..]);
            if other_len != STATE_FRAME_LEN {
                let mut short = bytes.clone();
                short.resize(other_len, 0);
                prop_assert!(McuToLinuxState::decode(&short).is_err());
            }
        }

        /// Frames with a valid frame CRC but random bus contents and sizes.
        #[test]
        fn parse_random_valid_frames(buses in proptest::collection::vec(any::<u8>(), BUS_COUNT * BUS_BUFFER_SIZE), sizes in any::<[u32; 5]>()) {
            let mut s = McuToLinuxState { state_size: sizes, ..Default::default() };
            for (i, chunk) in buses.chunks(BUS_BUFFER_SIZE).enumerate() {
                s.state[i].copy_from_slice(chunk);
            }
            let back = McuToLinuxState::decode(&s.encode()).unwrap();
            let _ = parse_feedback(&back);
        }
    }
}
