//! Emulator of the G1 `ai_sport` Hand SDK blend: the DDS peer an `rt/hand_sdk` adapter
//! talks to.
//!
//! It subscribes `unitree_go::msg::dds_::MotorCmds_` with 4 entries on `rt/hand_sdk`. The
//! weight is `cmds[0].mode / 100` (the other entries' mode is unused). Every control tick it
//! sends each motor, for all five fields (q, dq, tau, kp, kd),
//! `weight * user + (1 - weight) * default`, where default is ai_sport's own command
//! (docs/sources.md §6). It publishes nothing: no state topic is
//! documented. Tests inspect what it would send to the motors.
//!
//! Documented behaviour reproduced: all five fields blended; auto-fallback to ai_sport's own
//! command when the user stops publishing; user commands not forwarded in the damping state,
//! and the weight must be set again after leaving it; positive tau closes.
//! Assumed (not public; one table in [`HandSdkConfig`]): the fallback timeout (100 ms
//! default), the control rate (500 Hz), ai_sport's default and damping commands, mode > 100
//! clamped to weight 1 (and counted), messages with a wrong entry count or non-finite values
//! ignored (and counted), a step back to weight 0 on fallback / damping (no ramp down), and the
//! joint models' parameters.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use handgate_idl::unitree_go::MotorCmds_;

use crate::emu_common::{ensure_finite, EmulatorError, Hz};
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Silent, Tick};
use crate::sim::{JointModel, JointParams, MotorTarget};

use super::{MOTORS, TOPIC};

/// `cmds[0].mode` value meaning weight 1.
pub const WEIGHT_MODE_FULL: u8 = 100;

/// A blend weight in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Weight(f32);

impl Weight {
    pub const ZERO: Weight = Weight(0.0);
    pub const ONE: Weight = Weight(1.0);

    /// Decodes `cmds[0].mode` (weight * 100 as an integer). Values above 100 clamp to 1; the
    /// flag says so.
    pub fn from_mode(mode: u8) -> (Weight, bool) {
        let clamped = mode > WEIGHT_MODE_FULL;
        (Weight(f32::from(mode.min(WEIGHT_MODE_FULL)) / 100.0), clamped)
    }

    pub fn value(self) -> f32 {
        self.0
    }
}

/// `w * user + (1 - w) * default`, field by field, for all five fields. At w = 0 the result
/// is exactly `default` (the user command plays no part, even if it were not finite).
pub fn blend(w: Weight, user: &MotorTarget, default: &MotorTarget) -> MotorTarget {
    if w.0 == 0.0 {
        return *default;
    }
    let f = |u: f32, d: f32| w.0 * u + (1.0 - w.0) * d;
    MotorTarget {
        q: f(user.q, default.q),
        dq: f(user.dq, default.dq),
        tau: f(user.tau, default.tau),
        kp: f(user.kp, default.kp),
        kd: f(user.kd, default.kd),
    }
}

/// Where the emulated joints rest, rad (0 = open): slightly flexed, as a relaxed hand is, and
/// what ai_sport's own command holds by default. An assumption (the motors' ranges and
/// ai_sport's default posture are not public). The emulator publishes no state (none is
/// documented), so it has no measurement noise to add.
pub const HAND_SDK_REST_Q: f32 = 0.15;

/// Joint models run under the blended command (positive tau closes: q grows towards closed).
#[derive(Debug, Clone, PartialEq)]
pub struct HandSdkModels {
    pub params: [JointParams; MOTORS],
    pub initial_q: [f32; MOTORS],
}

impl Default for HandSdkModels {
    fn default() -> Self {
        // Assumption: a generic finger joint, 0 = open .. 1.7 rad = closed.
        let p = JointParams {
            inertia: 2.0e-4,
            friction: 0.02,
            tau_max: 1.5,
            q_min: 0.0,
            q_max: 1.7,
        };
        Self {
            params: [p; MOTORS],
            initial_q: [HAND_SDK_REST_Q; MOTORS],
        }
    }
}

