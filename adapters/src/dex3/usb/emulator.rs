//! An emulator of the Dex3-1's MCU at the USB seam.
//!
//! It parses command frames as the hand would: a frame with a bad frame CRC (or wrong length)
//! is ignored, a motor packet with a bad CRC is ignored (that motor does not answer), a packet
//! for id 15 is a broadcast to every motor of its bus and is not answered. Each motor runs
//! [`crate::sim::JointModel`] under its kp/kd/tau with the hardware's range of its side as
//! hard stops (the manual's, [`crate::dex3::physical`]), starting from the rest posture, and
//! reports position, speed and torque with measurement noise ([`EmulatorConfig::noise`]). Timeout protection: a motor whose last command set the timeout bit and that gets
//! no command for [`EmulatorConfig::motor_timeout`] goes limp and reports the timeout bit in its
//! feedback, latched until a command with the bit at 0 arrives (manual, docs/sources.md §2).
//!
//! ASSUMPTIONS (not public, see docs/dex3-usb.md): the MCU still replies with a state frame
//! when it ignores a bad command frame; a motor answers only when addressed; every sensor of a
//! bus reports in every reply without being addressed; status 0 ("lock"/"stop") means no
//! torque; replies put the motor packets first (in command order), then the sensor packets.
//!
//! Time: with [`EmulatorClock::PerExchange`] each exchange advances emulated time by a fixed
//! step (deterministic); with [`EmulatorClock::Wall`] by the real time elapsed since the last
//! exchange, as a real MCU would. [`Dex3Emulator::advance`] moves time explicitly.

use super::codec::{
    BusId, BusPayload, DeviceId, LinuxToMcuCmd, McuToLinuxState, MotorCmdFrame, MotorFeedbackFrame, RisMode,
    SensorFrame, BROADCAST_ID, BUS_BUFFER_SIZE, BUS_COUNT, MOTOR_CMD_LEN, STATE_FRAME_LEN,
};
use super::scaling::Scalings;
use super::transport::{Dex3Transport, TransportError};
use super::wiring::{BusAddr, WiringMap};
use crate::dex3::{Joint, MotorCommand, MotorStatus, Side, MOTOR_COUNT, PAD_COUNT, TAXELS_PER_PAD};
use crate::emu_common::Injected;
use crate::sim::{Contact, JointModel, JointParams, MotorTarget, Noise, Reading, Sensor};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// How emulated time advances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EmulatorClock {
    /// Each exchange advances time by this step.
    PerExchange(Duration),
    /// Each exchange advances time by the real time since the previous one (capped at 10 s).
    Wall,
}

/// Emulator settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorConfig {
    /// The emulated hand's own wiring (it may differ from the host's, to test discovery).
    pub wiring: WiringMap,
    pub scalings: Scalings,
    pub clock: EmulatorClock,
    /// Joint positions at power-up (IDL order); `None`: the rest posture
    /// ([`crate::dex3::physical::rest_wire`]).
    pub initial_q: Option<[f32; MOTOR_COUNT]>,
    /// Measurement noise on the reported position, speed and torque (default
    /// [`crate::dex3::physical::HG_MOTOR_NOISE`]; [`Noise::OFF`] for exact values).
    pub noise: Noise,
    /// Objects in the joints' paths (IDL order).
    pub contacts: [Option<Contact>; MOTOR_COUNT],
    /// Timeout protection delay (manual: 1 s).
    pub motor_timeout: Duration,
    /// Supply voltage, V.
    pub supply_v: f32,
    /// `mode[0]` of the state frame ("the model of the hand"; the value is not public).
    pub hand_model: u8,
    /// Pressure counts per N·m of contact torque on the pads of the contacting finger
    /// (an emulator figure, not a hardware one).
    pub pressure_counts_per_nm: f32,
    /// Faults of a hand that reports but does not move (`--fault`, docs/adapters.md
    /// "Motion"): a stuck motor stays where it is; frozen, each motor's feedback repeats its
    /// first reading after power-up (the frame around it stays live, so discovery and status
    /// work); ignore-commands, motor packets are answered but not applied.
    pub faults: Injected<MOTOR_COUNT>,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        Self {
            wiring: WiringMap::default(),
            scalings: Scalings::default(),
            clock: EmulatorClock::PerExchange(Duration::from_millis(1)),
            initial_q: None,
            noise: crate::dex3::physical::HG_MOTOR_NOISE,
            contacts: [None; MOTOR_COUNT],
            motor_timeout: Duration::from_secs(1),
            supply_v: 24.0,
            hand_model: 0,
            pressure_counts_per_nm: 20000.0,
            faults: Injected::default(),
        }
    }
}

