//! Emulator of `DFX_inspire_service`, the DDS peer of the Inspire DFX adapter: ONE service for
//! both hands (docs/sources.md §7 "Inspire DFX").
//!
//! Behaviour from the source (docs/sources.md §7):
//! - subscribes unitree_go `MotorCmds_` on `rt/inspire/cmd`, publishes `MotorStates_` on
//!   `rt/inspire/state`, always 12 entries (0–5 right, 6–11 left);
//! - only `q` is used: `int16(q · 1000)` clamped to [0, 1000] is the hand's ANGLE_SET, so a
//!   negative q closes fully and q > 1 opens fully;
//! - one loop at 100 Hz; the state (ANGLE_ACT / 1000 in `q`, failed reads in `lost`, nothing
//!   else) is published once per loop;
//! - commands are written only while the subscription is not timed out (1000 ms since the last
//!   command); it starts timed out, so at start-up nothing is commanded and the fingers stay
//!   at their rest posture; after 1 s of silence it stops writing and the hand holds (goes on
//!   to) its last target (**inference** in the source: the firmware keeps its last ANGLE_SET).
//!
//! Assumed (docs/adapters.md, the assumptions table; all in [`DfxTuning`] / [`DfxConfig`]):
//! finger motion is first order toward the target with a speed cap; the fingers rest nearly
//! open ([`DFX_REST_Q`]); a command with a count other than 12 or a non-finite q is ignored
//! and counted (the real service indexes 12 entries unchecked; a NaN cast to int16 is
//! undefined in C++); the hard stops are the register's span 0..1000 = q 0..1; the reported q
//! carries measurement noise ([`DFX_NOISE`], one ANGLE_ACT count) and is quantised to the
//! register (1/1000) and its span; `lost` stays 0 (the emulated serial link never fails); the
//! loop runs at the nominal 100 Hz also while commands stream (the real one is slower then:
//! four 5 ms serial transactions per cycle, docs/sources.md §7 inference).
//!
//! Option (tests): a constant load per entry ([`DfxConfig::sag`], default none): the finger's
//! position loop then settles that far from its ANGLE_SET instead of on it (a servo of finite
//! stiffness under a load, `crate::sim` "Sag"), so a client that re-takes its target from the
//! reported angle every loop makes the finger creep (docs/adapters.md, "Holds").

use std::time::{Duration, Instant};

use handgate_idl::unitree_go::{MotorCmds_, MotorState_, MotorStates_};

use super::{CMD_TOPIC, ENTRIES, SERVICE_RATE_HZ, SERVICE_TIMEOUT, STATE_TOPIC};
use crate::emu_common::{ensure_finite, EmulatorError, Hz};
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Silent, Tick};
use crate::sim::{Noise, Sag, Sensor};

/// Where an emulated finger rests before the first command (wire q): nearly open. A hand
/// powers up wherever it was left; this picks "left open, as xr_teleoperate's start-up
/// command (all q = 1.0) leaves it", 0.01 short of the open stop so the measurement noise
/// never reads past it. An assumption; profiles set their own (`emulator.initial`).
pub const DFX_REST_Q: f32 = 0.99;

/// The register's resolution: ANGLE_SET / ANGLE_ACT are integers 0..1000 (docs/sources.md §7).
pub const REGISTER_COUNTS: f32 = 1000.0;

/// A finger settles on its goal once within half a register count (wire q).
const SETTLE: f32 = 0.5 / REGISTER_COUNTS;

/// The hard stops (wire q): the ANGLE register's whole span 0..1000 (docs/sources.md §7: the
/// service clamps to it). xr_teleoperate's normalisation puts the URDF range on exactly this
/// span, so here the hardware's stops and the table's limits coincide.
pub const HARD_STOPS: (f32, f32) = (0.0, 1.0);

/// Measurement noise: σ of half an ANGLE_ACT count (1/1000 of the range) on `q`, then
/// quantised to whole counts; the service reports no velocity or torque. An assumption (an
/// angle read from the actuator flickers by a count at rest, as the EZGripper's half-tick σ).
pub const DFX_NOISE: Noise = Noise {
    q: 5.0e-4,
    dq: 0.0,
    tau: 0.0,
    seed: Noise::DEFAULT_SEED,
};

