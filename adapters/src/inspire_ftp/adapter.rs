//! Inspire FTP over DDS, as a client of Inspire's DDS driver (one driver per hand,
//! docs/sources.md §7): publishes `inspire::inspire_hand_ctrl` on `rt/inspire_hand/ctrl/{l,r}`
//! the way xr_teleoperate does (`angle_set` only, `mode = 0b0001`; angles 0–1000, 1000 = open,
//! through the table), plus `force_set` / `speed_set` with their mode bits where the profile
//! sets `dds.force_limit` / `dds.speed`; reads `inspire_hand_state` from
//! `rt/inspire_hand/state/{l,r}`.
//!
//! State: joint q from `angle_act` through the table; temperature per actuator; `err` ≠ 0 →
//! fault `MOTOR_ERROR`, `err` bit 3 (motor fault) or `status` 7 (actuator fault) / 255 (error)
//! → `HARDWARE`; `mode` = the highest status code of the six (0 opening … 3 stopped at force).
//! A sample whose `angle_act` does not have 6 entries is not this hand's state and is ignored
//! (the device goes stale as for any missing state, `DdsDevice`). dq and tau are not measured
//! (0): the hand reports no velocity and its force is in its own units.
//!
//! Touch: where the profile says the hand is on Modbus TCP (`dds.touch`, default true), the
//! client also reads `inspire_hand_touch` from `rt/inspire_hand/touch/{l,r}` and carries the
//! latest one in the state's pads, one named pad per segment (`front::pads_from_touch`). Over
//! RS-485 there is no touch topic and the state has no pads.

use handgate_idl::inspire::{
    InspireHandCtrl, InspireHandState, InspireHandTouch, ACTUATORS, MODE_ANGLE, MODE_FORCE, MODE_SPEED,
};

use std::sync::{Arc, Mutex};

use crate::control::{Active, MeasuredHold};
use crate::dds::{DdsError, Node, Reader};
use crate::dds_device::{DdsCodec, STATE_QOS};
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, Pad, SafeAction};

use super::front::{ERR_MOTOR_FAULT, STATUS_ACTUATOR_FAULT};
use super::table::{ANGLE_CLOSED, ANGLE_OPEN};

/// `status` 3: the actuator stopped because its force reached FORCE_SET (docs/wire-types.md).
pub const STATUS_AT_FORCE: u8 = 3;
/// `force_act` (the hand's force units) from which an actuator counts as pressing on something
/// (the motion verdict's contact). Assumption: about 50 units is well above the register's
/// noise and below any grasp's force (docs/adapters.md, the assumptions table).
pub const CONTACT_FORCE: i16 = 50;

/// `status` 255: error (docs/wire-types.md).
pub const STATUS_ERROR: u8 = 255;

/// The client codec.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FtpCodec {
    /// `force_set` for every actuator (0–1000), sent with bit 2 on every command.
    pub force_limit: Option<i16>,
    /// `speed_set` for every actuator (0–1000), sent with bit 3 on every command.
    pub speed: Option<i16>,
    /// The measured angles (`angle_act`, wire order), and the hold of them the "limp" safe
    /// state sends.
    pub(super) limp: MeasuredHold<[i16; ACTUATORS]>,
}

impl FtpCodec {
    /// Fills `m` with the `inspire_hand_ctrl` for wire angles `angles` (canonical order = wire
    /// order), its buffers reused: the SDK's default message (every array 6 zeros) with
    /// `angle_set` and the profile's force and speed.
    pub fn message(&self, angles: [i16; ACTUATORS], m: &mut InspireHandCtrl) {
        let set = |v: &mut Vec<i16>, values: [i16; ACTUATORS]| {
            v.clear();
            v.extend_from_slice(&values);
        };
        set(&mut m.pos_set, [0; ACTUATORS]);
        set(&mut m.angle_set, angles);
        set(&mut m.force_set, [self.force_limit.unwrap_or(0); ACTUATORS]);
        set(&mut m.speed_set, [self.speed.unwrap_or(0); ACTUATORS]);
        m.mode = MODE_ANGLE;
        if self.force_limit.is_some() {
            m.mode |= MODE_FORCE;
        }
        if self.speed.is_some() {
            m.mode |= MODE_SPEED;
        }
    }
}

