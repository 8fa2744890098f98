//! Emulator of the G1's resident Dex3-1 service: the DDS peer a Dex3 DDS adapter talks to.
//!
//! It subscribes `unitree_hg::msg::dds_::HandCmd_` on `rt/dex3/{side}/cmd` and publishes
//! `HandState_` on `rt/dex3/{side}/state` (default 500 Hz) and, optionally, the low-frequency
//! copy on `rt/lf/dex3/{side}/state` (default on, 50 Hz). Topics, joint order, the RIS mode
//! byte, URDF limits and pressure encoding follow docs/sources.md §1-§2 and the Dex3-1 user
//! manual; everything else is an assumption kept in [`Dex3Tuning`] (see `docs/adapters.md`,
//! "Emulators").
//!
//! Behaviour per motor (message index = motor id, order thumb_0, thumb_1, thumb_2, middle_0,
//! middle_1, index_0, index_1):
//! - status FOC (1): the motor runs `tau = kp*(q-q_m) + kd*(dq-dq_m) + tau_ff` on a
//!   [`JointModel`] with the hardware's range as hard stops ([`crate::dex3::physical`]);
//! - status lock (0), and any undocumented status 2..7: the motor HOLDS the position it had
//!   when it entered lock, with [`Dex3Tuning::hold_kp`]/[`Dex3Tuning::hold_kd`] (assumption:
//!   "lock" read as a position lock, not limp);
//! - timeout bit (7) set in the last command: after [`Dex3Tuning::timeout`] (1 s, manual)
//!   without an accepted command the motor stops (limp, zero torque) and its feedback mode has
//!   bit 7 set; it stays stopped until a command with bit 7 = 0 arrives (a command with bit 7
//!   still set is recorded but does not clear the latch — manual: "need to send 0 to clear").
//! - commands whose motor count is not 7 are ignored (nothing applied, the timeout clock not
//!   reset) and counted.
//!
//! The hand starts at [`crate::dex3::physical::REST_POSTURE`] and its state reports q, dq
//! and tau_est with measurement noise ([`Dex3ServiceConfig::noise`], default
//! [`crate::dex3::physical::HG_MOTOR_NOISE`]).

use std::time::{Duration, Instant};

use handgate_idl::unitree_hg::{
    HandCmd_, HandState_, IMUState_, MotorState_, PressSensorState_, DEX3_MOTORS, DEX3_PRESS_SENSORS,
};

use crate::emu_common::{ensure_finite, EmulatorError, Hz};
use crate::model::Side;
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Tick};
use crate::sim::{Contact, JointModel, JointParams, MotorTarget, Noise, Reading, Sensor};

use super::{cmd_topic, lf_state_topic, state_topic};

/// Motors per hand (docs/sources.md §2).
pub const MOTORS: usize = DEX3_MOTORS;
/// Pressure pads per hand (docs/sources.md §2, SDK C++ example; manual: 9 sensors, 33 points).
pub const PADS: usize = DEX3_PRESS_SENSORS;
/// Values in one `PressSensorState_::pressure` array.
pub const PAD_POINTS: usize = 12;
pub use super::{MotorStatus, RisMode, PRESS_NO_READING, PRESS_VALID_MIN, RIS_TIMEOUT_BIT};

/// A Dex3-1 joint, in message order (the shared [`super::Joint`]).
pub use super::Joint as Dex3Joint;

/// A Dex3-1 finger.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Finger {
    Thumb,
    Middle,
    Index,
}

impl Finger {
    pub const ALL: [Finger; 3] = [Finger::Thumb, Finger::Middle, Finger::Index];

    pub fn index(self) -> usize {
        self as usize
    }
}

/// Where a pressure pad sits and how many of its 12 points carry readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PadSpec {
    /// `None`: on the palm.
    pub finger: Option<Finger>,
    /// Points with readings (the rest report "no reading").
    pub points: usize,
}

/// Every value of the emulated service that is NOT taken from a public source, in one
/// overridable table. `Default` holds the documented assumptions.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex3Tuning {
    /// Timeout protection period (manual: "default 1s timeout").
    pub timeout: Duration,
    /// Gains holding a motor in status lock (assumption).
    pub hold_kp: f32,
    pub hold_kd: f32,
    /// Stiffness of an emulated object, N*m/rad (assumption).
    pub contact_stiffness: f32,
    /// Pad layout. The manual lists 3 palm pads of 2x2 points, 3 fingertip pads of 2x2 and 3
    /// finger pads of 3x1, but its figure mapping pad ids to places is not public. Assumed:
    /// 0-1 thumb, 2-3 middle, 4-5 index (2x2 then 3x1), 6-8 palm.
    pub pads: [PadSpec; PADS],
    /// Raw pressure added per N*m of contact torque on top of [`PRESS_VALID_MIN`] (assumption).
    pub press_raw_per_nm: f32,
    /// Pad and motor temperature reported, deg C (assumption).
    pub temperature_c: f32,
    /// Supply voltage reported, V (manual: working voltage 24-58 V; 52 V assumed, a G1 battery).
    pub power_v: f32,
    /// Supply current: idle plus a share per N*m of motor torque, A (assumption).
    pub power_a_idle: f32,
    pub power_a_per_nm: f32,
    /// Internal supply and buck output voltages, V (manual names them, values assumed).
    pub system_v: f32,
    pub device_v: f32,
    /// IMU: hand at rest, upright (assumption; the real reading depends on the arm pose).
    pub imu_quaternion: [f32; 4],
    pub imu_accelerometer: [f32; 3],
}