/// Values not taken from a public source (plus the 1000 ms timeout, which is).
#[derive(Debug, Clone, PartialEq)]
pub struct DfxTuning {
    /// Silence after which the service stops writing targets (docs/sources.md §7: 1000 ms).
    pub timeout: Duration,
    /// Time constant of the first-order finger motion, s (assumption).
    pub time_constant_s: f32,
    /// Fastest finger motion, wire units (full range) per second (assumption: a full stroke
    /// in about 0.8 s).
    pub max_speed: f32,
}

impl Default for DfxTuning {
    fn default() -> Self {
        Self {
            timeout: SERVICE_TIMEOUT,
            time_constant_s: 0.05,
            max_speed: 1.25,
        }
    }
}

/// Configuration of one emulated DFX_inspire_service (both hands).
#[derive(Debug, Clone, PartialEq)]
pub struct DfxConfig {
    /// Loop and state rate (docs/sources.md §7: nominal 100 Hz).
    pub rate: Hz,
    /// Wire q of each of the 12 entries at start (default [`DFX_REST_Q`]).
    pub initial: [f32; ENTRIES],
    /// Per entry, the wire q at which a closing finger meets an object (`None`: none).
    pub object_at: [Option<f32>; ENTRIES],
    /// Measurement noise on the reported q (default [`DFX_NOISE`]).
    pub noise: Noise,
    /// Per entry, a constant load on the finger as its position loop's steady-state error
    /// (wire q, signed; default none): while the service holds a target the finger settles
    /// there instead of on the target.
    pub sag: [Sag; ENTRIES],
    pub tuning: DfxTuning,
    /// (command, state) topics; `None` = `rt/inspire/cmd`, `rt/inspire/state`. The gateway's
    /// emulator backend puts the service on private topics.
    pub topics: Option<(String, String)>,
}

impl Default for DfxConfig {
    fn default() -> Self {
        Self {
            rate: Hz(SERVICE_RATE_HZ),
            initial: [DFX_REST_Q; ENTRIES],
            object_at: [None; ENTRIES],
            noise: DFX_NOISE,
            sag: [Sag::NONE; ENTRIES],
            tuning: DfxTuning::default(),
            topics: None,
        }
    }
}

/// One finger as the emulator sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerView {
    /// Position, wire q (1 open, 0 closed).
    pub q: f32,
    /// The hand's ANGLE_SET for it, wire q; `None` before the service ever wrote one.
    pub target: Option<f32>,
    /// Whether an object stops it now.
    pub blocked: bool,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct DfxSnapshot {
    /// The last command received, as it came (accepted or not).
    pub last_command: Option<MotorCmds_>,
    /// Accepted commands.
    pub commands: u64,
    /// Commands ignored (count other than 12, non-finite q).
    pub rejected: u64,
    /// ANGLE_SET writes to the hands (two per loop while not timed out).
    pub angle_set_writes: u64,
    /// Whether the subscription is timed out (no command in the last second, or none yet).
    pub timed_out: bool,
    pub fingers: [FingerView; ENTRIES],
    pub states_published: u64,
}

#[derive(Debug, Clone, Copy)]
struct Finger {
    q: f32,
    target: Option<f32>,
    object: Option<f32>,
    blocked: bool,
    sag: Sag,
}

/// The service logic without DDS.
#[derive(Debug, Clone)]
pub struct DfxCore {
    tuning: DfxTuning,
    fingers: [Finger; ENTRIES],
    latest: Option<[f32; ENTRIES]>,
    last_cmd_at: Option<Instant>,
    last_command: Option<MotorCmds_>,
    commands: u64,
    rejected: u64,
    angle_set_writes: u64,
    timed_out: bool,
    sensor: Sensor,
    /// Entries held where they are whatever the command (`--fault stuck=<joint>`; 0–5 right,
    /// 6–11 left).
    stuck: [bool; ENTRIES],
}

/// What the service writes for a commanded q: `int16(q · 1000)` clamped to [0, 1000], in wire
/// units (docs/sources.md §7).
pub fn angle_set(q: f32) -> f32 {
    (q * REGISTER_COUNTS).trunc().clamp(0.0, REGISTER_COUNTS) / REGISTER_COUNTS
}

