//! Every hold keeps the target it took when it began (docs/adapters.md, "Holds"): the
//! untouched hand of a shared message (Inspire DFX, Dex1 `actuator`), the watchdog's `hold`, a
//! client streaming `hold`, a reseed after a reconnect, and a `limp` a kind can only send as a
//! hold (BrainCo, Inspire FTP), each against an emulator whose held joints sag under a
//! constant load (`handgate_adapters::sim`, "Sag"). A target re-taken from such a measurement
//! every cycle integrates the sag and the joint creeps; a latched one does not.
//!
//! Simulated clock: the device side is what `DdsDevice`'s loop runs on each tick (the newest
//! state sample through the kind's `DdsCodec`, the link, `CommandState::step`, the codec's
//! message), the service side the emulator's DDS-free core, both stepped on simulated time at
//! the service's period, so each 60 s hold runs in well under a second of wall time and cannot
//! fail because the machine is busy. The drift is the emulated joint's true position (no
//! measurement noise) over 60 s, from 1 s after the hold began; `-- --nocapture` prints it.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::control::CommandState;
use handgate_adapters::dds_device::DdsCodec;
use handgate_adapters::link::{blind_hold, LinkTracker};
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{CommandBody, DeviceKind, HandCommand, JointState, SafeAction, Side};
use handgate_adapters::sim::Sag;

/// The device's state is stale (link down) this long after its last sample (the DDS devices'
/// default `stale_after`).
const STALE_AFTER: Duration = Duration::from_millis(200);

/// How long a hold is watched.
const HOLD: Duration = Duration::from_secs(60);

/// The load of every test, as a fraction of the joint's wire range: the position loop's
/// steady-state error under it (negative: toward lower wire values). 6·10⁻⁵ of the range, a
/// sixteenth of an Inspire register count: far below what the state resolves, so only a target
/// re-taken from the measurement every cycle shows it. Chosen so that the Inspire DFX hand no
/// client drives creeps, on the code before the fix, at the rates the issue measured against
/// a simulation (1.0 mrad/s thumb rotation, 0.36 mrad/s thumb bend; docs/adapters.md, "Holds").
const SAG: f32 = -6.0e-5;

/// The service half: an emulator's DDS-free core.
trait Service {
    type Cmd;
    type State;
    fn state(&mut self) -> Self::State;
    fn command(&mut self, cmd: &Self::Cmd, now: Instant);
    fn step(&mut self, now: Instant, dt: f32);
    /// The true position of message entry `e`, wire units.
    fn position(&self, e: usize) -> f32;
}

/// The device half of one DDS-client device, on simulated time.
struct Device<C: DdsCodec> {
    table: Arc<DeviceTable>,
    codec: C,
    cmd: CommandState,
    link: LinkTracker,
    joints: Vec<JointState>,
    last_sample: Option<Instant>,
}

impl<C: DdsCodec> Device<C> {
    fn new(kind: DeviceKind, side: Side, codec: C) -> Self {
        let table = Arc::new(kind.table(side, &TableOverrides::default()).unwrap());
        Self {
            cmd: CommandState::new(table.clone()),
            joints: vec![JointState::default(); table.joint_count()],
            table,
            codec,
            link: LinkTracker::default(),
            last_sample: None,
        }
    }

    /// One tick of the device loop at `now` with the newest state sample (`None`: none came):
    /// decode, follow the link (stale after [`STALE_AFTER`]), resolve, encode.
    fn tick(&mut self, now: Instant, sample: Option<&C::State>, period: Duration) -> Option<C::Cmd> {
        if let Some(st) = sample.and_then(|s| self.codec.decode(s, &self.table)) {
            self.joints = st.joints;
            self.last_sample = Some(now);
            if self.link.observe(true, &self.joints, &self.cmd) {
                self.codec.reconnected();
            }
        } else if self
            .last_sample
            .map_or(true, |t| now.saturating_duration_since(t) > STALE_AFTER)
        {
            self.link.observe(false, &self.joints, &self.cmd);
        }
        let active = self.cmd.step(&self.joints);
        if blind_hold(self.link.ever_measured(), &active) {
            return None;
        }
        self.codec.encode(&active, &self.table, period.as_secs_f32())
    }
}

