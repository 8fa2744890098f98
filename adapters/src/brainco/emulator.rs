//! Emulator of `brainco_hand_service`, the DDS peer a BrainCo Revo2 client talks to (one
//! hand per emulator, as one service loop per hand).
//!
//! Behaviour from docs/sources.md §7 "BrainCo Revo2":
//! - subscribes unitree_go `MotorCmds_` on `rt/brainco/{side}/cmd`, publishes `MotorStates_`
//!   on `rt/brainco/{side}/state`, 6 entries in the order thumb, thumb aux, index, middle,
//!   ring, pinky;
//! - `q` (position, 1 = closed) and `dq` (speed, 1 = fastest) of each entry are clamped to
//!   [0, 1] and sent to the hand together; `tau`, `kp`, `kd`, `mode` ignored;
//! - state: `q` = position, `dq` = speed, `tau_est` = current (A), each a hand register / 1000
//!   (so the emulator reports them in steps of 0.001), everything else zero;
//! - **no timeout**: every cycle re-sends the last command received, so the hand holds its
//!   last target indefinitely;
//! - **at start-up the stored command is `q = 0`, `dq = 1`**: the service drives the hand
//!   fully open before any client speaks.
//!
//! Assumed (no hardware here; [`BraincoTuning`] and [`BraincoConfig`], docs/adapters.md's
//! assumptions table): that the loop keeps its 500 Hz (`main.cpp` sleeps what is left of 2 ms
//! after writing the targets and reading the status over Modbus RTU; whether the bus leaves
//! room for that is not known here), the finger motion (first order toward the target, at
//! most `full_speed` of the stroke per second times the commanded speed), the currents, the
//! rest posture, the handling of a malformed command (ignored and counted), and the
//! measurement noise.
//!
//! Option (tests): a constant load per finger ([`BraincoConfig::sag`], default none): its
//! position loop then settles that far from its target (`crate::sim`, "Sag").

use std::time::Instant;

use handgate_idl::unitree_go::{MotorCmds_, MotorState_, MotorStates_};

use super::WIRE_LEN;
use crate::emu_common::{ensure_finite, EmulatorError, Hz, Side};
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Silent, Tick};
use crate::sim::{Noise, Sag, Sensor};

/// The service's loop and state rate, Hz: `main.cpp` targets a 2 ms period (docs/sources.md
/// §7). That the hand's Modbus exchange leaves room for it is an assumption.
pub const BRAINCO_DEFAULT_HZ: f64 = 500.0;

/// Where an emulated hand rests before the service opens it (wire, 0 = open): a relaxed,
/// unpowered hand sits slightly flexed. An assumption; profiles set their own
/// (`emulator.initial`).
pub const BRAINCO_REST_Q: [f32; WIRE_LEN] = [0.10, 0.05, 0.15, 0.15, 0.15, 0.15];

/// One count of the hand's 0–1000 registers, as the service reports it (docs/sources.md §7).
pub const REGISTER_STEP: f32 = 0.001;

/// Default measurement noise, in wire units: half a register count of position and speed
/// (after rounding to whole counts a reading at rest flickers by a count now and then, as the
/// EZGripper's half-tick figure), 5 mA of current (assumptions: the hand reports integers, and
/// a current sensor flickers by a few mA).
pub const BRAINCO_NOISE: Noise = Noise {
    q: 0.0005,
    dq: 0.0005,
    tau: 0.005,
    seed: Noise::DEFAULT_SEED,
};

/// Values not taken from a public source, in one overridable table.
#[derive(Debug, Clone, PartialEq)]
pub struct BraincoTuning {
    /// Fastest finger motion at speed 1, fraction of the full stroke per second (2.0: open to
    /// closed in 0.5 s).
    pub full_speed: f32,
    /// Time constant of the first-order approach to the target, s.
    pub time_constant_s: f32,
    /// Current at rest, while moving at full speed, and when pressing an object with the
    /// target a full stroke past it, A.
    pub idle_current_a: f32,
    pub moving_current_a: f32,
    pub stall_current_a: f32,
}

