//! The Robotiq adaptive grippers' register images (2F-85, 2F-140, Hand-E: one map), pure
//! encode and decode. Sources: the 2F-85/2F-140 and Hand-E instruction manuals' "Control"
//! chapters (robotiq.com/support), pyRobotiqGripper 3.3.14 (`gripper.py`, `constants.py`),
//! docs/robotiq.md.
//!
//! Modbus RTU, 115200 8N1, slave 9. Six request bytes from register 0x03E8 (FC16 / FC06 /
//! FC23 write, FC03 read back), six status bytes from 0x07D0 (FC03 or FC04, or the read half
//! of FC23). Bytes are packed big-endian into the 16-bit registers: byte 0 is the high byte
//! of the first register.
//!
//! | byte | request (0x03E8)                         | status (0x07D0)                                   |
//! |------|------------------------------------------|---------------------------------------------------|
//! | 0    | rACT bit 0, rGTO bit 3, rATR bit 4, rARD bit 5 | gACT bit 0, gGTO bit 3, gSTA bits 4-5, gOBJ bits 6-7 |
//! | 1    | reserved                                 | reserved                                          |
//! | 2    | reserved                                 | gFLT bits 0-3, kFLT bits 4-7                      |
//! | 3    | rPR position request (0 open, 255 closed)| gPR echo of rPR                                   |
//! | 4    | rSP speed                                | gPO position (encoder)                            |
//! | 5    | rFR force                                | gCU current, about 10 mA per count                |

/// The gripper's Modbus slave id (manual, factory default).
pub const SLAVE_ID: u8 = 9;
/// Factory baud rate (115200 8N1).
pub const BAUD: u32 = 115_200;
/// First request register (the "output" registers, robot → gripper).
pub const REQUEST_ADDR: u16 = 0x03E8;
/// First status register (the "input" registers, gripper → robot).
pub const STATUS_ADDR: u16 = 0x07D0;
/// Registers in each image (6 bytes).
pub const WORDS: usize = 3;
/// Approximate motor current per gCU count, mA (manual: "current ≈ 10 × value mA").
pub const MA_PER_CURRENT_COUNT: f32 = 10.0;
/// The manual's minimum time between two commands ("200 Hz is the usual speed, at least 5 ms
/// between commands").
pub const MIN_COMMAND_GAP: std::time::Duration = std::time::Duration::from_millis(5);
/// gFLT after one second without any communication (a minor fault).
pub const NO_COMMUNICATION_AFTER: std::time::Duration = std::time::Duration::from_secs(1);

/// gFLT values (manual, "Fault status").
pub mod fault {
    pub const NONE: u8 = 0x00;
    /// Priority fault: action delayed, the activation must complete first.
    pub const ACTION_DELAYED: u8 = 0x05;
    /// Priority fault: the activation bit must be set before the action.
    pub const NOT_ACTIVATED: u8 = 0x07;
    /// Minor fault: maximum operating temperature exceeded.
    pub const OVER_TEMPERATURE: u8 = 0x08;
    /// Minor fault: no communication during at least 1 second.
    pub const NO_COMMUNICATION: u8 = 0x09;
    /// Major faults (a reset and a rising edge of rACT clear them) start here.
    pub const MAJOR: u8 = 0x0A;
    /// Major fault: activation fault (an interference during activation).
    pub const ACTIVATION: u8 = 0x0D;
    /// Major fault: overcurrent.
    pub const OVERCURRENT: u8 = 0x0E;
}

/// gSTA: the activation status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Activation {
    /// Reset (or automatic release).
    #[default]
    Reset = 0,
    /// Activation in progress.
    InProgress = 1,
    /// Not used by the gripper.
    Unused = 2,
    /// Activation completed.
    Completed = 3,
}

impl Activation {
    pub fn from_bits(b: u8) -> Self {
        match b & 3 {
            0 => Activation::Reset,
            1 => Activation::InProgress,
            2 => Activation::Unused,
            _ => Activation::Completed,
        }
    }
}