/// Configuration of the emulated blend; every value here is an assumption (see module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct HandSdkConfig {
    /// Control tick rate (default 500 Hz).
    pub control_rate: Hz,
    /// Silence after which ai_sport falls back to its own command (default 100 ms; the real
    /// value is not published).
    pub user_timeout: Duration,
    /// ai_sport's own command per motor (default: a relaxed hold at [`HAND_SDK_REST_Q`] with
    /// kp 0.5, kd 0.05).
    pub defaults: [MotorTarget; MOTORS],
    /// What the motors get in the damping state (default: kp 0, kd 0.1).
    pub damping_command: [MotorTarget; MOTORS],
    /// Joint models under the blended command; `None`: no motion emulated.
    pub models: Option<HandSdkModels>,
    /// Distinct effective weights kept in the history (oldest dropped first).
    pub history_capacity: usize,
    /// Topic to listen on (default `rt/hand_sdk`; the gateway's emulator backend uses a
    /// private one).
    pub topic: String,
}

impl Default for HandSdkConfig {
    fn default() -> Self {
        Self {
            control_rate: Hz(500.0),
            user_timeout: Duration::from_millis(100),
            defaults: [MotorTarget {
                q: HAND_SDK_REST_Q,
                dq: 0.0,
                tau: 0.0,
                kp: 0.5,
                kd: 0.05,
            }; MOTORS],
            damping_command: [MotorTarget {
                kd: 0.1,
                ..MotorTarget::LIMP
            }; MOTORS],
            models: Some(HandSdkModels::default()),
            history_capacity: 4096,
            topic: TOPIC.to_string(),
        }
    }
}

impl HandSdkConfig {
    /// Checks the rate and that commands, joint parameters and positions are finite.
    pub fn validate(&self) -> Result<(), EmulatorError> {
        self.control_rate.period()?;
        let fields = |t: &MotorTarget| [t.q, t.dq, t.tau, t.kp, t.kd];
        for t in self.defaults.iter().chain(&self.damping_command) {
            ensure_finite("default / damping command", fields(t))?;
        }
        if let Some(m) = &self.models {
            ensure_finite("model initial_q", m.initial_q)?;
            for p in &m.params {
                ensure_finite("model params", [p.inertia, p.friction, p.tau_max, p.q_min, p.q_max])?;
                if !(p.inertia > 0.0 && p.q_min < p.q_max) {
                    return Err(EmulatorError::InvalidConfig(format!("bad joint params {p:?}")));
                }
            }
        }
        Ok(())
    }
}

/// Message counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HandSdkCounts {
    /// Every message taken from the topic.
    pub received: u64,
    /// Messages that set the user command and weight.
    pub accepted: u64,
    /// Ignored: not 4 entries.
    pub rejected_size: u64,
    /// Ignored: a non-finite field.
    pub rejected_non_finite: u64,
    /// Ignored: arrived in the damping state.
    pub ignored_damping: u64,
    /// Accepted with `cmds[0].mode` > 100 (weight clamped to 1).
    pub weight_clamped: u64,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct HandSdkSnapshot {
    /// The weight applied in the last tick.
    pub effective_weight: f32,
    /// The weight the user last set (0 until set, and again after damping).
    pub user_weight: f32,
    /// Whether a message has set the weight since start / since leaving damping.
    pub weight_set: bool,
    /// The user has been silent longer than the timeout: ai_sport's own command applies.
    pub fallback: bool,
    pub damping: bool,
    /// The last user command accepted (as targets, in message order).
    pub last_user: Option<[MotorTarget; MOTORS]>,
    /// What each motor was sent in the last tick.
    pub blended: [MotorTarget; MOTORS],
    pub counts: HandSdkCounts,
    /// Control ticks run.
    pub ticks: u64,
    /// Joint positions, if models run.
    pub joint_q: Option<[f32; MOTORS]>,
}

