//! The emulated Dex5-1 behind the robot's hand service: the physics of one hand without DDS
//! (commands in, time passes, state out), [`Dex5Core`], and the service it runs in,
//! [`Dex5Emulator`] (the generic service shell, `crate::service_emulator`) on
//! `rt/dex5/{side}/{cmd,state}` ([`super::topics`]) at [`super::SERVICE_HZ`]. Each cycle:
//! [`Dex5Core::on_command`] for each command taken, [`Dex5Core::step`], then the state
//! ([`Dex5Core::state_into`]) published.
//!
//! From the sources (docs/sources.md §7 "Dex5-1"): unitree_hg `HandCmd_` in, `HandState_` out,
//! 20 entries in the wire order of [`super::table::SLOTS`], 16 motors (each `Pitch_x4` rides
//! on its `Pitch_x3`'s motor), q in the URDF's radians within its ranges, the thumb's `Roll_12`
//! mirrored between the hands.
//!
//! Assumed (no hardware here; [`Dex5Tuning`], [`Dex5EmuConfig`], docs/adapters.md's
//! assumptions table):
//! - per motor, a first-order position loop toward the driving entry's target, time constant
//!   [`Dex5Tuning::time_constant_s`] at the configured nominal gains ([`Dex5EmuConfig::wire`],
//!   xr_teleoperate's by default) and shorter in proportion to a stiffer kp (a wrapper
//!   client's finger gain, a fifth of xr_teleoperate's, moves five times slower), at most the
//!   URDF's joint velocity, within the URDF's ranges (a `Pitch_x3`'s motor also within what
//!   its coupled `Pitch_x4` can follow); the state's tau_est is the PD law's
//!   torque `kp·(q* − q) + kd·(dq* − dq) + tau`, saturated at the URDF's effort;
//! - a coupled `Pitch_x4` reads its motor's position through the coupling; the
//!   entry's own command is ignored (its driver's entry moves the motor);
//! - mode byte 1 enables a motor, any other value turns it off; a motor off, or on with
//!   kp 0, applies no position control and stays where it is (nothing loads the fingers);
//! - every motor is off until the first command; afterwards the hand holds the last command
//!   indefinitely ([`Dex5Tuning::silence_timeout`] `None`), as no source describes a timeout;
//! - a command with the wrong entry count or a non-finite field is ignored and counted;
//! - an object met by a `Pitch_x3` and one met by its `Pitch_x4` stop their one motor at
//!   whichever the closing finger meets first;
//! - the rest posture ([`super::table::rest_posture`]), the noise ([`DEX5_NOISE`]), no pressure
//!   pads (no source says how many a Dex5 reports), an upright IMU, constant supply figures.

use std::time::{Duration, Instant};

use handgate_idl::unitree_hg::{HandCmd_, HandState_, IMUState_, MotorCmd_, MotorState_};

use super::table::{self, WireConfig, MAX_TAU, SLOTS, VELOCITY};
use super::{MODE_DISABLED, MODE_ENABLED, MOTORS, WIRE_LEN};
use crate::emu_common::{ensure_finite, EmulatorError, Hz};
use crate::model::Side;
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Silent, Tick};
use crate::sim::{Noise, Sensor};

/// Measurement noise: the Dex3-1's figures for the same unitree_hg motor feedback (one least
/// significant bit of position, speed and torque), an assumption.
pub const DEX5_NOISE: Noise = crate::dex3::physical::HG_MOTOR_NOISE;

/// Values of the emulated hand that no source gives, in one overridable table.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex5Tuning {
    /// Time constant of a motor's approach to its target at the nominal gains, s.
    pub time_constant_s: f32,
    /// Silence after which every motor turns off; `None`: the last command holds forever.
    pub silence_timeout: Option<Duration>,
    /// Motor temperature reported, °C.
    pub temperature_c: f32,
    /// Supply voltage and current reported (a G1 battery's voltage), V and A.
    pub power_v: f32,
    pub power_a: f32,
    /// IMU at rest, upright.
    pub imu_quaternion: [f32; 4],
    pub imu_accelerometer: [f32; 3],
}

