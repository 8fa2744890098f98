//! Emulator of `dex1_1_service`, the DDS peer a Dex1-1 gripper adapter talks to.
//!
//! Three wire variants exist in the field (docs/sources.md §4), chosen by [`Dex1Variant`]:
//! - [`Dex1Variant::Go`] (default, what dex1_1_service and current xr_teleoperate
//!   use): `unitree_go::msg::dds_::MotorCmds_` with 1 element on `rt/dex1/{side}/cmd`,
//!   `MotorStates_` with 1 element on `rt/dex1/{side}/state`;
//! - [`Dex1Variant::Hg`] (the seed dex1-1-dds-interface-spec.txt): `unitree_hg`
//!   `HandCmd_`/`HandState_` with 1 motor on the same topics, range 0..2pi;
//! - [`Dex1Variant::Actuator`] (older xr_teleoperate): `rt/unitree_actuator/{cmd,state}`
//!   with 2 elements, index 0 = right, 1 = left; one emulator serves both grippers.
//!
//! Behaviour (docs/sources.md §4 unless marked): 500 Hz loop; mode ignored; q = 0 closed .. ~5.4 open;
//! after 1000 ms without a command the gripper brakes (holds its position, keeps reporting
//! it; see [`GripperView::braked`]) and resumes on the next command; state carries q, dq,
//! tau_est. Assumed (the real service's control law is not public): the commanded q is
//! tracked with the commanded kp/kd when non-zero, else [`Dex1Tuning::default_kp`]/
//! [`Dex1Tuning::default_kd`]; dq and tau of the command are not used; the gripper starts
//! braked (no command yet); commands with a wrong element count or a non-finite q are
//! ignored and counted.
//!
//! Realism: the jaw's hard stops are the mechanism's range ([`hard_stops`]: dex1_1_service's
//! calibrated 322°, wider than the 5.4 rad clients command), it starts at [`DEX1_REST_Q`]
//! and its state reports q, dq and tau_est with measurement noise ([`Dex1Config::noise`]).

use std::time::{Duration, Instant};

use handgate_idl::unitree_go::{MotorCmds_, MotorState_ as GoMotorState, MotorStates_};
use handgate_idl::unitree_hg::{HandCmd_, HandState_, MotorState_ as HgMotorState};

use crate::dds::Node;
use crate::emu_common::{ensure_finite, EmulatorError, Hz, Side};
use crate::service_emulator::{Published, ServiceCore, ServiceEmulator, ServicePlan, ServiceWire, Silent, Tick};
use crate::sim::{Contact, JointModel, JointParams, MotorTarget, Noise, Sensor};

/// Nominal open position clients command (xr_teleoperate, EZGripper driver; docs/sources.md §4), rad.
pub const DEX1_OPEN_Q: f32 = super::table::DEFAULT_RANGE_RAD;
/// The range dex1_1_service calibrates (322 degrees; docs/sources.md §4), rad.
pub const DEX1_CALIBRATED_RANGE: f32 = 5.62;
/// The seed spec's open position (2pi), rad.
pub const SEED_SPEC_OPEN_Q: f32 = super::table::SEED_SPEC_RANGE_RAD;
/// Where an emulated gripper starts, rad: a gripper at rest is wherever it was left, and
/// this picks "left mostly open" (0.4 rad short of the 5.4 rad open end, so measurement
/// noise never reads past it). An assumption; profiles set their own (`emulator.initial`).
pub const DEX1_REST_Q: f32 = 5.0;

/// The jaw's hard stops (closed, open), rad: the mechanism's range, not the range clients
/// command. Go / Actuator: 0 .. dex1_1_service's calibrated 322° ([`DEX1_CALIBRATED_RANGE`],
/// docs/sources.md §4; assumed to be the mechanical range, since the service calibrates it end to end).
/// Hg (the seed spec): 0 .. 2π, the spec's own range (assumed; nothing in the field uses it).
pub fn hard_stops(variant: Dex1Variant) -> (f32, f32) {
    match variant {
        Dex1Variant::Hg => (0.0, SEED_SPEC_OPEN_Q),
        _ => (0.0, DEX1_CALIBRATED_RANGE),
    }
}

pub use super::adapter::Variant as Dex1Variant;

