//! Which (bus, id) is which joint and which pressure pad.
//!
//! NOT PUBLIC (docs/sources.md §3): the manual's bus figure is an image that did not survive. Every
//! feedback packet carries its id, so the real map can be learned with
//! [`super::discovery::discover`]. Until then [`WiringMap::default`] is an ASSUMPTION:
//!
//! | bus | motors (id → joint) | pads (sensor id → pad index) |
//! |---|---|---|
//! | 0 | 0 thumb_0, 1 thumb_1, 2 thumb_2 | 0 → 0, 1 → 1 |
//! | 1 | 0 index_0, 1 index_1 | 0 → 2, 1 → 3 |
//! | 2 | 0 middle_0, 1 middle_1 | 0 → 4, 1 → 5 |
//! | 3 | – | 0 → 6, 1 → 7 |
//! | 4 | – | 0 → 8 |
//!
//! (motors numbered from 0 on each bus, as the manual says). Pad indices are the
//! `press_sensor_state` indices of the DDS message; which physical pad each is remains open.

use super::codec::{BusId, DeviceId, BUS_BUFFER_SIZE, BUS_COUNT, MOTOR_CMD_LEN, MOTOR_FB_LEN, SENSOR_LEN};
use crate::dex3::{Joint, MOTOR_COUNT, PAD_COUNT};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A device address on the hand's internal buses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusAddr {
    pub bus: BusId,
    pub id: DeviceId,
}

impl BusAddr {
    /// Panics on out-of-range values: for constants only. Use the fields' `new` otherwise.
    pub fn of(bus: u8, id: u8) -> Self {
        Self {
            bus: BusId::new(bus).expect("bus constant"),
            id: DeviceId::new(id).expect("id constant"),
        }
    }
}

impl std::fmt::Display for BusAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "bus {} id {}", self.bus.get(), self.id.get())
    }
}

/// Joint and pad placement. `motors[j]` is the address of IDL joint `j`; `pads[p]` of pad `p`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WiringMap {
    pub motors: [BusAddr; MOTOR_COUNT],
    pub pads: [BusAddr; PAD_COUNT],
}

#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum WiringError {
    #[error("motor address {0} used twice")]
    DuplicateMotor(BusAddr),
    #[error("pad address {0} used twice")]
    DuplicatePad(BusAddr),
    #[error("bus {bus}: {what} needs {bytes} bytes, more than the {BUS_BUFFER_SIZE}-byte bus buffer")]
    BusFull { bus: u8, what: &'static str, bytes: usize },
}

impl Default for WiringMap {
    /// The documented ASSUMPTION (module docs).
    fn default() -> Self {
        let a = BusAddr::of;
        let mut motors = [a(0, 0); MOTOR_COUNT];
        motors[Joint::Thumb0.index()] = a(0, 0);
        motors[Joint::Thumb1.index()] = a(0, 1);
        motors[Joint::Thumb2.index()] = a(0, 2);
        motors[Joint::Index0.index()] = a(1, 0);
        motors[Joint::Index1.index()] = a(1, 1);
        motors[Joint::Middle0.index()] = a(2, 0);
        motors[Joint::Middle1.index()] = a(2, 1);
        let pads = [
            a(0, 0),
            a(0, 1),
            a(1, 0),
            a(1, 1),
            a(2, 0),
            a(2, 1),
            a(3, 0),
            a(3, 1),
            a(4, 0),
        ];
        Self { motors, pads }
    }
}

impl WiringMap {
    /// Checks that no address is used twice (motors and sensors have separate id spaces:
    /// their packets have different heads) and that each bus's packets fit its buffer.
    /// Ranges (bus < 5, id < 15) are enforced by the [`BusId`]/[`DeviceId`] types.
    pub fn validate(&self) -> Result<(), WiringError> {
        for (i, m) in self.motors.iter().enumerate() {
            if self.motors[..i].contains(m) {
                return Err(WiringError::DuplicateMotor(*m));
            }
        }
        for (i, p) in self.pads.iter().enumerate() {
            if self.pads[..i].contains(p) {
                return Err(WiringError::DuplicatePad(*p));
            }
        }
        for bus in 0..BUS_COUNT {
            let nm = self.motors.iter().filter(|m| m.bus.index() == bus).count();
            let ns = self.pads.iter().filter(|p| p.bus.index() == bus).count();
            let cmd = nm * MOTOR_CMD_LEN;
            if cmd > BUS_BUFFER_SIZE {
                return Err(WiringError::BusFull {
                    bus: bus as u8,
                    what: "motor commands",
                    bytes: cmd,
                });
            }
            let fb = nm * MOTOR_FB_LEN + ns * SENSOR_LEN;
            if fb > BUS_BUFFER_SIZE {
                return Err(WiringError::BusFull {
                    bus: bus as u8,
                    what: "motor feedback and sensor packets",
                    bytes: fb,
                });
            }
        }
        Ok(())
    }

