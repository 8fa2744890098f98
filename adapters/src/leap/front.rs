//! The virtual Dynamixel bus front (`kind = "leap_bus"`): a pseudo-terminal on which a LEAP
//! Hand program (LEAP_Hand_API, a dynamixel-sdk program, Dynamixel Wizard) finds the 16
//! XC330 of a LEAP Hand, ids 0-15, as on the U2D2's port, while handgate owns the real port
//! (or drives another kind of hand entirely). docs/fronts.md, "leap_bus".
//!
//! The servos are [`ServoBus`]'s control tables (ping, read, write, sync read, fast sync read,
//! sync write, reboot, the access rules), the same the emulator keeps. Their present current,
//! velocity and position are the bound device's state in LEAP units (its state routed to the
//! LEAP's 16 joints, through the LEAP table: 180° = flat), refreshed at the front's state
//! rate; a write of Goal Position (116) to any servo is a command: the written goals, through
//! the LEAP table, become canonical joint targets, routed to the bound device (joint for joint
//! on a LEAP Hand, through closure on any other kind). Every other write stays in the table (a
//! client's init, PID, goal current: read back as written, not applied to the device).
//!
//! Bad input: a byte stream that is no packet (garbage), a bad CRC, an impossible length, a
//! half packet followed by silence (`gap`): refused, counted per reason in the stream
//! front's counters and logged once per reason (`front::stream`); the session goes on.

use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::control_table::{ticks_to_rad, DEFAULT_IDS, MOTORS, RAD_PER_TICK, RAD_S_PER_VELOCITY_UNIT, TORQUE_PER_AMP};
use super::servos::ServoBus;
use crate::dds::DdsError;
use crate::dynamixel::control_table::reg;
use crate::dynamixel::protocol::{crc16, unstuff_into, PacketRef, HEADER, MAX_LENGTH_FIELD};
use crate::front::config::{FrontConfig, ServedSide, Silence, TopicKey};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{commands, routed, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use crate::front::stream::{serve_pty, Session, StreamError, StreamServer};
use crate::front::{FrontCommand, Rejection};
use crate::model::{DeviceKind, JointCommand, SafeAction};

/// The front's name (profile `kind = "leap_bus"`).
pub const NAME: &str = "leap_bus";
/// How often the servos' present values follow the bound device, Hz (the LEAP loop's rate).
pub const STATE_HZ: f64 = 500.0;
/// A half packet followed by this much silence is abandoned (counted `partial_frame`).
pub const GAP: Duration = Duration::from_millis(50);

/// `[[fronts]] kind = "leap_bus"`'s own keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeapBusConfig {
    /// Where the pseudo-terminal is linked (what a client opens as its port); default
    /// `<tmp>/handgate-<front name>`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pty: Option<PathBuf>,
}

impl ServedSide for LeapBusConfig {}

/// The link of a front named `name` with `c`.
pub fn link_of(c: &LeapBusConfig, name: &str) -> PathBuf {
    c.pty
        .clone()
        .unwrap_or_else(|| std::env::temp_dir().join(format!("handgate-{name}")))
}

/// What a client's writes asked of the bound device: the goal positions written, in ticks,
/// by joint (servo) index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GoalWrite {
    pub goals: [Option<i32>; MOTORS],
}

/// The servos the sessions answer from and the publisher refreshes.
type Image = Arc<Mutex<ServoBus>>;

fn lock(image: &Image) -> std::sync::MutexGuard<'_, ServoBus> {
    image.lock().unwrap_or_else(|p| p.into_inner())
}

/// One client's byte stream.
pub struct BusSession {
    image: Image,
    /// The unstuffed body of the packet being answered (its buffer reused).
    body: Vec<u8>,
}

impl BusSession {
    /// A session answering from `image`.
    pub fn new(image: Arc<Mutex<ServoBus>>) -> Self {
        Self {
            image,
            body: Vec::with_capacity(256),
        }
    }
}

impl Session for BusSession {
    type Msg = GoalWrite;

    fn on_bytes(
        &mut self,
        input: &[u8],
        _now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(GoalWrite),
    ) -> Result<usize, StreamError> {
        // A packet starts with the header; anything before the next header is garbage.
        if !input.starts_with(&HEADER[..input.len().min(HEADER.len())]) {
            let at = input
                .windows(HEADER.len())
                .position(|w| w == HEADER)
                .unwrap_or(input.len().saturating_sub(HEADER.len() - 1))
                .max(1);
            return Err(StreamError::skipping(
                at,
                "garbage",
                format!("{at} byte(s) before a packet header"),
            ));
        }
        if input.len() < 7 {
            return Ok(0);
        }
        let len = u16::from_le_bytes([input[5], input[6]]) as usize;
        if !(3..=MAX_LENGTH_FIELD).contains(&len) {
            return Err(StreamError::skipping(1, "bad_length", format!("length field {len}")));
        }
        let total = 7 + len;
        if input.len() < total {
            return Ok(0);
        }
        let got = u16::from_le_bytes([input[total - 2], input[total - 1]]);
        let want = crc16(&input[..total - 2]);
        if got != want {
            return Err(StreamError::skipping(
                1,
                "bad_crc",
                format!("CRC {got:04X}, expected {want:04X} (id {})", input[4]),
            ));
        }
        if !unstuff_into(&input[7..total - 2], &mut self.body) || self.body.is_empty() {
            return Err(StreamError::skipping(1, "garbage", "an unstuffed FF FF FD in the body"));
        }
        let pk = PacketRef {
            id: input[4],
            instruction: self.body[0],
            params: &self.body[1..],
        };
        // The command is handed on after the image is unlocked: the front may publish (lock
        // the image) on this very thread while it takes the command.
        let mut command = None;
        {
            let mut bus = lock(&self.image);
            let effect = bus.answer(pk, out);
            if let Some((addr, n)) = effect.wrote {
                let goal = reg::GOAL_POSITION;
                let mut w = GoalWrite::default();
                let wrote_goal = addr < goal.addr + goal.len && goal.addr < addr + n;
                bus.take_written(|i, s| {
                    if wrote_goal && i < MOTORS {
                        w.goals[i] = Some(s.get(goal) as i32);
                    }
                });
                if w.goals.iter().any(Option::is_some) {
                    command = Some(w);
                }
            }
        }
        if let Some(w) = command {
            sink(w);
        }
        Ok(total)
    }

