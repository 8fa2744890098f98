//! Emulator of Inspire's DDS driver for one RH56DFTP hand (the `inspire_hand_sdk` headless
//! driver), the peer the `inspire_ftp` codec talks to. Facts: docs/sources.md §7 ("Inspire
//! FTP"); every other number is an assumption listed in [`FtpTuning`] and in docs/adapters.md.
//!
//! - Subscribes `inspire::inspire_hand_ctrl` on `rt/inspire_hand/ctrl/{l,r}`; publishes
//!   `inspire_hand_state` on `rt/inspire_hand/state/{l,r}` and, over Modbus TCP only,
//!   `inspire_hand_touch` on `rt/inspire_hand/touch/{l,r}` (§7: "touch is not published over
//!   RS-485").
//! - Commands are written to the hand's registers when they arrive, in arrival order (the
//!   driver writes from its subscription callback): each register holds the latest value
//!   written. `mode` bits select the arrays written: 1 angle, 2 pos, 4 force, 8 speed; a clear
//!   bit leaves that register alone; mode 0 is a no-op. An array whose bit is set but whose
//!   length is not 6 is not written (the driver would fail to write it; counted).
//! - No timeout: silence changes nothing, the hand keeps its last targets (§7, inference).
//! - Loop: read all state registers (plus touch over TCP), publish, sleep 1 ms: the rate is
//!   the Modbus time's, not known here; 50 Hz over TCP is assumed, about 20 Hz over RS-485
//!   is Unitree's figure (§7; [`FtpTransport::rate`], `[devices.driver] rate_hz`).
//! - Before any command: no targets are written; the hand stays where it was left
//!   ([`FtpConfig::initial`], default [`REST_ANGLE`]).
//!
//! Model (assumed): each actuator follows its angle target with a first-order lag
//! ([`FtpTuning::time_constant_s`], settling on the target once within one unit) at most at `speed_set / 1000 ·` [`FtpTuning::max_speed`]
//! angle units per second, between the hard stops 0 and 1000 (the register's range, which is
//! the whole mechanical range: the URDF's limits are its ends). An object placed at an angle
//! ([`FtpConfig::object`]) blocks the closing finger there: the finger presses into it with a
//! stiffness of [`FtpTuning::contact_units_per_angle`] force units per angle unit and stops when
//! the force reaches `force_set` (status 3, "stopped at force"); its tactile pads then read
//! pressure in proportion to the force.
//!
//! Option (tests): a constant load per actuator ([`FtpConfig::sag`], default none): its
//! position loop then settles that far from its ANGLE_SET (`crate::sim`, "Sag").

use std::time::{Duration, Instant};

use handgate_idl::inspire::{
    InspireHandCtrl, InspireHandState, InspireHandTouch, ACTUATORS, MODE_ANGLE, MODE_FORCE, MODE_POS, MODE_SPEED,
    UNITS_MAX,
};

use crate::emu_common::{ensure_finite, EmulatorError, Hz, Side};
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Tick};
use crate::sim::{Noise, Sag, Sensor};

use super::front::{touch_fields_mut, SEGMENTS};
use super::table::URDF_RANGE;

/// Where an emulated hand starts, angle units per actuator: the linear actuators are
/// lead-screw driven and stay where they were left; "left nearly open" (100 units short of
/// 1000, so noise never reads past the open end) is assumed. Profiles set their own
/// (`emulator.initial`).
pub const REST_ANGLE: [f32; ACTUATORS] = [900.0; ACTUATORS];

/// Default measurement noise of the reported angle: one standard deviation of about one
/// register unit of a finger (1.7 rad / 1000 = 0.0017 rad), in canonical rad; converted per
/// actuator with its URDF span. Only the position figure is used (the driver reports no
/// velocity and no torque in N·m).
pub const ANGLE_NOISE: Noise = Noise {
    q: 0.0017,
    dq: 0.0,
    tau: 0.0,
    seed: Noise::DEFAULT_SEED,
};

/// How the driver reaches the hand (docs/sources.md §7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FtpTransport {
    /// Modbus TCP (the G1's default: 192.168.123.210 left, .211 right): state and touch.
    #[default]
    Tcp,
    /// Modbus RTU over RS-485: state only, no touch topic.
    Rs485,
}

