//! Profile → plan: turns a validated [`Profile`] into the typed [`Plan`] the runtime starts.
//! Everything a profile leaves out gets its documented default here or in the schema.

use std::time::Duration;

use handgate_adapters::device::Backend;
use handgate_adapters::dex3::usb::adapter::UsbSource;
use handgate_adapters::dex3::usb::{BusAddr, BusId, DeviceId, EmulatorConfig, WiringMap};
use handgate_adapters::hand_sdk::adapter::WeightRamp;
use handgate_adapters::mapping::Limits;
use handgate_adapters::model::DeviceKind;
use handgate_adapters::tables::{table_for, TableParams};

use handgate_adapters::dex1::adapter::actuator_index;
use handgate_adapters::dex1::SERVICE_BRAKE_AFTER;
use handgate_adapters::dex3::RIS_TIMEOUT;
use handgate_adapters::model::SafeAction;

use crate::plan::{
    canonical_topics, dex1_topics, dex3_topics, emulator_topics, Binding, DevicePlan, EmulatedPeer, FrontKind,
    FrontPlan, Plan, SilencePlan, Transport,
};
use crate::profile::{
    DeviceConfig, DeviceRate, FrontConfig, FrontKind as ProfileFrontKind, Profile, Silence, Topic,
    DEX1_DEFAULT_RANGE_RAD,
};

/// Why a profile could not become a plan (after validation these indicate a gap between the
/// validator and the runtime; they are reported like validation errors).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResolveError {
    #[error("devices[{0}] ({1}): {2}")]
    Device(usize, String, String),
    #[error("fronts[{0}]: {1}")]
    Front(usize, String),
}

/// How long without a state sample before a device's state is stale.
pub const DEFAULT_STALE_AFTER: Duration = Duration::from_millis(200);

fn table_params(d: &DeviceConfig) -> TableParams {
    let mut t = TableParams::default();
    if d.kind == DeviceKind::Dex1 {
        t.range_rad = d.dex1_range().0 as f32;
    }
    if let Some(ez) = &d.ezgripper {
        t.max_open_percent = ez.max_open_percent as f32;
    }
    t.max_step = d.limits.max_step.map(|r| r.0 as f32);
    let base = table_for(
        d.kind,
        d.side,
        &TableParams {
            limits: vec![],
            ..t.clone()
        },
    )
    .ok();
    for (name, l) in &d.limits.joints {
        let hw = base
            .as_ref()
            .and_then(|b| b.joint_by_name(name).ok().map(|id| b.joints[id.index()].limits))
            .unwrap_or(Limits::new(f32::NEG_INFINITY, f32::INFINITY));
        let min = l.min.map(|v| v.0 as f32).unwrap_or(hw.min);
        let max = l.max.map(|v| v.0 as f32).unwrap_or(hw.max);
        t.limits.push((name.clone(), Limits::new(min, max)));
    }
    if d.kind == DeviceKind::Dex3 {
        let names = DeviceKind::Dex3.joint_names();
        if !d.closure.open.is_empty() {
            t.open_posture = Some(
                names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| {
                        d.closure
                            .open
                            .get(*n)
                            .map(|r| r.0 as f32)
                            .unwrap_or(handgate_adapters::dex3::table::OPEN_POSTURE[i])
                    })
                    .collect(),
            );
        }
        if !d.closure.closed.is_empty() {
            t.closed_posture = Some(
                names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| {
                        d.closure
                            .closed
                            .get(*n)
                            .map(|r| r.0 as f32)
                            .unwrap_or(handgate_adapters::dex3::table::CLOSED_POSTURE[i])
                    })
                    .collect(),
            );
        }
    }
    t
}

