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

use crate::control::{Active, MeasuredHold};
use crate::dds::Reader;
use crate::dds_device::DdsCodec;
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, Pad, SafeAction};

use super::front::{ERR_MOTOR_FAULT, STATUS_ACTUATOR_FAULT};

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
    /// The `inspire_hand_ctrl` for wire angles `angles` (canonical order = wire order).
    pub fn message(&self, angles: [i16; ACTUATORS]) -> InspireHandCtrl {
        let mut m = InspireHandCtrl::sdk_default();
        m.angle_set = angles.to_vec();
        m.mode = MODE_ANGLE;
        if let Some(f) = self.force_limit {
            m.force_set = vec![f; ACTUATORS];
            m.mode |= MODE_FORCE;
        }
        if let Some(s) = self.speed {
            m.speed_set = vec![s; ACTUATORS];
            m.mode |= MODE_SPEED;
        }
        m
    }
}

/// A wire angle as an int16 register value, truncated as xr_teleoperate does after
/// clipping to [0, 1000].
pub fn angle_register(a: f32) -> i16 {
    if a.is_finite() {
        a.clamp(0.0, 1000.0) as i16
    } else {
        // Unreachable through the table (targets are finite); open is the safe value.
        1000
    }
}

impl DdsCodec for FtpCodec {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;

    fn encode(&mut self, active: &Active, table: &DeviceTable, _dt: f32) -> Option<Self::Cmd> {
        let targets = match active {
            // The hand has no torque-off: a limp safe state is a hold of the angles measured
            // when it began, kept until it ends (never re-taken from each new measurement:
            // docs/adapters.md, "Holds"); nothing before the hand was measured.
            Active::Safe(SafeAction::Limp, _) => return self.limp.hold().map(|a| self.message(a)),
            Active::Idle => return None,
            Active::Command(t) | Active::Safe(_, t) => t,
        };
        self.limp.release();
        let wire = table.to_wire(targets);
        let mut angles = [1000i16; ACTUATORS];
        for (map, w) in table.joints.iter().zip(&wire) {
            angles[map.wire_index] = angle_register(w.q);
        }
        Some(self.message(angles))
    }

    fn decode(&mut self, s: &Self::State, table: &DeviceTable) -> Option<HandState> {
        if s.angle_act.len() != ACTUATORS {
            return None;
        }
        let q: Vec<f32> = table
            .joints
            .iter()
            .map(|m| f32::from(s.angle_act[m.wire_index]))
            .collect();
        let mut act = [0i16; ACTUATORS];
        act.copy_from_slice(&s.angle_act);
        self.limp.measure(act);
        let zeros = vec![0.0; table.joint_count()];
        let mut joints = table.state_from_wire(&q, &zeros, &zeros);
        for (j, m) in joints.iter_mut().zip(&table.joints) {
            j.dq = 0.0;
            j.tau = 0.0;
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
        let mode = s.status.iter().copied().filter(|st| *st <= 7).max().unwrap_or(0);
        Some(HandState {
            joints,
            faults: f,
            mode,
            ..Default::default()
        })
    }
}

/// The device-side codec: [`FtpCodec`] plus, over Modbus TCP, the touch reader whose latest
/// sample rides along in every decoded state.
pub struct FtpClient {
    pub codec: FtpCodec,
    touch: Option<Reader<InspireHandTouch>>,
    pads: Vec<Pad>,
}

impl FtpClient {
    /// `touch`: the reader of the hand's touch topic (None over RS-485).
    pub fn new(codec: FtpCodec, touch: Option<Reader<InspireHandTouch>>) -> Self {
        Self {
            codec,
            touch,
            pads: Vec::new(),
        }
    }
}

impl DdsCodec for FtpClient {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;

    fn encode(&mut self, active: &Active, table: &DeviceTable, dt: f32) -> Option<Self::Cmd> {
        self.codec.encode(active, table, dt)
    }

    fn decode(&mut self, s: &Self::State, table: &DeviceTable) -> Option<HandState> {
        if let Some(t) = self.touch.as_ref().and_then(|r| r.take().pop()) {
            self.pads = super::front::pads_from_touch(&t);
        }
        let mut st = self.codec.decode(s, table)?;
        st.pads = self.pads.clone();
        Some(st)
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
