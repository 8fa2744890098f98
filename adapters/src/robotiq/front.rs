//! The Robotiq front (`kind = "robotiq"`): a Robotiq gripper's own interfaces for ANY bound
//! device, the way the Dex1 front serves an EZGripper. One register image (a Robotiq's
//! registers, activation and faults: [`Gripper::external`]) seen three ways, as on a UR arm
//! where the URCap and the tool forwarder reach one gripper:
//!
//! - Modbus RTU over TCP (UR's Tool Communication forwarder, port 54321: pyRobotiqGripper's
//!   `RTU_VIA_TCP`), bound to 127.0.0.1 unless the profile says otherwise;
//! - Modbus RTU on a pseudo-terminal (clients open its link as /dev/ttyUSB0);
//! - the URCap's text socket (port 63352, [`super::urcap`]).
//!
//! Slave 9 unless set, no exception responses (the gripper sends none: a bad request is
//! counted, logged once per client, and not answered). rPR maps to the bound device through
//! the front's table (a Robotiq of the profile's variant): joint for joint on a Robotiq,
//! through closure on any other hand; gPO is the device's position (its closure × 255 on
//! another hand), gOBJ its contact (its own contact flag, or the motion verdict "holding").
//! docs/fronts.md, "Robotiq".

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::emulator::{Gripper, Measured, Motion, Table, Tuning};
use super::regs::SLAVE_ID;
use crate::dds::DdsError;
use crate::discovery::diagnose::Served;
use crate::front::config::{FrontConfig, ServedSide, Silence, TopicKey};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{commands, routed, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use crate::front::stream::{serve_pty, serve_tcp, Session, StreamError, StreamLimits, StreamServer};
use crate::front::{FrontCommand, Rejection};
use crate::modbus::pdu::{Exception, Regs, Request};
use crate::modbus::server::RegisterMap;
use crate::modbus::session::{RtuSession, ServedMap};
use crate::model::{DeviceKind, JointCommand, SafeAction};
use crate::motion::Verdict;

/// UR's Tool Communication forwarder port, where RTU-over-TCP clients connect.
pub const RTU_TCP_PORT: u16 = 54321;
/// The Robotiq URCap's gripper socket.
pub const URCAP_PORT: u16 = 63352;
/// How long after the rising edge of rACT the front reports gSTA 3: the bound device is
/// already running, so only long enough for a client to see gSTA 1 (assumed).
pub const FRONT_ACTIVATION: Duration = Duration::from_millis(50);

/// The front's own keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotiqFrontConfig {
    /// Modbus slave id the RTU interfaces answer (9 from the factory).
    pub slave: u8,
    /// RTU over TCP, `address:port` (default 127.0.0.1:54321; `""`: off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rtu_tcp: Option<String>,
    /// The URCap text socket, `address:port` (default 127.0.0.1:63352; `""`: off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub urcap_tcp: Option<String>,
    /// Where the RTU pseudo-terminal is linked (default [`default_pty`]; `""`: off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pty: Option<PathBuf>,
    /// TCP clients served at once (each interface); one more is refused.
    pub max_clients: usize,
    /// A TCP client that sends nothing for this long is disconnected, ms.
    pub idle_ms: u64,
}

impl Default for RobotiqFrontConfig {
    fn default() -> Self {
        RobotiqFrontConfig {
            slave: SLAVE_ID,
            rtu_tcp: None,
            urcap_tcp: None,
            pty: None,
            max_clients: StreamLimits::default().max_clients,
            idle_ms: StreamLimits::default().idle.as_millis() as u64,
        }
    }
}

impl ServedSide for RobotiqFrontConfig {}

/// The pty link when the profile sets none (like the TCP ports, one front per gateway takes
/// the defaults; a second one sets its own).
pub fn default_pty() -> PathBuf {
    std::env::temp_dir().join("handgate-robotiq-rtu")
}