    fn gap(&self) -> Option<Duration> {
        Some(GAP)
    }
}

/// The front's wire side: the image the sessions answer from, refreshed from the bound device.
pub struct BusIo {
    image: Image,
    _server: StreamServer,
}

impl TypedIo for BusIo {
    type Msg = GoalWrite;

    fn decode(&self, bound: &[Bound<'_>], msg: &GoalWrite) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        let front = &b.route.front;
        let (kp, kd) = (front.hold_kp, front.hold_kd);
        let joints: Vec<Option<JointCommand>> = front
            .joints
            .iter()
            .enumerate()
            .map(|(i, j)| {
                msg.goals
                    .get(i)
                    .copied()
                    .flatten()
                    .map(|t| JointCommand::hold(j.q_from_wire(ticks_to_rad(t)), kp, kd))
            })
            .collect();
        let c = FrontCommand {
            joints,
            timeout_bit: false,
            tag: 0,
        };
        Ok(vec![(0, routed(b.route, c))])
    }

    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        let Some(b) = bound.first() else { return };
        let front = &b.route.front;
        let joints = b.routed_state();
        let mut bus = lock(&self.image);
        for ((s, j), st) in bus.servos.iter_mut().zip(&front.joints).zip(&joints) {
            let q = j.q_to_wire(st.q);
            let dq = j.rate_to_wire(st.dq);
            let tau = j.tau_to_wire(st.tau);
            if q.is_finite() {
                s.put(reg::PRESENT_POSITION, i64::from((q / RAD_PER_TICK).round() as i32));
            }
            if dq.is_finite() {
                s.put(reg::PRESENT_VELOCITY, (dq / RAD_S_PER_VELOCITY_UNIT).round() as i64);
            }
            if tau.is_finite() {
                let ma = (tau / TORQUE_PER_AMP * 1000.0).round().clamp(-32768.0, 32767.0);
                s.put(reg::PRESENT_CURRENT, ma as i64);
            }
        }
    }
}

/// The front's endpoint: the pty server and its image.
pub struct BusWire;

impl FrontWire<LeapBusConfig> for BusWire {
    fn served(_c: &LeapBusConfig, _plan: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        Vec::new()
    }

    fn open(
        c: &LeapBusConfig,
        _env: &FrontEnv,
        plan: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError> {
        let image: Image = Arc::new(Mutex::new(ServoBus::new(&DEFAULT_IDS)));
        let link = link_of(c, &plan.name);
        let name = plan.name.clone();
        commands(tx, dropped, move |inbox| {
            let for_sessions = image.clone();
            let server = serve_pty(
                &link,
                move || BusSession::new(for_sessions.clone()),
                inbox,
                &name,
                "leap_bus",
            )
            .map_err(|e| DdsError::Thread(format!("the leap_bus pty at {}: {e}", link.display())))?;
            Ok(BusIo { image, _server: server })
        })
    }
}

/// The LEAP Hand's own bus, for any device.
#[derive(Debug)]
pub struct LeapBusFront;

impl Front for LeapBusFront {
    type Config = LeapBusConfig;
    type Wire = BusWire;
    const KIND: FrontKind = FrontKind::of(&LeapBusFront);
    const FACTS: FrontFacts = FrontFacts::serving(NAME, Some(DeviceKind::Leap));
    /// No DDS topic: a pseudo-terminal.
    const TOPICS: &'static [TopicKey<LeapBusConfig>] = &[];

    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        STATE_HZ
    }
    /// `leap_bus_<device>`, which also names its default pty (`<tmp>/handgate-leap_bus_<device>`).
    fn default_name(_c: &LeapBusConfig, f: &FrontConfig, side: &str) -> String {
        match &f.device {
            Some(d) => format!("{NAME}_{d}"),
            None => format!("{NAME}_{side}"),
        }
    }
    /// A Dynamixel bus has no command timeout: the servos keep their last goal.
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn describe(c: &LeapBusConfig) -> Option<String> {
        Some(match &c.pty {
            Some(p) => format!("the virtual Dynamixel bus (ids 0-15, 4 Mbaud) on pty {}", p.display()),
            None => "the virtual Dynamixel bus (ids 0-15, 4 Mbaud) on pty <tmp>/handgate-<front name>".into(),
        })
    }
}

impl FrontKind {
    /// The LEAP Hand's Dynamixel bus on a pseudo-terminal.
    #[allow(non_upper_case_globals)]
    pub const LeapBus: FrontKind = LeapBusFront::KIND;
}