impl Default for Dex3Tuning {
    fn default() -> Self {
        let pad = |finger, points| PadSpec { finger, points };
        Self {
            timeout: Duration::from_secs(1),
            hold_kp: 1.5,
            hold_kd: 0.1,
            contact_stiffness: 20.0,
            pads: [
                pad(Some(Finger::Thumb), 4),
                pad(Some(Finger::Thumb), 3),
                pad(Some(Finger::Middle), 4),
                pad(Some(Finger::Middle), 3),
                pad(Some(Finger::Index), 4),
                pad(Some(Finger::Index), 3),
                pad(None, 4),
                pad(None, 4),
                pad(None, 4),
            ],
            press_raw_per_nm: 100_000.0,
            temperature_c: 32.0,
            power_v: 52.0,
            power_a_idle: 0.1,
            power_a_per_nm: 0.3,
            system_v: 12.0,
            device_v: 5.0,
            imu_quaternion: [1.0, 0.0, 0.0, 0.0],
            imu_accelerometer: [0.0, 0.0, 9.81],
        }
    }
}

/// Configuration of one emulated Dex3 service (one hand).
#[derive(Debug, Clone, PartialEq)]
pub struct Dex3ServiceConfig {
    pub side: Side,
    /// Rate of `rt/dex3/{side}/state` and of the emulated control loop (default
    /// [`super::SERVICE_HZ`]).
    pub state_rate: Hz,
    /// Rate of `rt/lf/dex3/{side}/state` (default [`super::SERVICE_LF_HZ`]).
    pub lf_rate: Hz,
    pub publish_lf: bool,
    /// Joint positions at start, rad, message order (clamped to the hard stops). Default:
    /// the rest posture ([`crate::dex3::physical::rest_wire`]).
    pub initial_q: [f32; MOTORS],
    /// Measurement noise on the reported q, dq, tau_est ([`Noise::OFF`] for exact values).
    pub noise: Noise,
    /// An object per finger ([`Finger::index`] order): how far (rad, >= 0) the finger's flex
    /// joints can close from 0 before they touch it. `None`: nothing to touch.
    pub objects: [Option<f32>; 3],
    /// An object per joint (message order): the wire position (rad) where it blocks the
    /// joint closing (closing direction: the table's wire sign for the joint and side,
    /// [`crate::dex3::table::wire_sign`]); what the profile's `[devices.emulator] object_at`
    /// places. Applied after `objects` (a joint set here takes this one). `None`: nothing.
    pub object_at: [Option<f32>; MOTORS],
    pub tuning: Dex3Tuning,
    /// (command, state, low-frequency state) topics; `None` = the standard ones. The
    /// gateway's emulator backend puts the service on private topics.
    pub topics: Option<(String, String, String)>,
}

impl Dex3ServiceConfig {
    pub fn new(side: Side) -> Self {
        Self {
            side,
            state_rate: Hz(super::SERVICE_HZ),
            lf_rate: Hz(super::SERVICE_LF_HZ),
            publish_lf: true,
            initial_q: std::array::from_fn(|i| crate::dex3::physical::rest_wire(side, i)),
            noise: crate::dex3::physical::HG_MOTOR_NOISE,
            objects: [None; 3],
            object_at: [None; MOTORS],
            tuning: Dex3Tuning::default(),
            topics: None,
        }
    }

    /// Checks rates and that positions, objects and tuning values are finite.
    pub fn validate(&self) -> Result<(), EmulatorError> {
        self.state_rate.period()?;
        self.lf_rate.period()?;
        ensure_finite("initial_q", self.initial_q)?;
        self.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        ensure_finite("objects", self.objects.into_iter().flatten())?;
        ensure_finite("object_at", self.object_at.into_iter().flatten())?;
        let t = &self.tuning;
        ensure_finite(
            "tuning",
            [
                t.hold_kp,
                t.hold_kd,
                t.contact_stiffness,
                t.press_raw_per_nm,
                t.temperature_c,
                t.power_v,
                t.power_a_idle,
                t.power_a_per_nm,
                t.system_v,
                t.device_v,
            ],
        )
    }
}

/// What one motor is doing, as the emulator sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorView {
    /// Mode of the last accepted command for this motor (`None` before any).
    pub commanded_mode: Option<RisMode>,
    /// What the motor applies now (hold gains in lock, zero when the timeout tripped).
    pub applied: MotorTarget,
    /// Timeout protection enabled by the last accepted command.
    pub timeout_enabled: bool,
    /// Timeout protection tripped (feedback bit 7).
    pub timeout_tripped: bool,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    /// Contact torque from the emulated object.
    pub contact_tau: f32,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex3Snapshot {
    /// The last command received, accepted or not.
    pub last_command: Option<HandCmd_>,
    /// Accepted commands (7 motors).
    pub commands: u64,
    /// Commands ignored for a wrong motor count.
    pub rejected: u64,
    /// Accepted motor commands whose id bits differ from their message index (applied by index).
    pub id_mismatches: u64,
    pub motors: [MotorView; MOTORS],
    pub states_published: u64,
    pub lf_published: u64,
}

#[derive(Debug, Clone, Copy)]
struct MotorSlot {
    mode: Option<RisMode>,
    /// The command as received (used in FOC).
    cmd: MotorTarget,
    hold_q: f32,
    tripped: bool,
}

/// The service's logic without DDS: commands in, time passes, state out. Pure enough to test
/// with synthetic instants.
#[derive(Debug, Clone)]
pub struct Dex3Core {
    side: Side,
    tuning: Dex3Tuning,
    joints: [JointModel; MOTORS],
    sensor: Sensor,
    slots: [MotorSlot; MOTORS],
    prev_dq: [f32; MOTORS],
    ddq: [f32; MOTORS],
    /// Motors held where they are whatever the command (`--fault stuck=<joint>`).
    stuck: [bool; MOTORS],
    last_cmd_at: Option<Instant>,
    last_command: Option<HandCmd_>,
    commands: u64,
    rejected: u64,
    id_mismatches: u64,
}