/// Values not taken from a public source (plus the 1000 ms brake delay, which is), in one
/// overridable table.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex1Tuning {
    /// Silence after which the gripper brakes (docs/sources.md §4: 1000 ms).
    pub brake_after: Duration,
    /// Gains used when a command's kp / kd is zero (assumption: xr_teleoperate's 5.0 / 0.05).
    pub default_kp: f32,
    pub default_kd: f32,
    /// Emulated jaw drive: inertia kg*m^2, viscous friction, torque limit N*m (assumption).
    pub inertia: f32,
    pub friction: f32,
    pub tau_max: f32,
    /// Object stiffness, N*m/rad (assumption).
    pub contact_stiffness: f32,
}

impl Default for Dex1Tuning {
    fn default() -> Self {
        Self {
            brake_after: Duration::from_millis(1000),
            default_kp: 5.0,
            default_kd: 0.05,
            inertia: 1.0e-3,
            friction: 0.05,
            tau_max: 2.0,
            contact_stiffness: 20.0,
        }
    }
}

/// Configuration of one emulated dex1_1_service.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex1Config {
    pub variant: Dex1Variant,
    /// The gripper served (ignored by [`Dex1Variant::Actuator`], which serves both).
    pub side: Side,
    /// Loop and state rate (default [`super::SERVICE_HZ`]).
    pub rate: Hz,
    /// Position range (closed, open), rad: the jaw's hard stops (default [`hard_stops`]).
    pub range: (f32, f32),
    /// Jaw position at start, rad (default [`DEX1_REST_Q`]).
    pub initial_q: f32,
    /// Measurement noise on the reported q, dq, tau_est (default the HG motor's,
    /// [`crate::dex3::physical::HG_MOTOR_NOISE`]: dex1_1_service drives the same motor frame).
    pub noise: Noise,
    /// Position (rad) at which the jaws meet a graspable object while closing; `None`: none.
    pub object: Option<f32>,
    /// A constant load on every jaw, N*m toward +q (opening; default 0): the jaw settles
    /// `load / kp` from its target (`crate::sim`, "Sag").
    pub load: f32,
    pub tuning: Dex1Tuning,
    /// (command, state) topics; `None` = the variant's standard topics. The gateway's
    /// emulator backend puts the service on private topics.
    pub topics: Option<(String, String)>,
}

impl Dex1Config {
    pub fn new(variant: Dex1Variant, side: Side) -> Self {
        Self {
            variant,
            side,
            rate: Hz(super::SERVICE_HZ),
            range: hard_stops(variant),
            initial_q: DEX1_REST_Q,
            noise: crate::dex3::physical::HG_MOTOR_NOISE,
            object: None,
            load: 0.0,
            tuning: Dex1Tuning::default(),
            topics: None,
        }
    }
}

/// The last command received, as it came.
#[derive(Debug, Clone, PartialEq)]
pub enum Dex1Command {
    Go(MotorCmds_),
    Hg(HandCmd_),
}

/// One gripper, as the emulator sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripperView {
    pub side: Side,
    /// Jaw position, rad (0 closed).
    pub q: f32,
    pub dq: f32,
    /// Reported torque, N*m (rises when the jaws press an object; 0 while braked).
    pub tau_est: f32,
    pub braked: bool,
    /// What the motor tracks (q, kp, kd after defaults).
    pub target: MotorTarget,
    /// Contact torque from the object.
    pub contact_tau: f32,
}

/// A consistent copy of the emulator's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex1Snapshot {
    pub last_command: Option<Dex1Command>,
    /// Accepted commands.
    pub commands: u64,
    /// Commands ignored (wrong element count, non-finite q).
    pub rejected: u64,
    pub grippers: Vec<GripperView>,
    pub states_published: u64,
}

#[derive(Debug, Clone)]
struct Gripper {
    side: Side,
    joint: JointModel,
    target: MotorTarget,
    braked: bool,
    last_cmd_at: Option<Instant>,
}

/// One element of a command, variant-independent: (q, kp, kd).
type JawCmd = (f32, f32, f32);

/// The service logic without DDS.
#[derive(Debug, Clone)]
pub struct Dex1Core {
    tuning: Dex1Tuning,
    grippers: Vec<Gripper>,
    sensor: Sensor,
    last_command: Option<Dex1Command>,
    commands: u64,
    rejected: u64,
    /// Per gripper (wire order), held where it is whatever the command (`--fault stuck=jaw`).
    stuck: Vec<bool>,
}