/// `Some(address)`, or `None` for an interface turned off (`""`).
fn address(set: &Option<String>, port: u16) -> Result<Option<SocketAddr>, String> {
    match set.as_deref() {
        None => Ok(Some(SocketAddr::from(([127, 0, 0, 1], port)))),
        Some("") => Ok(None),
        Some(s) => s
            .parse()
            .map(Some)
            .map_err(|_| format!("`{s}` is not address:port (e.g. 127.0.0.1:{port}), or \"\" to turn it off")),
    }
}

impl RobotiqFrontConfig {
    pub fn rtu_tcp_addr(&self) -> Result<Option<SocketAddr>, String> {
        address(&self.rtu_tcp, RTU_TCP_PORT)
    }

    pub fn urcap_addr(&self) -> Result<Option<SocketAddr>, String> {
        address(&self.urcap_tcp, URCAP_PORT)
    }

    /// The pty link, or `None` when turned off.
    pub fn pty_path(&self) -> Option<PathBuf> {
        match &self.pty {
            None => Some(default_pty()),
            Some(p) if p.as_os_str().is_empty() => None,
            Some(p) => Some(p.clone()),
        }
    }

    fn limits(&self) -> StreamLimits {
        StreamLimits {
            max_clients: self.max_clients,
            idle: Duration::from_millis(self.idle_ms),
            ..StreamLimits::default()
        }
    }
}

/// The register image every session of one front answers from.
pub type SharedImage = Arc<Mutex<Gripper>>;

/// A new front image: a Robotiq whose fingers are the bound device's.
pub fn image(now: Instant) -> SharedImage {
    Arc::new(Mutex::new(Gripper::external(
        Tuning {
            activation: FRONT_ACTIVATION,
            min_gap: Duration::ZERO,
            ..Tuning::default()
        },
        now,
    )))
}

fn lock(image: &SharedImage) -> std::sync::MutexGuard<'_, Gripper> {
    image.lock().unwrap_or_else(|p| p.into_inner())
}

/// A register image as a Modbus register map (RTU on a pty or over TCP): a front's, or the
/// standalone emulator's gripper.
pub struct ImageMap {
    image: SharedImage,
    now: Instant,
}

impl ImageMap {
    pub fn new(image: SharedImage) -> Self {
        Self {
            image,
            now: Instant::now(),
        }
    }
}

fn table_of(t: crate::modbus::pdu::Table) -> Table {
    match t {
        crate::modbus::pdu::Table::Holding => Table::Holding,
        crate::modbus::pdu::Table::Input => Table::Input,
    }
}

impl RegisterMap for ImageMap {
    fn read(&mut self, table: crate::modbus::pdu::Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        lock(&self.image)
            .read(table_of(table), addr, out, self.now)
            .map_err(|_| Exception::IllegalDataAddress)
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        lock(&self.image)
            .write(addr, values.iter(), self.now)
            .map_err(|_| Exception::IllegalDataAddress)
    }
}

impl ServedMap for ImageMap {
    type Msg = Motion;

    fn arrived(&mut self, now: Instant) {
        self.now = now;
    }

    fn performed(&mut self, _req: &Request<'_>, sink: &mut dyn FnMut(Motion)) {
        if let Some(m) = lock(&self.image).take_motion() {
            sink(m);
        }
    }
}

/// An RTU session on a register image: slave `slave`, no exception responses (the gripper
/// sends none).
pub fn rtu_session_on(image: SharedImage, slave: u8) -> RtuSession<ImageMap> {
    RtuSession::new(slave, ImageMap::new(image), super::regs::BAUD).exceptions(false)
}

/// The URCap text protocol on the front's image: one line at a time.
pub struct UrcapSession {
    image: SharedImage,
}

impl UrcapSession {
    pub fn new(image: SharedImage) -> Self {
        Self { image }
    }
}

impl Session for UrcapSession {
    type Msg = Motion;