/// Counters of what the emulated MCU saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    pub frames_ok: u64,
    pub frames_rejected: u64,
    pub motor_packets_ok: u64,
    pub motor_packets_bad_crc: u64,
    pub motor_packets_unknown_id: u64,
    pub broadcasts: u64,
    pub replies: u64,
    pub replies_dropped: u64,
    pub replies_corrupted: u64,
}

/// What to do with the reply of an exchange.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// `out` holds a state frame.
    Frame,
    /// Fault injection: no reply.
    Dropped,
}

#[derive(Debug, Clone, Default)]
struct Faults {
    drop_replies: u32,
    corrupt_frames: u32,
    corrupt_motor_packets: u32,
    stall_until: Option<Instant>,
    unplugged: bool,
    generation: u64,
}

#[derive(Debug, Clone)]
struct Motor {
    joint: JointModel,
    target: MotorTarget,
    status: u8,
    timeout_enabled: bool,
    timed_out: bool,
    last_cmd_at: Duration,
    last_command: Option<MotorCommand>,
}

/// The emulated hand.
#[derive(Debug, Clone)]
pub struct Dex3Emulator {
    side: Side,
    cfg: EmulatorConfig,
    motors: [Motor; MOTOR_COUNT],
    sensor: Sensor,
    now: Duration,
    last_wall: Option<Instant>,
    faults: Faults,
    stats: EmulatorStats,
    /// Frozen ([`EmulatorConfig::faults`]): the reading each motor repeats.
    frozen: [Option<Reading>; MOTOR_COUNT],
}

const STEP: Duration = Duration::from_millis(1);

impl Dex3Emulator {
    pub fn new(side: Side, cfg: EmulatorConfig) -> Self {
        let motors = Self::power_up_motors(side, &cfg);
        Self {
            side,
            sensor: Sensor::new(cfg.noise),
            cfg,
            motors,
            now: Duration::ZERO,
            last_wall: None,
            faults: Faults::default(),
            stats: EmulatorStats::default(),
            frozen: [None; MOTOR_COUNT],
        }
    }

    fn power_up_motors(side: Side, cfg: &EmulatorConfig) -> [Motor; MOTOR_COUNT] {
        std::array::from_fn(|i| {
            let j = Joint::ALL[i];
            let (lo, hi) = j.hard_stops(side);
            let q0 = cfg
                .initial_q
                .map(|q| q[i])
                .unwrap_or_else(|| crate::dex3::physical::rest_wire(side, i));
            let mut joint = JointModel::new(JointParams::dex3_finger(lo, hi), q0);
            joint.contact = cfg.contacts[i];
            Motor {
                joint,
                target: MotorTarget::LIMP,
                status: MotorStatus::Lock.raw(),
                timeout_enabled: false,
                timed_out: false,
                last_cmd_at: Duration::ZERO,
                last_command: None,
            }
        })
    }

    pub fn side(&self) -> Side {
        self.side
    }
    pub fn config(&self) -> &EmulatorConfig {
        &self.cfg
    }
    /// Emulated time since power-up.
    pub fn now(&self) -> Duration {
        self.now
    }
    pub fn stats(&self) -> EmulatorStats {
        self.stats
    }
    pub fn joint_q(&self, j: Joint) -> f32 {
        self.motors[j.index()].joint.q
    }
    /// Moves a joint by hand (as a person pushing a limp finger would).
    pub fn set_joint_q(&mut self, j: Joint, q: f32) {
        let m = &mut self.motors[j.index()].joint;
        m.q = q.clamp(m.params.q_min, m.params.q_max);
        m.dq = 0.0;
    }
    pub fn set_contact(&mut self, j: Joint, c: Option<Contact>) {
        self.motors[j.index()].joint.contact = c;
    }
    pub fn timed_out(&self, j: Joint) -> bool {
        self.motors[j.index()].timed_out
    }
    /// The last command this motor accepted (decoded back to SI units).
    pub fn last_command(&self, j: Joint) -> Option<MotorCommand> {
        self.motors[j.index()].last_command
    }