impl Default for BraincoTuning {
    fn default() -> Self {
        Self {
            full_speed: 2.0,
            time_constant_s: 0.03,
            idle_current_a: 0.02,
            moving_current_a: 0.3,
            stall_current_a: 1.2,
        }
    }
}

/// Configuration of one emulated `brainco_hand_service` hand.
#[derive(Debug, Clone, PartialEq)]
pub struct BraincoConfig {
    pub side: Side,
    /// Loop and state rate (default [`BRAINCO_DEFAULT_HZ`]).
    pub rate: Hz,
    /// Finger positions at power-up, wire (default [`BRAINCO_REST_Q`]); the service then
    /// opens the hand.
    pub initial: [f32; WIRE_LEN],
    /// Measurement noise on q, dq, tau_est (default [`BRAINCO_NOISE`]).
    pub noise: Noise,
    /// Per entry, the wire position at which the finger meets an object while closing.
    pub object: [Option<f32>; WIRE_LEN],
    /// Per entry, a constant load on the finger as its position loop's steady-state error
    /// (wire, signed; default none).
    pub sag: [Sag; WIRE_LEN],
    pub tuning: BraincoTuning,
    /// (command, state) topics; `None` = the side's standard ones ([`super::topics`]).
    pub topics: Option<(String, String)>,
}

impl BraincoConfig {
    pub fn new(side: Side) -> Self {
        Self {
            side,
            rate: Hz(BRAINCO_DEFAULT_HZ),
            initial: BRAINCO_REST_Q,
            noise: BRAINCO_NOISE,
            object: [None; WIRE_LEN],
            sag: [Sag::NONE; WIRE_LEN],
            tuning: BraincoTuning::default(),
            topics: None,
        }
    }
}

crate::emulated_hand!(BraincoConfig {
    initial: initial,
    object: object
});

/// One finger as the emulator sees it (wire units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerView {
    /// Position, 0 open .. 1 closed.
    pub q: f32,
    /// Velocity, stroke per second (positive closing).
    pub dq: f32,
    /// Motor current, A.
    pub current: f32,
    /// The stored command: target position and speed, both clamped to [0, 1].
    pub target_q: f32,
    pub target_speed: f32,
    /// Pressing on the object.
    pub contact: bool,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct BraincoSnapshot {
    /// The last accepted command, as it came.
    pub last_command: Option<MotorCmds_>,
    /// Accepted commands.
    pub commands: u64,
    /// Commands ignored (entry count other than 6, non-finite q or dq).
    pub rejected: u64,
    pub fingers: [FingerView; WIRE_LEN],
    pub states_published: u64,
}

/// The service logic without DDS.
#[derive(Debug, Clone)]
pub struct BraincoCore {
    tuning: BraincoTuning,
    fingers: [FingerView; WIRE_LEN],
    object: [Option<f32>; WIRE_LEN],
    sag: [Sag; WIRE_LEN],
    sensor: Sensor,
    last_command: Option<MotorCmds_>,
    commands: u64,
    rejected: u64,
    /// Fingers held where they are whatever the command (`--fault stuck=<joint>`).
    stuck: [bool; WIRE_LEN],
}

/// The hand's hard stops, wire: the service clamps to [0, 1] and sends 0–1000, the Revo2's
/// whole normalised travel (docs/sources.md §7), which is also the URDF range.
pub const HARD_STOPS: (f32, f32) = (0.0, 1.0);