/// A client's slowly moving closure at `t` (teleoperation: never the same twice in a row).
fn teleop(t: Duration) -> f32 {
    0.4 + 0.2 * (t.as_secs_f32() * 1.3).sin()
}

/// A service and the devices driving it, on one simulated clock.
struct Rig<S: Service, C: DdsCodec<Cmd = S::Cmd, State = S::State>> {
    t0: Instant,
    k: u32,
    period: Duration,
    service: S,
    devices: Vec<Device<C>>,
    seq: u64,
}

/// A joint to watch: (device, canonical joint, message entry).
type Watched = (usize, usize, usize);

impl<S: Service, C: DdsCodec<Cmd = S::Cmd, State = S::State>> Rig<S, C> {
    fn new(service: S, period: Duration, devices: Vec<Device<C>>) -> Self {
        Self {
            t0: Instant::now(),
            k: 0,
            period,
            service,
            devices,
            seq: 0,
        }
    }

    fn now(&self) -> Duration {
        self.period * self.k
    }

    /// Runs for `d`: each period `clients` command the devices, the service publishes, each
    /// device ticks on that sample (`deliver`: the samples reach the devices) and its message
    /// reaches the service, the service loops.
    fn run(&mut self, d: Duration, deliver: bool, mut clients: impl FnMut(&mut Self)) {
        let end = self.now() + d;
        while self.now() < end {
            clients(self);
            let now = self.t0 + self.now();
            let sample = self.service.state();
            let sample = deliver.then_some(&sample);
            for dev in &mut self.devices {
                if let Some(msg) = dev.tick(now, sample, self.period) {
                    self.service.command(&msg, now);
                }
            }
            self.service.step(now, self.period.as_secs_f32());
            self.k += 1;
        }
    }

    /// Device `i`'s client streams the teleoperation pose (`mirror`: its mirror image).
    fn teleop(&mut self, i: usize, mirror: bool) {
        self.seq += 1;
        let c = teleop(self.now());
        let c = if mirror { 1.0 - c } else { c };
        self.devices[i].cmd.submit(HandCommand::closure(self.seq, c)).unwrap();
    }

    /// Device `i`'s client sends the canonical interface's `hold` (mode safe).
    fn client_hold(&mut self, i: usize) {
        self.seq += 1;
        let hold = HandCommand {
            seq: self.seq,
            body: CommandBody::Safe(SafeAction::Hold),
            tag: 0,
        };
        self.devices[i].cmd.submit(hold).unwrap();
    }

    /// `joints` over the next [`HOLD`], from 1 s on, while `clients` go on: each must move
    /// less than `still` (wire units). Prints each one's drift in canonical mrad.
    fn watch(&mut self, what: &str, joints: &[Watched], still: f32, mut clients: impl FnMut(&mut Self)) {
        self.run(Duration::from_secs(1), true, &mut clients);
        let start: Vec<f32> = joints.iter().map(|&(_, _, e)| self.service.position(e)).collect();
        self.run(HOLD, true, &mut clients);
        let mut moved = Vec::new();
        for (&(d, j, e), start) in joints.iter().zip(start) {
            let end = self.service.position(e);
            let map = &self.devices[d].table.joints[j];
            let (a, b) = (map.q_from_wire(start), map.q_from_wire(end));
            eprintln!(
                "{what}: {:?} {}: {:+.2} mrad over {HOLD:?} ({a:+.4} -> {b:+.4} rad; wire {start} -> {end})",
                self.devices[d].table.side,
                map.name,
                (b - a) * 1e3,
            );
            if (end - start).abs() > still {
                moved.push(format!("{} entry {e}: wire {start} -> {end}", map.name));
            }
        }
        assert!(moved.is_empty(), "{what}: moved over {HOLD:?}: {moved:?}");
    }
}