impl FtpTransport {
    /// The driver's loop rate. The driver reads (24 Modbus requests per cycle over TCP, with
    /// touch), publishes and sleeps 1 ms, so its rate is set by the Modbus time, which no
    /// public source gives: 50 Hz over TCP is an **assumption** (docs/profiles.md
    /// "Assumptions"; `[devices.driver] rate_hz` on the emulator backend, the front's
    /// `state_hz`); about 20 Hz over RS-485 is Unitree's page. docs/sources.md §7.
    pub fn rate(self) -> Hz {
        match self {
            FtpTransport::Tcp => Hz(50.0),
            FtpTransport::Rs485 => Hz(20.0),
        }
    }

    /// Whether the driver publishes the touch topic.
    pub fn publishes_touch(self) -> bool {
        self == FtpTransport::Tcp
    }
}

/// Standard topics of one hand: (ctrl, state, touch); the suffix is the driver's `LR`
/// argument (docs/sources.md §7). One home: [`super::front::topics`].
pub use super::front::topics as standard_topics;

/// Assumed values (no hardware here; docs/adapters.md, assumptions table).
#[derive(Debug, Clone, PartialEq)]
pub struct FtpTuning {
    /// Angle units per second at `speed_set` 1000: a full stroke in 0.8 s (assumed).
    pub max_speed: f32,
    /// First-order lag of an actuator toward its target, s (assumed).
    pub time_constant_s: f32,
    /// `speed_set` and `force_set` the hand has before any command writes them (assumed:
    /// the maximum, 1000).
    pub initial_speed: i16,
    pub initial_force: i16,
    /// Force units per angle unit pressed into an object (assumed; 50 angle units of squeeze
    /// reach a force of 1000).
    pub contact_units_per_angle: f32,
    /// Taxel reading per force unit at the centre of a touched pad (assumed).
    pub touch_per_force: f32,
    /// Noise of force_act, current and each taxel, register units, one standard deviation
    /// (assumed), on whenever measurement noise is.
    pub force_noise: f32,
    pub current_noise: f32,
    pub touch_noise: f32,
    /// Actuator current at rest and per force unit (assumed register units, mA).
    pub current_idle: f32,
    pub current_per_force: f32,
    pub current_moving: f32,
    /// Actuator temperature, °C (assumed).
    pub temperature_c: u8,
}

impl Default for FtpTuning {
    fn default() -> Self {
        Self {
            max_speed: 1250.0,
            time_constant_s: 0.05,
            initial_speed: UNITS_MAX,
            initial_force: UNITS_MAX,
            contact_units_per_angle: 20.0,
            touch_per_force: 2.0,
            force_noise: 2.0,
            current_noise: 3.0,
            touch_noise: 2.0,
            current_idle: 20.0,
            current_per_force: 0.3,
            current_moving: 150.0,
            temperature_c: 34,
        }
    }
}

/// Configuration of one emulated driver (one hand).
#[derive(Debug, Clone, PartialEq)]
pub struct FtpConfig {
    pub side: Side,
    pub transport: FtpTransport,
    /// Loop and publish rate (default: the transport's).
    pub rate: Hz,
    /// Angle of each actuator at start, register units (default [`REST_ANGLE`]).
    pub initial: [f32; ACTUATORS],
    /// Angle (register units) at which an object blocks each closing actuator; `None`: none.
    /// The thumb rotation never touches.
    pub object: [Option<f32>; ACTUATORS],
    /// Per actuator, a constant load as its position loop's steady-state error (register
    /// units, signed; default none).
    pub sag: [Sag; ACTUATORS],
    /// Angle noise (`q`, canonical rad) and the seed of every draw.
    pub noise: Noise,
    /// Noise on force, current and taxels too ([`FtpTuning`]); `false` with [`Noise::OFF`]
    /// gives exact values.
    pub noisy: bool,
    pub tuning: FtpTuning,
    /// (ctrl, state, touch) topics; `None`: [`standard_topics`].
    pub topics: Option<(String, String, String)>,
}