impl BraincoCore {
    pub fn new(config: &BraincoConfig) -> Result<Self, EmulatorError> {
        let t = &config.tuning;
        ensure_finite("initial", config.initial)?;
        ensure_finite("object", config.object.into_iter().flatten())?;
        ensure_finite("sag", config.sag.map(|s| s.0))?;
        ensure_finite(
            "tuning",
            [
                t.full_speed,
                t.time_constant_s,
                t.idle_current_a,
                t.moving_current_a,
                t.stall_current_a,
            ],
        )?;
        if t.full_speed <= 0.0 || t.time_constant_s <= 0.0 {
            return Err(EmulatorError::InvalidConfig(
                "full_speed and time_constant_s must be > 0".into(),
            ));
        }
        config.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        let (lo, hi) = HARD_STOPS;
        let mut fingers = [FingerView {
            q: 0.0,
            dq: 0.0,
            current: t.idle_current_a,
            // docs/sources.md §7: before the first command the stored command is q 0, dq 1.
            target_q: 0.0,
            target_speed: 1.0,
            contact: false,
        }; WIRE_LEN];
        for (f, q) in fingers.iter_mut().zip(config.initial) {
            f.q = q.clamp(lo, hi);
        }
        Ok(Self {
            tuning: t.clone(),
            fingers,
            object: config.object,
            sag: config.sag,
            sensor: Sensor::new(config.noise),
            last_command: None,
            commands: 0,
            rejected: 0,
            stuck: [false; WIRE_LEN],
        })
    }

    /// Places (or removes) the object finger `i` (wire order) closes on, at wire position `at`.
    pub fn set_object(&mut self, i: usize, at: Option<f32>) {
        if let Some(o) = self.object.get_mut(i) {
            *o = at.filter(|a| a.is_finite());
        }
    }

    /// Handles one command; `false` (ignored, counted) unless it has 6 entries with finite
    /// `q` and `dq`.
    pub fn on_command(&mut self, cmd: &MotorCmds_) -> bool {
        if cmd.cmds.len() != WIRE_LEN || cmd.cmds.iter().any(|c| !(c.q.is_finite() && c.dq.is_finite())) {
            self.rejected += 1;
            return false;
        }
        for (f, c) in self.fingers.iter_mut().zip(&cmd.cmds) {
            f.target_q = c.q.clamp(0.0, 1.0);
            f.target_speed = c.dq.clamp(0.0, 1.0);
        }
        self.commands += 1;
        self.last_command = Some(cmd.clone());
        true
    }

    /// Advances the fingers by `dt` seconds toward the stored command (re-sent every cycle:
    /// there is no timeout).
    pub fn step(&mut self, dt: f32) {
        let t = &self.tuning;
        let (lo, hi) = HARD_STOPS;
        for (((f, obj), sag), stuck) in self.fingers.iter_mut().zip(self.object).zip(self.sag).zip(self.stuck) {
            if stuck {
                // A stuck finger stays where it is, whatever the command, drawing its idle
                // current (a stuck finger is told from a grasp by its current).
                f.dq = 0.0;
                f.current = t.idle_current_a;
                continue;
            }
            let vmax = t.full_speed * f.target_speed;
            // Under a load the position loop settles short of its target.
            let goal = sag.goal(f.target_q).clamp(lo, hi);
            let v = ((goal - f.q) / t.time_constant_s).clamp(-vmax, vmax);
            let before = f.q;
            let mut q = f.q + v * dt;
            // The hand's position loop resolves one register count: within half a count of
            // the target it is there (a first-order approach alone never arrives).
            if (goal - q).abs() < REGISTER_STEP * 0.5 && v.abs() > 0.0 {
                q = goal;
            }
            let mut q = q.clamp(lo, hi);
            f.contact = false;
            if let Some(at) = obj {
                if before <= at + 1e-6 && q > at && f.target_q > at {
                    q = at.max(before);
                    f.contact = true;
                } else if (before - at).abs() <= 1e-6 && f.target_q > at {
                    f.contact = true;
                }
            }
            f.dq = if dt > 0.0 { (q - before) / dt } else { 0.0 };
            f.q = q;
            f.current = match (f.contact, obj) {
                (true, Some(at)) => {
                    t.idle_current_a
                        + (t.stall_current_a - t.idle_current_a) * ((f.target_q - at) / 1.0).clamp(0.0, 1.0)
                }
                _ => t.idle_current_a + (t.moving_current_a - t.idle_current_a) * (f.dq.abs() / t.full_speed).min(1.0),
            } * if f.dq < 0.0 { -1.0 } else { 1.0 };
        }
    }