impl Dex1Core {
    pub fn new(config: &Dex1Config) -> Result<Self, EmulatorError> {
        let (lo, hi) = config.range;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(EmulatorError::InvalidConfig(format!("bad range {:?}", config.range)));
        }
        let t = &config.tuning;
        ensure_finite("initial_q", [config.initial_q, config.load])?;
        config.noise.validate().map_err(EmulatorError::InvalidConfig)?;
        ensure_finite("object", config.object)?;
        ensure_finite(
            "tuning",
            [
                t.default_kp,
                t.default_kd,
                t.inertia,
                t.friction,
                t.tau_max,
                t.contact_stiffness,
            ],
        )?;
        if t.inertia <= 0.0 {
            return Err(EmulatorError::InvalidConfig("inertia must be > 0".into()));
        }
        let params = JointParams {
            inertia: t.inertia,
            friction: t.friction,
            tau_max: t.tau_max,
            q_min: lo,
            q_max: hi,
        };
        let grippers: Vec<Gripper> = config
            .variant
            .layout(config.side)
            .into_iter()
            .map(|side| {
                let mut joint = JointModel::new(params, config.initial_q);
                joint.load = config.load;
                Gripper {
                    side,
                    target: MotorTarget {
                        q: joint.q,
                        ..MotorTarget::LIMP
                    },
                    joint,
                    braked: true,
                    last_cmd_at: None,
                }
            })
            .collect();
        let mut core = Self {
            tuning: config.tuning.clone(),
            stuck: vec![false; grippers.len()],
            grippers,
            sensor: Sensor::new(config.noise),
            last_command: None,
            commands: 0,
            rejected: 0,
        };
        for side in [Side::Left, Side::Right] {
            core.set_object(side, config.object);
        }
        Ok(core)
    }

    /// Places (or removes) the object `side`'s jaws close on.
    pub fn set_object(&mut self, side: Side, at: Option<f32>) {
        let k = self.tuning.contact_stiffness;
        for g in self.grippers.iter_mut().filter(|g| g.side == side) {
            g.joint.contact = at.filter(|a| a.is_finite()).map(|at| Contact {
                at,
                dir: -1.0, // closing is decreasing q
                stiffness: k,
            });
        }
    }

    /// Handles a unitree_go command.
    pub fn on_go(&mut self, cmd: &MotorCmds_, now: Instant) -> bool {
        self.last_command = Some(Dex1Command::Go(cmd.clone()));
        let jaws: Vec<JawCmd> = cmd.cmds.iter().map(|c| (c.q, c.kp, c.kd)).collect();
        self.apply(&jaws, now)
    }

    /// Handles a unitree_hg command.
    pub fn on_hg(&mut self, cmd: &HandCmd_, now: Instant) -> bool {
        self.last_command = Some(Dex1Command::Hg(cmd.clone()));
        let jaws: Vec<JawCmd> = cmd.motor_cmd.iter().map(|c| (c.q, c.kp, c.kd)).collect();
        self.apply(&jaws, now)
    }

    fn apply(&mut self, jaws: &[JawCmd], now: Instant) -> bool {
        if jaws.len() != self.grippers.len() || jaws.iter().any(|j| !j.0.is_finite()) {
            self.rejected += 1;
            return false;
        }
        self.commands += 1;
        let t = &self.tuning;
        for (g, &(q, kp, kd)) in self.grippers.iter_mut().zip(jaws) {
            let gain = |v: f32, default: f32| if v.is_finite() && v != 0.0 { v } else { default };
            g.target = MotorTarget {
                q: q.clamp(g.joint.params.q_min, g.joint.params.q_max),
                dq: 0.0,
                tau: 0.0,
                kp: gain(kp, t.default_kp),
                kd: gain(kd, t.default_kd),
            };
            g.braked = false;
            g.last_cmd_at = Some(now);
        }
        true
    }

    /// Applies the brake where due and advances the jaws by `dt` seconds.
    pub fn step(&mut self, now: Instant, dt: f32) {
        let brake_after = self.tuning.brake_after;
        for (g, &stuck) in self.grippers.iter_mut().zip(&self.stuck) {
            if !g.braked
                && g.last_cmd_at
                    .is_some_and(|t| now.saturating_duration_since(t) >= brake_after)
            {
                g.braked = true;
            }
            if g.braked || stuck {
                // The brake (or a stuck jaw) holds the jaw where it is; the motor applies
                // nothing.
                g.joint.dq = 0.0;
                g.joint.tau = 0.0;
            } else {
                g.joint.step(&g.target, dt);
            }
        }
    }

    fn view(g: &Gripper) -> GripperView {
        GripperView {
            side: g.side,
            q: g.joint.q,
            dq: g.joint.dq,
            tau_est: g.joint.tau,
            braked: g.braked,
            target: g.target,
            contact_tau: g.joint.contact_tau,
        }
    }

    /// unitree_go state: one element per gripper, q/dq/tau_est filled (docs/sources.md §4), measured
    /// (each call draws the noise once).
    pub fn go_state(&mut self) -> MotorStates_ {
        let sensor = &mut self.sensor;
        MotorStates_ {
            states: self
                .grippers
                .iter()
                .map(|g| {
                    let r = sensor.read(&g.joint);
                    GoMotorState {
                        q: r.q,
                        dq: r.dq,
                        tau_est: r.tau,
                        ..GoMotorState::default()
                    }
                })
                .collect(),
        }
    }

    /// unitree_hg state as the seed spec fills it: one motor, mode 0, temperature [25, 25],
    /// vol 12, no pressure sensors, everything else zero.
    pub fn hg_state(&mut self) -> HandState_ {
        let sensor = &mut self.sensor;
        HandState_ {
            motor_state: self
                .grippers
                .iter()
                .map(|g| {
                    let r = sensor.read(&g.joint);
                    HgMotorState {
                        q: r.q,
                        dq: r.dq,
                        tau_est: r.tau,
                        temperature: [25, 25],
                        vol: 12.0,
                        ..HgMotorState::default()
                    }
                })
                .collect(),
            ..HandState_::default()
        }
    }

    pub fn snapshot(&self) -> Dex1Snapshot {
        Dex1Snapshot {
            last_command: self.last_command.clone(),
            commands: self.commands,
            rejected: self.rejected,
            grippers: self.grippers.iter().map(Self::view).collect(),
            states_published: 0,
        }
    }
}