impl Dex3Core {
    pub fn new(config: &Dex3ServiceConfig) -> Self {
        let joints = Dex3Joint::ALL.map(|j| {
            let (lo, hi) = j.hard_stops(config.side);
            JointModel::new(JointParams::dex3_finger(lo, hi), config.initial_q[j.index()])
        });
        let slots = std::array::from_fn(|i| MotorSlot {
            mode: None,
            cmd: MotorTarget::LIMP,
            hold_q: joints[i].q,
            tripped: false,
        });
        let mut core = Self {
            side: config.side,
            tuning: config.tuning.clone(),
            joints,
            sensor: Sensor::new(config.noise),
            slots,
            prev_dq: [0.0; MOTORS],
            ddq: [0.0; MOTORS],
            stuck: [false; MOTORS],
            last_cmd_at: None,
            last_command: None,
            commands: 0,
            rejected: 0,
            id_mismatches: 0,
        };
        for f in Finger::ALL {
            core.set_object(f, config.objects[f.index()]);
        }
        for j in Dex3Joint::ALL {
            if let Some(at) = config.object_at[j.index()] {
                core.set_joint_object(j, Some(at));
            }
        }
        core
    }

    /// Places (or removes) an object blocking `joint` at wire position `at` (rad) in its
    /// closing direction (the table's wire sign for the joint and side).
    pub fn set_joint_object(&mut self, joint: Dex3Joint, at: Option<f32>) {
        let i = joint.index();
        self.joints[i].contact = at.filter(|a| a.is_finite()).map(|at| crate::sim::Contact {
            stiffness: self.tuning.contact_stiffness,
            ..crate::dex3::open::object_contact(self.side, i, at)
        });
    }

    /// Places (or removes) the object a finger closes on.
    pub fn set_object(&mut self, finger: Finger, closure: Option<f32>) {
        for j in Dex3Joint::ALL.into_iter().filter(|j| j.finger() == finger) {
            self.joints[j.index()].contact = match (closure, j.closing_dir(self.side)) {
                (Some(at), Some(dir)) if at.is_finite() => Some(Contact {
                    at: dir * at.abs(),
                    dir,
                    stiffness: self.tuning.contact_stiffness,
                }),
                _ => None,
            };
        }
    }

    /// Handles one received command at `now`. Returns whether it was accepted.
    pub fn on_command(&mut self, cmd: &HandCmd_, now: Instant) -> bool {
        self.last_command = Some(cmd.clone());
        if cmd.motor_cmd.len() != MOTORS {
            self.rejected += 1;
            return false;
        }
        self.commands += 1;
        self.last_cmd_at = Some(now);
        for (i, m) in cmd.motor_cmd.iter().enumerate() {
            let mode = RisMode::decode(m.mode);
            if usize::from(mode.id) != i {
                self.id_mismatches += 1;
            }
            let slot = &mut self.slots[i];
            let was_locked = matches!(slot.mode, Some(RisMode { status, .. }) if status != MotorStatus::Foc);
            if mode.status != MotorStatus::Foc && (!was_locked || slot.tripped) {
                slot.hold_q = self.joints[i].q;
            }
            if slot.tripped && !mode.timeout {
                slot.tripped = false;
            }
            slot.mode = Some(mode);
            slot.cmd = MotorTarget {
                q: m.q,
                dq: m.dq,
                tau: m.tau,
                kp: m.kp,
                kd: m.kd,
            };
        }
        true
    }

    /// Trips timeouts due at `now`.
    pub fn check_timeouts(&mut self, now: Instant) {
        let silent_for = match self.last_cmd_at {
            Some(t) => now.saturating_duration_since(t),
            None => return,
        };
        if silent_for < self.tuning.timeout {
            return;
        }
        for slot in &mut self.slots {
            if matches!(slot.mode, Some(m) if m.timeout) {
                slot.tripped = true;
            }
        }
    }

    fn applied(&self, i: usize) -> MotorTarget {
        let slot = &self.slots[i];
        if slot.tripped {
            return MotorTarget::LIMP;
        }
        match slot.mode {
            Some(RisMode {
                status: MotorStatus::Foc,
                ..
            }) => slot.cmd,
            // Before the first command, in lock and in undefined statuses: hold.
            _ => MotorTarget {
                q: slot.hold_q,
                dq: 0.0,
                tau: 0.0,
                kp: self.tuning.hold_kp,
                kd: self.tuning.hold_kd,
            },
        }
    }

    /// Checks timeouts and advances every joint by `dt` seconds.
    pub fn step(&mut self, now: Instant, dt: f32) {
        self.check_timeouts(now);
        for i in 0..MOTORS {
            if self.stuck[i] {
                // A stuck joint: it stays where it is, whatever the command, with no torque
                // (a stuck joint is told from a grasp by its torque).
                self.joints[i].dq = 0.0;
                self.joints[i].tau = 0.0;
                self.ddq[i] = 0.0;
                self.prev_dq[i] = 0.0;
                continue;
            }
            let target = self.applied(i);
            self.joints[i].step(&target, dt);
            let dq = self.joints[i].dq;
            self.ddq[i] = if dt > 0.0 { (dq - self.prev_dq[i]) / dt } else { 0.0 };
            self.prev_dq[i] = dq;
        }
    }

    fn finger_contact(&self, finger: Finger) -> f32 {
        Dex3Joint::ALL
            .into_iter()
            .filter(|j| j.finger() == finger)
            .map(|j| self.joints[j.index()].contact_tau)
            .fold(0.0, f32::max)
    }