    /// The state message, measured (each call draws the noise once per field), in the
    /// service's 0.001 steps, position within the register's 0..1.
    pub fn state(&mut self) -> MotorStates_ {
        let n = self.sensor.noise();
        let quant = |v: f32| (v / REGISTER_STEP).round() * REGISTER_STEP;
        let sensor = &mut self.sensor;
        MotorStates_ {
            states: self
                .fingers
                .iter()
                .map(|f| MotorState_ {
                    q: quant(sensor.add(f.q, n.q)).clamp(0.0, 1.0),
                    dq: quant(sensor.add(f.dq, n.dq)),
                    tau_est: quant(sensor.add(f.current, n.tau)),
                    ..MotorState_::default()
                })
                .collect(),
        }
    }
}

impl ServiceCore for BraincoCore {
    type Config = BraincoConfig;
    type Snapshot = BraincoSnapshot;

    fn from_config(config: &BraincoConfig) -> Result<Self, EmulatorError> {
        Self::new(config)
    }

    fn plan(config: &BraincoConfig) -> Result<ServicePlan, EmulatorError> {
        let (side, topics) = (config.side, config.topics.clone());
        ServicePlan::one_hand("brainco", side, config.rate, topics, super::topics(side))
    }

    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "a BrainCo hand")
    }

    fn report(&self, published: Published) -> BraincoSnapshot {
        BraincoSnapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            rejected: self.rejected,
            fingers: self.fingers,
            states_published: published.state,
        }
    }
}

impl ServiceWire<Self> for BraincoCore {
    type Cmd = MotorCmds_;
    type State = MotorStates_;
    type Extra = Silent;

    /// Latest wins: applied in arrival order, a malformed one leaves the previous.
    fn receive(core: &mut Self, cmd: &MotorCmds_, _now: Instant) {
        core.on_command(cmd);
    }

    fn cycle(core: &mut Self, tick: Tick) -> Option<MotorStates_> {
        core.step(tick.dt);
        Some(core.state())
    }
}

/// A running emulated `brainco_hand_service` (one hand). Dropping it stops its loop.
pub type BraincoEmulator = ServiceEmulator<BraincoCore>;

impl BraincoEmulator {
    /// Finger `i` (wire order).
    pub fn finger(&self, i: usize) -> FingerView {
        self.with_core(|c| c.fingers[i])
    }