    /// Faults: the next `n` exchanges get no reply (the command is still executed).
    pub fn drop_replies(&mut self, n: u32) {
        self.faults.drop_replies += n;
    }
    /// Faults: the next `n` replies carry a wrong frame CRC.
    pub fn corrupt_frames(&mut self, n: u32) {
        self.faults.corrupt_frames += n;
    }
    /// Faults: the next `n` motor packets sent back carry a wrong CRC.
    pub fn corrupt_motor_packets(&mut self, n: u32) {
        self.faults.corrupt_motor_packets += n;
    }
    /// Faults: for `d` of real time, commands do not reach the MCU and nothing comes back.
    pub fn stall_for(&mut self, d: Duration) {
        self.faults.stall_until = Some(Instant::now() + d);
    }
    /// Ends every pending fault (drops, corruptions, stall); does not replug.
    pub fn clear_faults(&mut self) {
        self.faults.drop_replies = 0;
        self.faults.corrupt_frames = 0;
        self.faults.corrupt_motor_packets = 0;
        self.faults.stall_until = None;
    }
    /// Real time left in a stall.
    pub fn stall_remaining(&self) -> Option<Duration> {
        let until = self.faults.stall_until?;
        until.checked_duration_since(Instant::now()).filter(|d| !d.is_zero())
    }
    /// Faults: the USB cable is pulled; open links fail with `Disconnected`, new opens with
    /// `NotFound`.
    pub fn unplug(&mut self) {
        self.faults.unplugged = true;
        self.faults.generation += 1;
    }
    pub fn replug(&mut self) {
        self.faults.unplugged = false;
        self.last_wall = None;
    }
    pub fn is_plugged(&self) -> bool {
        !self.faults.unplugged
    }
    /// Resets the MCU and the motors to power-up (joints back at `initial_q`, no targets).
    pub fn power_cycle(&mut self) {
        self.motors = Self::power_up_motors(self.side, &self.cfg);
        self.last_wall = None;
    }

    /// Advances emulated time by `dt` in 1 ms steps, applying timeout protection.
    pub fn advance(&mut self, dt: Duration) {
        let mut left = dt;
        while !left.is_zero() {
            let h = left.min(STEP);
            left -= h;
            self.now += h;
            for (m, stuck) in self.motors.iter_mut().zip(self.cfg.faults.stuck) {
                if m.timeout_enabled && !m.timed_out && self.now.saturating_sub(m.last_cmd_at) > self.cfg.motor_timeout
                {
                    m.timed_out = true;
                }
                if stuck {
                    // A stuck joint stays where it is, whatever the command, with no torque
                    // (a stuck joint is told from a grasp by its torque).
                    m.joint.dq = 0.0;
                    m.joint.tau = 0.0;
                    continue;
                }
                let t = if m.timed_out || m.status != MotorStatus::Foc.raw() {
                    MotorTarget::LIMP
                } else {
                    m.target
                };
                m.joint.step(&t, h.as_secs_f32());
            }
        }
    }

    fn tick_clock(&mut self) {
        match self.cfg.clock {
            EmulatorClock::PerExchange(dt) => self.advance(dt),
            EmulatorClock::Wall => {
                let now = Instant::now();
                if let Some(last) = self.last_wall {
                    let dt = now.duration_since(last).min(Duration::from_secs(10));
                    self.advance(dt);
                }
                self.last_wall = Some(now);
            }
        }
    }

    /// Handles one command frame and writes the reply into `out`.
    pub fn handle_frame(&mut self, cmd: &[u8], out: &mut [u8; STATE_FRAME_LEN]) -> Reply {
        self.tick_clock();
        let mut answered = Answered::default();
        match LinuxToMcuCmd::decode(cmd) {
            Ok(frame) => {
                self.stats.frames_ok += 1;
                for bus in BusId::ALL {
                    let payload = frame.buses[bus.index()].bytes();
                    for pkt in payload.chunks_exact(MOTOR_CMD_LEN) {
                        self.handle_motor_packet(bus, pkt, &mut answered);
                    }
                }
            }
            Err(_) => self.stats.frames_rejected += 1,
        }
        self.write_state(&answered, out);
        if self.faults.drop_replies > 0 {
            self.faults.drop_replies -= 1;
            self.stats.replies_dropped += 1;
            return Reply::Dropped;
        }
        if self.faults.corrupt_frames > 0 {
            self.faults.corrupt_frames -= 1;
            self.stats.replies_corrupted += 1;
            out[STATE_FRAME_LEN - 1] ^= 0x5A;
        }
        self.stats.replies += 1;
        Reply::Frame
    }

    fn handle_motor_packet(&mut self, bus: BusId, pkt: &[u8], answered: &mut Answered) {
        let f = match MotorCmdFrame::decode(pkt) {
            Ok(f) => f,
            Err(_) => {
                self.stats.motor_packets_bad_crc += 1;
                return;
            }
        };
        self.stats.motor_packets_ok += 1;
        let apply = !self.cfg.faults.ignore_commands;
        if f.mode.id == BROADCAST_ID {
            self.stats.broadcasts += 1;
            if apply {
                for (_, j) in self.cfg.wiring.joints_on(bus) {
                    self.apply(j.index(), &f);
                }
            }
            return;
        }
        let Ok(id) = DeviceId::new(f.mode.id) else { return };
        match self.cfg.wiring.joint_at(BusAddr { bus, id }) {
            Some(j) => {
                if apply {
                    self.apply(j.index(), &f);
                }
                answered.push(bus, j.index());
            }
            None => self.stats.motor_packets_unknown_id += 1,
        }
    }

