//! OYMotion ROHand over Modbus RTU (docs/rohand.md): its register table, its codec and its
//! emulator core; everything else is the kit's register-mapped hand
//! ([`crate::modbus::hand`]). Registers, units and codes: OYMotion's
//! `OHandModBusRTUProtocol_EN.md` (github oymotion/roh_firmware).

use crate::device::Backend;
use crate::kind::{DeviceKind, KindFacts, Rates, SectionSpec, Sides};
use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::modbus::hand::kind::HandKind;
use crate::modbus::hand::{EmuSpec, RegisterHand};
use crate::model::{faults, HandState, Side};

pub mod emulator;

impl DeviceKind {
    /// OYMotion ROHand on an RS-485 line.
    #[allow(non_upper_case_globals)]
    pub const Rohand: DeviceKind = DeviceKind::of(&HandKind::<Rohand>::NEW);
}

/// Registers (protocol doc, 4.1). Per-finger blocks are thumb bend, index, middle, ring,
/// little, thumb rotation (FORCE and FORCE_LIMIT: the five fingers, no rotation).
pub mod reg {
    pub const PROTOCOL_VERSION: u16 = 1000;
    pub const NODE_ID: u16 = 1005;
    pub const SUB_EXCEPTION: u16 = 1006;
    pub const FINGER_STATUS: u16 = 1085;
    pub const CURRENT_LIMIT: u16 = 1095;
    pub const CURRENT: u16 = 1105;
    pub const FORCE_LIMIT: u16 = 1115;
    pub const FORCE: u16 = 1120;
    pub const SPEED: u16 = 1125;
    pub const POS_TARGET: u16 = 1135;
    pub const POS: u16 = 1145;
    pub const ANGLE_TARGET: u16 = 1155;
    pub const ANGLE: u16 = 1165;
    /// One past the last register (ROH_FINGER_ANGLE9 = 1174).
    pub const END: u16 = 1175;
}

/// ROH_FINGER_STATUS codes (protocol doc, 4.3).
pub mod status {
    pub const OPENING: u16 = 0;
    pub const CLOSING: u16 = 1;
    pub const POS_REACHED: u16 = 2;
    pub const OVER_CURRENT: u16 = 3;
    pub const FORCE_REACHED: u16 = 4;
    pub const STUCK: u16 = 5;
}

/// Logical position of a closed finger (0 = open): OYMotion's examples close the hand
/// ("握拳") with 65535 and open it with 0.
pub const POS_CLOSED: f32 = 65535.0;
pub const FINGERS: usize = 6;

/// Canonical joints, in the registers' order.
pub const JOINTS: [&str; FINGERS] = ["thumb_bend", "index", "middle", "ring", "little", "thumb_rotate"];

/// Each joint's angle at the open and closed end, degrees (protocol doc 4.2: the fingers'
/// angle to the palm falls as they close; thumb bend and rotation rise).
pub const ANGLES_DEG: [(f32, f32); FINGERS] = [
    (2.26, 36.76),
    (178.37, 100.22),
    (176.06, 97.81),
    (176.54, 101.38),
    (174.86, 98.84),
    (0.0, 90.0),
];

/// A finger pressing at least this much is in contact, mN (assumed: docs/rohand.md).
pub const CONTACT_FORCE_MN: u16 = 500;

/// Canonical range of joint `i`: 0 (open) to its angular travel, rad.
pub fn span(i: usize) -> f32 {
    let (open, closed) = ANGLES_DEG[i];
    (closed - open).abs().to_radians()
}

/// The ROHand.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Rohand;

/// Where the state block starts: ROH_FINGER_STATUS0 .. ROH_FINGER_POS5 in one FC03 (66 words).
const STATE: u16 = reg::FINGER_STATUS;
fn at(regs: &[u16], r: u16, i: usize) -> u16 {
    regs.get((r - STATE) as usize + i).copied().unwrap_or(0)
}

impl RegisterHand for Rohand {
    const FACTS: KindFacts = KindFacts {
        sides: Sides::LeftOrRight { note: ", not center" },
        sections: &[SectionSpec {
            key: "rohand",
            backends: &[Backend::Serial, Backend::Emulator],
        }],
        // A round (FC16 of 6 targets when they change, FC03 of 66 words) is 145 bytes, 13.8 ms
        // at 115200 baud: 50 Hz leaves the line a margin (docs/rohand.md).
        ..KindFacts::new(
            "rohand",
            &JOINTS,
            &[Backend::Serial, Backend::Emulator],
            Rates::fixed(50.0),
        )
    };
    const SLAVE: u8 = 2;
    const BAUD: u32 = 115_200;
    const BAUDS: &'static [u32] = &[115_200];
    const STATE: (u16, u16) = (STATE, reg::POS + FINGERS as u16 - STATE);
    const TARGET: (u16, u16) = (reg::POS_TARGET, FINGERS as u16);
    type Core = emulator::RohandCore;

    fn table(side: Side) -> DeviceTable {
        let closed: Vec<f32> = (0..FINGERS).map(span).collect();
        DeviceTable {
            kind: DeviceKind::Rohand,
            side,
            joints: JOINTS
                .iter()
                .enumerate()
                .map(|(i, name)| JointMap {
                    name,
                    wire_index: i,
                    urdf: format!("{}_{name}_joint", side.as_str()),
                    sign: 1.0,
                    scale: POS_CLOSED / span(i),
                    offset: 0.0,
                    limits: Limits::new(0.0, span(i)),
                })
                .collect(),
            closure: ClosureMap::Postures {
                open: vec![0.0; FINGERS],
                closed,
                kp: 1.0,
                kd: 0.1,
            },
            hold_kp: 1.0,
            hold_kd: 0.1,
            max_step: None,
            max_kp: 10.0,
            max_kd: 1.0,
            max_tau: 1.0,
            urdf_frame: crate::mapping::UrdfFrame::Canonical,
            motion: crate::motion::MotionThresholds::HAND.with_contact(crate::motion::Contact::Reported),
        }
    }

    /// q from ROH_FINGER_POS; no velocity or torque on the wire (CURRENT is mA, not N·m);
    /// contact: STATUS_FORCE_REACHED or a finger's FORCE ≥ [`CONTACT_FORCE_MN`]; faults:
    /// over-current or stuck stops; mode: the highest status code.
    fn state(table: &DeviceTable, regs: &[u16], st: &mut HandState) {
        table.state_from_wire_into(&mut st.joints, |i| Some((f32::from(at(regs, reg::POS, i)), 0.0, 0.0)));
        let status = |i| at(regs, reg::FINGER_STATUS, i);
        st.faults = 0;
        if (0..FINGERS).any(|i| matches!(status(i), status::OVER_CURRENT | status::STUCK)) {
            st.faults |= faults::HARDWARE;
        }
        st.mode = (0..FINGERS).map(|i| status(i).min(255) as u8).max().unwrap_or(0);
        st.contact.clear();
        st.contact.extend(table.joints.iter().map(|j| {
            let i = j.wire_index;
            status(i) == status::FORCE_REACHED || (i < 5 && at(regs, reg::FORCE, i) >= CONTACT_FORCE_MN)
        }));
    }

    fn targets(wire: &[f32], out: &mut [u16]) {
        for (o, w) in out.iter_mut().zip(wire) {
            *o = w.round().clamp(0.0, POS_CLOSED) as u16;
        }
    }

    fn core(spec: &EmuSpec) -> emulator::RohandCore {
        emulator::RohandCore::new(spec)
    }
}

#[cfg(test)]
mod codec_tests;