    /// The HandState_ the service publishes now (7 motors, 9 pads); each call is one
    /// measurement (one set of noise draws).
    pub fn state(&mut self) -> HandState_ {
        let readings: [Reading; MOTORS] = std::array::from_fn(|i| self.sensor.read(&self.joints[i]));
        let t = &self.tuning;
        let motor_state = (0..MOTORS)
            .map(|i| {
                let slot = &self.slots[i];
                let status = slot.mode.map(|m| m.status).unwrap_or(MotorStatus::Lock);
                let mode = RisMode {
                    id: i as u8,
                    status,
                    timeout: slot.tripped,
                };
                let r = readings[i];
                MotorState_ {
                    mode: mode.encode(),
                    q: r.q,
                    dq: r.dq,
                    ddq: self.ddq[i],
                    tau_est: r.tau,
                    temperature: [t.temperature_c as i16; 2],
                    vol: t.power_v,
                    ..MotorState_::default()
                }
            })
            .collect();
        let press_sensor_state = t
            .pads
            .iter()
            .map(|pad| {
                let contact = pad.finger.map(|f| self.finger_contact(f)).unwrap_or(0.0);
                let mut p = PressSensorState_ {
                    pressure: [PRESS_NO_READING; PAD_POINTS],
                    ..PressSensorState_::default()
                };
                for k in 0..pad.points.min(PAD_POINTS) {
                    p.temperature[k] = t.temperature_c;
                    if contact > 0.0 {
                        p.pressure[k] = PRESS_VALID_MIN + t.press_raw_per_nm * contact;
                    }
                }
                p
            })
            .collect();
        let torque: f32 = self.joints.iter().map(|j| j.tau.abs()).sum();
        HandState_ {
            motor_state,
            press_sensor_state,
            imu_state: IMUState_ {
                quaternion: t.imu_quaternion,
                accelerometer: t.imu_accelerometer,
                temperature: t.temperature_c as i16,
                ..IMUState_::default()
            },
            power_v: t.power_v,
            power_a: t.power_a_idle + t.power_a_per_nm * torque,
            system_v: t.system_v,
            device_v: t.device_v,
            ..HandState_::default()
        }
    }

    fn view(&self, i: usize) -> MotorView {
        let slot = &self.slots[i];
        let j = &self.joints[i];
        MotorView {
            commanded_mode: slot.mode,
            applied: self.applied(i),
            timeout_enabled: matches!(slot.mode, Some(m) if m.timeout),
            timeout_tripped: slot.tripped,
            q: j.q,
            dq: j.dq,
            tau: j.tau,
            contact_tau: j.contact_tau,
        }
    }

    pub fn snapshot(&self) -> Dex3Snapshot {
        Dex3Snapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            rejected: self.rejected,
            id_mismatches: self.id_mismatches,
            motors: std::array::from_fn(|i| self.view(i)),
            states_published: 0,
            lf_published: 0,
        }
    }
}

impl ServiceCore for Dex3Core {
    type Config = Dex3ServiceConfig;
    type Snapshot = Dex3Snapshot;

    fn from_config(config: &Dex3ServiceConfig) -> Result<Self, EmulatorError> {
        config.validate()?;
        Ok(Self::new(config))
    }

    fn plan(config: &Dex3ServiceConfig) -> Result<ServicePlan, EmulatorError> {
        let side = config.side;
        let (cmd_t, state_t, lf_t) = config
            .topics
            .clone()
            .unwrap_or_else(|| (cmd_topic(side), state_topic(side), lf_state_topic(side)));
        let lf = config.publish_lf.then_some((lf_t, Some(config.lf_rate)));
        Ok(ServicePlan::new(format!("dex3-emu-{side}"), config.state_rate, cmd_t, Some(state_t)).with_extra(lf))
    }

    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "a Dex3-1")
    }

    fn report(&self, published: Published) -> Dex3Snapshot {
        Dex3Snapshot {
            states_published: published.state,
            lf_published: published.extra,
            ..self.snapshot()
        }
    }
}

impl ServiceWire<Self> for Dex3Core {
    type Cmd = HandCmd_;
    type State = HandState_;
    /// The low-frequency copy of the state.
    type Extra = HandState_;

    fn receive(core: &mut Self, cmd: &HandCmd_, now: Instant) {
        core.on_command(cmd, now);
    }

    fn cycle(core: &mut Self, tick: Tick) -> Option<HandState_> {
        core.step(tick.now, tick.dt);
        Some(core.state())
    }

    /// The same state, on the low-frequency topic.
    fn extra(_core: &mut Self, state: &HandState_) -> Option<HandState_> {
        Some(state.clone())
    }
}

/// A running emulated Dex3 service. Dropping it stops its loop.
pub type Dex3ServiceEmulator = ServiceEmulator<Dex3Core>;

impl Dex3ServiceEmulator {
    /// The last command received (accepted or not).
    pub fn last_command(&self) -> Option<HandCmd_> {
        self.with_core(|c| c.last_command.clone())
    }

    /// Accepted commands.
    pub fn commands_received(&self) -> u64 {
        self.with_core(|c| c.commands)
    }

    /// Commands ignored for a wrong motor count.
    pub fn commands_rejected(&self) -> u64 {
        self.with_core(|c| c.rejected)
    }

    /// What `joint`'s motor applies now.
    pub fn applied_target(&self, joint: Dex3Joint) -> MotorTarget {
        self.with_core(|c| c.applied(joint.index()))
    }

    /// Whether `joint`'s timeout protection has tripped.
    pub fn timeout_tripped(&self, joint: Dex3Joint) -> bool {
        self.with_core(|c| c.slots[joint.index()].tripped)
    }