    fn apply(&mut self, i: usize, f: &MotorCmdFrame) {
        let s = self.cfg.scalings;
        let now = self.now;
        let m = &mut self.motors[i];
        let cmd = MotorCommand {
            q: s.decode_cmd_position(f.pos_des),
            dq: s.decode_cmd_speed(f.spd_des),
            tau: s.decode_cmd_torque(f.tor_des),
            kp: s.decode_cmd_kp(f.k_pos),
            kd: s.decode_cmd_kd(f.k_spd),
            status: if f.mode.status.raw() == MotorStatus::Foc.raw() {
                MotorStatus::Foc
            } else {
                MotorStatus::Lock
            },
        };
        m.last_command = Some(cmd);
        m.last_cmd_at = now;
        if f.mode.timeout {
            m.timeout_enabled = true;
        } else {
            m.timeout_enabled = false;
            m.timed_out = false;
        }
        m.status = f.mode.status.raw();
        m.target = MotorTarget {
            q: cmd.q,
            dq: cmd.dq,
            tau: cmd.tau,
            kp: cmd.kp,
            kd: cmd.kd,
        };
    }

    fn write_state(&mut self, answered: &Answered, out: &mut [u8; STATE_FRAME_LEN]) {
        let s = self.cfg.scalings;
        let mut st = McuToLinuxState {
            mode: [self.cfg.hand_model, 0],
            ..Default::default()
        };
        let motor_v = self.cfg.supply_v.min(24.0);
        let mut total_tau = 0.0f32;
        for bus in BusId::ALL {
            let mut payload = BusPayload::default();
            for &i in answered.on(bus) {
                let m = &self.motors[i];
                total_tau += m.joint.tau.abs();
                let r = match (self.cfg.faults.frozen, self.frozen[i]) {
                    (true, Some(r)) => r,
                    (frozen, _) => {
                        let r = self.sensor.read(&m.joint);
                        if frozen {
                            self.frozen[i] = Some(r);
                        }
                        r
                    }
                };
                let fb = MotorFeedbackFrame {
                    mode: RisMode::new(
                        self.cfg.wiring.motors[i].id.get(),
                        MotorStatus::from_raw(m.status),
                        m.timed_out,
                    ),
                    temp_case: 35,
                    temp_winding: 40,
                    vol: s.encode_fb_voltage(motor_v),
                    torque: s.encode_fb_torque(r.tau),
                    speed: s.encode_fb_speed(r.dq),
                    pos: s.encode_fb_position(r.q),
                    error: 0,
                    ex_sensor: [0, 0],
                };
                let mut bytes = fb.encode();
                if self.faults.corrupt_motor_packets > 0 {
                    self.faults.corrupt_motor_packets -= 1;
                    bytes[22] ^= 0xA5;
                }
                // A validated wiring map always fits.
                let _ = payload.push(&bytes, bus.index());
            }
            for (id, pad) in self.cfg.wiring.pads_on(bus) {
                let frame = SensorFrame::new(id.get(), 0, self.pad_pressure(pad), [30; TAXELS_PER_PAD]);
                let _ = payload.push(&frame.encode(), bus.index());
            }
            st.set_bus(bus.index(), &payload);
        }
        st.pin_v = counts(self.cfg.supply_v, s.pin_v_per_count);
        st.pin_a = counts(0.2 + 0.5 * total_tau, s.pin_a_per_count);
        st.vin_v = counts(12.0, s.vin_v_per_count);
        st.vm_v = counts(5.0, s.vm_v_per_count);
        st.imu = [0.0, 0.0, 9.81, 0.0, 0.0, 0.0].map(|v: f32| (v / s.imu_accel_per_count).round() as i16);
        st.encode_into(out);
    }

    /// Emulated pads: 0,1 on the thumb tip joint, 2,3 index, 4,5 middle, 6..8 palm (no contact).
    fn pad_pressure(&self, pad: usize) -> [u16; TAXELS_PER_PAD] {
        let joint = match pad {
            0 | 1 => Some(Joint::Thumb2),
            2 | 3 => Some(Joint::Index1),
            4 | 5 => Some(Joint::Middle1),
            _ => None,
        };
        let tau = joint.map(|j| self.motors[j.index()].joint.contact_tau).unwrap_or(0.0);
        let v = (tau * self.cfg.pressure_counts_per_nm)
            .round()
            .clamp(0.0, u16::MAX as f32) as u16;
        debug_assert!(pad < PAD_COUNT);
        [v; TAXELS_PER_PAD]
    }
}