impl ServiceCore for Dex1Core {
    type Config = Dex1Config;
    type Snapshot = Dex1Snapshot;

    fn from_config(config: &Dex1Config) -> Result<Self, EmulatorError> {
        Self::new(config)
    }

    /// The variant's topics, the configured rate.
    fn plan(config: &Dex1Config) -> Result<ServicePlan, EmulatorError> {
        let (side, topics) = (config.side, config.topics.clone());
        ServicePlan::one_hand("dex1", side, config.rate, topics, Some(config.variant.topics(side)))
    }

    /// The gripper at wire element `entry` (the actuator pair: 0 right, 1 left).
    fn stick(&mut self, entry: usize) -> Result<(), EmulatorError> {
        crate::service_emulator::stick_entry(&mut self.stuck, entry, "this dex1_1_service")
    }

    fn report(&self, published: Published) -> Dex1Snapshot {
        Dex1Snapshot {
            states_published: published.state,
            ..self.snapshot()
        }
    }
}

/// The `unitree_go` wire (variants Go and Actuator).
enum GoWire {}
/// The seed spec's `unitree_hg` wire.
enum HgWire {}

impl ServiceWire<Dex1Core> for GoWire {
    type Cmd = MotorCmds_;
    type State = MotorStates_;
    type Extra = Silent;

    fn receive(core: &mut Dex1Core, cmd: &MotorCmds_, now: Instant) {
        core.on_go(cmd, now);
    }

    fn cycle(core: &mut Dex1Core, tick: Tick) -> Option<MotorStates_> {
        core.step(tick.now, tick.dt);
        Some(core.go_state())
    }
}

impl ServiceWire<Dex1Core> for HgWire {
    type Cmd = HandCmd_;
    type State = HandState_;
    type Extra = Silent;

    fn receive(core: &mut Dex1Core, cmd: &HandCmd_, now: Instant) {
        core.on_hg(cmd, now);
    }

    fn cycle(core: &mut Dex1Core, tick: Tick) -> Option<HandState_> {
        core.step(tick.now, tick.dt);
        Some(core.hg_state())
    }
}

/// A running emulated dex1_1_service. Dropping it stops its loop.
pub type Dex1Emulator = ServiceEmulator<Dex1Core>;