    /// Places (or removes) the object `finger` closes on.
    pub fn set_object(&self, finger: Finger, closure: Option<f32>) {
        self.with_core(|c| c.set_object(finger, closure));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emu_common::{wait_for, TEST_WAIT as WAIT};
    use handgate_idl::unitree_hg::MotorCmd_;
    use proptest::prelude::*;

    fn cmd_all(mode: impl Fn(u8) -> u8, q: [f32; MOTORS], kp: f32, kd: f32) -> HandCmd_ {
        let mut c = HandCmd_::with_motors(MOTORS);
        for (i, m) in c.motor_cmd.iter_mut().enumerate() {
            *m = MotorCmd_ {
                mode: mode(i as u8),
                q: q[i],
                kp,
                kd,
                ..MotorCmd_::default()
            };
        }
        c
    }

    proptest! {
        #[test]
        fn ris_mode_roundtrips(b in any::<u8>()) {
            prop_assert_eq!(RisMode::decode(b).encode(), b);
        }
    }

    #[test]
    fn ris_mode_fields() {
        let m = RisMode::decode(0x95);
        assert_eq!(m, RisMode::foc(5, true));
        assert_eq!(RisMode::foc(3, false).encode(), 0x13);
        assert_eq!(RisMode::decode(0x02).status, MotorStatus::Lock);
        assert_eq!(RisMode::decode(0x72).status, MotorStatus::Undefined(7));
    }

    #[test]
    fn limits_are_mirrored_and_closing_signs_follow_facts() {
        for j in Dex3Joint::ALL {
            let (l0, l1) = j.limits(Side::Left);
            let (r0, r1) = j.limits(Side::Right);
            assert_eq!((r0, r1), (-l1, -l0), "{j:?}");
            assert!(l0 <= 0.0 && l1 >= 0.0);
        }
        #[allow(clippy::approx_constant)]
        let urdf_index0 = (-1.5708, 0.0);
        assert_eq!(Dex3Joint::Index0.limits(Side::Left), urdf_index0);
        assert_eq!(Dex3Joint::Middle1.limits(Side::Right), (0.0, 1.7453));
        #[allow(clippy::approx_constant)]
        let thumb1_right = (-1.0472, 0.6108);
        assert_eq!(Dex3Joint::Thumb1.limits(Side::Right), thumb1_right);
        assert_eq!(Dex3Joint::Index1.closing_dir(Side::Left), Some(-1.0));
        assert_eq!(Dex3Joint::Index1.closing_dir(Side::Right), Some(1.0));
        assert_eq!(Dex3Joint::Thumb0.closing_dir(Side::Right), None);
        // Closing goes into the range, not out of it.
        for side in [Side::Left, Side::Right] {
            for j in Dex3Joint::ALL {
                if let Some(d) = j.closing_dir(side) {
                    let (lo, hi) = j.limits(side);
                    assert!(if d > 0.0 { hi > 0.5 } else { lo < -0.5 }, "{side:?} {j:?}");
                }
            }
        }
    }

    #[test]
    fn timeout_trips_after_one_second_latches_and_clears_with_bit_zero() {
        let mut core = Dex3Core::new(&Dex3ServiceConfig::new(Side::Right));
        let t0 = Instant::now();
        assert!(core.on_command(&cmd_all(|i| 0x90 | i, [0.2; MOTORS], 1.5, 0.1), t0));
        core.step(t0 + Duration::from_millis(999), 0.001);
        assert!(core.slots.iter().all(|s| !s.tripped));
        core.step(t0 + Duration::from_millis(1000), 0.001);
        assert!(core.slots.iter().all(|s| s.tripped));
        assert!(core.state().motor_state.iter().all(|m| m.mode & 0x80 != 0));
        assert_eq!(core.applied(0), MotorTarget::LIMP);
        // Bit 7 still set: stays tripped.
        core.on_command(
            &cmd_all(|i| 0x90 | i, [0.2; MOTORS], 1.5, 0.1),
            t0 + Duration::from_secs(2),
        );
        assert!(core.slots.iter().all(|s| s.tripped));
        // Bit 7 = 0 clears and the command applies again.
        core.on_command(
            &cmd_all(|i| 0x10 | i, [0.2; MOTORS], 1.5, 0.1),
            t0 + Duration::from_secs(3),
        );
        core.step(t0 + Duration::from_secs(10), 0.001);
        assert!(core.slots.iter().all(|s| !s.tripped), "timeout disabled now");
        assert_eq!(core.applied(5).q, 0.2);
        assert!(core
            .state()
            .motor_state
            .iter()
            .enumerate()
            .all(|(i, m)| m.mode == 0x10 | i as u8));
    }

    #[test]
    fn no_timeout_without_bit() {
        let mut core = Dex3Core::new(&Dex3ServiceConfig::new(Side::Left));
        let t0 = Instant::now();
        core.on_command(&cmd_all(|i| 0x10 | i, [0.0; MOTORS], 1.5, 0.1), t0);
        core.step(t0 + Duration::from_secs(60), 0.001);
        assert!(core.slots.iter().all(|s| !s.tripped));
    }

    #[test]
    fn lock_holds_where_it_entered_lock() {
        let mut cfg = Dex3ServiceConfig::new(Side::Right);
        cfg.initial_q[3] = 0.4;
        let mut core = Dex3Core::new(&cfg);
        let t0 = Instant::now();
        // Lock (status 0) with a far target: the target is not applied, the position is held.
        core.on_command(&cmd_all(|i| i, [1.5; MOTORS], 3.0, 0.1), t0);
        for k in 0..500 {
            core.step(t0 + Duration::from_millis(k), 0.001);
        }
        assert!((core.joints[3].q - 0.4).abs() < 0.01, "q = {}", core.joints[3].q);
        assert_eq!(core.applied(3).q, 0.4);
        assert_eq!(core.state().motor_state[3].mode, 0x03);
        // An undefined status (2) holds too, and is reported back as received.
        core.on_command(
            &cmd_all(|i| 0x20 | i, [1.5; MOTORS], 3.0, 0.1),
            t0 + Duration::from_secs(1),
        );
        assert_eq!(core.applied(3).q, 0.4);
        assert_eq!(core.state().motor_state[3].mode, 0x23);
        // FOC releases the hold.
        core.on_command(
            &cmd_all(|i| 0x10 | i, [1.5; MOTORS], 3.0, 0.1),
            t0 + Duration::from_secs(1),
        );
        assert_eq!(core.applied(3).q, 1.5);
    }

    #[test]
    fn invalid_configs_are_errors() {
        let mut c = Dex3ServiceConfig::new(Side::Left);
        c.initial_q[2] = f32::NAN;
        assert!(matches!(c.validate(), Err(EmulatorError::InvalidConfig(_))));
        let mut c = Dex3ServiceConfig::new(Side::Left);
        c.lf_rate = Hz(0.0);
        assert!(c.validate().is_err());
        let mut c = Dex3ServiceConfig::new(Side::Left);
        c.objects[1] = Some(f32::INFINITY);
        assert!(c.validate().is_err());
        assert!(Dex3ServiceConfig::new(Side::Right).validate().is_ok());
    }

    #[test]
    fn id_bits_not_matching_the_index_are_counted_and_applied_by_index() {
        let mut core = Dex3Core::new(&Dex3ServiceConfig::new(Side::Right));
        let mut q = [0.0; MOTORS];
        q[4] = 0.7;
        // Every motor claims id 0.
        core.on_command(&cmd_all(|_| 0x10, q, 1.5, 0.1), Instant::now());
        assert_eq!(core.id_mismatches, 6);
        assert_eq!(core.applied(4).q, 0.7);
    }

    #[test]
    fn wrong_size_is_rejected_without_effect() {
        let mut core = Dex3Core::new(&Dex3ServiceConfig::new(Side::Right));
        let before = core.snapshot().motors;
        let t0 = Instant::now();
        for n in [0, 6, 8] {
            let mut c = HandCmd_::with_motors(n);
            c.motor_cmd.iter_mut().for_each(|m| m.mode = 0x90);
            assert!(!core.on_command(&c, t0));
        }
        assert_eq!(core.rejected, 3);
        assert_eq!(core.commands, 0);
        assert_eq!(core.snapshot().motors, before);
        assert_eq!(core.last_command.as_ref().map(|c| c.motor_cmd.len()), Some(8));
        core.step(t0 + Duration::from_secs(5), 0.001);
        assert!(core.slots.iter().all(|s| !s.tripped));
    }

    #[test]
    fn state_sizes_pressure_and_power() {
        let mut cfg = Dex3ServiceConfig::new(Side::Left);
        cfg.objects[Finger::Index.index()] = Some(0.5);
        let mut core = Dex3Core::new(&cfg);
        let s = core.state();
        assert_eq!(s.motor_state.len(), MOTORS);
        assert_eq!(s.press_sensor_state.len(), PADS);
        assert!(s
            .press_sensor_state
            .iter()
            .all(|p| p.pressure == [PRESS_NO_READING; 12]));
        assert!((24.0..=58.0).contains(&s.power_v));
        // Close the left index (negative) onto the object at -0.5.
        let t0 = Instant::now();
        core.on_command(
            &cmd_all(|i| 0x10 | i, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5, -1.5], 1.5, 0.1),
            t0,
        );
        for k in 0..2000 {
            core.step(t0 + Duration::from_millis(k), 0.001);
        }
        let s = core.state();
        assert!(
            s.motor_state[5].q < -0.45 && s.motor_state[5].q > -0.7,
            "q = {}",
            s.motor_state[5].q
        );
        for (i, pad) in core.tuning.pads.iter().enumerate() {
            let p = &s.press_sensor_state[i];
            if pad.finger == Some(Finger::Index) {
                assert!(
                    p.pressure[..pad.points].iter().all(|&v| v >= PRESS_VALID_MIN),
                    "pad {i}"
                );
                assert!(p.pressure[pad.points..].iter().all(|&v| v == PRESS_NO_READING));
            } else {
                assert!(p.pressure.iter().all(|&v| v == PRESS_NO_READING), "pad {i}");
            }
        }
    }