/// A wire angle as an int16 register value, truncated as xr_teleoperate does after
/// clipping to [0, 1000] ([`ANGLE_CLOSED`], [`ANGLE_OPEN`]).
pub fn angle_register(a: f32) -> i16 {
    if a.is_finite() {
        a.clamp(ANGLE_CLOSED, ANGLE_OPEN) as i16
    } else {
        // Unreachable through the table (targets are finite); open is the safe value.
        ANGLE_OPEN as i16
    }
}

impl DdsCodec for FtpCodec {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut Self::Cmd) -> bool {
        let targets = match active {
            // The hand has no torque-off: a limp safe state is a hold of the angles measured
            // when it began, kept until it ends (never re-taken from each new measurement:
            // docs/adapters.md, "Holds"); nothing before the hand was measured.
            Active::Safe(SafeAction::Limp, _) => {
                return match self.limp.hold() {
                    Some(a) => {
                        self.message(a, msg);
                        true
                    }
                    None => false,
                };
            }
            Active::Idle => return false,
            Active::Command(t) | Active::Safe(_, t) => t,
        };
        self.limp.release();
        let mut angles = [1000i16; ACTUATORS];
        for (i, w) in table.wire_targets(targets) {
            angles[i] = angle_register(w.q);
        }
        self.message(angles, msg);
        true
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        if s.angle_act.len() != ACTUATORS {
            return false;
        }
        let mut act = [0i16; ACTUATORS];
        act.copy_from_slice(&s.angle_act);
        self.limp.measure(act);
        table.state_from_wire_into(&mut st.joints, |i| {
            s.angle_act.get(i).map(|a| (f32::from(*a), 0.0, 0.0))
        });
        for (j, m) in st.joints.iter_mut().zip(&table.joints) {
            // Not measured: 0 (not the -0.0 of a mirrored joint).
            (j.dq, j.tau) = (0.0, 0.0);
            j.temperature = s.temperature.get(m.wire_index).map(|t| f32::from(*t));
        }
        let mut f = 0;
        if s.err.iter().any(|e| *e != 0) {
            f |= faults::MOTOR_ERROR;
        }
        if s.err.iter().any(|e| e & ERR_MOTOR_FAULT != 0)
            || s.status
                .iter()
                .any(|st| *st == STATUS_ACTUATOR_FAULT || *st == STATUS_ERROR)
        {
            f |= faults::HARDWARE;
        }
        st.faults = f;
        st.mode = s.status.iter().copied().filter(|st| *st <= 7).max().unwrap_or(0);
        // Contact, as the hand reports it per actuator (the table's `Contact::Reported`): stopped
        // at its force limit (status 3), or pressing with at least CONTACT_FORCE.
        st.contact.clear();
        st.contact.extend(table.joints.iter().map(|j| {
            s.status.get(j.wire_index) == Some(&STATUS_AT_FORCE)
                || s.force_act.get(j.wire_index).is_some_and(|f| *f >= CONTACT_FORCE)
        }));
        true
    }
}

/// The newest touch sample, left by the touch reader's callback (on CycloneDDS's thread) for
/// the device loop.
type LatestTouch = Arc<Mutex<Option<InspireHandTouch>>>;

/// The device-side codec: [`FtpCodec`] plus, over Modbus TCP, the touch reader whose latest
/// sample rides along in every decoded state.
pub struct FtpClient {
    pub codec: FtpCodec,
    touch: Option<(Reader<InspireHandTouch>, LatestTouch)>,
    pads: Vec<Pad>,
}