    fn on_bytes(
        &mut self,
        input: &[u8],
        now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(Motion),
    ) -> Result<usize, StreamError> {
        let Some(end) = input.iter().position(|b| *b == b'\n') else {
            if input.len() > super::urcap::MAX_LINE {
                return Err(StreamError::new(
                    "overlong",
                    format!("{} bytes without a line end", input.len()),
                ));
            }
            return Ok(0);
        };
        let line = &input[..end];
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let mut g = lock(&self.image);
        let r = super::urcap::answer_line(line, &mut g, now, out);
        if let Some(m) = g.take_motion() {
            sink(m);
        }
        match r {
            Ok(()) => Ok(end + 1),
            Err(e) => Err(StreamError::skipping(end + 1, e.reason, e.detail)),
        }
    }
}

/// The running front's wire side: the image, its servers.
pub struct RobotiqIo {
    image: SharedImage,
    _servers: Vec<StreamServer>,
}

impl RobotiqIo {
    pub fn image(&self) -> &SharedImage {
        &self.image
    }
}

/// The command a client's motion makes for the bound device `b`: rPR through the front's
/// table (a stop holds the device's position).
pub fn decode(b: &Bound<'_>, m: &Motion) -> Result<Routed, Rejection> {
    let jaw = &b.route.front.joints[0];
    let q = match *m {
        Motion::Go { position, .. } => jaw.q_from_wire(f32::from(position)),
        Motion::Stop => b.routed_state().first().map_or(0.0, |j| j.q),
    };
    let c = FrontCommand {
        joints: vec![Some(JointCommand {
            q,
            ..JointCommand::default()
        })],
        timeout_bit: false,
        tag: 0,
    };
    Ok(routed(b.route, c))
}

/// What the image shows of the bound device `b`: its position through the front's table and
/// whether it holds something.
pub fn measured(b: &Bound<'_>) -> Measured {
    let jaw = &b.route.front.joints[0];
    let q = b.routed_state().first().map_or(0.0, |j| j.q);
    let position = jaw.q_to_wire(q);
    Measured {
        position: if position.is_finite() {
            position.clamp(0.0, 255.0)
        } else {
            0.0
        },
        contact: b.state.contact.iter().any(|c| *c) || b.state.motion.verdict == Verdict::Holding,
    }
}

impl TypedIo for RobotiqIo {
    type Msg = Motion;

    fn decode(&self, bound: &[Bound<'_>], msg: &Motion) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        Ok(vec![(0, decode(b, msg)?)])
    }

    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        let Some(b) = bound.first() else { return };
        let m = measured(b);
        lock(&self.image).set_measured(m);
    }
}

fn bind_error(what: &str, at: &str, e: std::io::Error) -> DdsError {
    DdsError::Thread(format!("the Robotiq front's {what} at {at}: {e}"))
}

/// Its wire side: no DDS endpoint; the RTU-over-TCP, pty and URCap servers.
pub struct RobotiqWire;

impl FrontWire<RobotiqFrontConfig> for RobotiqWire {
    fn served(_c: &RobotiqFrontConfig, _plan: &FrontPlan) -> Vec<Served> {
        Vec::new()
    }