    /// `object_at` on one joint: closing it toward a far target stops at the object, with
    /// contact torque and pressure on that finger's pads; the same command without the object
    /// closes to the target.
    #[test]
    fn object_at_blocks_the_closing_joint_with_pressure() {
        for side in [Side::Left, Side::Right] {
            let run = |object: Option<f32>| {
                let mut cfg = Dex3ServiceConfig {
                    noise: Noise::OFF,
                    ..Dex3ServiceConfig::new(side)
                };
                let i = Dex3Joint::Middle0.index();
                let dir = crate::dex3::table::wire_sign(side, i);
                cfg.object_at[i] = object.map(|o| dir * o);
                let mut core = Dex3Core::new(&cfg);
                let mut q = cfg.initial_q;
                q[i] = dir * 1.4; // far into the closing range
                let t0 = Instant::now();
                core.on_command(&cmd_all(|m| 0x10 | m, q, 1.5, 0.1), t0);
                for k in 0..2000 {
                    core.step(t0 + Duration::from_millis(k), 0.001);
                }
                let s = core.state();
                let middle_pressure = core
                    .tuning
                    .pads
                    .iter()
                    .zip(&s.press_sensor_state)
                    .filter(|(p, _)| p.finger == Some(Finger::Middle))
                    .map(|(p, st)| st.pressure[..p.points].iter().copied().fold(0.0, f32::max))
                    .fold(0.0, f32::max);
                (
                    s.motor_state[i].q * dir,
                    core.snapshot().motors[i].contact_tau,
                    middle_pressure,
                )
            };
            let (q, tau, press) = run(Some(0.5));
            assert!((0.5..0.65).contains(&q), "{side:?}: stopped at the object, q = {q}");
            assert!(tau > 0.3, "{side:?}: contact torque {tau}");
            assert!(press > PRESS_VALID_MIN, "{side:?}: pressure {press}");
            let (q, tau, press) = run(None);
            assert!(q > 1.3, "{side:?}: without the object it closes, q = {q}");
            assert_eq!(tau, 0.0);
            assert!(
                press < PRESS_VALID_MIN,
                "{side:?}: no pressure without the object: {press}"
            );
        }
    }