/// What the state reports for a measured position: the ANGLE_ACT register (an integer in its
/// span) / 1000.
pub fn angle_act(q: f32) -> f32 {
    (q * REGISTER_COUNTS).round().clamp(0.0, REGISTER_COUNTS) / REGISTER_COUNTS
}

impl DfxCore {
    pub fn new(config: &DfxConfig) -> Result<Self, EmulatorError> {
        let t = &config.tuning;
        ensure_finite("initial", config.initial)?;
        ensure_finite("object_at", config.object_at.into_iter().flatten())?;
        ensure_finite("tuning", [t.time_constant_s, t.max_speed])?;
        ensure_finite("sag", config.sag.map(|s| s.0))?;
        if t.time_constant_s <= 0.0 || t.max_speed <= 0.0 {
            return Err(EmulatorError::InvalidConfig(
                "time_constant_s and max_speed must be > 0".into(),
            ));
        }
        config.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        let (lo, hi) = HARD_STOPS;
        let mut fingers = [Finger {
            q: DFX_REST_Q,
            target: None,
            object: None,
            blocked: false,
            sag: Sag::NONE,
        }; ENTRIES];
        for (i, f) in fingers.iter_mut().enumerate() {
            f.q = config.initial[i].clamp(lo, hi);
            f.object = config.object_at[i];
            f.sag = config.sag[i];
        }
        Ok(Self {
            tuning: t.clone(),
            fingers,
            latest: None,
            last_cmd_at: None,
            last_command: None,
            commands: 0,
            rejected: 0,
            angle_set_writes: 0,
            timed_out: true,
            sensor: Sensor::new(config.noise),
            stuck: [false; ENTRIES],
        })
    }

    /// Handles a command (latest wins: it replaces what the loop writes next).
    pub fn on_cmd(&mut self, cmd: &MotorCmds_, now: Instant) -> bool {
        self.last_command = Some(cmd.clone());
        if cmd.cmds.len() != ENTRIES || cmd.cmds.iter().any(|c| !c.q.is_finite()) {
            self.rejected += 1;
            return false;
        }
        let mut q = [0.0; ENTRIES];
        for (q, c) in q.iter_mut().zip(&cmd.cmds) {
            *q = c.q;
        }
        self.latest = Some(q);
        self.last_cmd_at = Some(now);
        self.commands += 1;
        true
    }

    /// Places (or removes) an object in entry `i`'s closing path at wire q `at`.
    pub fn set_object(&mut self, i: usize, at: Option<f32>) {
        if let Some(f) = self.fingers.get_mut(i) {
            f.object = at.filter(|a| a.is_finite());
        }
    }

    /// One loop: writes the latest command unless timed out, then advances the fingers by `dt`.
    pub fn step(&mut self, now: Instant, dt: f32) {
        self.timed_out = self
            .last_cmd_at
            .map_or(true, |t| now.saturating_duration_since(t) >= self.tuning.timeout);
        if !self.timed_out {
            if let Some(latest) = self.latest {
                for (f, q) in self.fingers.iter_mut().zip(latest) {
                    f.target = Some(angle_set(q));
                }
                // One ANGLE_SET write per hand.
                self.angle_set_writes += 2;
            }
        }
        let (lo, hi) = HARD_STOPS;
        let t = &self.tuning;
        for (f, stuck) in self.fingers.iter_mut().zip(self.stuck) {
            let Some(target) = f.target.filter(|_| !stuck) else {
                // Not commanded yet, or stuck: it stays where it is.
                continue;
            };
            // Under a load the position loop settles short of its target.
            let target = f.sag.goal(target).clamp(lo, hi);
            // An object stops a closing finger (closing = decreasing q) where it meets it.
            let floor = f.object.filter(|o| f.q >= *o);
            let goal = floor.map_or(target, |o| target.max(o));
            let v = ((goal - f.q) / t.time_constant_s).clamp(-t.max_speed, t.max_speed);
            let mut q = f.q + v * dt;
            // Never overshoot the goal in one step, and settle on it within half a register
            // count (the firmware's position loop ends on its target).
            if (goal - f.q).signum() != (goal - q).signum() || (goal - q).abs() < SETTLE {
                q = goal;
            }
            f.q = q.clamp(lo, hi);
            f.blocked = floor.is_some_and(|o| target < o && (f.q - o).abs() < SETTLE);
        }
    }