impl Dex1Emulator {
    /// Starts the service on `node`, on its variant's wire.
    pub fn start(node: &Node, config: Dex1Config) -> Result<Self, EmulatorError> {
        match config.variant {
            Dex1Variant::Hg => Self::start_on::<HgWire>(node, config),
            _ => Self::start_on::<GoWire>(node, config),
        }
    }

    /// The last command received (accepted or not).
    pub fn last_command(&self) -> Option<Dex1Command> {
        self.with_core(|c| c.last_command.clone())
    }

    /// Accepted commands.
    pub fn commands_received(&self) -> u64 {
        self.with_core(|c| c.commands)
    }

    /// Ignored commands.
    pub fn commands_rejected(&self) -> u64 {
        self.with_core(|c| c.rejected)
    }

    /// `side`'s gripper, if this emulator serves it.
    pub fn gripper(&self, side: Side) -> Option<GripperView> {
        self.with_core(|c| c.grippers.iter().find(|g| g.side == side).map(Dex1Core::view))
    }

    /// Whether the configured side's gripper is braked (for the 2-element variant: the
    /// configured side too; use [`Dex1Emulator::gripper`] for the other).
    pub fn braked(&self) -> bool {
        self.gripper(self.config().side).is_some_and(|g| g.braked)
    }

    /// The configured side's jaw position, rad.
    pub fn jaw_position(&self) -> f32 {
        self.gripper(self.config().side).map_or(f32::NAN, |g| g.q)
    }