impl Default for Dex5Tuning {
    fn default() -> Self {
        Self {
            time_constant_s: 0.05,
            silence_timeout: None,
            temperature_c: 32.0,
            power_v: 52.0,
            power_a: 0.2,
            imu_quaternion: [1.0, 0.0, 0.0, 0.0],
            imu_accelerometer: [0.0, 0.0, 9.81],
        }
    }
}

/// Configuration of one emulated hand.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex5EmuConfig {
    pub side: Side,
    /// Loop and state rate (default [`super::SERVICE_HZ`]).
    pub rate: Hz,
    /// (command, state) topics; `None` = the side's standard ones ([`super::topics`]).
    pub topics: Option<(String, String)>,
    /// The commands it takes (default one entry per joint, as xr_teleoperate sends), the gains
    /// at which a motor moves with the tuning's time constant (default xr_teleoperate's) and
    /// the coupling of each `Pitch_x4` to its `Pitch_x3`.
    pub wire: WireConfig,
    /// Wire q per entry at power-up (default the rest posture); a coupled entry's is its
    /// motor's, through the coupling (its own value here is not used).
    pub initial: [f32; WIRE_LEN],
    /// Measurement noise on q, dq, tau_est (default [`DEX5_NOISE`]).
    pub noise: Noise,
    /// Per entry, the wire position at which that joint meets an object while closing (its
    /// motor stops there). Only joints that close (not the spreads or the thumb's yaw: ignored
    /// there); a `Pitch_x3` and its `Pitch_x4` both given: the one met first.
    pub object_at: [Option<f32>; WIRE_LEN],
    pub tuning: Dex5Tuning,
}

impl Dex5EmuConfig {
    pub fn new(side: Side) -> Self {
        let wire = WireConfig::default();
        let rest = table::rest_posture(wire.coupling);
        Self {
            side,
            rate: Hz(super::SERVICE_HZ),
            topics: None,
            wire,
            initial: std::array::from_fn(|i| rest[i] * table::wire_sign(side, i)),
            noise: DEX5_NOISE,
            object_at: [None; WIRE_LEN],
            tuning: Dex5Tuning::default(),
        }
    }
}

crate::emulated_hand!(Dex5EmuConfig {
    initial: initial,
    object: object_at
});

/// One motor as the emulator sees it (wire units of its driving entry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorView {
    /// The entry whose target moves it (its `Pitch_x3` for a coupled pair).
    pub driver: usize,
    pub q: f32,
    pub dq: f32,
    /// The PD law's torque in the last step (what tau_est reports).
    pub tau: f32,
    /// The command in force (its driving entry's), as received.
    pub command: MotorCmd_,
    /// Enabled by the command in force (off before the first command and after a timeout).
    pub on: bool,
    /// Where it meets an object while closing, and whether it is pressing on it.
    pub object: Option<f32>,
    pub contact: bool,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex5Snapshot {
    /// The last command accepted, as it came.
    pub last_command: Option<HandCmd_>,
    pub commands: u64,
    /// Commands ignored (wrong entry count, non-finite field).
    pub rejected: u64,
    /// The silence timeout turned the motors off (cleared by the next command).
    pub timed_out: bool,
    pub motors: [MotorView; MOTORS],
    /// State messages the service published.
    pub states_published: u64,
}

/// The hand's physics and the service's command handling, without DDS.
#[derive(Debug, Clone)]
pub struct Dex5Core {
    side: Side,
    wire: WireConfig,
    tuning: Dex5Tuning,
    sensor: Sensor,
    motors: [MotorView; MOTORS],
    last_cmd_at: Option<Instant>,
    last_command: Option<HandCmd_>,
    commands: u64,
    rejected: u64,
    timed_out: bool,
    /// Wire entries held where they are whatever the command (`--fault stuck=<joint>`): a
    /// stuck entry holds its motor (a coupled pair's both joints).
    stuck: [bool; WIRE_LEN],
}