/// The blend logic without DDS.
#[derive(Debug, Clone)]
pub struct HandSdkCore {
    config: HandSdkConfig,
    user: Option<[MotorTarget; MOTORS]>,
    weight: Weight,
    weight_set: bool,
    last_user_at: Option<Instant>,
    damping: bool,
    effective: Weight,
    fallback: bool,
    blended: [MotorTarget; MOTORS],
    history: VecDeque<f32>,
    counts: HandSdkCounts,
    ticks: u64,
    joints: Option<[JointModel; MOTORS]>,
}

impl HandSdkCore {
    pub fn new(config: HandSdkConfig) -> Self {
        let joints = config
            .models
            .as_ref()
            .map(|m| std::array::from_fn(|i| JointModel::new(m.params[i], m.initial_q[i])));
        Self {
            blended: config.defaults,
            config,
            user: None,
            weight: Weight::ZERO,
            weight_set: false,
            last_user_at: None,
            damping: false,
            effective: Weight::ZERO,
            fallback: false,
            // Starts at 0: a first message with weight 1 shows as a 0 -> 1 step.
            history: VecDeque::from([0.0]),
            counts: HandSdkCounts::default(),
            ticks: 0,
            joints,
        }
    }

    /// Handles one message received at `now`. Returns whether it was accepted.
    pub fn on_command(&mut self, msg: &MotorCmds_, now: Instant) -> bool {
        self.counts.received += 1;
        if self.damping {
            self.counts.ignored_damping += 1;
            return false;
        }
        if msg.cmds.len() != MOTORS {
            self.counts.rejected_size += 1;
            return false;
        }
        if msg
            .cmds
            .iter()
            .any(|c| ![c.q, c.dq, c.tau, c.kp, c.kd].iter().all(|v| v.is_finite()))
        {
            self.counts.rejected_non_finite += 1;
            return false;
        }
        let (w, clamped) = Weight::from_mode(msg.cmds[0].mode);
        self.counts.weight_clamped += u64::from(clamped);
        self.counts.accepted += 1;
        self.user = Some(std::array::from_fn(|i| {
            let c = &msg.cmds[i];
            MotorTarget {
                q: c.q,
                dq: c.dq,
                tau: c.tau,
                kp: c.kp,
                kd: c.kd,
            }
        }));
        self.weight = w;
        self.weight_set = true;
        self.last_user_at = Some(now);
        true
    }

    /// Enters or leaves the damping state. Leaving it forgets the weight: it is 0 until a new
    /// message sets it (docs/sources.md §6).
    pub fn set_damping(&mut self, on: bool) {
        if self.damping && !on {
            self.weight_set = false;
            self.weight = Weight::ZERO;
        }
        self.damping = on;
    }

    /// One control tick at `now`: decides the weight, blends, records, moves the joints.
    pub fn tick(&mut self, now: Instant, dt: f32) {
        self.ticks += 1;
        self.fallback = !self.damping
            && self.weight_set
            && self
                .last_user_at
                .is_some_and(|t| now.saturating_duration_since(t) > self.config.user_timeout);
        let w = if self.damping || !self.weight_set || self.fallback {
            Weight::ZERO
        } else {
            self.weight
        };
        self.effective = w;
        self.blended = if self.damping {
            self.config.damping_command
        } else {
            match &self.user {
                Some(user) => std::array::from_fn(|i| blend(w, &user[i], &self.config.defaults[i])),
                None => self.config.defaults,
            }
        };
        if self.history.back() != Some(&w.0) {
            if self.history.len() >= self.config.history_capacity.max(1) {
                self.history.pop_front();
            }
            self.history.push_back(w.0);
        }
        if let Some(joints) = self.joints.as_mut() {
            for (j, t) in joints.iter_mut().zip(&self.blended) {
                j.step(t, dt);
            }
        }
    }

    /// Distinct effective weights in the order applied.
    pub fn weight_history(&self) -> Vec<f32> {
        self.history.iter().copied().collect()
    }