/// gOBJ: object detection (only meaningful while gGTO = 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Object {
    /// Fingers in motion towards the requested position, no object detected.
    #[default]
    Moving = 0,
    /// Fingers stopped by a contact while opening.
    ContactOpening = 1,
    /// Fingers stopped by a contact while closing.
    ContactClosing = 2,
    /// Fingers at the requested position (no object, or it was lost).
    AtPosition = 3,
}

impl Object {
    pub fn from_bits(b: u8) -> Self {
        match b & 3 {
            0 => Object::Moving,
            1 => Object::ContactOpening,
            2 => Object::ContactClosing,
            _ => Object::AtPosition,
        }
    }

    /// Stopped on an object (either direction).
    pub fn contact(self) -> bool {
        matches!(self, Object::ContactOpening | Object::ContactClosing)
    }
}

/// The request image (robot → gripper), 6 bytes from 0x03E8.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Request {
    /// rACT: activate (must stay 1 after activation).
    pub act: bool,
    /// rGTO: go to the requested position.
    pub gto: bool,
    /// rATR: automatic release (emergency).
    pub atr: bool,
    /// rARD: automatic release direction (1 opening).
    pub ard: bool,
    /// rPR: position request, 0 open .. 255 closed.
    pub position: u8,
    /// rSP: speed, 0 (minimum) .. 255 (maximum).
    pub speed: u8,
    /// rFR: force, 0 .. 255.
    pub force: u8,
}

impl Request {
    /// The six bytes.
    pub fn to_bytes(&self) -> [u8; 6] {
        let b0 = u8::from(self.act) | u8::from(self.gto) << 3 | u8::from(self.atr) << 4 | u8::from(self.ard) << 5;
        [b0, 0, 0, self.position, self.speed, self.force]
    }

    /// From six bytes (reserved bytes and bits ignored).
    pub fn from_bytes(b: &[u8; 6]) -> Self {
        Request {
            act: b[0] & 1 != 0,
            gto: b[0] & 1 << 3 != 0,
            atr: b[0] & 1 << 4 != 0,
            ard: b[0] & 1 << 5 != 0,
            position: b[3],
            speed: b[4],
            force: b[5],
        }
    }

    /// The three registers.
    pub fn to_words(&self) -> [u16; WORDS] {
        bytes_to_words(&self.to_bytes())
    }

    pub fn from_words(w: &[u16; WORDS]) -> Self {
        Self::from_bytes(&words_to_bytes(w))
    }

    /// A command to go to `position` at `speed` and `force`, activated.
    pub fn go(position: u8, speed: u8, force: u8) -> Self {
        Request {
            act: true,
            gto: true,
            position,
            speed,
            force,
            ..Request::default()
        }
    }
}

/// The status image (gripper → robot), 6 bytes from 0x07D0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Status {
    /// gACT: echo of rACT.
    pub act: bool,
    /// gGTO: echo of rGTO (going to the requested position).
    pub gto: bool,
    /// gSTA.
    pub activation: Activation,
    /// gOBJ.
    pub object: Object,
    /// gFLT (low nibble of byte 2).
    pub fault: u8,
    /// kFLT: the optional controller's fault (high nibble of byte 2).
    pub controller_fault: u8,
    /// gPR: echo of rPR.
    pub requested: u8,
    /// gPO: position, 0 open .. 255 closed.
    pub position: u8,
    /// gCU: current, [`MA_PER_CURRENT_COUNT`] mA per count.
    pub current: u8,
}

impl Status {
    pub fn to_bytes(&self) -> [u8; 6] {
        let b0 = u8::from(self.act) | u8::from(self.gto) << 3 | (self.activation as u8) << 4 | (self.object as u8) << 6;
        [
            b0,
            0,
            (self.fault & 0x0F) | (self.controller_fault & 0x0F) << 4,
            self.requested,
            self.position,
            self.current,
        ]
    }