impl FtpClient {
    /// `touch`: the hand's touch topic (None over RS-485), read on `node`.
    pub fn new(node: &Node, codec: FtpCodec, touch: Option<&str>) -> Result<Self, DdsError> {
        let touch = match touch {
            Some(topic) => {
                let latest = LatestTouch::default();
                let l = latest.clone();
                let reader = node.reader_with_callback::<InspireHandTouch, _>(topic, STATE_QOS, move |h| {
                    let mut v = Vec::new();
                    h.take_into(&mut v);
                    if let Some(t) = v.pop() {
                        *l.lock().unwrap_or_else(|p| p.into_inner()) = Some(t);
                    }
                })?;
                Some((reader, latest))
            }
            None => None,
        };
        Ok(Self {
            codec,
            touch,
            pads: Vec::new(),
        })
    }
}

impl DdsCodec for FtpClient {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, dt: f32, msg: &mut Self::Cmd) -> bool {
        self.codec.encode_into(active, table, dt, msg)
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        let touch = self
            .touch
            .as_ref()
            .and_then(|(_, latest)| latest.lock().unwrap_or_else(|p| p.into_inner()).take());
        if let Some(t) = touch {
            super::front::pads_from_touch_into(&t, &mut self.pads);
        }
        if !self.codec.decode_into(s, table, st) {
            return false;
        }
        st.pads.clone_from(&self.pads);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Side;

    #[test]
    fn open_and_fist_in_angle_mode() {
        let t = super::super::table::table(Side::Left);
        let mut c = FtpCodec::default();
        let open = t.closure_targets(0.0, None).unwrap();
        let m = c.encode(&Active::Command(open), &t, 0.01).unwrap();
        assert_eq!((m.mode, m.angle_set.clone()), (MODE_ANGLE, vec![1000; 6]));
        let fist = t.closure_targets(1.0, None).unwrap();
        let m = c.encode(&Active::Command(fist), &t, 0.01).unwrap();
        assert_eq!(m.angle_set, vec![0, 0, 0, 0, 1000, 1000]);
        assert!(c.encode(&Active::Idle, &t, 0.01).is_none());
        let mut c = FtpCodec {
            force_limit: Some(300),
            speed: Some(700),
            ..Default::default()
        };
        let m = c
            .encode(&Active::Command(t.closure_targets(0.0, None).unwrap()), &t, 0.01)
            .unwrap();
        assert_eq!(m.mode, MODE_ANGLE | MODE_FORCE | MODE_SPEED);
        assert_eq!((m.force_set[0], m.speed_set[5]), (300, 700));
    }

    /// The hand has no torque-off: `limp` holds the angles measured when it began (never the
    /// table's zeros, which would open the hand), kept while the measurement moves; nothing
    /// before a measurement.
    #[test]
    fn limp_holds_the_angles_measured_when_it_began() {
        let t = super::super::table::table(Side::Left);
        let mut c = FtpCodec::default();
        let limp = Active::Safe(SafeAction::Limp, t.safe_targets(SafeAction::Limp, &[]));
        assert!(c.encode(&limp, &t, 0.01).is_none(), "nothing measured: silent");
        let mut s = InspireHandState::sdk_default();
        s.angle_act = vec![400, 410, 420, 430, 440, 450];
        c.decode(&s, &t).unwrap();
        assert_eq!(
            c.encode(&limp, &t, 0.01).unwrap().angle_set,
            vec![400, 410, 420, 430, 440, 450]
        );
        s.angle_act = vec![399, 409, 419, 429, 439, 449];
        c.decode(&s, &t).unwrap();
        let m = c.encode(&limp, &t, 0.01).unwrap();
        assert_eq!(
            (m.mode, m.angle_set),
            (MODE_ANGLE, vec![400, 410, 420, 430, 440, 450]),
            "kept"
        );
        // A command ends the limp; the next one begins at the newest measurement.
        c.encode(&Active::Command(t.closure_targets(0.0, None).unwrap()), &t, 0.01);
        assert_eq!(
            c.encode(&limp, &t, 0.01).unwrap().angle_set,
            vec![399, 409, 419, 429, 439, 449]
        );
    }
}