impl Dex5Core {
    pub fn new(config: &Dex5EmuConfig) -> Result<Self, EmulatorError> {
        let t = &config.tuning;
        ensure_finite("initial", config.initial)?;
        ensure_finite("object_at", config.object_at.into_iter().flatten())?;
        ensure_finite("tuning", [t.time_constant_s, t.temperature_c, t.power_v, t.power_a])?;
        if t.time_constant_s <= 0.0 {
            return Err(EmulatorError::InvalidConfig("time_constant_s must be > 0".into()));
        }
        config.wire.gains.validate().map_err(EmulatorError::InvalidConfig)?;
        let k = config.wire.coupling;
        if !(k.is_finite() && k > 0.0) {
            return Err(EmulatorError::InvalidConfig(format!("coupling must be > 0, got {k}")));
        }
        config.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        let side = config.side;
        let motors = std::array::from_fn(|m| {
            let driver = table::motor_driver(m).unwrap_or(0);
            let (lo, hi) = table::motor_limits(side, driver, config.wire.coupling);
            MotorView {
                driver,
                q: config.initial[driver].clamp(lo, hi),
                dq: 0.0,
                tau: 0.0,
                command: MotorCmd_::default(),
                on: false,
                object: None,
                contact: false,
            }
        });
        let mut core = Self {
            side,
            wire: config.wire,
            tuning: t.clone(),
            sensor: Sensor::new(config.noise),
            motors,
            last_cmd_at: None,
            last_command: None,
            commands: 0,
            rejected: 0,
            timed_out: false,
            stuck: [false; WIRE_LEN],
        };
        for (i, at) in config.object_at.iter().enumerate() {
            let (Some(at), Some(dir)) = (at, table::closing_dir(side, i)) else {
                continue;
            };
            let m = SLOTS[i].motor;
            let other = core.motors[m].object;
            core.set_object(i, Some(*at));
            // Two objects on one motor (a Pitch_x3's and its Pitch_x4's): the first one met.
            if let (Some(o), Some(new)) = (other, core.motors[m].object) {
                if (o - new) * dir < 0.0 {
                    core.motors[m].object = Some(o);
                }
            }
        }
        Ok(core)
    }

    /// Places (or removes) an object entry `i` meets at wire position `at` while closing (a
    /// coupled entry's position is converted to its motor's). Ignored for entries that close
    /// nothing.
    pub fn set_object(&mut self, i: usize, at: Option<f32>) {
        if i >= WIRE_LEN || table::closing_dir(self.side, i).is_none() {
            return;
        }
        let at = at.filter(|a| a.is_finite());
        let at = if table::is_coupled(i) {
            at.map(|a| a / self.wire.coupling)
        } else {
            at
        };
        self.motors[SLOTS[i].motor].object = at;
    }

    /// Handles one command received at `now`; `false` (ignored, counted) unless it has the
    /// layout's entry count and only finite values.
    pub fn on_command(&mut self, cmd: &HandCmd_, now: Instant) -> bool {
        let finite = |m: &MotorCmd_| [m.q, m.dq, m.tau, m.kp, m.kd].iter().all(|v| v.is_finite());
        let layout = self.wire.layout;
        if cmd.motor_cmd.len() != layout.entries() || !cmd.motor_cmd.iter().all(finite) {
            self.rejected += 1;
            return false;
        }
        for m in &mut self.motors {
            let c = cmd.motor_cmd[layout.entry(m.driver)];
            m.command = c;
            m.on = c.mode == MODE_ENABLED;
        }
        self.commands += 1;
        self.last_cmd_at = Some(now);
        self.last_command = Some(cmd.clone());
        self.timed_out = false;
        true
    }