    pub fn from_bytes(b: &[u8; 6]) -> Self {
        Status {
            act: b[0] & 1 != 0,
            gto: b[0] & 1 << 3 != 0,
            activation: Activation::from_bits(b[0] >> 4),
            object: Object::from_bits(b[0] >> 6),
            fault: b[2] & 0x0F,
            controller_fault: b[2] >> 4,
            requested: b[3],
            position: b[4],
            current: b[5],
        }
    }

    pub fn to_words(&self) -> [u16; WORDS] {
        bytes_to_words(&self.to_bytes())
    }

    pub fn from_words(w: &[u16; WORDS]) -> Self {
        Self::from_bytes(&words_to_bytes(w))
    }

    /// Activated and ready to move (gSTA = 3).
    pub fn activated(&self) -> bool {
        self.activation == Activation::Completed
    }

    /// A major fault (a reset and a new activation clear it).
    pub fn major_fault(&self) -> bool {
        self.fault >= fault::MAJOR
    }

    /// The motor current, mA.
    pub fn current_ma(&self) -> f32 {
        f32::from(self.current) * MA_PER_CURRENT_COUNT
    }
}

/// Six bytes as three big-endian registers.
pub fn bytes_to_words(b: &[u8; 6]) -> [u16; WORDS] {
    [
        u16::from_be_bytes([b[0], b[1]]),
        u16::from_be_bytes([b[2], b[3]]),
        u16::from_be_bytes([b[4], b[5]]),
    ]
}

/// Three registers as six bytes.
pub fn words_to_bytes(w: &[u16; WORDS]) -> [u8; 6] {
    let [a, b] = w[0].to_be_bytes();
    let [c, d] = w[1].to_be_bytes();
    let [e, f] = w[2].to_be_bytes();
    [a, b, c, d, e, f]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pyRobotiqGripper's activation word (`0b0000100100000000`: rACT and rGTO in the high
    /// byte of register 1000) and its status decoding (gOBJ bits 6-7 of the high byte of
    /// register 2000, gFLT the low nibble of register 2001's high byte, gPR its low byte, gPO
    /// and gCU register 2002).
    #[test]
    fn images_match_the_manual_and_pyrobotiqgripper() {
        let r = Request {
            act: true,
            gto: true,
            ..Request::default()
        };
        assert_eq!(r.to_words(), [0b0000_1001_0000_0000, 0, 0]);
        let r = Request {
            atr: true,
            ard: true,
            ..Request::go(0xAB, 0xCD, 0xEF)
        };
        assert_eq!(r.to_bytes(), [0x39, 0, 0, 0xAB, 0xCD, 0xEF]);
        assert_eq!(r.to_words(), [0x3900, 0x00AB, 0xCDEF]);
        assert_eq!(Request::from_words(&r.to_words()), r);

        // The manual's example: activated, at position, object detected closing at 0xBB.
        let s = Status {
            act: true,
            gto: true,
            activation: Activation::Completed,
            object: Object::ContactClosing,
            fault: fault::NO_COMMUNICATION,
            controller_fault: 0,
            requested: 0xFF,
            position: 0xBB,
            current: 0x10,
        };
        assert_eq!(s.to_bytes(), [0b1011_1001, 0, 0x09, 0xFF, 0xBB, 0x10]);
        assert_eq!(Status::from_words(&s.to_words()), s);
        assert_eq!(s.current_ma(), 160.0);
        assert!(s.activated() && !s.major_fault() && s.object.contact());
    }

    /// Every byte pattern survives decode → encode for the bits the map defines.
    #[test]
    fn decode_encode_keeps_every_defined_bit() {
        for b0 in 0..=255u8 {
            let b = [b0, 0, b0, b0 ^ 0x55, b0.wrapping_mul(3), !b0];
            let s = Status::from_bytes(&b);
            let mut want = b;
            want[0] &= 0b1111_1001;
            assert_eq!(s.to_bytes(), want, "{b:?}");
            let r = Request::from_bytes(&b);
            let mut want = [b0 & 0b0011_1001, 0, 0, b[3], b[4], b[5]];
            want[1] = 0;
            assert_eq!(r.to_bytes(), want, "{b:?}");
        }
    }
}