mod inspire_dfx {
    use super::*;
    use handgate_adapters::inspire_dfx::adapter::{DfxCodec, SharedTargets};
    use handgate_adapters::inspire_dfx::emulator::{DfxConfig, DfxCore};
    use handgate_adapters::inspire_dfx::HAND_ENTRIES;
    use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};

    impl Service for DfxCore {
        type Cmd = MotorCmds_;
        type State = MotorStates_;
        fn state(&mut self) -> MotorStates_ {
            DfxCore::state(self)
        }
        fn command(&mut self, cmd: &MotorCmds_, now: Instant) {
            self.on_cmd(cmd, now);
        }
        fn step(&mut self, now: Instant, dt: f32) {
            DfxCore::step(self, now, dt);
        }
        fn position(&self, e: usize) -> f32 {
            self.snapshot().fingers[e].q
        }
    }

    /// The service's and the devices' period (100 Hz, docs/sources.md §7).
    const PERIOD: Duration = Duration::from_millis(10);
    /// Within a hand: thumb bend, thumb rotation (docs/sources.md §7), the joints the issue
    /// saw creep.
    const THUMB: [usize; 2] = [4, 5];
    /// Less than half a register count (what the hand's position loop resolves, and below
    /// what its state reports), wire q.
    const STILL: f32 = 0.5e-3;
    const RIGHT: usize = 0;
    const LEFT: usize = 1;

    /// The emulated service (default noise, a load on every thumb joint) and a right and a
    /// left device sharing their targets, as a profile opens them.
    fn rig() -> Rig<DfxCore, DfxCodec> {
        let mut cfg = DfxConfig::default();
        for e in [RIGHT, LEFT] {
            for j in THUMB {
                cfg.sag[e * HAND_ENTRIES + j] = Sag(SAG);
            }
        }
        let shared = SharedTargets::default();
        let dev = |side| {
            Device::new(
                DeviceKind::InspireDfx,
                side,
                DfxCodec::with_shared(side, shared.clone()).unwrap(),
            )
        };
        // Devices in element order: index = element.
        Rig::new(
            DfxCore::new(&cfg).unwrap(),
            PERIOD,
            vec![dev(Side::Right), dev(Side::Left)],
        )
    }

    /// The thumb joints of hand element `e`.
    fn thumb(e: usize) -> [Watched; 2] {
        THUMB.map(|j| (e, j, e * HAND_ENTRIES + j))
    }

    /// The hand no client drives, held in every message of the other hand's device while
    /// that hand is driven (the issue: 1.0 and 0.36 mrad/s on the thumb against a simulation).
    #[test]
    fn the_untouched_hand_of_the_shared_message_holds_still_while_the_other_is_driven() {
        rig().watch("untouched hand", &thumb(RIGHT), STILL, |r| r.teleop(LEFT, false));
    }

    /// The watchdog's hold of a hand whose client left, while the other hand is still driven.
    #[test]
    fn a_watchdog_hold_holds_still_while_the_other_hand_is_driven() {
        let mut rig = rig();
        rig.run(Duration::from_secs(2), true, |r| {
            r.teleop(LEFT, false);
            r.teleop(RIGHT, true);
        });
        // The left's client leaves; the front's watchdog trips, once.
        rig.devices[LEFT].cmd.request_safe(SafeAction::Hold);
        rig.watch("watchdog hold", &thumb(LEFT), STILL, |r| r.teleop(RIGHT, true));
    }

    /// A client streaming the canonical interface's `hold` every cycle: one hold, begun by the
    /// first, not a new hold at a new measurement each cycle.
    #[test]
    fn a_streamed_hold_request_holds_still() {
        let mut rig = rig();
        rig.run(Duration::from_secs(2), true, |r| {
            r.teleop(LEFT, false);
            r.teleop(RIGHT, true);
        });
        rig.watch("streamed hold", &thumb(LEFT), STILL, |r| {
            r.client_hold(LEFT);
            r.teleop(RIGHT, true);
        });
    }

    /// A reseed after the service's state stopped for longer than `stale_after`: a hold at the
    /// first new measurement, kept; the hand no client drives is held from there too.
    #[test]
    fn a_reseed_after_a_reconnect_holds_still() {
        let mut rig = rig();
        rig.run(Duration::from_secs(2), true, |r| r.teleop(LEFT, false));
        rig.run(Duration::from_millis(500), false, |r| r.teleop(LEFT, false));
        assert!(!rig.devices[LEFT].cmd.counters.snapshot().link_up, "stale: link down");
        // Back: the left is reseeded to a hold; its client is gone.
        let [a, b] = thumb(LEFT);
        let [c, d] = thumb(RIGHT);
        rig.watch("reseed", &[a, b, c, d], STILL, |_| {});
        assert_eq!(rig.devices[LEFT].cmd.counters.snapshot().reseeds, 1);
    }
}