    /// The published state: 12 entries, `q` = ANGLE_ACT / 1000 (measured, quantised),
    /// `lost` 0, nothing else (docs/sources.md §7).
    pub fn state(&mut self) -> MotorStates_ {
        let sd = self.sensor.noise().q;
        let sensor = &mut self.sensor;
        MotorStates_ {
            states: self
                .fingers
                .iter()
                .map(|f| MotorState_ {
                    q: angle_act(sensor.add(f.q, sd)),
                    ..MotorState_::default()
                })
                .collect(),
        }
    }

    pub fn snapshot(&self) -> DfxSnapshot {
        let mut fingers = [FingerView {
            q: 0.0,
            target: None,
            blocked: false,
        }; ENTRIES];
        for (v, f) in fingers.iter_mut().zip(&self.fingers) {
            *v = FingerView {
                q: f.q,
                target: f.target,
                blocked: f.blocked,
            };
        }
        DfxSnapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            rejected: self.rejected,
            angle_set_writes: self.angle_set_writes,
            timed_out: self.timed_out,
            fingers,
            states_published: 0,
        }
    }
}

impl ServiceCore for DfxCore {
    type Config = DfxConfig;
    type Snapshot = DfxSnapshot;

    fn from_config(config: &DfxConfig) -> Result<Self, EmulatorError> {
        Self::new(config)
    }

    fn plan(config: &DfxConfig) -> Result<ServicePlan, EmulatorError> {
        let (cmd_topic, state_topic) = topics(config);
        Ok(ServicePlan::new(
            "inspire-dfx-emu",
            config.rate,
            cmd_topic,
            Some(state_topic),
        ))
    }

    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "DFX_inspire_service's two hands")
    }

    fn report(&self, published: Published) -> DfxSnapshot {
        DfxSnapshot {
            states_published: published.state,
            ..self.snapshot()
        }
    }
}

impl ServiceWire<Self> for DfxCore {
    type Cmd = MotorCmds_;
    type State = MotorStates_;
    type Extra = Silent;

    fn receive(core: &mut Self, cmd: &MotorCmds_, now: Instant) {
        core.on_cmd(cmd, now);
    }

    fn cycle(core: &mut Self, tick: Tick) -> Option<MotorStates_> {
        core.step(tick.now, tick.dt);
        Some(core.state())
    }
}

/// (command, state) topics of a service started with `config`.
fn topics(config: &DfxConfig) -> (String, String) {
    config
        .topics
        .clone()
        .unwrap_or_else(|| (CMD_TOPIC.to_string(), STATE_TOPIC.to_string()))
}

/// A running emulated DFX_inspire_service (both hands). Dropping it stops its loop.
pub type DfxEmulator = ServiceEmulator<DfxCore>;

impl DfxEmulator {
    /// (command, state) topics it serves.
    pub fn topics(&self) -> (String, String) {
        topics(self.config())
    }

    /// Entry `i`'s finger (0–5 right, 6–11 left).
    pub fn finger(&self, i: usize) -> FingerView {
        self.snapshot().fingers[i]
    }