    /// Places (or removes) the object finger `i` (wire order) closes on.
    pub fn set_object(&self, i: usize, at: Option<f32>) {
        self.with_core(|c| c.set_object(i, at));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_idl::unitree_go::MotorCmd_;

    fn cmd(q: f32, dq: f32) -> MotorCmds_ {
        MotorCmds_ {
            cmds: vec![
                MotorCmd_ {
                    q,
                    dq,
                    ..Default::default()
                };
                WIRE_LEN
            ],
        }
    }

    fn exact() -> BraincoConfig {
        BraincoConfig {
            noise: Noise::OFF,
            ..BraincoConfig::new(Side::Left)
        }
    }

    fn run(core: &mut BraincoCore, seconds: f32) {
        for _ in 0..(seconds / 0.01).round() as usize {
            core.step(0.01);
        }
    }

    #[test]
    fn starts_at_rest_and_the_service_opens_the_hand() {
        let mut core = BraincoCore::new(&exact()).unwrap();
        let s = core.state();
        assert_eq!(s.states.len(), 6);
        assert!((s.states[2].q - 0.15).abs() < 1e-6, "rest posture first: {s:?}");
        run(&mut core, 1.0);
        assert!(core.state().states.iter().all(|m| m.q == 0.0), "opened with no command");
        assert_eq!(core.report(Published::default()).commands, 0);
    }

    #[test]
    fn holds_the_last_target_forever_and_speed_scales_motion() {
        let mut core = BraincoCore::new(&exact()).unwrap();
        assert!(core.on_command(&cmd(0.8, 1.0)));
        run(&mut core, 1.0);
        assert!((core.fingers[3].q - 0.8).abs() < 1e-3);
        // No command for a long time: nothing changes (no timeout).
        run(&mut core, 30.0);
        assert!((core.fingers[3].q - 0.8).abs() < 1e-3);
        // Half speed: after 0.1 s the fingers moved at most 0.1 of the stroke (2.0 * 0.5 * 0.1).
        core.on_command(&cmd(0.0, 0.5));
        run(&mut core, 0.1);
        let moved = 0.8 - core.fingers[3].q;
        assert!(moved > 0.05 && moved <= 0.1 + 1e-4, "moved {moved}");
        // Speed 0 (clamped from -1): stays where it is.
        let here = core.fingers[3].q;
        core.on_command(&cmd(1.0, -1.0));
        run(&mut core, 0.5);
        assert_eq!(core.fingers[3].q, here);
    }

    #[test]
    fn clamps_out_of_range_and_ignores_malformed() {
        let mut core = BraincoCore::new(&exact()).unwrap();
        assert!(core.on_command(&cmd(7.0, 3.0)));
        assert_eq!((core.fingers[0].target_q, core.fingers[0].target_speed), (1.0, 1.0));
        run(&mut core, 2.0);
        assert_eq!(core.fingers[0].q, HARD_STOPS.1, "hard stop at the register's 1000");
        assert!(!core.on_command(&cmd(f32::NAN, 1.0)));
        assert!(!core.on_command(&cmd(0.5, f32::INFINITY)));
        assert!(!core.on_command(&MotorCmds_::with_len(5)));
        assert!(!core.on_command(&MotorCmds_::with_len(12)));
        assert_eq!((core.commands, core.rejected), (1, 4));
        assert_eq!(core.fingers[0].target_q, 1.0, "a malformed command leaves the target");
    }

    #[test]
    fn object_stops_the_finger_and_raises_the_current() {
        let mut cfg = exact();
        cfg.object[2] = Some(0.4);
        let mut core = BraincoCore::new(&cfg).unwrap();
        core.on_command(&cmd(1.0, 1.0));
        run(&mut core, 1.0);
        let s = core.state();
        assert!((s.states[2].q - 0.4).abs() < 1e-6, "{s:?}");
        assert!(s.states[2].tau_est > 0.5, "pressing: {}", s.states[2].tau_est);
        assert_eq!(s.states[3].q, 1.0);
        assert!(s.states[3].tau_est < 0.1);
    }

    #[test]
    fn state_is_quantised_noisy_and_the_same_seed_repeats() {
        fn run(cfg: &BraincoConfig) -> Vec<[f32; 3]> {
            let mut core = BraincoCore::new(cfg).unwrap();
            (0..20)
                .map(|_| {
                    let s = core.state().states[1];
                    [s.q, s.dq, s.tau_est]
                })
                .collect()
        }
        let cfg = BraincoConfig::new(Side::Right);
        let a = run(&cfg);
        assert_eq!(a, run(&cfg));
        assert_ne!(
            a,
            run(&BraincoConfig {
                noise: cfg.noise.with_seed(1),
                ..cfg.clone()
            })
        );
        assert!(a.iter().any(|s| s[0] != BRAINCO_REST_Q[1]), "noise on by default");
        for s in &a {
            for v in s {
                assert!(((v / REGISTER_STEP) - (v / REGISTER_STEP).round()).abs() < 1e-2, "{v}");
            }
        }
        let exact = run(&BraincoConfig {
            noise: Noise::OFF,
            ..cfg
        });
        assert!(exact
            .iter()
            .all(|s| (s[0] - BRAINCO_REST_Q[1]).abs() < 1e-6 && s[1] == 0.0));
    }

    #[test]
    fn bad_configuration_is_refused() {
        let mut c = exact();
        c.initial[0] = f32::NAN;
        assert!(BraincoCore::new(&c).is_err());
        let mut c = exact();
        c.tuning.full_speed = 0.0;
        assert!(BraincoCore::new(&c).is_err());
        assert!(BraincoConfig::new(Side::Left).rate.period().is_ok());
    }
}