    pub fn snapshot(&self) -> HandSdkSnapshot {
        HandSdkSnapshot {
            effective_weight: self.effective.0,
            user_weight: self.weight.0,
            weight_set: self.weight_set,
            fallback: self.fallback,
            damping: self.damping,
            last_user: self.user,
            blended: self.blended,
            counts: self.counts,
            ticks: self.ticks,
            joint_q: self.joints.as_ref().map(|j| std::array::from_fn(|i| j[i].q)),
        }
    }
}

/// The largest rise between consecutive weights of a history (0 for none): a ramp keeps it
/// small, a 0 -> 1 step makes it 1.
pub fn largest_weight_step_up(history: &[f32]) -> f32 {
    history.windows(2).map(|w| w[1] - w[0]).fold(0.0, f32::max)
}

impl ServiceCore for HandSdkCore {
    type Config = HandSdkConfig;
    type Snapshot = HandSdkSnapshot;

    fn from_config(config: &HandSdkConfig) -> Result<Self, EmulatorError> {
        config.validate()?;
        Ok(Self::new(config.clone()))
    }

    fn plan(config: &HandSdkConfig) -> Result<ServicePlan, EmulatorError> {
        Ok(ServicePlan::new(
            "hand-sdk-emu",
            config.control_rate,
            config.topic.clone(),
            None,
        ))
    }

    fn report(&self, _published: Published) -> HandSdkSnapshot {
        self.snapshot()
    }
}

impl ServiceWire<Self> for HandSdkCore {
    type Cmd = MotorCmds_;
    type State = Silent;
    type Extra = Silent;

    fn receive(core: &mut Self, msg: &MotorCmds_, now: Instant) {
        core.on_command(msg, now);
    }

    /// One control tick; nothing published (no state topic is documented).
    fn cycle(core: &mut Self, tick: Tick) -> Option<Silent> {
        core.tick(tick.now, tick.dt);
        None
    }
}

/// A running emulated ai_sport blend. Dropping it stops its loop.
pub type HandSdkEmulator = ServiceEmulator<HandSdkCore>;

impl HandSdkEmulator {
    /// The weight applied in the last tick.
    pub fn effective_weight(&self) -> f32 {
        self.with_core(|c| c.effective.0)
    }

    /// What each motor was sent in the last tick.
    pub fn last_blended(&self) -> [MotorTarget; MOTORS] {
        self.with_core(|c| c.blended)
    }

    /// Distinct effective weights in the order applied (see [`largest_weight_step_up`]).
    pub fn weight_history(&self) -> Vec<f32> {
        self.with_core(|c| c.weight_history())
    }

    /// The user went silent: ai_sport's own command applies.
    pub fn fallback(&self) -> bool {
        self.with_core(|c| c.fallback)
    }

    pub fn counts(&self) -> HandSdkCounts {
        self.with_core(|c| c.counts)
    }

