//! The RH56 register map (RH56 user manual V1.09 §2.4, as pyrh56 0.4.0's `registers.py` and
//! inspire-rh56dftp 0.1.0's `registers.py` transcribe it; docs/inspire-rh56.md).
//!
//! Addresses are **byte** addresses of one register file: a "short" register is two bytes,
//! little-endian, and a block of six shorts (one per finger) spans 12 bytes, so ANGLE_SET at
//! 1486 is followed by FORCE_SET at 1498. The serial protocol reads and writes byte ranges of
//! this file. Over Modbus (RTU or TCP) a request's start address is such a byte address and each
//! Modbus register is the next two bytes (so FC03 at 1546 for 6 registers returns the six
//! angles): inspire-rh56dftp reads 105 registers from 3000 and gets the pinky's tip (9 cells at
//! 3000) and nail (96 cells at 3018) in one answer, which only this reading explains. On the
//! Modbus wire the words are big-endian, as Modbus says (inspire-rh56dftp: "the Modbus TCP
//! gateway converts to BE on the wire").

/// Fingers in register order: little (pinky), ring, middle, index, thumb bend, thumb rotation.
pub const FINGERS: usize = 6;

/// The hand's id on the bus (1 byte; default 1).
pub const HAND_ID: u16 = 1000;
/// Baud rate selector (1 byte).
pub const BAUD_RATE: u16 = 1002;
/// Writing 1 clears the fingers' error bits (1 byte).
pub const CLEAR_ERROR: u16 = 1004;
/// Writing 1 saves the parameters to flash (1 byte).
pub const SAVE: u16 = 1005;
/// Supply voltage, mV (1 short, read-only).
pub const VOLTAGE: u16 = 1472;
/// Actuator position targets, 0..2000 (6 shorts).
pub const POS_SET: u16 = 1474;
/// Angle targets, 0..1000 with 1000 = open, -1 = keep this finger's target (6 shorts).
pub const ANGLE_SET: u16 = 1486;
/// Force thresholds, 0..1000 (6 shorts).
pub const FORCE_SET: u16 = 1498;
/// Speeds, 0..1000 (6 shorts).
pub const SPEED_SET: u16 = 1522;
/// Actuator positions, 0..2000 (6 shorts, read-only).
pub const POS_ACT: u16 = 1534;
/// Measured angles, 0..1000 (6 shorts, read-only).
pub const ANGLE_ACT: u16 = 1546;
/// Measured forces, signed, grams (6 shorts, read-only).
pub const FORCE_ACT: u16 = 1582;
/// Motor currents, mA (6 shorts, read-only).
pub const CURRENT: u16 = 1594;
/// Error bits per finger (6 bytes, read-only): see [`error_bits`].
pub const ERROR: u16 = 1606;
/// Status code per finger (6 bytes, read-only): see [`status`].
pub const STATUS: u16 = 1612;
/// Temperature per finger, °C (6 bytes, read-only).
pub const TEMP: u16 = 1618;
/// The DFTP's tactile cells start here (inspire-rh56dftp `TACTILE_REGIONS`).
pub const TACTILE: u16 = 3000;

/// The register file the emulator keeps: every address above, up to the palm's last cell.
pub const FILE_START: u16 = HAND_ID;
/// One past the last byte (the palm's 112 cells end at 4900 + 224).
pub const FILE_END: u16 = 5124;

/// Bytes of a six-short block.
pub const BLOCK: usize = 2 * FINGERS;

/// The feedback the device polls besides the angles, in one read: FORCE_ACT through TEMP
/// (force, current, error, status, temperature: 42 bytes).
pub const SLOW_BLOCK: (u16, usize) = (FORCE_ACT, (TEMP - FORCE_ACT) as usize + FINGERS);

/// Whether a write may touch `[addr, addr + len)`: the parameters (1000..1472) and the
/// targets (POS_SET..SPEED_SET's end). The measured values and the tactile cells are read-only.
pub fn writable(addr: u16, len: usize) -> bool {
    let end = addr as usize + len;
    let within = |a: u16, b: u16| addr >= a && end <= b as usize;
    len > 0 && (within(FILE_START, VOLTAGE) || within(POS_SET, POS_ACT))
}

/// Whether `[addr, addr + len)` lies inside the register file.
pub fn readable(addr: u16, len: usize) -> bool {
    len > 0 && addr >= FILE_START && addr as usize + len <= FILE_END as usize
}

/// STATUS codes (manual V1.09; pyrh56 `STATUS_TEXT`).
pub mod status {
    pub const RELEASING: u8 = 0;
    pub const GRASPING: u8 = 1;
    pub const POSITION_REACHED: u8 = 2;
    pub const FORCE_REACHED: u8 = 3;
    pub const OVERCURRENT: u8 = 5;
    pub const STALL: u8 = 6;
    pub const ACTUATOR_FAULT: u8 = 7;
}