impl FtpConfig {
    pub fn new(side: Side) -> Self {
        Self {
            side,
            transport: FtpTransport::Tcp,
            rate: FtpTransport::Tcp.rate(),
            initial: REST_ANGLE,
            object: [None; ACTUATORS],
            sag: [Sag::NONE; ACTUATORS],
            noise: ANGLE_NOISE,
            noisy: true,
            tuning: FtpTuning::default(),
            topics: None,
        }
    }

    /// Exact values: no noise anywhere.
    pub fn exact(mut self) -> Self {
        self.noise = Noise::OFF;
        self.noisy = false;
        self
    }

    /// Over RS-485: no touch topic, about 20 Hz.
    pub fn rs485(mut self) -> Self {
        self.transport = FtpTransport::Rs485;
        self.rate = FtpTransport::Rs485.rate();
        self
    }
}

/// `status` codes (docs/wire-types.md, inspire_hand_state).
pub mod status {
    pub const OPENING: u8 = 0;
    pub const CLOSING: u8 = 1;
    pub const AT_POSITION: u8 = 2;
    pub const AT_FORCE: u8 = 3;
}

/// One actuator as the emulator sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorView {
    /// Angle, register units (1000 open).
    pub angle: f32,
    /// ANGLE_SET in force (register units).
    pub angle_set: f32,
    pub speed_set: i16,
    pub force_set: i16,
    /// Contact force with the object, force units (0 without contact).
    pub force: f32,
    pub status: u8,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct FtpSnapshot {
    pub last_command: Option<InspireHandCtrl>,
    /// Commands received (every one, mode 0 included).
    pub commands: u64,
    /// Commands with mode 0 (no operation).
    pub noops: u64,
    /// Arrays whose mode bit was set but whose length was not 6 (not written).
    pub bad_arrays: u64,
    pub actuators: [ActuatorView; ACTUATORS],
    pub states_published: u64,
    pub touches_published: u64,
}

#[derive(Debug, Clone, Copy)]
struct Actuator {
    angle: f32,
    target: f32,
    speed_set: i16,
    force_set: i16,
    force: f32,
    status: u8,
    object: Option<f32>,
    sag: Sag,
}

/// The driver and hand without DDS.
#[derive(Debug, Clone)]
pub struct FtpCore {
    tuning: FtpTuning,
    act: [Actuator; ACTUATORS],
    sensor: Sensor,
    noisy: bool,
    last_command: Option<InspireHandCtrl>,
    commands: u64,
    noops: u64,
    bad_arrays: u64,
    /// Actuators held where they are whatever the command (`--fault stuck=<joint>`).
    stuck: [bool; ACTUATORS],
}

const MAX: f32 = UNITS_MAX as f32;

/// A register value as the hand takes it: −1 = leave this actuator's target alone (the
/// Inspire header's "-1: no change", docs/sources.md §7, assumed to be the firmware's), other
/// values clamped to 0..=1000 (assumed).
fn register(v: i16) -> Option<i16> {
    (v != -1).then(|| v.clamp(0, UNITS_MAX))
}

impl FtpCore {
    pub fn new(config: &FtpConfig) -> Result<Self, EmulatorError> {
        ensure_finite("initial", config.initial)?;
        ensure_finite("object", config.object.into_iter().flatten())?;
        ensure_finite("sag", config.sag.map(|s| s.0))?;
        config.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        let t = &config.tuning;
        ensure_finite(
            "tuning",
            [
                t.max_speed,
                t.time_constant_s,
                t.contact_units_per_angle,
                t.touch_per_force,
                t.force_noise,
                t.current_noise,
                t.touch_noise,
                t.current_idle,
                t.current_per_force,
                t.current_moving,
            ],
        )?;
        if t.max_speed <= 0.0 || t.time_constant_s <= 0.0 || t.contact_units_per_angle <= 0.0 {
            return Err(EmulatorError::InvalidConfig(
                "max_speed, time_constant_s and contact_units_per_angle must be > 0".into(),
            ));
        }
        let mut act = [Actuator {
            angle: 0.0,
            target: 0.0,
            speed_set: t.initial_speed,
            force_set: t.initial_force,
            force: 0.0,
            status: status::AT_POSITION,
            object: None,
            sag: Sag::NONE,
        }; ACTUATORS];
        for (i, a) in act.iter_mut().enumerate() {
            a.angle = config.initial[i].clamp(0.0, MAX);
            a.target = a.angle;
            a.sag = config.sag[i];
        }
        let mut core = Self {
            tuning: config.tuning.clone(),
            act,
            sensor: Sensor::new(config.noise),
            noisy: config.noisy,
            last_command: None,
            commands: 0,
            noops: 0,
            bad_arrays: 0,
            stuck: [false; ACTUATORS],
        };
        for (i, o) in config.object.iter().enumerate() {
            core.set_object(i, *o);
        }
        Ok(core)
    }

