//! What a kind's `open` gets: the device's resolved settings ([`DeviceSpec`]) and the open
//! environment ([`OpenEnv`]): the gateway's DDS participant and the resources several
//! devices share (one Dynamixel bus for every EZGripper on a port), keyed by type and name
//! and kept alive as long as the runtime.

use std::any::{Any, TypeId};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::dds::Node;
use crate::device::{Backend, DeviceError, DeviceInfo};
use crate::kind::{DeviceKind, KindConfig, Problem};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::sim::{Noise, NOISE_MAX_DQ, NOISE_MAX_Q, NOISE_MAX_TAU};

/// `[devices.emulator]`: options of a device on the emulator backend (every kind).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EmulatorSection {
    /// Joint -> initial position, canonical rad (omitted joints: the kind's rest posture,
    /// docs/adapters.md).
    pub initial: BTreeMap<String, f64>,
    /// Joint -> canonical position where an emulated object blocks the closing joint, rad.
    pub object_at: BTreeMap<String, f64>,
    /// Measurement noise on the emulated state (default true: the kind's figures,
    /// docs/adapters.md). `false`: exact values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<bool>,
    /// Seed of the noise (default fixed: runs repeat exactly). Mixed with the device name, so
    /// two devices never share a stream.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Overrides of the kind's standard deviations, in the device's wire units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_noise_rad: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity_noise_rad_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_noise_nm: Option<f64>,
    /// A fault the emulated service injects (`stuck=<joint>`, `frozen`, `ignore-commands`:
    /// docs/adapters.md "Motion"), on the kinds whose emulator takes it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fault: Option<String>,
}

impl EmulatorSection {
    /// The noise to emulate, given the kind's default figures: off, or the defaults with
    /// this profile's overrides and seed (mixed with `device`, FNV-1a).
    pub fn noise_for(&self, device: &str, kind_default: Noise) -> Noise {
        if self.noise == Some(false) {
            return Noise::OFF;
        }
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in device.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        Noise {
            q: self.position_noise_rad.map(|v| v as f32).unwrap_or(kind_default.q),
            dq: self.velocity_noise_rad_s.map(|v| v as f32).unwrap_or(kind_default.dq),
            tau: self.torque_noise_nm.map(|v| v as f32).unwrap_or(kind_default.tau),
            seed: self.seed.unwrap_or(Noise::DEFAULT_SEED) ^ h,
        }
    }

    /// The keys this section sets (in documentation order).
    pub fn keys_set(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        for (key, set) in [
            ("initial", !self.initial.is_empty()),
            ("object_at", !self.object_at.is_empty()),
            ("noise", self.noise.is_some()),
            ("seed", self.seed.is_some()),
            ("position_noise_rad", self.position_noise_rad.is_some()),
            ("velocity_noise_rad_s", self.velocity_noise_rad_s.is_some()),
            ("torque_noise_nm", self.torque_noise_nm.is_some()),
            ("fault", self.fault.is_some()),
        ] {
            if set {
                out.push(key);
            }
        }
        out
    }

    /// The fault to inject, parsed (`None`: none set).
    pub fn fault_arg(&self) -> Option<Result<crate::emu_common::FaultArg, String>> {
        self.fault.as_deref().map(str::parse)
    }

    /// A problem with `fault` for a `kind` whose emulator takes the fault forms `takes`: not
    /// parsed, or a form it cannot inject.
    pub fn fault_problem(&self, kind: &str, takes: &[&str]) -> Option<Problem> {
        let key = ["emulator", "fault"];
        match self.fault_arg()? {
            Err(e) => Some(Problem::new(&key, e)),
            Ok(_) if takes.is_empty() => Some(Problem::new(
                &key,
                format!("has no effect on a {kind}: its emulator injects no fault, remove it"),
            )),
            Ok(f) if !takes.contains(&f.form()) => Some(Problem::new(
                &key,
                format!(
                    "has no effect on a {kind}: its emulator cannot inject {} (it takes {})",
                    f.form(),
                    takes.join(", ")
                ),
            )),
            Ok(_) => None,
        }
    }

    /// Checks the noise keys (positions are checked against the kind's joints by the profile).
    pub fn validate(&self) -> Vec<Problem> {
        let mut out = Vec::new();
        for (key, v, max) in [
            ("position_noise_rad", self.position_noise_rad, NOISE_MAX_Q),
            ("velocity_noise_rad_s", self.velocity_noise_rad_s, NOISE_MAX_DQ),
            ("torque_noise_nm", self.torque_noise_nm, NOISE_MAX_TAU),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && (0.0..=f64::from(max)).contains(&v)) {
                    out.push(Problem::new(
                        &["emulator", key],
                        format!("must be between 0 and {max} (measurement noise, one standard deviation), got {v}"),
                    ));
                }
            }
        }
        let overrides =
            self.position_noise_rad.is_some() || self.velocity_noise_rad_s.is_some() || self.torque_noise_nm.is_some();
        if self.noise == Some(false) && (overrides || self.seed.is_some()) {
            out.push(Problem::new(
                &["emulator", "noise"],
                "is false: seed and *_noise_* keys would have no effect, remove them",
            ));
        }
        out
    }
}