mod dex1_actuator {
    use super::*;
    use handgate_adapters::dex1::adapter::{actuator_index, Dex1GoCodec, SharedElements, Variant};
    use handgate_adapters::dex1::emulator::{Dex1Config, Dex1Core};
    use handgate_adapters::dex3::physical::HG_MOTOR_NOISE;
    use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};

    impl Service for Dex1Core {
        type Cmd = MotorCmds_;
        type State = MotorStates_;
        fn state(&mut self) -> MotorStates_ {
            self.go_state()
        }
        fn command(&mut self, cmd: &MotorCmds_, now: Instant) {
            self.on_go(cmd, now);
        }
        fn step(&mut self, now: Instant, dt: f32) {
            Dex1Core::step(self, now, dt);
        }
        fn position(&self, e: usize) -> f32 {
            self.snapshot().grippers[e].q
        }
    }

    /// The Dex1 service's and devices' rate (docs/sources.md §4: 500 Hz).
    const PERIOD: Duration = Duration::from_millis(2);

    /// The gripper no client drives, held in every message of the other gripper's device
    /// (`rt/unitree_actuator`: both grippers in one message).
    #[test]
    fn the_untouched_gripper_of_the_shared_message_holds_still_while_the_other_is_driven() {
        let mut cfg = Dex1Config::new(Variant::Actuator, Side::Left);
        // The jaw's range is its wire range: the load that sags it by SAG of it under the
        // hold gains (kp 5.0, the Dex1 table's).
        let (lo, hi) = cfg.range;
        cfg.load = SAG * (hi - lo) * handgate_adapters::dex1::table::KP;
        let shared = SharedElements::default();
        let dev = |side| {
            Device::new(
                DeviceKind::Dex1,
                side,
                Dex1GoCodec::with_shared(Variant::Actuator, side, shared.clone()),
            )
        };
        // Devices in element order: index = element.
        let (right, left) = (actuator_index(Side::Right), actuator_index(Side::Left));
        assert_eq!((right, left), (0, 1));
        let mut rig = Rig::new(
            Dex1Core::new(&cfg).unwrap(),
            PERIOD,
            vec![dev(Side::Right), dev(Side::Left)],
        );
        // Half an encoder count (HG motor frame), rad.
        let still = HG_MOTOR_NOISE.q / 2.0;
        rig.watch("untouched gripper", &[(left, 0, left)], still, |r| {
            r.teleop(right, false)
        });
    }
}

/// A kind without a torque-off sends its `limp` as a hold: of the position measured when the
/// limp began, kept.
mod limp_as_hold {
    use super::*;