    /// The joint at a motor address.
    pub fn joint_at(&self, addr: BusAddr) -> Option<Joint> {
        self.motors.iter().position(|m| *m == addr).and_then(Joint::from_index)
    }

    /// The pad index at a sensor address.
    pub fn pad_at(&self, addr: BusAddr) -> Option<usize> {
        self.pads.iter().position(|p| *p == addr)
    }

    /// Joints on `bus`, ordered by motor id (on the stack).
    pub fn joints_on(&self, bus: BusId) -> impl Iterator<Item = (DeviceId, Joint)> {
        self.motors_in_frame_order()
            .into_iter()
            .filter(move |(at, _)| at.bus == bus)
            .map(|(at, j)| (at.id, j))
    }

    /// Every joint with its address, in command-frame order: by bus, then by motor id (on
    /// the stack: the device loop builds a frame every cycle).
    pub fn motors_in_frame_order(&self) -> [(BusAddr, Joint); MOTOR_COUNT] {
        let mut v = Joint::ALL.map(|j| (self.motors[j.index()], j));
        v.sort_unstable_by_key(|(at, j)| (at.bus, at.id, *j));
        v
    }

    /// Pads on `bus`, ordered by sensor id (on the stack: the emulator answers with them on
    /// every exchange).
    pub fn pads_on(&self, bus: BusId) -> impl Iterator<Item = (DeviceId, usize)> {
        let mut v: [(BusAddr, usize); PAD_COUNT] = std::array::from_fn(|p| (self.pads[p], p));
        v.sort_unstable();
        v.into_iter()
            .filter(move |(at, _)| at.bus == bus)
            .map(|(at, p)| (at.id, p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_complete() {
        let w = WiringMap::default();
        w.validate().unwrap();
        for j in Joint::ALL {
            assert_eq!(w.joint_at(w.motors[j.index()]), Some(j));
        }
        assert_eq!(w.joint_at(BusAddr::of(1, 0)), Some(Joint::Index0));
        assert_eq!(w.pad_at(BusAddr::of(4, 0)), Some(8));
        assert_eq!(
            w.joints_on(BusId::new(0).unwrap()).map(|x| x.1).collect::<Vec<_>>(),
            vec![Joint::Thumb0, Joint::Thumb1, Joint::Thumb2]
        );
    }

    #[test]
    fn duplicates_rejected() {
        let mut w = WiringMap::default();
        w.motors[3] = w.motors[0];
        assert_eq!(w.validate(), Err(WiringError::DuplicateMotor(w.motors[0])));
        let mut w = WiringMap::default();
        w.pads[8] = w.pads[0];
        assert!(matches!(w.validate(), Err(WiringError::DuplicatePad(_))));
    }

    #[test]
    fn overfull_bus_rejected() {
        let mut w = WiringMap::default();
        // 3 motors (78 B) + 5 sensors (220 B) on bus 0 exceeds 240.
        for (p, id) in [(2usize, 2u8), (3, 3), (4, 4)] {
            w.pads[p] = BusAddr::of(0, id);
        }
        assert!(matches!(w.validate(), Err(WiringError::BusFull { bus: 0, .. })));
    }

    #[test]
    fn serde_rejects_out_of_range() {
        let w = WiringMap::default();
        let json = serde_json::to_string(&w).unwrap();
        let back: WiringMap = serde_json::from_str(&json).unwrap();
        assert_eq!(back, w);
        let bad_bus = json.replacen("\"bus\":0", "\"bus\":5", 1);
        assert!(serde_json::from_str::<WiringMap>(&bad_bus).is_err());
        let bad_id = json.replacen("\"id\":2", "\"id\":15", 1);
        assert!(serde_json::from_str::<WiringMap>(&bad_id).is_err());
        let short = r#"{"motors":[{"bus":0,"id":0}],"pads":[]}"#;
        assert!(serde_json::from_str::<WiringMap>(short).is_err());
    }
}