/// One device as its kind opens it; `C` its kind's configuration, erased (`dyn
/// KindConfig`: the profile and the runtime) or typed (the kind's own code,
/// [`crate::kind::Kind`]).
#[derive(Debug)]
pub struct DeviceSpec<'a, C: ?Sized = dyn KindConfig> {
    pub name: &'a str,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    /// Loop / publish rate, Hz.
    pub rate_hz: f64,
    /// A measurement older than this is stale (and the link down).
    pub stale_after: Duration,
    /// Devices that are clients of a DDS service: commands published on arrival (`false`:
    /// only at the loop's ticks) and the bound on the samples a second the service receives
    /// (`None`: [`crate::dds_device::Forwarding::DEFAULT_FACTOR`] × the loop rate).
    pub forward_on_arrival: bool,
    pub max_send_hz: Option<f64>,
    /// The device's table (profile overrides applied).
    pub table: &'a Arc<DeviceTable>,
    pub emulator: &'a EmulatorSection,
    /// The kind's own profile keys.
    pub config: &'a C,
}

impl<C: ?Sized> Clone for DeviceSpec<'_, C> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<C: ?Sized> Copy for DeviceSpec<'_, C> {}

impl<'a, C: ?Sized> DeviceSpec<'a, C> {
    /// The `[devices.emulator] fault` its emulator injects, its stuck joint found in the
    /// device's table (`None`: none set).
    pub fn emulator_fault(&self) -> Result<Option<crate::emu_common::Fault>, DeviceError> {
        match self.emulator.fault_arg() {
            Some(f) => Ok(Some(f.map_err(DeviceError::Config)?.resolve(self.table)?)),
            None => Ok(None),
        }
    }

    /// The same device with its configuration as `config` (the kind's typed view).
    pub fn typed<T>(&self, config: &'a T) -> DeviceSpec<'a, T> {
        DeviceSpec {
            name: self.name,
            kind: self.kind,
            side: self.side,
            backend: self.backend,
            rate_hz: self.rate_hz,
            stale_after: self.stale_after,
            forward_on_arrival: self.forward_on_arrival,
            max_send_hz: self.max_send_hz,
            table: self.table,
            emulator: self.emulator,
            config,
        }
    }

    /// How a DDS-client device whose loop runs at `rate_hz` forwards commands.
    pub fn forwarding(&self, rate_hz: f64) -> crate::dds_device::Forwarding {
        let default = crate::dds_device::Forwarding::default_for(rate_hz);
        crate::dds_device::Forwarding {
            on_arrival: self.forward_on_arrival,
            max_send_hz: self.max_send_hz.unwrap_or(default.max_send_hz).max(rate_hz),
        }
    }

    /// A client of a DDS service publishing on `cmd_topic` and reading `state_topic`, at
    /// `rate_hz`, with this device's staleness and forwarding.
    pub fn dds_client_at(
        &self,
        rate_hz: f64,
        cmd_topic: String,
        state_topic: Option<String>,
    ) -> crate::dds_device::DdsDeviceConfig {
        crate::dds_device::DdsDeviceConfig {
            cmd_topic,
            state_topic,
            rate_hz,
            stale_after: self.stale_after,
            forward: self.forwarding(rate_hz),
        }
    }

    /// [`DeviceSpec::dds_client_at`] the device's own rate.
    pub fn dds_client(&self, cmd_topic: String, state_topic: String) -> crate::dds_device::DdsDeviceConfig {
        self.dds_client_at(self.rate_hz, cmd_topic, Some(state_topic))
    }

    /// The identity every adapter reports.
    pub fn info(&self) -> DeviceInfo {
        DeviceInfo {
            name: self.name.to_string(),
            kind: self.kind,
            side: self.side,
            backend: self.backend,
            table: self.table.clone(),
        }
    }

    /// Wire position of `joint` at start on the emulator backend: `emulator.initial` through
    /// the table, else `default` (already wire).
    pub fn initial_wire(&self, joint: &str, default: f32) -> f32 {
        match (self.table.joint_by_name(joint), self.emulator.initial.get(joint)) {
            (Ok(id), Some(q)) => self.table.joints[id.index()].q_to_wire(*q as f32),
            _ => default,
        }
    }

    /// Wire position where an emulated object blocks `joint`, if the profile places one.
    pub fn object_wire(&self, joint: &str) -> Option<f32> {
        let id = self.table.joint_by_name(joint).ok()?;
        let q = self.emulator.object_at.get(joint)?;
        Some(self.table.joints[id.index()].q_to_wire(*q as f32))
    }
}

/// Resources shared by several devices, by type and key (kept alive by the runtime).
#[derive(Default)]
pub struct Shared {
    items: HashMap<(TypeId, String), Box<dyn Any + Send + Sync>>,
}

impl std::fmt::Debug for Shared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shared").field("items", &self.items.len()).finish()
    }
}

impl Shared {
    /// Stores `item` under `key` (replacing one of the same type and key).
    pub fn insert<R: Any + Send + Sync>(&mut self, key: &str, item: R) {
        self.items.insert((TypeId::of::<R>(), key.to_string()), Box::new(item));
    }

    /// The item of type `R` under `key`, a default one stored there first if there is none
    /// (what several devices share, e.g. one command message: `dds_device::SharedMessage`).
    pub fn get_or_default<R: Any + Send + Sync + Default + Clone>(&mut self, key: &str) -> R {
        if let Some(r) = self.get::<R>(key) {
            return r.clone();
        }
        let r = R::default();
        self.insert(key, r.clone());
        r
    }

    /// The item of type `R` under `key`.
    pub fn get<R: Any + Send + Sync>(&self, key: &str) -> Option<&R> {
        self.items
            .get(&(TypeId::of::<R>(), key.to_string()))
            .and_then(|b| b.downcast_ref::<R>())
    }
}

/// Where devices are opened.
pub struct OpenEnv<'a> {
    /// The gateway's DDS participant (DDS-client devices and their emulated peers use it).
    pub node: &'a Node,
    pub shared: &'a mut Shared,
}
