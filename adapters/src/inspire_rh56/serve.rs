//! The RH56 front's registry entry (`kind = "inspire_rh56"`) and its servers, for any bound
//! hand (docs/fronts.md, "Inspire RH56"): the hand's serial protocol on a pseudo-terminal
//! (`serve = "serial"`), Modbus RTU on a pty (`serve = "modbus_rtu"`), or Modbus TCP as the
//! RH56DFTP serves it (`serve = "modbus_tcp"`, on 127.0.0.1:6000 unless `listen` says
//! otherwise); the Modbus sessions are the kit's. The pure codecs are [`super::front`] and
//! [`super::modbus`].

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::front::{decode, AngleWrite, Image, SerialSession, SharedImage};
use super::modbus::FrontMap;
use crate::dds::DdsError;
use crate::discovery::diagnose::Served;
use crate::front::config::{FrontConfig, ServedSide, Silence, TopicKey};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{commands, routed, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use crate::front::stream::{serve_pty, serve_tcp, StreamLimits, StreamServer};
use crate::front::Rejection;
use crate::modbus::session::{RtuSession, TcpSession};
use crate::model::{DeviceKind, SafeAction};

/// What the front serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rh56Serve {
    /// The hand's own serial protocol on a pty.
    #[default]
    Serial,
    /// Modbus TCP (the DFTP's interface) on `listen`.
    ModbusTcp,
    /// Modbus RTU (slave `id`) on a pty.
    ModbusRtu,
}

/// The DFTP's Modbus TCP port (inspire-rh56dftp `DEFAULT_PORT`, the DFTP manual).
pub const MODBUS_TCP_PORT: u16 = 6000;

/// The front's own keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rh56FrontConfig {
    pub serve: Rh56Serve,
    /// The hand id clients address on the serial protocol (HAND_ID; requests for another id
    /// get no answer). Over Modbus TCP every unit id is this hand.
    pub id: u8,
    /// `serial`, `modbus_rtu`: where the pseudo-terminal is linked (clients open it as a serial port);
    /// default [`default_pty`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pty: Option<PathBuf>,
    /// `modbus_tcp`: the address to listen on; default 127.0.0.1:6000 (loopback: another host
    /// reaches it only where the profile says so).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub listen: Option<String>,
    /// `modbus_tcp`: clients served at once (one more is refused and counted); default 16.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_clients: Option<usize>,
    /// `modbus_tcp`: a client silent this long is closed, s; default 60.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub idle_s: Option<f64>,
}

impl Default for Rh56FrontConfig {
    fn default() -> Self {
        Rh56FrontConfig {
            serve: Rh56Serve::Serial,
            id: 1,
            pty: None,
            listen: None,
            max_clients: None,
            idle_s: None,
        }
    }
}

impl ServedSide for Rh56FrontConfig {}

/// The pty link of a front serving hand id `id` when the profile sets none.
pub fn default_pty(id: u8) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-inspire_rh56-id{id}"))
}

impl Rh56FrontConfig {
    pub fn pty_path(&self) -> PathBuf {
        self.pty.clone().unwrap_or_else(|| default_pty(self.id))
    }

    /// The Modbus TCP address (`listen`, or 127.0.0.1:6000).
    pub fn listen_addr(&self) -> Result<SocketAddr, String> {
        match &self.listen {
            None => Ok(SocketAddr::from(([127, 0, 0, 1], MODBUS_TCP_PORT))),
            Some(a) => a
                .parse()
                .map_err(|_| format!("`{a}` is not an address and port, e.g. 127.0.0.1:6000")),
        }
    }

    /// The TCP server's limits.
    pub fn limits(&self) -> StreamLimits {
        let d = StreamLimits::default();
        StreamLimits {
            max_clients: self.max_clients.unwrap_or(d.max_clients),
            idle: self.idle_s.map_or(d.idle, Duration::from_secs_f64),
            ..d
        }
    }
}

/// The running front's wire side: the image its sessions answer from, its server.
pub struct Rh56Io {
    image: SharedImage,
    _server: StreamServer,
}

impl TypedIo for Rh56Io {
    type Msg = AngleWrite;

    fn decode(&self, bound: &[Bound<'_>], msg: &AngleWrite) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        Ok(decode(msg, &b.route.front)?
            .map(|c| vec![(0, routed(b.route, c))])
            .unwrap_or_default())
    }

    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        let Some(b) = bound.first() else { return };
        let joints = b.routed_state();
        self.image
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .publish(&b.route.front, &joints, b.state);
    }
}

/// Its wire side: no DDS endpoint, a pty server.
pub struct Rh56Wire;

impl FrontWire<Rh56FrontConfig> for Rh56Wire {
    fn served(_c: &Rh56FrontConfig, _plan: &FrontPlan) -> Vec<Served> {
        Vec::new()
    }