    // ---- over real DDS (domains 30..=35) ----

    use crate::dds::{Node, Qos, Reader, Writer};

    struct Client {
        _node: Node,
        cmd: Writer<HandCmd_>,
        state: Reader<HandState_>,
    }

    fn setup(domain: u32, config: Dex3ServiceConfig) -> (Dex3ServiceEmulator, Client) {
        let side = config.side;
        crate::emu_common::isolated_test_domain(domain);
        let emu_node = Node::new(domain, None).unwrap();
        let emu = Dex3ServiceEmulator::start(&emu_node, config).unwrap();
        let node = Node::new(domain, None).unwrap();
        let cmd = node
            .writer::<HandCmd_>(&cmd_topic(side), Qos::Reliable { depth: 4 })
            .unwrap();
        let state = node.reader::<HandState_>(&state_topic(side), Qos::BestEffort).unwrap();
        cmd.wait_matched(1, WAIT).unwrap();
        state.wait_matched(1, WAIT).unwrap();
        (
            emu,
            Client {
                _node: node,
                cmd,
                state,
            },
        )
    }

    impl Client {
        /// Publishes `cmd` once per received state sample (like a client loop paced by the
        /// state stream) until `done(latest state)` holds.
        fn drive_until(&mut self, cmd: &HandCmd_, mut done: impl FnMut(&HandState_) -> bool) -> HandState_ {
            let deadline = Instant::now() + WAIT;
            loop {
                self.cmd.write(cmd.clone()).unwrap();
                let s = self.state.wait_take(WAIT).unwrap().pop().unwrap();
                if done(&s) {
                    return s;
                }
                assert!(Instant::now() < deadline, "condition not reached; last state {s:?}");
            }
        }

        fn watch_until(&self, mut done: impl FnMut(&HandState_) -> bool) -> HandState_ {
            let deadline = Instant::now() + WAIT;
            loop {
                let s = self.state.wait_take(WAIT).unwrap().pop().unwrap();
                if done(&s) {
                    return s;
                }
                assert!(Instant::now() < deadline, "condition not reached; last state {s:?}");
            }
        }
    }

    #[test]
    fn dds_moves_commanded_joint_and_reports_full_state() {
        let (emu, mut client) = setup(30, Dex3ServiceConfig::new(Side::Right));
        let mut q = [0.0; MOTORS];
        q[Dex3Joint::Index0.index()] = 1.0;
        let cmd = cmd_all(|i| 0x10 | i, q, 1.5, 0.1);
        let s = client.drive_until(&cmd, |s| (s.motor_state[5].q - 1.0).abs() < 0.05);
        assert_eq!(s.motor_state.len(), MOTORS);
        assert_eq!(s.press_sensor_state.len(), PADS);
        for (i, m) in s.motor_state.iter().enumerate() {
            assert_eq!(m.mode, 0x10 | i as u8);
        }
        assert!(s.motor_state[0].q.abs() < 0.05);
        assert!((24.0..=58.0).contains(&s.power_v));
        let qn: f32 = s.imu_state.quaternion.iter().map(|v| v * v).sum();
        assert!((qn - 1.0).abs() < 1e-4);
        let g: f32 = s.imu_state.accelerometer.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((g - 9.81).abs() < 0.1);
        let snap = emu.snapshot();
        assert!(snap.commands >= 1);
        assert_eq!(snap.rejected, 0);
        assert_eq!(snap.last_command, Some(cmd));
        assert_eq!(emu.applied_target(Dex3Joint::Index0).q, 1.0);
    }

    #[test]
    fn dds_left_hand_closes_negative_and_stops_at_urdf_limit() {
        // At the stop the noise would read either side of it: exact values here.
        let config = Dex3ServiceConfig {
            noise: Noise::OFF,
            ..Dex3ServiceConfig::new(Side::Left)
        };
        let (_emu, mut client) = setup(31, config);
        let mut q = [0.0; MOTORS];
        q[Dex3Joint::Middle0.index()] = -1.0;
        q[Dex3Joint::Index0.index()] = 1.0; // outside [-1.5708, 0]: stops at 0
        let cmd = cmd_all(|i| 0x10 | i, q, 1.5, 0.1);
        let s = client.drive_until(&cmd, |s| (s.motor_state[3].q + 1.0).abs() < 0.05);
        assert!(s.motor_state[5].q <= 0.0 && s.motor_state[5].q > -0.05);
    }

    #[test]
    fn dds_timeout_bit_trips_after_silence_and_clears_with_bit_zero() {
        let (emu, mut client) = setup(32, Dex3ServiceConfig::new(Side::Right));
        let armed = cmd_all(|i| 0x90 | i, [0.0; MOTORS], 1.5, 0.1);
        let written = Instant::now();
        client.cmd.write(armed.clone()).unwrap();
        wait_for(|| emu.commands_received() >= 1);
        assert!(!emu.timeout_tripped(Dex3Joint::Thumb0));
        let s = client.watch_until(|s| s.motor_state.iter().all(|m| m.mode & 0x80 != 0));
        // The service trips 1 s after it received the command, which is after the write.
        assert!(written.elapsed() >= Duration::from_secs(1));
        assert_eq!(s.motor_state[2].mode, 0x92);
        assert!(Dex3Joint::ALL.iter().all(|&j| emu.timeout_tripped(j)));
        assert_eq!(emu.applied_target(Dex3Joint::Index1), MotorTarget::LIMP);
        // A command that keeps bit 7 set does not clear the latch.
        let n = emu.commands_received();
        client.cmd.write(armed).unwrap();
        wait_for(|| emu.commands_received() > n);
        assert!(emu.timeout_tripped(Dex3Joint::Middle0));
        // Bit 7 = 0 clears it.
        let clear = cmd_all(|i| 0x10 | i, [0.0; MOTORS], 1.5, 0.1);
        client.drive_until(&clear, |s| s.motor_state.iter().all(|m| m.mode & 0x80 == 0));
        assert!(!emu.timeout_tripped(Dex3Joint::Middle0));
        assert_eq!(emu.applied_target(Dex3Joint::Middle0).kp, 1.5);
    }

