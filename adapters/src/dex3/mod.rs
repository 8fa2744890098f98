//! Dex3-1 hand: what both transports share (the RIS mode byte, pressure encoding), the
//! mapping table, the DDS client of a G1's resident service and that service's emulator.

pub mod dds_client;
pub mod dds_service_emulator;
pub mod table;

/// Raw pressure meaning "no reading" (manual; FACTS §2).
pub const PRESS_NO_READING: f32 = 30_000.0;
/// Smallest raw value of a valid reading (FACTS §2: valid readings are >= 100000).
pub const PRESS_VALID_MIN: f32 = 100_000.0;
/// RIS mode: bit 7, the timeout flag.
pub const RIS_TIMEOUT_BIT: u8 = 0x80;

/// Status field (bits 4-6) of the RIS mode byte (manual: 0 lock, 1 FOC).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MotorStatus {
    Lock,
    Foc,
    /// A value the manual does not define (2..=7).
    Undefined(u8),
}

/// The RIS mode byte of a Dex3 motor (manual "RIS_Mode_t"; FACTS §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RisMode {
    /// Motor id, bits 0-3.
    pub id: u8,
    pub status: MotorStatus,
    /// Bit 7: in a command, enable the 1 s timeout; in feedback, the timeout tripped.
    pub timeout: bool,
}

impl RisMode {
    pub fn decode(byte: u8) -> Self {
        let status = match (byte >> 4) & 0x7 {
            0 => MotorStatus::Lock,
            1 => MotorStatus::Foc,
            s => MotorStatus::Undefined(s),
        };
        Self {
            id: byte & 0x0F,
            status,
            timeout: byte & RIS_TIMEOUT_BIT != 0,
        }
    }

    pub fn encode(self) -> u8 {
        let status = match self.status {
            MotorStatus::Lock => 0,
            MotorStatus::Foc => 1,
            MotorStatus::Undefined(s) => s & 0x7,
        };
        (self.id & 0x0F) | (status << 4) | if self.timeout { RIS_TIMEOUT_BIT } else { 0 }
    }

    /// FOC mode for motor `id`, timeout protection as given (typical: `0x10 | id`).
    pub fn foc(id: u8, timeout: bool) -> Self {
        Self {
            id,
            status: MotorStatus::Foc,
            timeout,
        }
    }
}