/// The joints (IDL index) a command frame addressed, per bus in packet order (a joint
/// addressed twice answers twice): the reply's motor packets. Fixed-size, on the stack: at most
/// one per command packet a bus buffer holds.
#[derive(Debug, Clone, Copy, Default)]
struct Answered {
    joints: [[usize; Answered::PER_BUS]; BUS_COUNT],
    len: [usize; BUS_COUNT],
}

impl Answered {
    const PER_BUS: usize = BUS_BUFFER_SIZE / MOTOR_CMD_LEN;

    fn push(&mut self, bus: BusId, joint: usize) {
        let b = bus.index();
        // A bus buffer holds at most PER_BUS command packets, each answered at most once.
        if let Some(slot) = self.joints[b].get_mut(self.len[b]) {
            *slot = joint;
            self.len[b] += 1;
        }
    }

    fn on(&self, bus: BusId) -> &[usize] {
        &self.joints[bus.index()][..self.len[bus.index()]]
    }
}

fn counts(v: f32, per_count: f32) -> u16 {
    (v / per_count).round().clamp(0.0, u16::MAX as f32) as u16
}

/// A shared emulator (one per emulated hand).
pub type SharedEmulator = Arc<Mutex<Dex3Emulator>>;

/// Locks a shared emulator, recovering from a poisoned lock (a panicking test thread).
pub fn lock(emu: &SharedEmulator) -> MutexGuard<'_, Dex3Emulator> {
    emu.lock().unwrap_or_else(|e| e.into_inner())
}

/// In-process transport to a [`SharedEmulator`].
pub struct EmulatorTransport {
    emu: SharedEmulator,
    generation: u64,
}

impl EmulatorTransport {
    /// "Opens the device": fails with `NotFound` while the emulator is unplugged.
    pub fn open(emu: &SharedEmulator) -> Result<Self, TransportError> {
        let e = lock(emu);
        if !e.is_plugged() {
            return Err(TransportError::NotFound("emulated Dex3-1 (unplugged)".into()));
        }
        Ok(Self {
            emu: emu.clone(),
            generation: e.faults.generation,
        })
    }

    /// A factory for the device loop.
    pub fn factory(emu: SharedEmulator) -> super::transport::TransportFactory {
        Box::new(move || Ok(Box::new(EmulatorTransport::open(&emu)?) as Box<dyn Dex3Transport>))
    }
}

impl Dex3Transport for EmulatorTransport {
    fn exchange(
        &mut self,
        cmd: &[u8; super::codec::CMD_FRAME_LEN],
        state: &mut [u8; STATE_FRAME_LEN],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let mut e = lock(&self.emu);
        if !e.is_plugged() || e.faults.generation != self.generation {
            return Err(TransportError::Disconnected);
        }
        if let Some(left) = e.stall_remaining() {
            drop(e);
            std::thread::sleep(left.min(timeout));
            return Err(TransportError::Timeout(timeout));
        }
        match e.handle_frame(cmd, state) {
            Reply::Frame => Ok(()),
            Reply::Dropped => {
                drop(e);
                std::thread::sleep(timeout);
                Err(TransportError::Timeout(timeout))
            }
        }
    }