    /// Advances every motor by `dt` seconds at `now` (turning them off first if the silence
    /// timeout has run out).
    pub fn step(&mut self, now: Instant, dt: f32) {
        if let (Some(limit), Some(at)) = (self.tuning.silence_timeout, self.last_cmd_at) {
            if !self.timed_out && now.saturating_duration_since(at) >= limit {
                self.timed_out = true;
                self.motors.iter_mut().for_each(|m| m.on = false);
            }
        }
        let dt = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
        let stuck = self.stuck;
        for (n, m) in self.motors.iter_mut().enumerate() {
            if SLOTS.iter().zip(stuck).any(|(s, st)| st && s.motor == n) {
                // A stuck motor stays where it is, whatever the command.
                (m.dq, m.tau, m.contact) = (0.0, 0.0, false);
                continue;
            }
            let c = m.command;
            if !(m.on && c.kp > 0.0) || dt == 0.0 {
                (m.dq, m.tau, m.contact) = (0.0, 0.0, false);
                continue;
            }
            let i = m.driver;
            let (lo, hi) = table::motor_limits(self.side, i, self.wire.coupling);
            let goal = c.q.clamp(lo, hi);
            let tc = self.tuning.time_constant_s * self.wire.gains.kp[i] / c.kp;
            let vmax = VELOCITY[i] * dt;
            let before = m.q;
            let mut q = before + ((goal - before) * (1.0 - (-dt / tc).exp())).clamp(-vmax, vmax);
            m.contact = false;
            if let (Some(at), Some(dir)) = (m.object, table::closing_dir(self.side, i)) {
                // A closing motion that would cross the object stops on it; a joint already
                // past it (the object placed there) closes no further.
                let past = |x: f32| (x - at) * dir > 0.0;
                if past(q) && (q - before) * dir > 0.0 {
                    q = if past(before) { before } else { at };
                }
                m.contact = past(goal) && (q - at) * dir >= -1e-6;
            }
            m.dq = (q - before) / dt;
            m.q = q;
            m.tau = (c.kp * (c.q - q) + c.kd * (c.dq - m.dq) + c.tau).clamp(-MAX_TAU, MAX_TAU);
        }
    }

    /// The state the service publishes now, into `out` (its buffers reused); each call is one
    /// measurement (one set of noise draws).
    pub fn state_into(&mut self, out: &mut HandState_) {
        let t = &self.tuning;
        let n = self.sensor.noise();
        out.motor_state.clear();
        for (i, s) in SLOTS.iter().enumerate() {
            let m = &self.motors[s.motor];
            let k = if table::is_coupled(i) { self.wire.coupling } else { 1.0 };
            let temperature = t.temperature_c.round() as i16;
            out.motor_state.push(MotorState_ {
                mode: if m.on { MODE_ENABLED } else { MODE_DISABLED },
                q: self.sensor.add(k * m.q, n.q),
                dq: self.sensor.add(k * m.dq, n.dq),
                tau_est: self.sensor.add(m.tau, n.tau),
                temperature: [temperature; 2],
                vol: t.power_v,
                ..Default::default()
            });
        }
        out.press_sensor_state.clear();
        out.imu_state = IMUState_ {
            quaternion: t.imu_quaternion,
            accelerometer: t.imu_accelerometer,
            temperature: t.temperature_c.round() as i16,
            ..Default::default()
        };
        (out.power_v, out.power_a) = (t.power_v, t.power_a);
        (out.system_v, out.device_v, out.error, out.reserve) = (0.0, 0.0, [0; 2], [0; 2]);
    }

    /// [`Self::state_into`] a new message.
    pub fn state(&mut self) -> HandState_ {
        let mut out = HandState_::default();
        self.state_into(&mut out);
        out
    }

    /// Wire q of entry `i` as the hand is now (no noise; a coupled entry through its motor).
    pub fn position(&self, i: usize) -> f32 {
        let q = self.motors[SLOTS[i].motor].q;
        if table::is_coupled(i) {
            self.wire.coupled(q)
        } else {
            q
        }
    }

    pub fn snapshot(&self) -> Dex5Snapshot {
        Dex5Snapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            rejected: self.rejected,
            timed_out: self.timed_out,
            motors: self.motors,
            states_published: 0,
        }
    }
}

impl ServiceCore for Dex5Core {
    type Config = Dex5EmuConfig;
    type Snapshot = Dex5Snapshot;

    fn from_config(config: &Dex5EmuConfig) -> Result<Self, EmulatorError> {
        Self::new(config)
    }

    fn plan(config: &Dex5EmuConfig) -> Result<ServicePlan, EmulatorError> {
        let (side, topics) = (config.side, config.topics.clone());
        ServicePlan::one_hand("dex5", side, config.rate, topics, super::topics(side))
    }

    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "a Dex5-1")
    }

    fn report(&self, published: Published) -> Dex5Snapshot {
        Dex5Snapshot {
            states_published: published.state,
            ..self.snapshot()
        }
    }
}

impl ServiceWire<Self> for Dex5Core {
    type Cmd = HandCmd_;
    type State = HandState_;
    type Extra = Silent;

    /// Applied in arrival order; a malformed one is ignored and counted.
    fn receive(core: &mut Self, cmd: &HandCmd_, now: Instant) {
        core.on_command(cmd, now);
    }

