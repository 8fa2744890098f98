//! The RH56 front's registry entry (`kind = "inspire_rh56"`) and its servers: the hand's serial
//! protocol on a pseudo-terminal, for any bound hand (docs/fronts.md, "Inspire RH56"). The
//! pure codec is [`super::front`].

use std::path::PathBuf;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::front::{decode, AngleWrite, Image, SerialSession, SharedImage};
use crate::dds::DdsError;
use crate::discovery::diagnose::Served;
use crate::front::config::{FrontConfig, ServedSide, Silence, TopicKey};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{commands, routed, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use crate::front::stream::{serve_pty, StreamServer};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction};

/// The front's own keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rh56FrontConfig {
    /// The hand id clients address (HAND_ID; requests for another id get no answer).
    pub id: u8,
    /// Where the serial protocol's pseudo-terminal is linked (clients open it as a serial
    /// port); default [`default_pty`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pty: Option<PathBuf>,
}

impl Default for Rh56FrontConfig {
    fn default() -> Self {
        Rh56FrontConfig { id: 1, pty: None }
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
        let (id, link, name) = (c.id, c.pty_path(), plan.name.clone());
        commands(tx, dropped, move |inbox| {
            let image: SharedImage = Arc::new(Mutex::new(Image::new(id)));
            let im = image.clone();
            let server = serve_pty(&link, move || SerialSession::new(id, im.clone()), inbox, &name, "rh56 serial")
                .map_err(|e| DdsError::Thread(format!("the RH56 serial front's pty at {}: {e}", link.display())))?;
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
    fn default_name(_c: &Rh56FrontConfig, f: &FrontConfig, _side: &str) -> String {
        format!("inspire_rh56_{}", f.device.as_ref().map_or("?", |d| d.as_str()))
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
        out
    }
    fn describe(c: &Rh56FrontConfig) -> Option<String> {
        Some(format!(
            "the RH56 serial protocol, hand id {}, on pty {}",
            c.id,
            c.pty_path().display()
        ))
    }
}

impl FrontKind {
    /// The Inspire RH56's own serial protocol on a pty.
    #[allow(non_upper_case_globals)]
    pub const InspireRh56: FrontKind = Rh56Front::KIND;
}