/// The profile's (partial) wiring over the USB adapter's default map.
fn wiring(w: Option<&crate::profile::WiringConfig>) -> Result<WiringMap, String> {
    let mut m = WiringMap::default();
    let Some(w) = w else { return Ok(m) };
    let addr = |s: &crate::profile::BusSlot| -> Result<BusAddr, String> {
        Ok(BusAddr {
            bus: BusId::new(s.bus).map_err(|e| e.to_string())?,
            id: DeviceId::new(s.id).map_err(|e| e.to_string())?,
        })
    };
    for (name, slot) in &w.joints {
        let j = DeviceKind::Dex3
            .joint(name)
            .ok_or_else(|| format!("unknown joint {name}"))?;
        m.motors[j.index()] = addr(slot)?;
    }
    for (name, slot) in &w.pads {
        let i: usize = name
            .strip_prefix("pad_")
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| format!("unknown pad {name}"))?;
        *m.pads.get_mut(i).ok_or_else(|| format!("unknown pad {name}"))? = addr(slot)?;
    }
    m.validate().map_err(|e| e.to_string())?;
    Ok(m)
}

fn device(i: usize, d: &DeviceConfig) -> Result<DevicePlan, ResolveError> {
    let err = |m: String| ResolveError::Device(i, d.name.to_string(), m);
    let rate_hz = match d.rate() {
        DeviceRate::Hz(r) => r.0,
        DeviceRate::AsFastAsBus => 1000.0,
    };
    let table = table_params(d);
    let t = table_for(d.kind, d.side, &table).map_err(|e| err(e.to_string()))?;
    // Emulator initial positions are canonical; the emulated peers take wire values.
    let initial = |name: &str, default: f32| -> f32 {
        let id = match t.joint_by_name(name) {
            Ok(id) => id,
            Err(_) => return default,
        };
        let j = &t.joints[id.index()];
        d.emulator
            .as_ref()
            .and_then(|e| e.initial.get(name))
            .map(|r| j.q_to_wire(r.0 as f32))
            .unwrap_or(default)
    };
    let emulator = d.emulator.clone().unwrap_or_default();
    let noise = |kind_default| emulator.noise_for(&d.name.0, kind_default);
    let ramp = |d: &DeviceConfig| {
        let h = d.hand_sdk.clone().unwrap_or_default();
        (
            WeightRamp {
                target: h.weight as f32,
                per_second: h.ramp_per_s as f32,
            },
            h.publish_hz.map(|r| r.0).unwrap_or(rate_hz),
            h.topic.0,
        )
    };
    let transport = match (d.kind, d.backend) {
        (DeviceKind::Dex3, Backend::Dds) => {
            let (cmd, state) = d.dds_topics().unwrap_or((None, None));
            let (c, s, _) = dex3_topics(d.side);
            Transport::Dex3Dds {
                cmd_topic: cmd.map(|t| t.0).unwrap_or(c),
                state_topic: state.map(|t| t.0).unwrap_or(s),
                timeout_bit: d.usb.as_ref().map(|u| u.timeout_bit).unwrap_or(true),
            }
        }
        (DeviceKind::Dex1, Backend::Dds) => {
            let (cmd, state) = d.dds_topics().unwrap_or((None, None));
            let (c, s) = dex1_topics(d.dex1_variant(), d.side);
            Transport::Dex1Dds {
                variant: d.dex1_variant(),
                cmd_topic: cmd.map(|t| t.0).unwrap_or(c),
                state_topic: state.map(|t| t.0).unwrap_or(s),
            }
        }
        (DeviceKind::HandSdk, Backend::Dds) => {
            let (ramp, publish_hz, topic) = ramp(d);
            Transport::HandSdk {
                topic,
                ramp,
                publish_hz,
            }
        }
        (DeviceKind::Dex3, Backend::Usb | Backend::Emulator) => {
            let usb = d.usb.clone().unwrap_or_default();
            let source = if d.backend == Backend::Usb {
                match &usb.socket {
                    // `usb.socket`: the MCU emulator in another process (`handgate emulate`).
                    Some(path) => UsbSource::Socket(path.clone()),
                    None => UsbSource::Hardware {
                        serial: usb.serial.clone(),
                    },
                }
            } else {
                let mut q = [0.0f32; 7];
                for j in &t.joints {
                    // Omitted joints start at the hand's rest posture.
                    let rest = handgate_adapters::dex3::physical::rest_wire(d.side, j.wire_index);
                    q[j.wire_index] = initial(j.name, rest);
                }
                UsbSource::Emulator(Box::new(EmulatorConfig {
                    initial_q: Some(q),
                    noise: noise(handgate_adapters::dex3::physical::HG_MOTOR_NOISE),
                    ..Default::default()
                }))
            };
            Transport::Dex3Usb {
                source,
                timeout_bit: usb.timeout_bit,
                wiring: wiring(usb.wiring.as_ref()).map_err(err)?,
                scalings: usb.scalings.unwrap_or_default(),
            }
        }
        (DeviceKind::Ezgripper, Backend::Serial | Backend::Emulator) => {
            let ez = d.ezgripper.clone().unwrap_or_default();
            let emulated = d.backend == Backend::Emulator;
            Transport::EzGripper {
                port: ez.port.clone(),
                emulated,
                baud: ez.baud,
                servo_id: ez.servo_id_for(d.side),
                force_pct: ez.force_limit_percent.map(f32::from).unwrap_or(100.0),
                // An emulated gripper powers up uncalibrated, like a real one: calibrate it.
                calibrate_on_start: ez.calibrate_on_start || emulated,
                emulator_noise: noise(handgate_adapters::ezgripper::emulator::MX64_NOISE),
                zero_ticks: ez.zero_ticks,
                response_timeout_ms: ez.response_timeout_ms,
                params: handgate_adapters::ezgripper::EzGripperParams {
                    // The profile's max_open_percent is both the Dex1 scale and the clamp.
                    max_open_pct: f32::from(ez.max_open_percent),
                    ..ez.params.clone().unwrap_or_default()
                },
            }
        }
        (DeviceKind::Dex1, Backend::Emulator) => {
            let jaw = &t.joints[0];
            let object = d
                .emulator
                .as_ref()
                .and_then(|e| e.object_at.get("jaw"))
                .map(|r| jaw.q_to_wire(r.0 as f32));
            Transport::EmulatedDds(EmulatedPeer::Dex1Service {
                initial_q: initial("jaw", handgate_adapters::dex1::emulator::DEX1_REST_Q),
                object_q: object,
                noise: noise(handgate_adapters::dex3::physical::HG_MOTOR_NOISE),
            })
        }
        (DeviceKind::HandSdk, Backend::Emulator) => {
            let (ramp, publish_hz, _) = ramp(d);
            Transport::EmulatedDds(EmulatedPeer::AiSport { ramp, publish_hz })
        }
        (kind, backend) => {
            return Err(err(format!(
                "backend {backend} for a {kind} is not available in this build"
            )));
        }
    };
    Ok(DevicePlan {
        name: d.name.to_string(),
        kind: d.kind,
        side: d.side,
        backend: d.backend,
        table,
        rate_hz,
        stale_after: DEFAULT_STALE_AFTER,
        safe_action: d.watchdog.safe_action,
        transport,
    })
}