    fn open(
        c: &RobotiqFrontConfig,
        _env: &FrontEnv,
        plan: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError> {
        let name = plan.name.clone();
        let (slave, limits) = (c.slave, c.limits());
        let rtu_tcp = c.rtu_tcp_addr().map_err(DdsError::Thread)?;
        let urcap = c.urcap_addr().map_err(DdsError::Thread)?;
        let pty = c.pty_path();
        commands(tx, dropped, move |inbox| {
            let image = image(Instant::now());
            let mut servers = Vec::new();
            if let Some(at) = rtu_tcp {
                let im = image.clone();
                let s = serve_tcp(
                    at,
                    limits,
                    move || rtu_session_on(im.clone(), slave),
                    inbox.clone(),
                    &name,
                    "robotiq rtu-over-tcp",
                )
                .map_err(|e| bind_error("RTU over TCP", &at.to_string(), e))?;
                servers.push(("RTU over TCP", s));
            }
            if let Some(link) = &pty {
                let im = image.clone();
                let s = serve_pty(
                    link,
                    move || rtu_session_on(im.clone(), slave),
                    inbox.clone(),
                    &name,
                    "robotiq rtu",
                )
                .map_err(|e| bind_error("RTU pty", &link.display().to_string(), e))?;
                servers.push(("RTU pty", s));
            }
            if let Some(at) = urcap {
                let im = image.clone();
                let s = serve_tcp(
                    at,
                    limits,
                    move || UrcapSession::new(im.clone()),
                    inbox,
                    &name,
                    "robotiq urcap",
                )
                .map_err(|e| bind_error("URCap socket", &at.to_string(), e))?;
                servers.push(("URCap socket", s));
            }
            // One line each, with where it serves (a port 0 in the profile resolved).
            for (what, s) in &servers {
                tracing::info!(front = %name, "robotiq front: {what} at {}", s.at);
            }
            Ok(RobotiqIo {
                image,
                _servers: servers.into_iter().map(|(_, s)| s).collect(),
            })
        })
    }
}

/// A Robotiq gripper's interfaces for any device.
#[derive(Debug)]
pub struct RobotiqFront;

impl Front for RobotiqFront {
    type Config = RobotiqFrontConfig;
    type Wire = RobotiqWire;
    const KIND: FrontKind = FrontKind::of(&RobotiqFront);
    const FACTS: FrontFacts = FrontFacts::serving("robotiq", Some(DeviceKind::Robotiq));
    const TOPICS: &'static [TopicKey<RobotiqFrontConfig>] = &[];

    /// The image follows the device at its rate, at most the manual's 200 Hz.
    fn default_state_hz(device_hz: Option<f64>) -> f64 {
        device_hz.map_or(200.0, |d| d.min(200.0))
    }
    fn default_name(_c: &RobotiqFrontConfig, f: &FrontConfig, _side: &str) -> String {
        format!("robotiq_{}", f.device.as_ref().map_or("?", |d| d.as_str()))
    }
    /// A Robotiq keeps its last request when its master falls silent (it only reports gFLT
    /// 0x09); `watchdog` mode: the device's watchdog.
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(
        c: &RobotiqFrontConfig,
        _f: &FrontConfig,
        _served: Option<crate::model::Side>,
        _dangling: bool,
    ) -> Vec<(&'static str, String)> {
        let mut out = Vec::new();
        if !(1..=247).contains(&c.slave) {
            out.push((
                "slave",
                format!("must be a Modbus slave id between 1 and 247, got {}", c.slave),
            ));
        }
        if let Err(e) = c.rtu_tcp_addr() {
            out.push(("rtu_tcp", e));
        }
        if let Err(e) = c.urcap_addr() {
            out.push(("urcap_tcp", e));
        }
        if let (Ok(Some(a)), Ok(Some(b))) = (c.rtu_tcp_addr(), c.urcap_addr()) {
            if a == b && a.port() != 0 {
                out.push((
                    "urcap_tcp",
                    format!("is rtu_tcp's address too ({a}): one port, one protocol"),
                ));
            }
        }
        if c.max_clients == 0 {
            out.push(("max_clients", "must be at least 1".into()));
        }
        if c.idle_ms == 0 {
            out.push(("idle_ms", "must be at least 1 ms".into()));
        }
        out
    }
    fn describe(c: &RobotiqFrontConfig) -> Option<String> {
        let on = |a: Result<Option<SocketAddr>, String>| match a {
            Ok(Some(a)) => a.to_string(),
            _ => "off".into(),
        };
        Some(format!(
            "Robotiq slave {}: RTU over TCP {}, RTU pty {}, URCap socket {}",
            c.slave,
            on(c.rtu_tcp_addr()),
            c.pty_path().map_or("off".into(), |p| p.display().to_string()),
            on(c.urcap_addr()),
        ))
    }
}

impl FrontKind {
    /// A Robotiq gripper's own interfaces (RTU over TCP, RTU on a pty, the URCap socket).
    #[allow(non_upper_case_globals)]
    pub const Robotiq: FrontKind = RobotiqFront::KIND;
}