    #[test]
    fn dds_wrong_motor_count_is_rejected_and_counted() {
        let config = Dex3ServiceConfig::new(Side::Left);
        let initial = config.initial_q;
        let (emu, mut client) = setup(33, config);
        let mut six = HandCmd_::with_motors(6);
        six.motor_cmd.iter_mut().for_each(|m| {
            m.mode = 0x10;
            m.q = -1.0;
            m.kp = 1.5;
        });
        client.cmd.write(six).unwrap();
        wait_for(|| emu.commands_rejected() >= 1);
        client.cmd.write(HandCmd_::with_motors(8)).unwrap();
        wait_for(|| emu.commands_rejected() >= 2);
        let snap = emu.snapshot();
        assert_eq!(snap.commands, 0);
        assert_eq!(snap.last_command.map(|c| c.motor_cmd.len()), Some(8));
        // Nothing applied: every motor still holds its initial position.
        assert!(snap
            .motors
            .iter()
            .zip(initial)
            .all(|(m, q0)| m.commanded_mode.is_none() && m.applied.q == q0));
        let good = cmd_all(|i| 0x10 | i, [0.0; MOTORS], 1.5, 0.1);
        client.cmd.write(good).unwrap();
        wait_for(|| emu.commands_received() >= 1);
        assert_eq!(emu.commands_rejected(), 2);
    }

    #[test]
    fn dds_low_frequency_copy_is_published_at_a_lower_rate() {
        crate::emu_common::isolated_test_domain(34);
        let emu_node = Node::new(34, None).unwrap();
        let emu = Dex3ServiceEmulator::start(&emu_node, Dex3ServiceConfig::new(Side::Right)).unwrap();
        let node = Node::new(34, None).unwrap();
        let hf = node
            .reader::<HandState_>(&state_topic(Side::Right), Qos::Reliable { depth: 4096 })
            .unwrap();
        let lf = node
            .reader::<HandState_>(&lf_state_topic(Side::Right), Qos::Reliable { depth: 4096 })
            .unwrap();
        hf.wait_matched(1, WAIT).unwrap();
        lf.wait_matched(1, WAIT).unwrap();
        // Start counting from an empty cache on both.
        let _ = (hf.take(), lf.take());
        let (mut n_hf, mut n_lf) = (0usize, 0usize);
        let deadline = Instant::now() + WAIT;
        while n_lf < 10 {
            n_lf += lf.take().iter().filter(|s| s.motor_state.len() == MOTORS).count();
            n_hf += hf.take().len();
            assert!(Instant::now() < deadline, "lf stream too slow: {n_lf}");
            std::thread::yield_now();
        }
        n_hf += hf.take().len();
        assert!(n_hf > n_lf, "state {n_hf} vs lf {n_lf}");
        let snap = emu.snapshot();
        assert!(snap.states_published > snap.lf_published);
    }

    #[test]
    fn dds_pads_report_contact_on_the_touching_finger_only() {
        let mut cfg = Dex3ServiceConfig::new(Side::Right);
        cfg.publish_lf = false;
        let (emu, mut client) = setup(35, cfg);
        emu.set_object(Finger::Middle, Some(0.6));
        let q = [0.0, 0.0, 0.0, 1.5, 1.5, 0.0, 0.0];
        let cmd = cmd_all(|i| 0x10 | i, q, 1.5, 0.1);
        let pads = emu.config().tuning.pads;
        let s = client.drive_until(&cmd, |s| {
            pads.iter()
                .zip(&s.press_sensor_state)
                .filter(|(p, _)| p.finger == Some(Finger::Middle))
                .all(|(p, st)| st.pressure[..p.points].iter().all(|&v| v >= PRESS_VALID_MIN))
        });
        assert!(
            s.motor_state[3].q < 0.75,
            "middle_0 stopped by the object: {}",
            s.motor_state[3].q
        );
        for (p, st) in pads.iter().zip(&s.press_sensor_state) {
            if p.finger != Some(Finger::Middle) {
                assert!(st.pressure.iter().all(|&v| v == PRESS_NO_READING));
            }
        }
        assert_eq!(emu.snapshot().lf_published, 0);
    }

    #[test]
    fn rest_posture_not_all_zero_and_the_same_seed_gives_the_same_noise() {
        fn run(cfg: &Dex3ServiceConfig) -> Vec<Vec<[f32; 3]>> {
            let mut core = Dex3Core::new(cfg);
            (0..20)
                .map(|_| {
                    core.state()
                        .motor_state
                        .iter()
                        .map(|m| [m.q, m.dq, m.tau_est])
                        .collect()
                })
                .collect()
        }
        for side in [Side::Left, Side::Right] {
            let cfg = Dex3ServiceConfig::new(side);
            let a = run(&cfg);
            assert!(a[0].iter().any(|m| m[0] != 0.0), "{side:?}: {:?}", a[0]);
            assert_eq!(a, run(&cfg));
            let other = Dex3ServiceConfig {
                noise: cfg.noise.with_seed(cfg.noise.seed ^ 1),
                ..cfg.clone()
            };
            assert_ne!(a, run(&other));
            let exact = run(&Dex3ServiceConfig {
                noise: Noise::OFF,
                ..cfg.clone()
            });
            for (i, m) in exact[0].iter().enumerate() {
                assert_eq!(m[0], crate::dex3::physical::rest_wire(side, i));
                assert!((a[0][i][0] - m[0]).abs() <= 3.0 * cfg.noise.q + 1e-6);
            }
        }
    }
}