/// What silence means for front `f` driving device `d` (docs/fronts.md, "Silence").
pub fn silence_plan(f: &FrontConfig, d: &DeviceConfig) -> SilencePlan {
    let dog = {
        let t = d.watchdog.timeout_ms.as_duration();
        let t = f.watchdog_ms.map_or(t, |w| t.min(w.as_duration()));
        (t, d.watchdog.safe_action)
    };
    let (after, timeout_bit) = match (f.silence, f.kind) {
        // The Dex3 front honours the RIS timeout bit either way: in watchdog mode it shortens
        // the watchdog to at most the motors' own timeout, as before.
        (Silence::Watchdog, ProfileFrontKind::Dex3) => (Some(dog), Some((dog.0.min(RIS_TIMEOUT), dog.1))),
        (Silence::Watchdog, _) => (Some(dog), None),
        // The G1 Dex3 service forwards commands to motors that keep their last target; a
        // motor whose last command set the timeout bit stops (goes limp) 1 s later.
        (Silence::Service, ProfileFrontKind::Dex3) => (None, Some((RIS_TIMEOUT, SafeAction::Limp))),
        // dex1_1_service brakes: holds the measured position 1 s after the last command.
        (Silence::Service, ProfileFrontKind::Dex1) => (Some((SERVICE_BRAKE_AFTER, SafeAction::Hold)), None),
        // handgate's own interface: its service semantics are the strict watchdog.
        (Silence::Service, _) => (Some(dog), None),
    };
    SilencePlan {
        mode: if f.kind == ProfileFrontKind::Canonical {
            Silence::Watchdog
        } else {
            f.silence
        },
        after,
        timeout_bit,
    }
}