    /// Places (or removes) the object `side`'s jaws close on.
    pub fn set_object(&self, side: Side, at: Option<f32>) {
        self.with_core(|c| c.set_object(side, at));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dds::{Qos, Reader, Writer};
    use crate::emu_common::{wait_for, TEST_WAIT as WAIT};
    use handgate_idl::unitree_go::MotorCmd_ as GoMotorCmd;
    use handgate_idl::unitree_hg::MotorCmd_ as HgMotorCmd;

    fn go(qs: &[f32], kp: f32, kd: f32) -> MotorCmds_ {
        MotorCmds_ {
            cmds: qs
                .iter()
                .map(|&q| GoMotorCmd {
                    q,
                    kp,
                    kd,
                    ..GoMotorCmd::default()
                })
                .collect(),
        }
    }

    fn run(core: &mut Dex1Core, t0: Instant, from_ms: u64, to_ms: u64) {
        for k in from_ms..to_ms {
            core.step(t0 + Duration::from_millis(k), 0.001);
        }
    }

    /// The `variant` service's configuration with exact values (no measurement noise).
    fn exact(variant: Dex1Variant) -> Dex1Config {
        Dex1Config {
            noise: Noise::OFF,
            ..Dex1Config::new(variant, Side::Left)
        }
    }

    /// On the actuator pair the stuck jaw is the one at its wire element (1: left); the other
    /// follows.
    #[test]
    fn a_stuck_jaw_of_the_actuator_pair_stays_while_the_other_follows() {
        let mut core = Dex1Core::new(&exact(Dex1Variant::Actuator)).unwrap();
        core.stick(crate::dex1::adapter::actuator_index(Side::Left)).unwrap();
        assert!(core.stick(2).is_err(), "the pair has two jaws");
        let t0 = Instant::now();
        assert!(core.on_go(&go(&[2.0, 2.0], 5.0, 0.05), t0));
        run(&mut core, t0, 0, 900);
        let q = |side| core.grippers.iter().find(|g| g.side == side).unwrap().joint.q;
        assert_eq!(q(Side::Left), DEX1_REST_Q, "stuck where it started");
        assert!((q(Side::Right) - 2.0).abs() < 0.1, "{}", q(Side::Right));
    }

    #[test]
    fn tracks_q_with_default_gains_then_brakes_and_resumes() {
        // Exact held values: no measurement noise.
        let mut core = Dex1Core::new(&exact(Dex1Variant::Go)).unwrap();
        assert!(core.grippers[0].braked, "braked before any command");
        let t0 = Instant::now();
        assert!(core.on_go(&go(&[2.0], 0.0, 0.0), t0));
        assert_eq!(core.grippers[0].target.kp, 5.0);
        run(&mut core, t0, 0, 999);
        assert!(!core.grippers[0].braked);
        assert!(
            (core.grippers[0].joint.q - 2.0).abs() < 0.05,
            "q = {}",
            core.grippers[0].joint.q
        );
        run(&mut core, t0, 999, 1001);
        assert!(core.grippers[0].braked);
        let held = core.grippers[0].joint.q;
        run(&mut core, t0, 1001, 3000);
        assert_eq!(core.grippers[0].joint.q, held);
        assert_eq!(core.go_state().states[0].q, held);
        assert_eq!(core.go_state().states[0].dq, 0.0);
        assert!(core.on_go(&go(&[4.0], 8.0, 0.1), t0 + Duration::from_secs(3)));
        assert!(!core.grippers[0].braked);
        assert_eq!(core.grippers[0].target.kp, 8.0);
        run(&mut core, t0, 3000, 3500);
        assert!(core.grippers[0].joint.q > 3.5);
    }

    #[test]
    fn commands_are_clamped_to_the_range_and_bad_ones_rejected() {
        let mut core = Dex1Core::new(&Dex1Config::new(Dex1Variant::Go, Side::Right)).unwrap();
        let t0 = Instant::now();
        core.on_go(&go(&[9.0], 0.0, 0.0), t0);
        // The jaw's hard stop is the calibrated mechanical range, beyond the 5.4 rad clients
        // command: an unclamped 9.0 ends there, not at 5.4.
        assert_eq!(core.grippers[0].target.q, DEX1_CALIBRATED_RANGE);
        const { assert!(DEX1_CALIBRATED_RANGE > DEX1_OPEN_Q) };
        assert!(!core.on_go(&go(&[], 0.0, 0.0), t0));
        assert!(!core.on_go(&go(&[1.0, 1.0], 0.0, 0.0), t0));
        assert!(!core.on_go(&go(&[f32::NAN], 0.0, 0.0), t0));
        assert_eq!((core.commands, core.rejected), (1, 3));
        assert!(Dex1Core::new(&Dex1Config {
            range: (1.0, 1.0),
            ..Dex1Config::new(Dex1Variant::Go, Side::Right)
        })
        .is_err());
        assert!(Dex1Core::new(&Dex1Config {
            initial_q: f32::NAN,
            ..Dex1Config::new(Dex1Variant::Go, Side::Right)
        })
        .is_err());
    }

    #[test]
    fn object_stops_the_jaws_and_raises_tau_est() {
        let mut cfg = Dex1Config::new(Dex1Variant::Go, Side::Right);
        cfg.object = Some(2.0);
        let mut core = Dex1Core::new(&cfg).unwrap();
        let t0 = Instant::now();
        core.on_go(&go(&[0.0], 0.0, 0.0), t0);
        run(&mut core, t0, 0, 900);
        let s = core.go_state().states[0];
        assert!(s.q < 2.0 && s.q > 1.8, "q = {}", s.q);
        assert!(s.tau_est < -1.0, "closing torque against the object: {}", s.tau_est);
        // Without the object the same command closes fully with little torque left.
        core.set_object(Side::Right, None);
        core.on_go(&go(&[0.0], 0.0, 0.0), t0 + Duration::from_millis(900));
        run(&mut core, t0, 900, 1800);
        let s = core.go_state().states[0];
        assert!(s.q < 0.05 && s.tau_est.abs() < 0.5, "{s:?}");
    }

    #[test]
    fn hg_variant_uses_seed_range_and_one_motor() {
        let cfg = Dex1Config::new(Dex1Variant::Hg, Side::Left);
        assert_eq!(cfg.range.1, SEED_SPEC_OPEN_Q);
        let mut core = Dex1Core::new(&cfg).unwrap();
        let mut c = HandCmd_::with_motors(1);
        c.motor_cmd[0] = HgMotorCmd {
            q: 6.0,
            ..HgMotorCmd::default()
        };
        assert!(core.on_hg(&c, Instant::now()));
        assert!(!core.on_hg(&HandCmd_::with_motors(7), Instant::now()));
        let s = core.hg_state();
        assert_eq!(s.motor_state.len(), 1);
        assert!(s.press_sensor_state.is_empty());
    }

    // ---- over real DDS (domains 36..=41) ----

    /// Publishes `cmd` once per received state sample until `done` holds. Returns the state
    /// and the instant just before the last write.
    fn drive_until<C: Clone + handgate_idl::TopicType, S: Clone + handgate_idl::TopicType + std::fmt::Debug>(
        w: &mut Writer<C>,
        r: &Reader<S>,
        cmd: &C,
        mut done: impl FnMut(&S) -> bool,
    ) -> (S, Instant) {
        let deadline = Instant::now() + WAIT;
        loop {
            let written = Instant::now();
            w.write(cmd.clone()).unwrap();
            let s = r.wait_take(WAIT).unwrap().pop().unwrap();
            if done(&s) {
                return (s, written);
            }
            assert!(Instant::now() < deadline, "condition not reached; last {s:?}");
        }
    }

    fn watch_until<S: Clone + handgate_idl::TopicType + std::fmt::Debug>(
        r: &Reader<S>,
        mut done: impl FnMut(&S) -> bool,
    ) -> S {
        let deadline = Instant::now() + WAIT;
        loop {
            let s = r.wait_take(WAIT).unwrap().pop().unwrap();
            if done(&s) {
                return s;
            }
            assert!(Instant::now() < deadline, "condition not reached; last {s:?}");
        }
    }

    #[test]
    fn dds_go_variant_tracks_q_brakes_after_silence_and_resumes() {
        crate::emu_common::isolated_test_domain(36);
        let emu_node = Node::new(36, None).unwrap();
        // Exact held values: no measurement noise.
        let cfg = exact(Dex1Variant::Go);
        let emu = Dex1Emulator::start(&emu_node, cfg).unwrap();
        let node = Node::new(36, None).unwrap();
        let mut w = node
            .writer::<MotorCmds_>("rt/dex1/left/cmd", Qos::Reliable { depth: 4 })
            .unwrap();
        let r = node
            .reader::<MotorStates_>("rt/dex1/left/state", Qos::BestEffort)
            .unwrap();
        w.wait_matched(1, WAIT).unwrap();
        r.wait_matched(1, WAIT).unwrap();
        assert!(emu.braked());
        let cmd = go(&[2.5], 5.0, 0.05);
        let (s, last_write) = drive_until(&mut w, &r, &cmd, |s: &MotorStates_| (s.states[0].q - 2.5).abs() < 0.05);
        assert_eq!(s.states.len(), 1);
        assert!(!emu.braked());
        wait_for(|| emu.braked());
        assert!(last_write.elapsed() >= Duration::from_secs(1));
        // Braked: the jaw holds and the state keeps reporting the held position.
        let held = emu.jaw_position();
        let s = watch_until(&r, |s: &MotorStates_| s.states[0].dq == 0.0);
        assert_eq!(s.states[0].q, held);
        assert_eq!(s.states[0].tau_est, 0.0);
        // The next command releases the brake.
        let cmd = go(&[0.5], 0.0, 0.0);
        drive_until(&mut w, &r, &cmd, |s: &MotorStates_| (s.states[0].q - 0.5).abs() < 0.05);
        assert!(!emu.braked());
        let snap = emu.snapshot();
        assert_eq!(snap.last_command, Some(Dex1Command::Go(cmd)));
        assert_eq!(snap.rejected, 0);
        assert_eq!(snap.grippers[0].target.kp, 5.0, "kp 0 falls back to the default");
    }

    #[test]
    fn dds_unitree_actuator_index_0_drives_the_right_gripper() {
        crate::emu_common::isolated_test_domain(37);
        let emu_node = Node::new(37, None).unwrap();
        let cfg = Dex1Config::new(Dex1Variant::Actuator, Side::Left);
        let emu = Dex1Emulator::start(&emu_node, cfg).unwrap();
        let node = Node::new(37, None).unwrap();
        let mut w = node
            .writer::<MotorCmds_>("rt/unitree_actuator/cmd", Qos::Reliable { depth: 4 })
            .unwrap();
        let r = node
            .reader::<MotorStates_>("rt/unitree_actuator/state", Qos::BestEffort)
            .unwrap();
        w.wait_matched(1, WAIT).unwrap();
        r.wait_matched(1, WAIT).unwrap();
        // index 0 -> 1.0 rad, index 1 -> 4.0 rad
        let cmd = go(&[1.0, 4.0], 5.0, 0.05);
        let (s, _) = drive_until(&mut w, &r, &cmd, |s: &MotorStates_| {
            (s.states[0].q - 1.0).abs() < 0.05 && (s.states[1].q - 4.0).abs() < 0.05
        });
        assert_eq!(s.states.len(), 2);
        assert!((emu.gripper(Side::Right).unwrap().q - 1.0).abs() < 0.1);
        assert!((emu.gripper(Side::Left).unwrap().q - 4.0).abs() < 0.1);
        // One element is not this variant's shape: ignored and counted.
        w.write(go(&[0.0], 5.0, 0.05)).unwrap();
        wait_for(|| emu.commands_rejected() >= 1);
    }

    #[test]
    fn dds_hg_variant_serves_hand_cmd_with_one_motor() {
        crate::emu_common::isolated_test_domain(38);
        let emu_node = Node::new(38, None).unwrap();
        let emu = Dex1Emulator::start(&emu_node, Dex1Config::new(Dex1Variant::Hg, Side::Right)).unwrap();
        let node = Node::new(38, None).unwrap();
        let mut w = node
            .writer::<HandCmd_>("rt/dex1/right/cmd", Qos::Reliable { depth: 4 })
            .unwrap();
        let r = node
            .reader::<HandState_>("rt/dex1/right/state", Qos::BestEffort)
            .unwrap();
        w.wait_matched(1, WAIT).unwrap();
        r.wait_matched(1, WAIT).unwrap();
        let mut cmd = HandCmd_::with_motors(1);
        cmd.motor_cmd[0].q = 3.0;
        let (s, _) = drive_until(&mut w, &r, &cmd, |s: &HandState_| {
            (s.motor_state[0].q - 3.0).abs() < 0.05
        });
        assert_eq!(s.motor_state.len(), 1);
        assert!(s.press_sensor_state.is_empty());
        assert!(emu.commands_received() >= 1);
    }

    #[test]
    fn dds_grasped_object_stops_jaws_and_raises_tau_est() {
        crate::emu_common::isolated_test_domain(39);
        let emu_node = Node::new(39, None).unwrap();
        let emu = Dex1Emulator::start(&emu_node, Dex1Config::new(Dex1Variant::Go, Side::Right)).unwrap();
        emu.set_object(Side::Right, Some(1.5));
        let node = Node::new(39, None).unwrap();
        let mut w = node
            .writer::<MotorCmds_>("rt/dex1/right/cmd", Qos::Reliable { depth: 4 })
            .unwrap();
        let r = node
            .reader::<MotorStates_>("rt/dex1/right/state", Qos::BestEffort)
            .unwrap();
        w.wait_matched(1, WAIT).unwrap();
        r.wait_matched(1, WAIT).unwrap();
        let (s, _) = drive_until(&mut w, &r, &go(&[0.0], 5.0, 0.05), |s: &MotorStates_| {
            s.states[0].q < 1.55 && s.states[0].dq.abs() < 0.01
        });
        assert!(s.states[0].q > 1.3, "jaws stop at the object: {}", s.states[0].q);
        assert!(s.states[0].tau_est.abs() > 1.0, "tau_est {}", s.states[0].tau_est);
        assert!(emu.gripper(Side::Right).unwrap().contact_tau > 1.0);
    }

    #[test]
    fn rest_position_not_zero_and_the_same_seed_gives_the_same_noise() {
        fn run(cfg: &Dex1Config) -> Vec<[f32; 3]> {
            let mut core = Dex1Core::new(cfg).unwrap();
            (0..20)
                .map(|_| {
                    let s = core.go_state().states[0];
                    [s.q, s.dq, s.tau_est]
                })
                .collect()
        }
        let cfg = Dex1Config::new(Dex1Variant::Go, Side::Left);
        let a = run(&cfg);
        assert_ne!(a[0][0], 0.0);
        assert!((a[0][0] - DEX1_REST_Q).abs() <= 3.0 * cfg.noise.q + 1e-6);
        assert_eq!(a, run(&cfg));
        let other = Dex1Config {
            noise: cfg.noise.with_seed(cfg.noise.seed ^ 1),
            ..cfg.clone()
        };
        assert_ne!(a, run(&other));
        let exact = run(&Dex1Config {
            noise: Noise::OFF,
            ..cfg.clone()
        });
        assert!(exact.iter().all(|s| *s == [DEX1_REST_Q, 0.0, 0.0]));
        assert_eq!(cfg.range, (0.0, DEX1_CALIBRATED_RANGE));
    }
}