    /// Places (or removes) an object that blocks actuator `i` closing past `angle` (register
    /// units). The thumb rotation (5) never touches: ignored there.
    pub fn set_object(&mut self, i: usize, angle: Option<f32>) {
        if i < ACTUATORS - 1 {
            self.act[i].object = angle.filter(|a| a.is_finite()).map(|a| a.clamp(0.0, MAX));
        }
    }

    /// Handles one command as the driver does: writes the arrays whose mode bit is set.
    pub fn on_command(&mut self, c: &InspireHandCtrl) {
        self.commands += 1;
        self.last_command = Some(c.clone());
        if c.mode & 0x0F == 0 {
            self.noops += 1;
            return;
        }
        // Register write order assumed: angle, pos, force, speed (the mode bits' order).
        for (bit, arr) in [
            (MODE_ANGLE, &c.angle_set),
            (MODE_POS, &c.pos_set),
            (MODE_FORCE, &c.force_set),
            (MODE_SPEED, &c.speed_set),
        ] {
            if c.mode & bit == 0 {
                continue;
            }
            if arr.len() != ACTUATORS {
                self.bad_arrays += 1;
                continue;
            }
            for (a, v) in self.act.iter_mut().zip(arr) {
                let Some(v) = register(*v) else { continue };
                match bit {
                    MODE_ANGLE => a.target = f32::from(v),
                    // Actuator stroke: assumed 0 at the open end, i.e. pos = 1000 − angle
                    // (which end is closed is not established, docs/sources.md §7).
                    MODE_POS => a.target = MAX - f32::from(v),
                    MODE_FORCE => a.force_set = v,
                    _ => a.speed_set = v,
                }
            }
        }
    }

    /// Advances every actuator by `dt` seconds.
    pub fn step(&mut self, dt: f32) {
        let t = &self.tuning;
        for (a, stuck) in self.act.iter_mut().zip(self.stuck) {
            if stuck {
                // A stuck actuator stays where it is, whatever the command, and presses on
                // nothing (a stuck finger is told from a grasp by its force).
                a.force = 0.0;
                if a.status == status::AT_FORCE {
                    a.status = status::CLOSING;
                }
                continue;
            }
            let vmax = t.max_speed * f32::from(a.speed_set) / MAX;
            // Under a load the position loop settles short of its target.
            let goal = a.sag.goal(a.target).clamp(0.0, MAX);
            let want = ((goal - a.angle) / t.time_constant_s).clamp(-vmax, vmax);
            let mut next = (a.angle + want * dt).clamp(0.0, MAX);
            // The hand's position loop settles on the register value within one unit (its
            // resolution; assumed), so a reached target reads exactly.
            if (goal - next).abs() < 1.0 {
                next = goal;
            }
            // Closing = decreasing angle. Pressing into an object raises the force; the
            // finger stops where the force reaches force_set.
            let mut at_force = false;
            if let Some(obj) = a.object {
                let limit = f32::from(a.force_set.max(0));
                let deepest = obj - limit / t.contact_units_per_angle;
                if next < deepest {
                    next = deepest.min(a.angle.max(next));
                    at_force = true;
                }
            }
            let moved = next - a.angle;
            a.angle = next;
            a.force = a
                .object
                .map_or(0.0, |obj| ((obj - a.angle) * t.contact_units_per_angle).max(0.0));
            a.status = if at_force || (a.force > 0.0 && a.force >= f32::from(a.force_set.max(0))) {
                status::AT_FORCE
            } else if (a.target - a.angle).abs() < 1.0 {
                status::AT_POSITION
            } else if moved > 0.0 || a.target > a.angle {
                status::OPENING
            } else {
                status::CLOSING
            };
        }
    }