fn front(i: usize, f: &FrontConfig, p: &Profile) -> Result<FrontPlan, ResolveError> {
    let lookup = |n: &crate::profile::DeviceName| p.devices.iter().find(|d| &d.name == n);
    let dev = f.device.as_ref().and_then(lookup);
    let topics = f.topics(dev);
    let need = |t: Option<Topic>, what: &str| {
        t.map(|t| t.0)
            .ok_or_else(|| ResolveError::Front(i, format!("no {what} topic (side center?)")))
    };
    let kind = match f.kind {
        ProfileFrontKind::Dex3 => FrontKind::Dex3 {
            lf_state_topic: topics.lf_state.clone().map(|t| t.0),
            lf_state_hz: topics.lf_state_hz.map(|r| r.0).unwrap_or(50.0),
        },
        ProfileFrontKind::Dex1 => FrontKind::Dex1 {
            variant: f.dex1_variant(),
            range_rad: f
                .bindings(lookup)
                .first()
                .and_then(|(_, n)| lookup(n))
                .filter(|d| d.kind == DeviceKind::Dex1)
                .map(|d| d.dex1_range().0 as f32)
                .unwrap_or(DEX1_DEFAULT_RANGE_RAD as f32),
        },
        ProfileFrontKind::Canonical => FrontKind::Canonical,
        ProfileFrontKind::JointState => FrontKind::JointState {
            devices: match dev {
                Some(d) => vec![d.name.to_string()],
                None => p.devices.iter().map(|d| d.name.to_string()).collect(),
            },
            urdf_names: f.urdf_names.unwrap_or(true),
        },
    };
    let mut bindings = Vec::new();
    if f.kind != ProfileFrontKind::JointState {
        for (side, n) in f.bindings(lookup) {
            let d = lookup(n).ok_or_else(|| ResolveError::Front(i, format!("no device named {n}")))?;
            bindings.push(Binding {
                device: n.to_string(),
                side,
                element: if f.is_actuator() { actuator_index(side) } else { 0 },
                silence: silence_plan(f, d),
            });
        }
        if bindings.is_empty() {
            return Err(ResolveError::Front(i, "a device is required".into()));
        }
    }
    let (cmd_topic, state_topic) = match f.kind {
        ProfileFrontKind::JointState => (None, need(topics.state, "state")?),
        ProfileFrontKind::Canonical => {
            let (c, s) = canonical_topics(&bindings[0].device);
            (
                Some(topics.cmd.map(|t| t.0).unwrap_or(c)),
                topics.state.map(|t| t.0).unwrap_or(s),
            )
        }
        _ => (Some(need(topics.cmd, "command")?), need(topics.state, "state")?),
    };
    Ok(FrontPlan {
        name: f.display_name(dev),
        kind,
        bindings,
        cmd_topic,
        state_topic,
        state_hz: topics.state_hz.0,
    })
}

/// The plan for a validated profile.
pub fn plan(p: &Profile) -> Result<Plan, Vec<ResolveError>> {
    let mut errors = Vec::new();
    let devices: Vec<DevicePlan> = p
        .devices
        .iter()
        .enumerate()
        .filter_map(|(i, d)| device(i, d).map_err(|e| errors.push(e)).ok())
        .collect();
    let fronts: Vec<FrontPlan> = p
        .fronts
        .iter()
        .enumerate()
        .filter_map(|(i, f)| front(i, f, p).map_err(|e| errors.push(e)).ok())
        .collect();
    if !errors.is_empty() {
        return Err(errors);
    }
    Ok(Plan {
        profile: p.name.clone(),
        domain: p.dds.domain.0,
        interface: p.dds.interface.clone(),
        status_topic: p.status.topic.0.clone(),
        status_hz: p.status.rate_hz.0,
        devices,
        fronts,
    })
}

/// Emulator topics are private per device; exported for tests and docs.
pub fn private_topics(device: &str) -> (String, String) {
    emulator_topics(device)
}