    /// Places (or removes) an object in entry `i`'s closing path.
    pub fn set_object(&self, i: usize, at: Option<f32>) {
        self.with_core(|c| c.set_object(i, at));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_idl::unitree_go::MotorCmd_;

    fn cmd(q: [f32; ENTRIES]) -> MotorCmds_ {
        MotorCmds_ {
            cmds: q
                .iter()
                .map(|&q| MotorCmd_ {
                    q,
                    ..MotorCmd_::default()
                })
                .collect(),
        }
    }

    fn exact() -> DfxConfig {
        DfxConfig {
            noise: Noise::OFF,
            ..DfxConfig::default()
        }
    }

    /// Steps `core` every 10 ms (the service's period) from `from_ms` to `to_ms` after `t0`.
    fn run(core: &mut DfxCore, t0: Instant, from_ms: u64, to_ms: u64) {
        let mut k = from_ms;
        while k < to_ms {
            core.step(t0 + Duration::from_millis(k), 0.01);
            k += 10;
        }
    }

    #[test]
    fn a_stuck_entry_stays_where_it_is_while_the_others_follow() {
        let mut core = DfxCore::new(&exact()).unwrap();
        core.stick(9).unwrap(); // the left index
        assert!(core.stick(ENTRIES).is_err(), "an entry the pair does not have");
        let t0 = Instant::now();
        assert!(core.on_cmd(&cmd([0.2; 12]), t0));
        run(&mut core, t0, 0, 900);
        let s = core.snapshot();
        assert_eq!(s.fingers[9].q, DFX_REST_Q, "stuck where it rested");
        assert!(s.fingers.iter().enumerate().all(|(i, f)| i == 9 || f.q == 0.2));
    }

    #[test]
    fn starts_at_rest_timed_out_and_writes_nothing_until_a_command() {
        let mut core = DfxCore::new(&exact()).unwrap();
        let t0 = Instant::now();
        run(&mut core, t0, 0, 3000);
        let s = core.snapshot();
        assert!(s.timed_out);
        assert_eq!(s.angle_set_writes, 0);
        assert!(s.fingers.iter().all(|f| f.target.is_none() && f.q == DFX_REST_Q));
        let st = core.state();
        assert_eq!(st.states.len(), 12);
        assert!(st
            .states
            .iter()
            .all(|m| m.q == DFX_REST_Q && m.dq == 0.0 && m.lost == 0));
    }

    #[test]
    fn follows_the_latest_command_then_stops_writing_after_1_s_and_holds_the_last_target() {
        let mut core = DfxCore::new(&exact()).unwrap();
        let t0 = Instant::now();
        assert!(core.on_cmd(&cmd([0.2; 12]), t0));
        let mut q = [0.2; 12];
        q[6] = 0.7;
        // Latest wins: the second command replaces the first before the loop writes.
        assert!(core.on_cmd(&cmd(q), t0));
        run(&mut core, t0, 0, 100);
        let s = core.snapshot();
        assert!(!s.timed_out);
        assert_eq!(s.fingers[6].target, Some(0.7));
        assert_eq!(s.fingers[0].target, Some(0.2));
        // First order with a speed cap: moving, not there yet after 100 ms.
        assert!(
            s.fingers[0].q < DFX_REST_Q && s.fingers[0].q > 0.2,
            "{}",
            s.fingers[0].q
        );
        run(&mut core, t0, 100, 990);
        let s = core.snapshot();
        assert!((s.fingers[0].q - 0.2).abs() < 1e-3, "{}", s.fingers[0].q);
        assert!((s.fingers[6].q - 0.7).abs() < 1e-3);
        let writes = s.angle_set_writes;
        assert_eq!(writes, 2 * 99, "two ANGLE_SET writes (one per hand) per loop");
        // Silence: from 1 s after the command the service writes nothing more...
        run(&mut core, t0, 1000, 3000);
        let s = core.snapshot();
        assert!(s.timed_out);
        assert_eq!(s.angle_set_writes, writes);
        // ...and the hand holds its last target.
        assert!((s.fingers[0].q - 0.2).abs() < 1e-3);
        assert_eq!(core.state().states[6].q, 0.7);
        // The next command is written again.
        assert!(core.on_cmd(&cmd([1.0; 12]), t0 + Duration::from_millis(3000)));
        run(&mut core, t0, 3000, 3010);
        assert!(core.snapshot().angle_set_writes > writes);
    }

    #[test]
    fn q_is_clamped_to_the_register_span_and_the_fingers_stop_at_the_hard_stops() {
        assert_eq!(angle_set(-0.5), 0.0);
        assert_eq!(angle_set(1.5), 1.0);
        assert_eq!(angle_set(0.4567), 0.456);
        let mut core = DfxCore::new(&exact()).unwrap();
        let t0 = Instant::now();
        let mut q = [-3.0; 12];
        q[6..].copy_from_slice(&[7.0; 6]);
        core.on_cmd(&cmd(q), t0);
        // The target stays after the service's timeout: the fingers go on to it.
        run(&mut core, t0, 0, 1500);
        let s = core.snapshot();
        assert!(
            s.fingers[..6]
                .iter()
                .all(|f| f.q == HARD_STOPS.0 && f.target == Some(0.0)),
            "{:?}",
            s.fingers
        );
        assert!(s.fingers[6..].iter().all(|f| f.q == HARD_STOPS.1));
    }

    /// A load (`DfxConfig::sag`) moves a finger held at a fixed ANGLE_SET once, by the sag,
    /// and never further; the other fingers settle on their target.
    #[test]
    fn a_loaded_finger_settles_off_its_target_by_the_sag_and_stays() {
        let mut cfg = exact();
        cfg.sag[5] = Sag(-0.003);
        let mut core = DfxCore::new(&cfg).unwrap();
        let t0 = Instant::now();
        core.on_cmd(&cmd([0.5; 12]), t0);
        run(&mut core, t0, 0, 900);
        let s = core.snapshot();
        assert!((s.fingers[5].q - 0.497).abs() < 1e-6, "{:?}", s.fingers[5]);
        assert_eq!(s.fingers[4].q, 0.5);
        // The service times out after 1 s; the hand keeps its target, the finger its sag.
        run(&mut core, t0, 900, 60_000);
        assert!((core.snapshot().fingers[5].q - 0.497).abs() < 1e-6);
        assert!(DfxCore::new(&DfxConfig {
            sag: [Sag(f32::NAN); ENTRIES],
            ..exact()
        })
        .is_err());
    }

    #[test]
    fn bad_commands_are_ignored_and_counted() {
        let mut core = DfxCore::new(&exact()).unwrap();
        let t0 = Instant::now();
        assert!(!core.on_cmd(&MotorCmds_::with_len(6), t0));
        assert!(!core.on_cmd(&MotorCmds_::default(), t0));
        let mut q = [0.5; 12];
        q[3] = f32::NAN;
        assert!(!core.on_cmd(&cmd(q), t0));
        run(&mut core, t0, 0, 100);
        let s = core.snapshot();
        assert_eq!((s.commands, s.rejected, s.angle_set_writes), (0, 3, 0));
        assert!(s.timed_out);
        assert!(DfxCore::new(&DfxConfig {
            tuning: DfxTuning {
                max_speed: 0.0,
                ..DfxTuning::default()
            },
            ..exact()
        })
        .is_err());
    }

    #[test]
    fn an_object_stops_a_closing_finger() {
        let mut cfg = exact();
        cfg.object_at[3] = Some(0.4);
        let mut core = DfxCore::new(&cfg).unwrap();
        let t0 = Instant::now();
        core.on_cmd(&cmd([0.0; 12]), t0);
        run(&mut core, t0, 0, 1500);
        let s = core.snapshot();
        assert!(
            (s.fingers[3].q - 0.4).abs() < 1e-4 && s.fingers[3].blocked,
            "{:?}",
            s.fingers[3]
        );
        assert!(s.fingers[2].q < 1e-3);
    }

    #[test]
    fn rest_is_not_zero_noise_is_seeded_and_quantised() {
        fn run(cfg: &DfxConfig) -> Vec<f32> {
            let mut core = DfxCore::new(cfg).unwrap();
            (0..20).flat_map(|_| core.state().states).map(|m| m.q).collect()
        }
        let cfg = DfxConfig::default();
        let a = run(&cfg);
        assert!(a
            .iter()
            .all(|q| (q - DFX_REST_Q).abs() <= 3.0 * DFX_NOISE.q + 1e-3 && *q <= 1.0));
        assert!(a.iter().any(|q| *q != DFX_REST_Q), "noise on by default");
        assert!(
            a.iter().all(|q| (q * 1000.0 - (q * 1000.0).round()).abs() < 1e-3),
            "ANGLE_ACT counts"
        );
        assert_eq!(a, run(&cfg));
        assert_ne!(
            a,
            run(&DfxConfig {
                noise: cfg.noise.with_seed(cfg.noise.seed ^ 1),
                ..cfg.clone()
            })
        );
        assert!(run(&exact()).iter().all(|q| *q == DFX_REST_Q));
    }
}