    fn open(
        c: &Rh56FrontConfig,
        _env: &FrontEnv,
        plan: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError> {
        let (c, name) = (c.clone(), plan.name.clone());
        commands(tx, dropped, move |inbox| {
            let image: SharedImage = Arc::new(Mutex::new(Image::new(c.id)));
            let im = image.clone();
            let server = match c.serve {
                Rh56Serve::Serial => {
                    let (id, link) = (c.id, c.pty_path());
                    serve_pty(
                        &link,
                        move || SerialSession::new(id, im.clone()),
                        inbox,
                        &name,
                        "rh56 serial",
                    )
                    .map_err(|e| DdsError::Thread(format!("the RH56 serial front's pty at {}: {e}", link.display())))?
                }
                Rh56Serve::ModbusRtu => {
                    let (id, link) = (c.id, c.pty_path());
                    serve_pty(
                        &link,
                        move || RtuSession::new(id, FrontMap::new(im.clone()), 115_200),
                        inbox,
                        &name,
                        "rh56 modbus rtu",
                    )
                    .map_err(|e| {
                        DdsError::Thread(format!("the RH56 Modbus RTU front's pty at {}: {e}", link.display()))
                    })?
                }
                Rh56Serve::ModbusTcp => {
                    let at = c.listen_addr().map_err(DdsError::Thread)?;
                    serve_tcp(
                        at,
                        c.limits(),
                        move || TcpSession::any_unit(FrontMap::new(im.clone())),
                        inbox,
                        &name,
                        "rh56 modbus tcp",
                    )
                    .map_err(|e| DdsError::Thread(format!("the RH56 Modbus TCP front on {at}: {e}")))?
                }
            };
            Ok(Rh56Io { image, _server: server })
        })
    }
}

/// The Inspire RH56's own interface for any hand.
#[derive(Debug)]
pub struct Rh56Front;

impl Front for Rh56Front {
    type Config = Rh56FrontConfig;
    type Wire = Rh56Wire;
    const KIND: FrontKind = FrontKind::of(&Rh56Front);
    const FACTS: FrontFacts = FrontFacts::serving("inspire_rh56", Some(DeviceKind::InspireRh56));
    const TOPICS: &'static [TopicKey<Rh56FrontConfig>] = &[];

    /// The image is refreshed at the device's rate, at most 100 Hz (Unitree's DFX service's).
    fn default_state_hz(device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn default_name(c: &Rh56FrontConfig, f: &FrontConfig, _side: &str) -> String {
        let d = f.device.as_ref().map_or("?", |d| d.as_str());
        match c.serve {
            Rh56Serve::Serial => format!("inspire_rh56_{d}"),
            Rh56Serve::ModbusTcp => format!("inspire_rh56_tcp_{d}"),
            Rh56Serve::ModbusRtu => format!("inspire_rh56_rtu_{d}"),
        }
    }
    /// The hand keeps its last target when its client falls silent; `watchdog` mode: the
    /// device's watchdog.
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(
        c: &Rh56FrontConfig,
        _f: &FrontConfig,
        _served: Option<crate::model::Side>,
        _dangling: bool,
    ) -> Vec<(&'static str, String)> {
        let mut out = Vec::new();
        if c.id == 0 || c.id == 255 {
            out.push(("id", format!("must be between 1 and 254, got {}", c.id)));
        }
        if c.pty.as_ref().is_some_and(|p| p.as_os_str().is_empty()) {
            out.push(("pty", "must be a path (or absent: a temporary one)".to_string()));
        }
        if let Err(e) = c.listen_addr() {
            out.push(("listen", e));
        }
        match c.serve {
            Rh56Serve::Serial | Rh56Serve::ModbusRtu => {
                for (key, set) in [
                    ("listen", c.listen.is_some()),
                    ("max_clients", c.max_clients.is_some()),
                    ("idle_s", c.idle_s.is_some()),
                ] {
                    if set {
                        out.push((key, "is for serve = \"modbus_tcp\"; a pty has one client".to_string()));
                    }
                }
            }
            Rh56Serve::ModbusTcp => {
                if c.pty.is_some() {
                    out.push(("pty", "is for serve = \"serial\" or \"modbus_rtu\"".to_string()));
                }
                if c.max_clients == Some(0) {
                    out.push(("max_clients", "must be at least 1".to_string()));
                }
                if c.idle_s.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
                    out.push(("idle_s", "must be a positive number of seconds".to_string()));
                }
            }
        }
        out
    }
    fn describe(c: &Rh56FrontConfig) -> Option<String> {
        Some(match c.serve {
            Rh56Serve::Serial => format!(
                "the RH56 serial protocol, hand id {}, on pty {}",
                c.id,
                c.pty_path().display()
            ),
            Rh56Serve::ModbusRtu => format!("RH56 Modbus RTU, slave {}, on pty {}", c.id, c.pty_path().display()),
            Rh56Serve::ModbusTcp => format!(
                "RH56 Modbus TCP on {}",
                c.listen_addr().map_or_else(|e| e, |a| a.to_string())
            ),
        })
    }
}

impl FrontKind {
    /// The Inspire RH56's own interfaces: its serial protocol on a pty, Modbus TCP.
    #[allow(non_upper_case_globals)]
    pub const InspireRh56: FrontKind = Rh56Front::KIND;
}