    fn cycle(core: &mut Self, tick: Tick) -> Option<HandState_> {
        core.step(tick.now, tick.dt);
        Some(core.state())
    }
}

/// A running emulated Dex5-1 hand service (one hand). Dropping it stops its loop.
pub type Dex5Emulator = ServiceEmulator<Dex5Core>;

impl Dex5Emulator {
    /// Wire q of entry `i` (no noise).
    pub fn position(&self, i: usize) -> f32 {
        self.with_core(|c| c.position(i))
    }

    /// Places (or removes) the object entry `i` meets while closing.
    pub fn set_object(&self, i: usize, at: Option<f32>) {
        self.with_core(|c| c.set_object(i, at));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex5::table::{closed_posture, rest_posture, wire_sign, CommandLayout, GainSource, Gains, COUPLING};

    const DT: f32 = 0.002;

    fn quiet(side: Side) -> Dex5EmuConfig {
        Dex5EmuConfig {
            noise: Noise::OFF,
            ..Dex5EmuConfig::new(side)
        }
    }

    /// A command holding wire positions `q` (one per entry) at `gains`.
    fn cmd(q: &[f32; WIRE_LEN], gains: &Gains) -> HandCmd_ {
        HandCmd_ {
            motor_cmd: (0..WIRE_LEN)
                .map(|i| MotorCmd_ {
                    mode: MODE_ENABLED,
                    q: q[i],
                    kp: gains.kp[i],
                    kd: gains.kd[i],
                    ..Default::default()
                })
                .collect(),
            reserve: [0; 4],
        }
    }

    fn closed_wire(side: Side) -> [f32; WIRE_LEN] {
        let c = closed_posture(COUPLING);
        std::array::from_fn(|i| c[i] * wire_sign(side, i))
    }

    /// Runs `core` for `secs` from `t0` in steps of [`DT`]; returns the time reached.
    fn run(core: &mut Dex5Core, t0: Instant, secs: f32) -> Instant {
        let n = (secs / DT).round() as u32;
        let mut now = t0;
        for _ in 0..n {
            now += Duration::from_secs_f32(DT);
            core.step(now, DT);
        }
        now
    }

    #[test]
    fn a_stuck_entry_holds_its_motor_while_the_others_close() {
        let side = Side::Left;
        let mut core = Dex5Core::new(&quiet(side)).unwrap();
        // index_1 (its own motor) and index_3 (a coupled Pitch_x4: holds its Pitch_x3's motor).
        core.stick(1).unwrap();
        core.stick(7).unwrap();
        assert!(core.stick(WIRE_LEN).is_err(), "an entry the hand does not have");
        let before: Vec<f32> = (0..WIRE_LEN).map(|i| core.position(i)).collect();
        let t0 = Instant::now();
        assert!(core.on_command(&cmd(&closed_wire(side), &Gains::default()), t0));
        run(&mut core, t0, 1.5);
        for i in [1, 6, 7] {
            assert_eq!(core.position(i), before[i], "entry {i} stays where it was");
        }
        assert!(
            (core.position(5) - closed_wire(side)[5]).abs() < 1e-3,
            "middle_1 closes"
        );
    }

    #[test]
    fn it_rests_off_and_not_at_zero_until_the_first_command() {
        for side in [Side::Left, Side::Right] {
            let mut core = Dex5Core::new(&quiet(side)).unwrap();
            run(&mut core, Instant::now(), 0.5);
            let s = core.state();
            assert_eq!(s.motor_state.len(), 20);
            assert!(s.motor_state.iter().all(|m| m.mode == MODE_DISABLED));
            assert!(
                s.motor_state.iter().any(|m| m.q != 0.0),
                "xr_teleoperate waits for a non-zero state"
            );
            let rest = rest_posture(COUPLING);
            for (i, m) in s.motor_state.iter().enumerate() {
                assert!((m.q - rest[i] * wire_sign(side, i)).abs() < 1e-6, "{side:?} {i}");
            }
            assert!(s.press_sensor_state.is_empty());
            assert_eq!(s.imu_state.quaternion, [1.0, 0.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn it_closes_to_the_commanded_posture_and_the_coupled_joints_follow() {
        for side in [Side::Left, Side::Right] {
            let mut core = Dex5Core::new(&quiet(side)).unwrap();
            let t0 = Instant::now();
            let mut c = cmd(&closed_wire(side), &Gains::default());
            c.motor_cmd[7].q = 0.0; // a coupled entry's own target is not its motor's
            assert!(core.on_command(&c, t0));
            run(&mut core, t0, 1.5);
            let s = core.state();
            for (i, (m, want)) in s.motor_state.iter().zip(closed_wire(side)).enumerate() {
                assert!((m.q - want).abs() < 1e-3, "{side:?} {i}: {} against {want}", m.q);
                assert_eq!(m.mode, MODE_ENABLED);
            }
            assert!(
                s.motor_state[17].q * wire_sign(side, 17) > 0.5,
                "the thumb roll closed on its side"
            );
        }
    }

    #[test]
    fn speed_is_bounded_by_the_urdf_and_softer_gains_move_slower() {
        let t0 = Instant::now();
        let mut ten_x = Gains::default();
        ten_x.kp.iter_mut().for_each(|k| *k *= 10.0);
        // index Pitch_22 from 0 towards `to` for `secs` at `gains`.
        let progress = |to: f32, gains: &Gains, secs: f32| {
            let mut cfg = quiet(Side::Right);
            cfg.initial = [0.0; WIRE_LEN];
            let mut core = Dex5Core::new(&cfg).unwrap();
            let mut target = [0.0; WIRE_LEN];
            target[1] = to;
            core.on_command(&cmd(&target, gains), t0);
            run(&mut core, t0, secs);
            core.position(1)
        };
        let fast = progress(1.5, &ten_x, 0.1);
        assert!(fast <= VELOCITY[1] * 0.1 + 1e-4, "at most the URDF's velocity: {fast}");
        assert!(fast > 0.3, "{fast}");
        let p: Vec<f32> = [ten_x, Gains::default(), Gains::of(GainSource::UnitreeDdsWrapper)]
            .iter()
            .map(|g| progress(0.2, g, 0.05))
            .collect();
        assert!(p[0] > p[1] && p[1] > p[2] && p[2] > 0.0, "stiffer is faster: {p:?}");
    }

    #[test]
    fn mode_zero_kp_zero_and_limp_leave_a_motor_where_it_is() {
        let t0 = Instant::now();
        let mut core = Dex5Core::new(&quiet(Side::Left)).unwrap();
        let before: Vec<f32> = (0..WIRE_LEN).map(|i| core.position(i)).collect();
        let mut c = cmd(&closed_wire(Side::Left), &Gains::default());
        for m in &mut c.motor_cmd[..8] {
            m.mode = MODE_DISABLED;
        }
        for m in &mut c.motor_cmd[8..16] {
            (m.kp, m.kd) = (0.0, 0.0);
        }
        core.on_command(&c, t0);
        run(&mut core, t0, 0.5);
        for (i, b) in before.iter().enumerate().take(16) {
            assert_eq!(core.position(i), *b, "{i}");
        }
        assert!(core.position(18) > before[18] + 0.5, "the thumb, enabled, moved");
        let s = core.state();
        assert_eq!(
            (s.motor_state[0].mode, s.motor_state[9].mode),
            (MODE_DISABLED, MODE_ENABLED)
        );
        assert_eq!(s.motor_state[9].tau_est, 0.0);
    }

    #[test]
    fn malformed_commands_are_ignored_and_counted() {
        let t0 = Instant::now();
        let mut core = Dex5Core::new(&quiet(Side::Right)).unwrap();
        let good = cmd(&closed_wire(Side::Right), &Gains::default());
        assert!(
            !core.on_command(&HandCmd_::sdk_default(), t0),
            "a Dex3 client's seven entries"
        );
        let mut nan = good.clone();
        nan.motor_cmd[4].dq = f32::NAN;
        assert!(!core.on_command(&nan, t0));
        let mut short = good.clone();
        short.motor_cmd.truncate(16);
        assert!(!core.on_command(&short, t0), "sixteen entries need the motor layout");
        let snap = core.snapshot();
        assert_eq!((snap.commands, snap.rejected), (0, 3));
        assert!(snap.motors.iter().all(|m| !m.on) && snap.last_command.is_none());
        assert!(core.on_command(&good, t0));
        assert_eq!(core.snapshot().last_command, Some(good));
    }

    #[test]
    fn the_motor_layout_takes_sixteen_entries_thumb_first() {
        let t0 = Instant::now();
        let mut cfg = quiet(Side::Right);
        cfg.wire.layout = CommandLayout::Motors;
        let mut core = Dex5Core::new(&cfg).unwrap();
        let mut c = HandCmd_::with_motors(MOTORS);
        for m in &mut c.motor_cmd {
            (m.mode, m.q, m.kp, m.kd) = (MODE_ENABLED, 0.0, 0.1, 0.001);
        }
        (c.motor_cmd[0].q, c.motor_cmd[0].kp) = (0.4, 1.0); // thumb yaw
        c.motor_cmd[6].q = 1.0; // index Pitch_23 (and its Pitch_24)
        assert!(core.on_command(&c, t0));
        run(&mut core, t0, 1.0);
        assert!((core.position(16) - 0.4).abs() < 1e-3);
        assert!((core.position(2) - 1.0).abs() < 1e-3);
        assert!((core.position(3) - COUPLING * 1.0).abs() < 1e-3);
    }

    #[test]
    fn an_object_stops_a_closing_joint_and_the_law_pushes_on_it() {
        let t0 = Instant::now();
        let mut cfg = quiet(Side::Left);
        cfg.object_at[2] = Some(0.8);
        cfg.object_at[0] = Some(0.1); // a spread closes nothing: no object
        let mut core = Dex5Core::new(&cfg).unwrap();
        core.on_command(&cmd(&closed_wire(Side::Left), &Gains::default()), t0);
        run(&mut core, t0, 1.0);
        assert!((core.position(2) - 0.8).abs() < 1e-6);
        assert!((core.position(3) - COUPLING * 0.8).abs() < 1e-6);
        let snap = core.snapshot();
        let m = snap.motors[SLOTS[2].motor];
        assert!(m.contact && m.tau > 0.0, "{m:?}");
        assert_eq!(snap.motors[SLOTS[0].motor].object, None);
        // Opening leaves the object.
        core.on_command(&cmd(&[0.0; WIRE_LEN], &Gains::default()), t0);
        run(&mut core, t0, 1.0);
        assert!(core.position(2).abs() < 1e-3 && !core.snapshot().motors[SLOTS[2].motor].contact);
    }

    #[test]
    fn two_objects_on_one_motor_stop_it_at_the_first_met() {
        let t0 = Instant::now();
        for (x3, x4, stop) in [(0.8, 0.9, 0.8), (1.2, 0.5, 0.5 / COUPLING)] {
            let mut cfg = quiet(Side::Right);
            (cfg.object_at[6], cfg.object_at[7]) = (Some(x3), Some(x4)); // middle Pitch_33, Pitch_34
            let mut core = Dex5Core::new(&cfg).unwrap();
            core.on_command(&cmd(&closed_wire(Side::Right), &Gains::default()), t0);
            run(&mut core, t0, 1.0);
            assert!(
                (core.position(6) - stop).abs() < 1e-5,
                "{x3} {x4}: {}",
                core.position(6)
            );
        }
    }

    #[test]
    fn the_service_plan_is_the_sides_topics_at_the_configured_rate() {
        let plan = Dex5Core::plan(&Dex5EmuConfig::new(Side::Left)).unwrap();
        assert_eq!(
            (plan.cmd_topic.as_str(), plan.state_topic.as_deref()),
            ("rt/dex5/left/cmd", Some("rt/dex5/left/state"))
        );
        assert_eq!((plan.rate, plan.extra), (Hz(crate::dex5::SERVICE_HZ), None));
        let private = Dex5EmuConfig {
            rate: Hz(250.0),
            topics: Some(("a/cmd".into(), "a/state".into())),
            ..Dex5EmuConfig::new(Side::Right)
        };
        let plan = Dex5Core::plan(&private).unwrap();
        assert_eq!(
            (plan.cmd_topic.as_str(), plan.state_topic.as_deref(), plan.rate),
            ("a/cmd", Some("a/state"), Hz(250.0))
        );
        assert!(Dex5Core::plan(&Dex5EmuConfig::new(Side::Center)).is_err());
    }

    #[test]
    fn a_service_cycle_applies_the_commands_then_publishes_the_state() {
        let t0 = Instant::now();
        let mut core = Dex5Core::from_config(&quiet(Side::Left)).unwrap();
        let good = cmd(&closed_wire(Side::Left), &Gains::default());
        <Dex5Core as ServiceWire<Dex5Core>>::receive(&mut core, &HandCmd_::sdk_default(), t0);
        <Dex5Core as ServiceWire<Dex5Core>>::receive(&mut core, &good, t0);
        let tick = Tick {
            now: t0 + Duration::from_millis(2),
            dt: 0.002,
            period: Duration::from_millis(2),
        };
        let s = <Dex5Core as ServiceWire<Dex5Core>>::cycle(&mut core, tick).unwrap();
        assert_eq!(s.motor_state.len(), WIRE_LEN);
        assert!(
            s.motor_state.iter().all(|m| m.mode == MODE_ENABLED),
            "the good command in force"
        );
        let published = Published { state: 7, extra: 0 };
        let snap = core.report(published);
        assert_eq!((snap.commands, snap.rejected, snap.states_published), (1, 1, 7));
    }

    #[test]
    fn silence_holds_by_default_and_times_out_when_configured() {
        let t0 = Instant::now();
        let closed = cmd(&closed_wire(Side::Right), &Gains::default());
        let mut hold = Dex5Core::new(&quiet(Side::Right)).unwrap();
        hold.on_command(&closed, t0);
        run(&mut hold, t0, 10.0);
        assert!(hold.snapshot().motors.iter().all(|m| m.on) && !hold.snapshot().timed_out);

        let mut cfg = quiet(Side::Right);
        cfg.tuning.silence_timeout = Some(Duration::from_secs(1));
        let mut core = Dex5Core::new(&cfg).unwrap();
        core.on_command(&closed, t0);
        let t1 = run(&mut core, t0, 0.9);
        assert!(!core.snapshot().timed_out);
        let at = core.position(1);
        let t2 = run(&mut core, t1, 0.2);
        assert!(core.snapshot().timed_out && core.snapshot().motors.iter().all(|m| !m.on));
        assert!(core
            .state()
            .motor_state
            .iter()
            .all(|m| m.mode == MODE_DISABLED && m.tau_est == 0.0));
        run(&mut core, t2, 1.0);
        assert!((core.position(1) - at).abs() < 0.05, "off: it stays about where it was");
        core.on_command(&closed, t2);
        assert!(!core.snapshot().timed_out);
    }

    #[test]
    fn noise_is_seeded_and_bounded() {
        let mut a = Dex5Core::new(&Dex5EmuConfig::new(Side::Left)).unwrap();
        let mut b = Dex5Core::new(&Dex5EmuConfig::new(Side::Left)).unwrap();
        let (sa, sb) = (a.state(), b.state());
        assert_eq!(sa, sb, "same seed, same readings");
        for (i, m) in sa.motor_state.iter().enumerate() {
            assert!((m.q - a.position(i)).abs() <= 3.0 * DEX5_NOISE.q + 1e-6);
        }
        assert!(sa.motor_state.iter().any(|m| m.q != a.position(0)));
        let mut out = HandState_::default();
        a.state_into(&mut out);
        let ptr = out.motor_state.as_ptr();
        a.state_into(&mut out);
        assert_eq!(out.motor_state.as_ptr(), ptr, "buffer reused");
    }

    #[test]
    fn invalid_configurations_are_refused() {
        let bad = |f: fn(&mut Dex5EmuConfig)| {
            let mut c = Dex5EmuConfig::new(Side::Left);
            f(&mut c);
            Dex5Core::new(&c).is_err()
        };
        assert!(bad(|c| c.initial[3] = f32::NAN));
        assert!(bad(|c| c.object_at[2] = Some(f32::INFINITY)));
        assert!(bad(|c| c.tuning.time_constant_s = 0.0));
        assert!(bad(|c| c.wire.gains.kp[5] = 0.0));
        assert!(bad(|c| c.wire.coupling = f32::NAN));
        assert!(bad(|c| c.noise.q = -1.0));
        assert!(Dex5Core::new(&Dex5EmuConfig::new(Side::Right)).is_ok());
    }
}