    fn describe(&self) -> String {
        format!("in-process Dex3-1 emulator ({})", lock(&self.emu).side.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex3::usb::codec::{McuToLinuxState, CMD_FRAME_LEN};
    use crate::dex3::usb::convert::{apply_state, build_command};
    use crate::dex3::{Dex3Command, Dex3Measurement};

    fn exchange(emu: &mut Dex3Emulator, cmd: &Dex3Command, timeout_bit: bool) -> Dex3Measurement {
        let frame = build_command(cmd, &WiringMap::default(), &Scalings::default(), timeout_bit).encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        assert_eq!(emu.handle_frame(&frame, &mut out), Reply::Frame);
        let st = McuToLinuxState::decode(&out).unwrap();
        let mut m = Dex3Measurement::empty(Instant::now());
        let rep = apply_state(&mut m, &st, &WiringMap::default(), &Scalings::default());
        assert_eq!(rep.counters.total(), 0);
        m
    }

    fn target(j: Joint, q: f32) -> Dex3Command {
        let mut c = Dex3Command::hold([0.0; MOTOR_COUNT], 0.0, 0.05);
        *c.motor_mut(j) = MotorCommand {
            q,
            kp: 1.5,
            kd: 0.1,
            ..Default::default()
        };
        c
    }

    /// The three faults of `EmulatorConfig::faults`: each keeps the commanded index_0 from
    /// reaching 1.0 (stuck: at its start; frozen: its first reading repeated, bit for bit;
    /// ignore-commands: nothing applied), while every motor still answers.
    #[test]
    fn injected_faults_keep_a_commanded_joint_from_moving_and_every_motor_answering() {
        use crate::emu_common::Fault;
        let c = target(Joint::Index0, 1.0);
        for fault in [
            Fault::Stuck(Joint::Index0.index()),
            Fault::Frozen,
            Fault::IgnoreCommands,
        ] {
            let cfg = EmulatorConfig {
                faults: Injected::of(Some(fault), "a Dex3-1").unwrap(),
                ..Default::default()
            };
            let mut emu = Dex3Emulator::new(Side::Right, cfg);
            let start = emu.joint_q(Joint::Index0);
            let first = exchange(&mut emu, &c, true);
            let mut m = first.clone();
            for _ in 0..2000 {
                m = exchange(&mut emu, &c, true);
            }
            assert!(m.motors.iter().all(|m| m.present), "{fault:?}");
            assert!(
                (m.motor(Joint::Index0).q - 1.0).abs() > 0.2,
                "{fault:?}: {:?}",
                m.motor(Joint::Index0)
            );
            match fault {
                Fault::Stuck(_) => assert_eq!(emu.joint_q(Joint::Index0), start),
                Fault::Frozen => {
                    assert_eq!(m.motor(Joint::Index0).q, first.motor(Joint::Index0).q);
                    assert!((emu.joint_q(Joint::Index0) - 1.0).abs() < 0.02, "it moves unseen");
                }
                Fault::IgnoreCommands => assert!(emu.last_command(Joint::Index0).is_none()),
            }
        }
        assert!(Injected::<MOTOR_COUNT>::of(Some(Fault::Stuck(MOTOR_COUNT)), "a Dex3-1").is_err());
    }

    #[test]
    fn pd_command_moves_joint_and_feedback_reports_it() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        let c = target(Joint::Index0, 1.0);
        let mut m = exchange(&mut emu, &c, true);
        for _ in 0..2000 {
            m = exchange(&mut emu, &c, true);
        }
        assert!(
            (m.motor(Joint::Index0).q - 1.0).abs() < 0.02,
            "{:?}",
            m.motor(Joint::Index0)
        );
        assert!(m.motors.iter().all(|m| m.present && !m.timeout));
        assert!(m.pads.iter().all(|p| p.present));
        assert_eq!(emu.stats().frames_ok, 2001);
        assert!((m.power.power_v - 24.0).abs() < 0.01);
        let lc = emu.last_command(Joint::Index0).unwrap();
        assert!((lc.q - 1.0).abs() < 1e-3 && (lc.kp - 1.5).abs() < 1e-4);
    }

    #[test]
    fn joint_limits_follow_side() {
        let mut emu = Dex3Emulator::new(Side::Left, EmulatorConfig::default());
        // Closing is negative on the left: +1 rad is beyond index_0's upper stop (0).
        let c = target(Joint::Index0, 1.0);
        for _ in 0..500 {
            exchange(&mut emu, &c, false);
        }
        assert_eq!(emu.joint_q(Joint::Index0), 0.0);
    }

    #[test]
    fn timeout_trips_latches_and_clears() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        let c = target(Joint::Middle0, 0.8);
        for _ in 0..1500 {
            exchange(&mut emu, &c, true);
        }
        let q_before = emu.joint_q(Joint::Middle0);
        // No commands for 1.2 s.
        emu.advance(Duration::from_millis(1200));
        assert!(emu.timed_out(Joint::Middle0));
        // Commands with the bit still set: stays latched and limp.
        let m = exchange(&mut emu, &target(Joint::Middle0, 0.2), true);
        assert!(m.motor(Joint::Middle0).timeout);
        for _ in 0..300 {
            exchange(&mut emu, &target(Joint::Middle0, 0.2), true);
        }
        assert!(
            (emu.joint_q(Joint::Middle0) - q_before).abs() < 0.05,
            "limp joint moved"
        );
        // A command with the bit at 0 clears it and the motor follows again.
        let m = exchange(&mut emu, &target(Joint::Middle0, 0.2), false);
        assert!(!m.motor(Joint::Middle0).timeout);
        for _ in 0..1500 {
            exchange(&mut emu, &target(Joint::Middle0, 0.2), false);
        }
        assert!((emu.joint_q(Joint::Middle0) - 0.2).abs() < 0.02);
    }