    fn noise(&mut self, v: f32, sd: f32) -> f32 {
        if self.noisy {
            self.sensor.add(v, sd)
        } else {
            v
        }
    }

    /// The state registers as the driver reads them (each call draws the noise once).
    pub fn state(&mut self) -> InspireHandState {
        let t = self.tuning.clone();
        let mut s = InspireHandState::sdk_default();
        let q_sd = self.sensor.noise().q;
        for (i, (lo, hi)) in URDF_RANGE.into_iter().enumerate() {
            let a = self.act[i];
            let angle_sd = q_sd * MAX / (hi - lo);
            let angle = self.sensor.add(a.angle, angle_sd);
            s.angle_act[i] = to_reg(angle, 0.0, MAX);
            s.pos_act[i] = to_reg(MAX - angle, 0.0, MAX);
            let force = self.noise(a.force, t.force_noise);
            s.force_act[i] = to_reg(force, -MAX, 3000.0);
            let moving = a.status == status::OPENING || a.status == status::CLOSING;
            let current = t.current_idle + t.current_per_force * a.force + if moving { t.current_moving } else { 0.0 };
            s.current[i] = to_reg(self.noise(current, t.current_noise), 0.0, 3000.0);
            s.err[i] = 0;
            s.status[i] = a.status;
            s.temperature[i] = t.temperature_c;
        }
        s
    }

    /// The tactile arrays (each call draws the noise once per taxel). The fingertip pad
    /// (`top`) of a finger pressing an object reads a bump centred on the pad, the fingertip
    /// end (`tip`) and the finger pad a third and a fifth of it; the palm reads noise only
    /// (assumed layout of contact).
    pub fn touch(&mut self) -> InspireHandTouch {
        let mut out = InspireHandTouch::sdk_default();
        let f: [f32; 5] = std::array::from_fn(|i| self.act[i].force * self.tuning.touch_per_force);
        let sd = self.tuning.touch_noise;
        for (&(name, rows, cols), arr) in SEGMENTS.iter().zip(touch_fields_mut(&mut out)) {
            let (finger, part) = name.split_once('_').unwrap_or((name, ""));
            let force = match finger {
                "pinky" => f[0],
                "ring" => f[1],
                "middle" => f[2],
                "index" => f[3],
                "thumb" => f[4],
                _ => 0.0,
            };
            let peak = match part {
                "top" => force,
                "tip" => force / 3.0,
                _ => force / 5.0,
            };
            let (rows, cols) = (f32::from(rows), f32::from(cols));
            let (cr, cc) = ((rows - 1.0) / 2.0, (cols - 1.0) / 2.0);
            for (k, v) in arr.iter_mut().enumerate() {
                let (r, c) = ((k as f32 / cols).floor(), k as f32 % cols);
                let d2 = ((r - cr) / (rows / 2.0)).powi(2) + ((c - cc) / (cols / 2.0)).powi(2);
                let x = peak * (-2.0 * d2).exp();
                *v = to_reg(self.noise(x, sd).abs(), 0.0, f32::from(i16::MAX));
            }
        }
        out
    }

    pub fn snapshot(&self) -> FtpSnapshot {
        FtpSnapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            noops: self.noops,
            bad_arrays: self.bad_arrays,
            actuators: std::array::from_fn(|i| {
                let a = self.act[i];
                ActuatorView {
                    angle: a.angle,
                    angle_set: a.target,
                    speed_set: a.speed_set,
                    force_set: a.force_set,
                    force: a.force,
                    status: a.status,
                }
            }),
            states_published: 0,
            touches_published: 0,
        }
    }
}

fn to_reg(v: f32, lo: f32, hi: f32) -> i16 {
    v.round().clamp(lo, hi) as i16
}

impl ServiceCore for FtpCore {
    type Config = FtpConfig;
    type Snapshot = FtpSnapshot;

    fn from_config(config: &FtpConfig) -> Result<Self, EmulatorError> {
        Self::new(config)
    }