    /// Enters or leaves the robot's damping state.
    pub fn set_damping(&self, on: bool) {
        self.with_core(|c| c.set_damping(on));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dds::{Node, Qos, Writer};
    use crate::emu_common::{wait_for, TEST_WAIT as WAIT};
    use handgate_idl::unitree_go::MotorCmd_;
    use proptest::prelude::*;

    fn t(q: f32, dq: f32, tau: f32, kp: f32, kd: f32) -> MotorTarget {
        MotorTarget { q, dq, tau, kp, kd }
    }

    fn msg(mode: u8, targets: [MotorTarget; MOTORS]) -> MotorCmds_ {
        MotorCmds_ {
            cmds: targets
                .iter()
                .enumerate()
                .map(|(i, x)| MotorCmd_ {
                    // Only cmds[0].mode carries the weight; the others are unused.
                    mode: if i == 0 { mode } else { 77 },
                    q: x.q,
                    dq: x.dq,
                    tau: x.tau,
                    kp: x.kp,
                    kd: x.kd,
                    ..MotorCmd_::default()
                })
                .collect(),
        }
    }

    #[test]
    fn weight_decoding() {
        assert_eq!(Weight::from_mode(0), (Weight::ZERO, false));
        assert_eq!(Weight::from_mode(50), (Weight(0.5), false));
        assert_eq!(Weight::from_mode(100), (Weight::ONE, false));
        assert_eq!(Weight::from_mode(101), (Weight::ONE, true));
        assert_eq!(Weight::from_mode(255), (Weight::ONE, true));
    }

    #[test]
    fn blend_known_values() {
        let user = t(3.0, 1.0, 0.5, 6.0, 0.25);
        let def = t(1.0, 0.0, 0.0, 2.0, 0.5);
        assert_eq!(blend(Weight(0.25), &user, &def), t(1.5, 0.25, 0.125, 3.0, 0.4375));
        assert_eq!(blend(Weight::ONE, &user, &def), user);
        assert_eq!(blend(Weight::ZERO, &user, &def), def);
        let nan = t(f32::NAN, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(blend(Weight::ZERO, &nan, &def), def);
    }

    proptest! {
        #[test]
        fn blend_stays_between_user_and_default(
            mode in 0u8..=100,
            u in prop::array::uniform5(-10.0f32..10.0),
            d in prop::array::uniform5(-10.0f32..10.0),
        ) {
            let (w, _) = Weight::from_mode(mode);
            let r = blend(w, &t(u[0], u[1], u[2], u[3], u[4]), &t(d[0], d[1], d[2], d[3], d[4]));
            let r = [r.q, r.dq, r.tau, r.kp, r.kd];
            for k in 0..5 {
                let (lo, hi) = (u[k].min(d[k]), u[k].max(d[k]));
                prop_assert!(r[k] >= lo - 1e-5 && r[k] <= hi + 1e-5, "field {} = {} not in [{}, {}]", k, r[k], lo, hi);
            }
        }
    }

    #[test]
    fn core_fallback_damping_and_counts() {
        let mut core = HandSdkCore::new(HandSdkConfig::default());
        let t0 = Instant::now();
        let user = [t(1.0, 0.0, 0.3, 1.0, 0.1); 4];
        assert!(core.on_command(&msg(100, user), t0));
        core.tick(t0 + Duration::from_millis(100), 0.002);
        assert_eq!(core.effective, Weight::ONE);
        core.tick(t0 + Duration::from_millis(101), 0.002);
        assert!(core.fallback);
        assert_eq!(core.blended, core.config.defaults);
        // Damping: ignored, damping command sent, weight forgotten on exit.
        core.on_command(&msg(100, user), t0 + Duration::from_millis(200));
        core.set_damping(true);
        assert!(!core.on_command(&msg(100, user), t0 + Duration::from_millis(201)));
        core.tick(t0 + Duration::from_millis(202), 0.002);
        assert_eq!(core.blended, core.config.damping_command);
        core.set_damping(false);
        core.tick(t0 + Duration::from_millis(203), 0.002);
        assert_eq!(core.effective, Weight::ZERO);
        assert!(!core.fallback, "weight unset is not fallback");
        assert!(!core.on_command(&MotorCmds_::with_len(3), t0));
        assert!(core.on_command(&msg(200, user), t0 + Duration::from_millis(204)));
        core.tick(t0 + Duration::from_millis(205), 0.002);
        assert_eq!(core.effective, Weight::ONE);
        let c = core.counts;
        assert_eq!(
            (
                c.received,
                c.accepted,
                c.ignored_damping,
                c.rejected_size,
                c.weight_clamped
            ),
            (5, 3, 1, 1, 1)
        );
        assert_eq!(core.weight_history(), vec![0.0, 1.0, 0.0, 1.0]);
    }

    #[test]
    fn invalid_configs_are_errors() {
        let mut c = HandSdkConfig::default();
        c.defaults[3].kp = f32::NAN;
        assert!(matches!(c.validate(), Err(EmulatorError::InvalidConfig(_))));
        let c = HandSdkConfig {
            control_rate: Hz(-5.0),
            ..HandSdkConfig::default()
        };
        assert!(c.validate().is_err());
        assert!(HandSdkConfig::default().validate().is_ok());
    }

    #[test]
    fn step_detector_sees_steps_and_ramps() {
        assert_eq!(largest_weight_step_up(&[0.0, 1.0]), 1.0);
        assert!(largest_weight_step_up(&[0.0, 0.1, 0.2, 0.3, 0.0]) < 0.11);
        assert_eq!(largest_weight_step_up(&[]), 0.0);
    }

    // ---- over real DDS (domains 42..=47) ----

    /// A fallback timeout no test thread stall can reach (for tests not about fallback).
    fn patient() -> HandSdkConfig {
        HandSdkConfig {
            user_timeout: Duration::from_secs(60),
            ..HandSdkConfig::default()
        }
    }

    fn setup(domain: u32, config: HandSdkConfig) -> (HandSdkEmulator, Node, Writer<MotorCmds_>) {
        crate::emu_common::isolated_test_domain(domain);
        let emu_node = Node::new(domain, None).unwrap();
        let emu = HandSdkEmulator::start(&emu_node, config).unwrap();
        let node = Node::new(domain, None).unwrap();
        let w = node.writer::<MotorCmds_>(TOPIC, Qos::Reliable { depth: 4 }).unwrap();
        w.wait_matched(1, WAIT).unwrap();
        (emu, node, w)
    }

    /// Writes `m` and waits until the emulator has taken it and run a tick after it.
    fn send(emu: &HandSdkEmulator, w: &mut Writer<MotorCmds_>, m: MotorCmds_) {
        let before = emu.counts().received;
        w.write(m).unwrap();
        wait_for(|| emu.counts().received > before);
        let ticks = emu.snapshot().ticks;
        wait_for(|| emu.snapshot().ticks > ticks);
    }

    #[test]
    fn dds_blend_is_exact_for_known_inputs() {
        let mut cfg = patient();
        cfg.defaults = [
            t(1.0, 0.0, 0.0, 2.0, 0.5),
            t(0.0, 0.0, 0.5, 1.0, 0.25),
            t(-1.0, 0.5, 0.0, 0.0, 0.0),
            t(2.0, -1.0, -0.5, 4.0, 1.0),
        ];
        let (emu, _node, mut w) = setup(42, cfg);
        let user = [
            t(3.0, 1.0, 0.5, 6.0, 0.25),
            t(4.0, 2.0, -0.5, 5.0, 0.25),
            t(1.0, 0.5, 1.0, 8.0, 2.0),
            t(2.0, 1.0, 0.5, 0.0, 0.0),
        ];
        send(&emu, &mut w, msg(25, user));
        assert_eq!(emu.effective_weight(), 0.25);
        assert_eq!(
            emu.last_blended(),
            [
                t(1.5, 0.25, 0.125, 3.0, 0.4375),
                t(1.0, 0.5, 0.25, 2.0, 0.25),
                t(-0.5, 0.5, 0.25, 2.0, 0.5),
                t(2.0, -0.5, -0.25, 3.0, 0.75),
            ]
        );
        send(&emu, &mut w, msg(50, user));
        assert_eq!(emu.last_blended()[0], t(2.0, 0.5, 0.25, 4.0, 0.375));
        send(&emu, &mut w, msg(100, user));
        assert_eq!(emu.last_blended(), user);
        assert!(!emu.fallback());
    }

    #[test]
    fn dds_falls_back_to_ai_sport_command_when_the_user_goes_silent() {
        let cfg = HandSdkConfig::default();
        let defaults = cfg.defaults;
        let (emu, _node, mut w) = setup(43, cfg);
        let user = [t(1.0, 0.0, 0.3, 1.0, 0.1); 4];
        let written = Instant::now();
        send(&emu, &mut w, msg(100, user));
        wait_for(|| emu.fallback());
        assert!(written.elapsed() > Duration::from_millis(100));
        assert_eq!(emu.effective_weight(), 0.0);
        assert_eq!(emu.last_blended(), defaults);
        // Publishing again takes over again (read from the history: a stalled test thread
        // may let the 100 ms fallback happen once more before it looks).
        send(&emu, &mut w, msg(100, user));
        let h = emu.weight_history();
        assert!(h.windows(3).any(|x| x == [1.0, 0.0, 1.0]), "{h:?}");
    }

    #[test]
    fn dds_damping_ignores_commands_and_requires_the_weight_again() {
        // Long timeout: a zero weight below can only come from the damping rule.
        let cfg = patient();
        let damping_cmd = cfg.damping_command;
        let (emu, _node, mut w) = setup(44, cfg);
        let user = [t(1.0, 0.0, 0.3, 1.0, 0.1); 4];
        send(&emu, &mut w, msg(50, user));
        assert_eq!(emu.effective_weight(), 0.5);
        emu.set_damping(true);
        let ticks = emu.snapshot().ticks;
        wait_for(|| emu.snapshot().ticks > ticks);
        assert_eq!(emu.effective_weight(), 0.0);
        assert_eq!(emu.last_blended(), damping_cmd);
        send(&emu, &mut w, msg(100, user));
        assert_eq!(emu.counts().ignored_damping, 1);
        assert_eq!(emu.last_blended(), damping_cmd);
        emu.set_damping(false);
        let ticks = emu.snapshot().ticks;
        wait_for(|| emu.snapshot().ticks > ticks + 5);
        let s = emu.snapshot();
        assert_eq!(s.effective_weight, 0.0);
        assert!(!s.weight_set && !s.fallback);
        send(&emu, &mut w, msg(40, user));
        assert_eq!(emu.effective_weight(), 0.4);
    }

    #[test]
    fn dds_wrong_entry_counts_are_ignored_and_mode_over_100_clamps() {
        let (emu, _node, mut w) = setup(45, patient());
        send(&emu, &mut w, MotorCmds_::with_len(3));
        send(&emu, &mut w, MotorCmds_::with_len(5));
        let c = emu.counts();
        assert_eq!((c.rejected_size, c.accepted), (2, 0));
        assert_eq!(emu.effective_weight(), 0.0);
        send(&emu, &mut w, msg(180, [t(0.5, 0.0, 0.0, 1.0, 0.0); 4]));
        let c = emu.counts();
        assert_eq!((c.accepted, c.weight_clamped), (1, 1));
        assert_eq!(emu.effective_weight(), 1.0);
    }

    #[test]
    fn dds_weight_history_shows_a_ramp_without_a_step() {
        let (emu, _node, mut w) = setup(46, patient());
        let user = [t(1.0, 0.0, 0.0, 1.0, 0.1); 4];
        for mode in (0..=100).step_by(10) {
            send(&emu, &mut w, msg(mode, user));
        }
        let h = emu.weight_history();
        assert_eq!(h.last(), Some(&1.0));
        assert!(largest_weight_step_up(&h) <= 0.1 + 1e-6, "{h:?}");
        // A client stepping 0 -> 1 is visible in the history.
        send(&emu, &mut w, msg(0, user));
        send(&emu, &mut w, msg(100, user));
        assert_eq!(largest_weight_step_up(&emu.weight_history()), 1.0);
    }

    #[test]
    fn dds_positive_tau_closes_negative_opens() {
        let (emu, _node, mut w) = setup(47, HandSdkConfig::default());
        let close = msg(100, [t(0.0, 0.0, 0.3, 0.0, 0.05); 4]);
        let open = msg(100, [t(0.0, 0.0, -0.3, 0.0, 0.05); 4]);
        let deadline = Instant::now() + WAIT;
        while !emu.snapshot().joint_q.unwrap().iter().all(|&q| q > 1.0) {
            send(&emu, &mut w, close.clone());
            assert!(Instant::now() < deadline);
        }
        while !emu.snapshot().joint_q.unwrap().iter().all(|&q| q < 0.2) {
            send(&emu, &mut w, open.clone());
            assert!(Instant::now() < deadline);
        }
    }
}