    #[test]
    fn no_timeout_without_the_bit() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        exchange(&mut emu, &target(Joint::Middle0, 0.8), false);
        emu.advance(Duration::from_secs(3));
        assert!(!emu.timed_out(Joint::Middle0));
    }

    #[test]
    fn rejects_bad_frame_crc_and_bad_motor_crc() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        let w = WiringMap::default();
        let s = Scalings::default();
        let mut frame = build_command(&target(Joint::Thumb0, 0.5), &w, &s, true).encode();
        frame[100] ^= 1;
        let mut out = [0u8; STATE_FRAME_LEN];
        emu.handle_frame(&frame, &mut out);
        assert_eq!(emu.stats().frames_rejected, 1);
        assert!(emu.last_command(Joint::Thumb0).is_none());
        // The reply carries no motor packets (nobody was addressed) but the sensors.
        let st = McuToLinuxState::decode(&out).unwrap();
        let p = crate::dex3::usb::codec::parse_feedback(&st);
        assert!(p.motors.is_empty());
        assert_eq!(p.sensors.len(), PAD_COUNT);

        // Corrupt thumb_0's packet inside a frame with a correct frame CRC.
        let mut cmd = build_command(&target(Joint::Thumb0, 0.5), &w, &s, true);
        let mut bytes = cmd.buses[0].bytes().to_vec();
        bytes[8] ^= 0x10;
        cmd.buses[0].clear();
        cmd.buses[0].push(&bytes, 0).unwrap();
        emu.handle_frame(&cmd.encode(), &mut out);
        assert_eq!(emu.stats().motor_packets_bad_crc, 1);
        assert!(emu.last_command(Joint::Thumb0).is_none());
        assert!(emu.last_command(Joint::Thumb1).is_some());
        let st = McuToLinuxState::decode(&out).unwrap();
        assert_eq!(
            crate::dex3::usb::codec::parse_feedback(&st).motors.len(),
            MOTOR_COUNT - 1
        );
        // Wrong length.
        emu.handle_frame(&[0u8; CMD_FRAME_LEN - 4], &mut out);
        assert_eq!(emu.stats().frames_rejected, 2);
    }

    #[test]
    fn broadcast_applies_to_bus_without_reply() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        let mut cmd = LinuxToMcuCmd::default();
        let f = MotorCmdFrame {
            mode: RisMode::new(BROADCAST_ID, MotorStatus::Foc, false),
            k_spd: 3000,
            ..Default::default()
        };
        cmd.buses[0].push(&f.encode(), 0).unwrap();
        let mut out = [0u8; STATE_FRAME_LEN];
        emu.handle_frame(&cmd.encode(), &mut out);
        assert_eq!(emu.stats().broadcasts, 1);
        assert!(emu.last_command(Joint::Thumb2).is_some());
        assert!(emu.last_command(Joint::Index0).is_none());
        let st = McuToLinuxState::decode(&out).unwrap();
        assert!(crate::dex3::usb::codec::parse_feedback(&st).motors.is_empty());
    }

    #[test]
    fn faults_corrupt_and_drop() {
        let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
        let frame = build_command(
            &Dex3Command::damping(0.1),
            &WiringMap::default(),
            &Scalings::default(),
            true,
        )
        .encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        emu.corrupt_frames(1);
        assert_eq!(emu.handle_frame(&frame, &mut out), Reply::Frame);
        assert!(McuToLinuxState::decode(&out).is_err());
        emu.corrupt_motor_packets(2);
        emu.handle_frame(&frame, &mut out);
        let st = McuToLinuxState::decode(&out).unwrap();
        assert_eq!(crate::dex3::usb::codec::parse_feedback(&st).counters.bad_crc, 2);
        emu.drop_replies(1);
        assert_eq!(emu.handle_frame(&frame, &mut out), Reply::Dropped);
        assert_eq!(emu.handle_frame(&frame, &mut out), Reply::Frame);
    }

    #[test]
    fn contact_produces_pressure() {
        let mut cfg = EmulatorConfig::default();
        cfg.contacts[Joint::Index1.index()] = Some(Contact {
            at: 0.5,
            dir: 1.0,
            stiffness: 20.0,
        });
        let mut emu = Dex3Emulator::new(Side::Right, cfg);
        let mut m = exchange(&mut emu, &target(Joint::Index1, 1.5), true);
        for _ in 0..2000 {
            m = exchange(&mut emu, &target(Joint::Index1, 1.5), true);
        }
        assert!(m.pads[2].pressure[0] > 0.0 && m.pads[3].pressure[5] > 0.0);
        assert_eq!(m.pads[0].pressure[0], 0.0);
    }

    /// `[devices.emulator] object_at` reaches the MCU emulator the emulator backend opens:
    /// closing index_1 toward a far target stops at the object (canonical 0.5 rad, either
    /// side), with contact torque and pressure on the index pads; without it the joint closes.
    #[test]
    fn profile_object_at_stops_the_closing_joint_with_pressure() {
        use crate::device::Backend;
        use crate::dex3::config::Dex3Profile;
        use crate::kind::DeviceKind;
        use crate::open::{DeviceSpec, EmulatorSection};
        for side in [Side::Left, Side::Right] {
            let run = |object: Option<f64>| {
                let table = std::sync::Arc::new(crate::dex3::table::table(side));
                let mut section = EmulatorSection {
                    noise: Some(false),
                    ..Default::default()
                };
                if let Some(o) = object {
                    section.object_at.insert("index_1".into(), o);
                }
                let profile = Dex3Profile::default();
                let spec = DeviceSpec {
                    name: "d",
                    kind: DeviceKind::Dex3,
                    side,
                    backend: Backend::Emulator,
                    rate_hz: 500.0,
                    stale_after: Duration::from_millis(100),
                    forward_on_arrival: true,
                    max_send_hz: None,
                    table: &table,
                    emulator: &section,
                    config: &profile,
                };
                let crate::dex3::usb::adapter::UsbSource::Emulator(cfg) =
                    crate::dex3::open::usb_source(&spec, &profile)
                else {
                    panic!("the emulator backend opens the MCU emulator")
                };
                let mut emu = Dex3Emulator::new(side, *cfg);
                let dir = crate::dex3::table::wire_sign(side, Joint::Index1.index());
                let c = target(Joint::Index1, dir * 1.6);
                let mut m = exchange(&mut emu, &c, true);
                for _ in 0..2000 {
                    m = exchange(&mut emu, &c, true);
                }
                let j = m.motor(Joint::Index1);
                (j.q * dir, j.tau * dir, m.pads[2].pressure[0].max(m.pads[3].pressure[0]))
            };
            let (q, tau, press) = run(Some(0.5));
            assert!((0.5..0.65).contains(&q), "{side:?}: stopped at the object, q = {q}");
            assert!(tau > 0.3, "{side:?}: pressing on it, tau = {tau}");
            assert!(press > 0.0, "{side:?}: pressure {press}");
            let (q, _, press) = run(None);
            assert!(q > 1.4, "{side:?}: without the object it closes, q = {q}");
            assert_eq!(press, 0.0, "{side:?}");
        }
    }

    #[test]
    fn unplug_disconnects_open_links() {
        let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(Side::Left, EmulatorConfig::default())));
        let mut t = EmulatorTransport::open(&emu).unwrap();
        let cmd = LinuxToMcuCmd::default().encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        t.exchange(&cmd, &mut out, Duration::from_millis(10)).unwrap();
        lock(&emu).unplug();
        assert!(matches!(
            t.exchange(&cmd, &mut out, Duration::from_millis(10)),
            Err(TransportError::Disconnected)
        ));
        assert!(matches!(
            EmulatorTransport::open(&emu),
            Err(TransportError::NotFound(_))
        ));
        lock(&emu).replug();
        assert!(t.exchange(&cmd, &mut out, Duration::from_millis(10)).is_err());
        let mut t2 = EmulatorTransport::open(&emu).unwrap();
        t2.exchange(&cmd, &mut out, Duration::from_millis(10)).unwrap();
    }

    /// The first reply is the rest posture plus noise, never all zero; the same seed gives
    /// the same noise, another seed other noise; `Noise::OFF` reads the rest posture exactly
    /// (to the frame's resolution).
    #[test]
    fn rest_posture_not_all_zero_and_the_same_seed_gives_the_same_noise() {
        let run = |cfg: EmulatorConfig| {
            let mut emu = Dex3Emulator::new(Side::Left, cfg);
            // FOC with zero gains: the motors apply nothing, the joints stay at rest.
            let c = Dex3Command::hold([0.0; MOTOR_COUNT], 0.0, 0.0);
            (0..20)
                .map(|_| {
                    let m = exchange(&mut emu, &c, false);
                    Joint::ALL.map(|j| {
                        let s = m.motor(j);
                        [s.q, s.dq, s.tau]
                    })
                })
                .collect::<Vec<_>>()
        };
        let a = run(EmulatorConfig::default());
        assert!(a[0].iter().any(|m| m[0] != 0.0), "{:?}", a[0]);
        assert_eq!(a, run(EmulatorConfig::default()));
        let noise = crate::dex3::physical::HG_MOTOR_NOISE;
        let other = run(EmulatorConfig {
            noise: noise.with_seed(noise.seed + 1),
            ..Default::default()
        });
        assert_ne!(a, other);
        let exact = run(EmulatorConfig {
            noise: Noise::OFF,
            ..Default::default()
        });
        for (i, m) in exact[0].iter().enumerate() {
            let rest = crate::dex3::physical::rest_wire(Side::Left, i);
            assert!((m[0] - rest).abs() < 2.0e-4, "joint {i}: {m:?} vs rest {rest}");
            // With noise: within 3 standard deviations plus the frame's resolution.
            assert!(
                (a[0][i][0] - rest).abs() <= 3.0 * noise.q + 2.0e-4,
                "joint {i}: {:?}",
                a[0][i]
            );
        }
        assert!(exact.iter().all(|s| s == &exact[0]));
    }
}