    /// The touch topic only over Modbus TCP, at the loop's rate.
    fn plan(config: &FtpConfig) -> Result<ServicePlan, EmulatorError> {
        let (ctrl, state, touch) = config.topics.clone().unwrap_or_else(|| standard_topics(config.side));
        let name = format!("ftp-emu-{}", config.side);
        let touch = config.transport.publishes_touch().then_some((touch, None));
        Ok(ServicePlan::new(name, config.rate, ctrl, Some(state)).with_extra(touch))
    }

    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "an Inspire FTP hand")
    }

    fn report(&self, published: Published) -> FtpSnapshot {
        FtpSnapshot {
            states_published: published.state,
            touches_published: published.extra,
            ..self.snapshot()
        }
    }
}

impl ServiceWire<Self> for FtpCore {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;
    type Extra = InspireHandTouch;

    /// Commands are applied as they arrived, each writing its registers.
    fn receive(core: &mut Self, cmd: &InspireHandCtrl, _now: Instant) {
        core.on_command(cmd);
    }

    fn cycle(core: &mut Self, tick: Tick) -> Option<InspireHandState> {
        core.step(dt_for(tick.dt, tick.period));
        Some(core.state())
    }

    fn extra(core: &mut Self, _state: &InspireHandState) -> Option<InspireHandTouch> {
        Some(core.touch())
    }
}

/// A running emulated Inspire DDS driver for one hand. Dropping it stops its loop.
pub type FtpEmulator = ServiceEmulator<FtpCore>;

impl FtpEmulator {
    /// Actuator `i`'s angle, register units.
    pub fn angle(&self, i: usize) -> f32 {
        self.with_core(|c| c.act[i].angle)
    }

    /// Places (or removes) the object actuator `i` closes on (register units).
    pub fn set_object(&self, i: usize, angle: Option<f32>) {
        self.with_core(|c| c.set_object(i, angle));
    }
}