/// ERROR bits (manual V1.09; pyrh56 `ERROR_BITS`).
pub mod error_bits {
    pub const STALL: u8 = 1 << 0;
    pub const OVER_TEMPERATURE: u8 = 1 << 1;
    pub const OVERCURRENT: u8 = 1 << 2;
    pub const MOTOR: u8 = 1 << 3;
    pub const COMMUNICATION: u8 = 1 << 4;
}

/// The DFTP's 17 tactile regions: (canonical pad name, first cell's byte address, rows, cols),
/// one short per cell, 0..4095 (inspire-rh56dftp `TACTILE_REGIONS`, manual PRJ-02-TS-U-010
/// §2.6.20). The pad names are the FTP kind's (`inspire_ftp::front::SEGMENTS`; its `top` is the
/// manual's `nail`); the palm is listed 8 × 14 in the client and 14 × 8 in the FTP's DDS driver,
/// 112 cells either way.
pub const TACTILE_REGIONS: [(&str, u16, u16, u16); 17] = [
    ("pinky_tip", 3000, 3, 3),
    ("pinky_top", 3018, 12, 8),
    ("pinky_pad", 3210, 10, 8),
    ("ring_tip", 3370, 3, 3),
    ("ring_top", 3388, 12, 8),
    ("ring_pad", 3580, 10, 8),
    ("middle_tip", 3740, 3, 3),
    ("middle_top", 3758, 12, 8),
    ("middle_pad", 3950, 10, 8),
    ("index_tip", 4110, 3, 3),
    ("index_top", 4128, 12, 8),
    ("index_pad", 4320, 10, 8),
    ("thumb_tip", 4480, 3, 3),
    ("thumb_top", 4498, 12, 8),
    ("thumb_middle", 4690, 3, 3),
    ("thumb_pad", 4708, 12, 8),
    ("palm", 4900, 14, 8),
];

/// The tactile cells (1062, contiguous from [`TACTILE`]: two bytes a cell).
pub const TACTILE_CELLS: usize = (FILE_END - TACTILE) as usize / 2;

/// The tactile cells read in 11 requests of at most 224 bytes (112 Modbus registers), each
/// whole regions: a finger's tip and nail, then its pad; the thumb's tip and nail, its middle
/// and pad; the palm. (byte address, bytes). inspire-rh56dftp reads the same batches.
pub const TACTILE_BATCHES: [(u16, usize); 11] = [
    (3000, 210),
    (3210, 160),
    (3370, 210),
    (3580, 160),
    (3740, 210),
    (3950, 160),
    (4110, 210),
    (4320, 160),
    (4480, 210),
    (4690, 210),
    (4900, 224),
];

/// Largest tactile cell value (12-bit ADC).
pub const TACTILE_MAX: u16 = 4095;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_follow_each_other_and_regions_do_not_overlap() {
        assert_eq!(ANGLE_SET as usize + BLOCK, FORCE_SET as usize);
        assert_eq!(POS_ACT as usize + BLOCK, ANGLE_SET as usize + 60);
        assert_eq!(ERROR as usize + FINGERS, STATUS as usize);
        assert_eq!(STATUS as usize + FINGERS, TEMP as usize);
        assert_eq!(SLOW_BLOCK.1, 42);
        let mut end = TACTILE as usize;
        for (name, addr, r, c) in TACTILE_REGIONS {
            assert!(addr as usize >= end, "{name} overlaps the region before");
            end = addr as usize + 2 * (r * c) as usize;
        }
        assert_eq!(end, FILE_END as usize);
        // inspire-rh56dftp's batches: a finger's tip and nail are contiguous in Modbus
        // registers from the tip's address (2 bytes a register).
        assert_eq!(3000 + 2 * 9, 3018);
        // The batches cover the cells once, in order.
        let mut at = TACTILE as usize;
        for (a, n) in TACTILE_BATCHES {
            assert_eq!(a as usize, at);
            assert!(n <= 224 && n % 2 == 0);
            at += n;
        }
        assert_eq!(at, FILE_END as usize);
        assert_eq!(TACTILE_CELLS, 1062);
    }

    #[test]
    fn targets_are_writable_and_measurements_are_not() {
        assert!(writable(ANGLE_SET, BLOCK));
        assert!(writable(CLEAR_ERROR, 1));
        assert!(writable(POS_SET, 4 * BLOCK));
        assert!(!writable(ANGLE_ACT, BLOCK));
        assert!(!writable(SPEED_SET, BLOCK + 1), "runs into POS_ACT");
        assert!(!writable(TACTILE, 2));
        assert!(!writable(ANGLE_SET, 0));
        assert!(readable(TEMP, FINGERS));
        assert!(!readable(FILE_END - 1, 2));
        assert!(!readable(999, 2));
    }
}