    /// The client drives the hand for 2 s, then leaves; the watchdog's action is `limp`. The
    /// fingers stop where they are (within a hundredth of the wire range `range` after 1 s)
    /// and stay there.
    fn limp_after_teleop<S, C>(rig: &mut Rig<S, C>, what: &str, joints: &[Watched], range: f32, still: f32)
    where
        S: Service,
        C: DdsCodec<Cmd = S::Cmd, State = S::State>,
    {
        rig.run(Duration::from_secs(2), true, |r| r.teleop(0, false));
        rig.devices[0].cmd.request_safe(SafeAction::Limp);
        let at: Vec<f32> = joints.iter().map(|&(_, _, e)| rig.service.position(e)).collect();
        rig.run(Duration::from_secs(1), true, |_| {});
        for (&(_, j, e), at) in joints.iter().zip(at) {
            let now = rig.service.position(e);
            assert!(
                (now - at).abs() <= range / 100.0,
                "{what}: joint {j} did not stop where it was: wire {at} -> {now} in 1 s"
            );
        }
        rig.watch(what, joints, still, |_| {});
    }

    mod brainco {
        use super::*;
        use handgate_adapters::brainco::adapter::BraincoCodec;
        use handgate_adapters::brainco::emulator::{BraincoConfig, BraincoCore, REGISTER_STEP};
        use handgate_adapters::brainco::WIRE_LEN;
        use handgate_adapters::service_emulator::ServiceCore;
        use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};

        impl Service for BraincoCore {
            type Cmd = MotorCmds_;
            type State = MotorStates_;
            fn state(&mut self) -> MotorStates_ {
                BraincoCore::state(self)
            }
            fn command(&mut self, cmd: &MotorCmds_, _now: Instant) {
                self.on_command(cmd);
            }
            fn step(&mut self, _now: Instant, dt: f32) {
                BraincoCore::step(self, dt);
            }
            fn position(&self, e: usize) -> f32 {
                self.report(Default::default()).fingers[e].q
            }
        }

        #[test]
        fn a_brainco_limp_holds_still() {
            let mut cfg = BraincoConfig::new(Side::Left);
            cfg.sag = [Sag(SAG); WIRE_LEN];
            let dev = Device::new(DeviceKind::Brainco, Side::Left, BraincoCodec::default());
            let mut rig = Rig::new(BraincoCore::new(&cfg).unwrap(), Duration::from_millis(10), vec![dev]);
            let joints: Vec<Watched> = (0..WIRE_LEN).map(|j| (0, j, j)).collect();
            limp_after_teleop(&mut rig, "brainco limp", &joints, 1.0, REGISTER_STEP / 2.0);
        }
    }

    mod inspire_ftp {
        use super::*;
        use handgate_adapters::inspire_ftp::adapter::FtpCodec;
        use handgate_adapters::inspire_ftp::emulator::{FtpConfig, FtpCore};
        use handgate_idl::inspire::{InspireHandCtrl, InspireHandState, ACTUATORS, UNITS_MAX};

        impl Service for FtpCore {
            type Cmd = InspireHandCtrl;
            type State = InspireHandState;
            fn state(&mut self) -> InspireHandState {
                FtpCore::state(self)
            }
            fn command(&mut self, cmd: &InspireHandCtrl, _now: Instant) {
                self.on_command(cmd);
            }
            fn step(&mut self, _now: Instant, dt: f32) {
                FtpCore::step(self, dt);
            }
            fn position(&self, e: usize) -> f32 {
                self.snapshot().actuators[e].angle
            }
        }

        #[test]
        fn an_inspire_ftp_limp_holds_still() {
            let mut cfg = FtpConfig::new(Side::Left);
            // The wire range is the ANGLE register's 0..1000.
            cfg.sag = [Sag(SAG * f32::from(UNITS_MAX)); ACTUATORS];
            let period = Duration::from_secs_f64(1.0 / cfg.rate.0);
            let dev = Device::new(DeviceKind::InspireFtp, Side::Left, FtpCodec::default());
            let mut rig = Rig::new(FtpCore::new(&cfg).unwrap(), period, vec![dev]);
            let joints: Vec<Watched> = (0..ACTUATORS).map(|j| (0, j, j)).collect();
            // Half a register unit.
            limp_after_teleop(&mut rig, "inspire_ftp limp", &joints, f32::from(UNITS_MAX), 0.5);
        }
    }
}