/// `tick_dt` bounds a step at 10 ms; this driver's own period is 20 ms (50 Hz) or 50 ms
/// (20 Hz), so a nominal tick advances the model by its real period.
fn dt_for(dt: f32, period: Duration) -> f32 {
    if dt >= 0.01 {
        period.as_secs_f32().min(0.1)
    } else {
        dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn angles(c: &mut FtpCore) -> Vec<i16> {
        c.state().angle_act
    }

    fn cmd(mode: i8, angle: [i16; 6]) -> InspireHandCtrl {
        InspireHandCtrl {
            angle_set: angle.to_vec(),
            mode,
            ..InspireHandCtrl::sdk_default()
        }
    }

    fn run(c: &mut FtpCore, secs: f32) {
        for _ in 0..(secs / 0.02) as usize {
            c.step(0.02);
        }
    }

    #[test]
    fn starts_at_rest_and_holds_without_commands() {
        let mut c = FtpCore::new(&FtpConfig::new(Side::Left).exact()).unwrap();
        assert_eq!(angles(&mut c), vec![900; 6]);
        run(&mut c, 2.0);
        assert_eq!(angles(&mut c), vec![900; 6], "no command, no motion");
    }

    #[test]
    fn angle_mode_moves_at_a_bounded_speed_and_mode_bits_select_arrays() {
        let mut c = FtpCore::new(&FtpConfig::new(Side::Right).exact()).unwrap();
        c.on_command(&cmd(MODE_ANGLE, [0, 0, 0, 0, 1000, 1000]));
        c.step(0.02);
        let a = c.state().angle_act;
        // 1250 units/s at most: 25 units in 20 ms.
        assert!(a[0] >= 875 && a[0] < 900, "{a:?}");
        run(&mut c, 2.0);
        assert_eq!(angles(&mut c), vec![0, 0, 0, 0, 1000, 1000]);
        // Angle bit clear: angle_set ignored.
        let mut speed_only = cmd(MODE_SPEED, [500; 6]);
        speed_only.speed_set = vec![800; 6];
        c.on_command(&speed_only);
        c.on_command(&cmd(0, [1000; 6]));
        run(&mut c, 1.0);
        assert_eq!(angles(&mut c), vec![0, 0, 0, 0, 1000, 1000]);
        let s = c.snapshot();
        assert_eq!((s.commands, s.noops), (3, 1));
        assert_eq!(s.actuators[0].speed_set, 800);
        assert_eq!(s.actuators[0].force_set, 1000, "force_set untouched: its bit was clear");
        // Speed 100 of 1000: ten times slower.
        let mut slow = cmd(MODE_ANGLE | MODE_SPEED, [1000; 6]);
        slow.speed_set = vec![100; 6];
        c.on_command(&slow);
        c.step(0.02);
        assert!(c.state().angle_act[0] <= 3, "2.5 units in 20 ms");
        // -1 leaves a target alone; out-of-range values clamp; a short array is not written.
        c.on_command(&cmd(MODE_ANGLE, [-1, 2000, -50, 500, 500, 500]));
        let s = c.snapshot();
        assert_eq!(s.actuators[0].angle_set, 1000.0);
        assert_eq!(s.actuators[1].angle_set, 1000.0);
        assert_eq!(s.actuators[2].angle_set, 0.0);
        let mut short = cmd(MODE_ANGLE, [0; 6]);
        short.angle_set.pop();
        c.on_command(&short);
        assert_eq!(c.snapshot().bad_arrays, 1);
        assert_eq!(c.snapshot().actuators[3].angle_set, 500.0);
    }

    #[test]
    fn an_object_stops_the_finger_at_force_and_lights_its_pads() {
        let mut cfg = FtpConfig::new(Side::Left).exact();
        cfg.object[3] = Some(600.0);
        let mut c = FtpCore::new(&cfg).unwrap();
        let mut m = cmd(MODE_ANGLE | MODE_FORCE, [0; 6]);
        m.force_set = vec![500; 6];
        c.on_command(&m);
        run(&mut c, 2.0);
        let s = c.state();
        // Index pressed into the object until 500 force units: 25 angle units past it.
        assert_eq!(s.angle_act[3], 575);
        assert_eq!(s.force_act[3], 500);
        assert_eq!(s.status[3], status::AT_FORCE);
        assert_eq!((s.angle_act[2], s.status[2]), (0, status::AT_POSITION));
        let t = c.touch();
        let peak = *t.fingerfour_top_touch.iter().max().unwrap();
        assert!(peak > 500, "index fingertip pad pressed: {peak}");
        assert!(t.fingerthree_top_touch.iter().all(|v| *v == 0), "middle free");
        assert!(t.palm_touch.iter().all(|v| *v == 0));
        // Hard stop: the open end is 1000 even past it.
        c.on_command(&cmd(MODE_ANGLE, [1000; 6]));
        run(&mut c, 2.0);
        assert_eq!(angles(&mut c), vec![1000; 6]);
        assert_eq!(c.state().force_act[3], 0);
    }

    #[test]
    fn noise_at_rest_is_seeded_and_bounded() {
        let read = |cfg: &FtpConfig| {
            let mut c = FtpCore::new(cfg).unwrap();
            (0..10).map(|_| (c.state(), c.touch())).collect::<Vec<_>>()
        };
        let cfg = FtpConfig::new(Side::Left);
        let a = read(&cfg);
        assert_eq!(a, read(&cfg), "same seed, same noise");
        let other = FtpConfig {
            noise: cfg.noise.with_seed(1),
            ..cfg.clone()
        };
        assert_ne!(a, read(&other));
        for (s, _) in &a {
            for (i, v) in s.angle_act.iter().enumerate() {
                let (lo, hi) = URDF_RANGE[i];
                let sd = cfg.noise.q * 1000.0 / (hi - lo);
                assert!(f32::from((v - 900).abs()) <= 3.0 * sd + 0.5, "actuator {i}: {v}");
            }
        }
        assert!(
            a.iter().any(|(s, _)| s.angle_act.iter().any(|v| *v != 900)),
            "angle noise visible"
        );
        let taxels: Vec<i16> = a.iter().flat_map(|(_, t)| t.palm_touch.clone()).collect();
        assert!(taxels.iter().any(|v| *v != 0) && taxels.iter().all(|v| *v <= 6));
    }
}
