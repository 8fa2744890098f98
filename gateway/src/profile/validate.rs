//! Semantic checks on a deserialized profile. Every check runs; all problems are returned.

use std::collections::{BTreeMap, HashMap};

use super::error::KeyPath;
use super::hardware::{joint_names, joint_range};
use super::schema::*;

/// A problem found by [`validate`]: key path and message (the loader adds the origin).
pub type Problem = (KeyPath, String);

/// Checks everything that serde cannot: ranges, names, cross references, topic clashes.
pub fn validate(p: &Profile) -> Vec<Problem> {
    let mut c = Checker::default();
    c.profile(p);
    c.out
}

#[derive(Default)]
struct Checker {
    out: Vec<Problem>,
}

fn root() -> KeyPath {
    KeyPath::root()
}

/// "a dex3", "an ezgripper".
fn a(word: &str) -> String {
    let article = if word.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {word}")
}

fn is_name(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-')
}

impl Checker {
    fn err(&mut self, key: KeyPath, msg: impl Into<String>) {
        self.out.push((key, msg.into()));
    }

    fn rate(&mut self, key: KeyPath, r: RateHz, max: f64) {
        if !(r.0.is_finite() && r.0 > 0.0 && r.0 <= max) {
            self.err(key, format!("must be a rate above 0 and at most {max} Hz, got {}", r.0));
        }
    }

    fn topic(&mut self, key: KeyPath, t: &Topic) {
        let s = t.as_str();
        if s.is_empty() || s.chars().any(char::is_whitespace) || s.starts_with('/') || s.ends_with('/') {
            self.err(
                key,
                format!("`{s}` is not a topic name (non-empty, no spaces, no leading or trailing `/`)"),
            );
        }
    }

    fn profile(&mut self, p: &Profile) {
        // dds
        if p.dds.domain.0 > MAX_DOMAIN_ID {
            self.err(
                root().key("dds").key("domain"),
                format!("must be between 0 and {MAX_DOMAIN_ID}, got {}", p.dds.domain.0),
            );
        }
        if let Some(i) = &p.dds.interface {
            if i.trim().is_empty() || i.chars().any(char::is_whitespace) {
                self.err(
                    root().key("dds").key("interface"),
                    format!("`{i}` is not an interface name"),
                );
            }
        }
        // log
        if let Err(e) = tracing_subscriber::EnvFilter::try_new(&p.log.level) {
            self.err(
                root().key("log").key("level"),
                format!("`{}` is not a log filter: {e}", p.log.level),
            );
        }
        // status
        self.topic(root().key("status").key("topic"), &p.status.topic);
        self.rate(
            root().key("status").key("rate_hz"),
            p.status.rate_hz,
            MAX_STATUS_RATE_HZ,
        );

        // devices
        let mut by_name: HashMap<&str, usize> = HashMap::new();
        for (i, d) in p.devices.iter().enumerate() {
            let k = root().key("devices").index(i);
            if !is_name(d.name.as_str()) {
                self.err(
                    k.key("name"),
                    format!("`{}` is not a device name (use a-z, 0-9, `_`, `-`)", d.name),
                );
            }
            if let Some(first) = by_name.insert(d.name.as_str(), i) {
                by_name.insert(d.name.as_str(), first);
                self.err(
                    k.key("name"),
                    format!("duplicate device name `{}` (also devices[{first}])", d.name),
                );
            }
            self.device(&k, d);
        }
        self.fleet_buses(p);

        // fronts
        let mut cmd_topics: BTreeMap<Topic, usize> = BTreeMap::new();
        let mut state_topics: BTreeMap<Topic, usize> = BTreeMap::new();
        let mut names: BTreeMap<String, usize> = BTreeMap::new();
        let known = || {
            let v: Vec<&str> = p.devices.iter().map(|d| d.name.as_str()).collect();
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        for (i, f) in p.fronts.iter().enumerate() {
            let k = root().key("fronts").index(i);
            let mut missing = false;
            if let Some(els) = &f.devices {
                if !f.is_actuator() {
                    self.err(
                        k.key("devices"),
                        "only an actuator dex1 front binds devices by element; use `device`",
                    );
                }
                if f.device.is_some() {
                    self.err(
                        k.key("devices"),
                        "give either `device` (one gripper, on the front's side) or `devices` (by element), not both",
                    );
                }
                if f.side.is_some() {
                    self.err(
                        k.key("side"),
                        "an actuator front bound with `devices` serves both elements (0 = right, 1 = left); drop `side`",
                    );
                }
                if els.bound().is_empty() {
                    self.err(
                        k.key("devices"),
                        "bind at least one element: `devices = { right = \"..\", left = \"..\" }`",
                    );
                }
                if let (Some(r), Some(l)) = (&els.right, &els.left) {
                    if r == l {
                        self.err(k.key("devices"), format!("`{r}` is bound to both elements"));
                    }
                }
                for (side, n) in els.bound() {
                    if !by_name.contains_key(n.as_str()) {
                        missing = true;
                        self.err(
                            k.key("devices").key(side.as_str()),
                            format!("no device named `{n}` (devices: {})", known()),
                        );
                    }
                }
            }
            let dev = match &f.device {
                Some(n) => match by_name.get(n.as_str()) {
                    Some(&di) => Some(&p.devices[di]),
                    None => {
                        self.err(k.key("device"), format!("no device named `{n}` (devices: {})", known()));
                        None
                    }
                },
                None => {
                    if f.kind != FrontKind::JointState && f.devices.is_none() {
                        self.err(
                            k.key("device"),
                            format!("{} front must name its device", a(f.kind.as_str())),
                        );
                    }
                    None
                }
            };
            let dangling = (f.device.is_some() && dev.is_none()) || missing;
            self.front(&k, f, dev, dangling);
            if dev.is_none() && f.kind != FrontKind::JointState && (f.devices.is_none() || missing) {
                // Its topics depend on a device that is not there; already reported.
                continue;
            }
            let name = f.display_name(dev);
            if f.name.is_some() && !is_name(&name) {
                self.err(
                    k.key("name"),
                    format!("`{name}` is not a front name (use a-z, 0-9, `_`, `-`)"),
                );
            }
            match names.get(&name) {
                // Two derived names only coincide on fronts serving the same topic: reported below.
                Some(&j) if f.name.is_some() || p.fronts[j].name.is_some() => self.err(
                    k.key("name"),
                    format!("front name `{name}` is also fronts[{j}]'s; give each front its own `name`"),
                ),
                Some(_) => {}
                None => {
                    names.insert(name, i);
                }
            }
            let topics = f.topics(dev);
            let mut cmd_clash = None;
            if let Some(t) = &topics.cmd {
                if t == &p.status.topic {
                    self.err(k.key("cmd_topic"), format!("command topic `{t}` is the status topic"));
                }
                match cmd_topics.get(t) {
                    Some(&j) => {
                        cmd_clash = Some(j);
                        let why = if f.is_actuator() && p.fronts[j].is_actuator() {
                            ": one actuator front serves both grippers, `devices = { right = \"..\", left = \"..\" }`"
                        } else {
                            ""
                        };
                        self.err(
                            k.key("cmd_topic"),
                            format!("command topic `{t}` is already served by fronts[{j}]{why}"),
                        );
                    }
                    None => {
                        cmd_topics.insert(t.clone(), i);
                    }
                }
            }
            // Two publishers of one state topic would interleave two views of the fleet.
            let state_key = if f.kind == FrontKind::JointState {
                "topic"
            } else {
                "state_topic"
            };
            for (key, t) in [(state_key, &topics.state), ("lf_state_topic", &topics.lf_state)] {
                let Some(t) = t else { continue };
                if t == &p.status.topic {
                    self.err(k.key(key), format!("state topic `{t}` is the status topic"));
                }
                match state_topics.get(t) {
                    // Same pair of fronts as the command clash: one error is enough.
                    Some(&j) if cmd_clash == Some(j) => {}
                    Some(&j) => self.err(
                        k.key(key),
                        format!("state topic `{t}` is already published by fronts[{j}]: two fronts would interleave their state on it"),
                    ),
                    None => {
                        state_topics.insert(t.clone(), i);
                    }
                }
            }
            // A front must not serve a topic handgate itself uses to reach a DDS device on
            // the same domain: it would answer its own commands.
            for (di, d) in p.devices.iter().enumerate() {
                if let Some((dcmd, dstate)) = d.dds_topics() {
                    let clash = |a: &Option<Topic>, b: &Option<Topic>| a.is_some() && a == b;
                    if clash(&topics.cmd, &dcmd) || clash(&topics.state, &dstate) || clash(&topics.lf_state, &dstate) {
                        self.err(
                            k.clone(),
                            format!(
                                "serves `{}` which devices[{di}] (`{}`, backend dds) uses to reach the real device on the same domain",
                                topics.cmd.clone().or(topics.state.clone()).map(|t| t.0).unwrap_or_default(),
                                d.name
                            ),
                        );
                    }
                }
            }
        }
    }

    fn joint(&mut self, key: KeyPath, d: &DeviceConfig, joint: &str) -> Option<(f64, f64)> {
        if !joint_names(d.kind).contains(&joint) {
            self.err(
                key,
                format!(
                    "unknown joint `{joint}` for {} (joints: {})",
                    a(d.kind.as_str()),
                    joint_names(d.kind).join(", ")
                ),
            );
            return None;
        }
        joint_range(d.kind, d.side, joint)
    }

    fn position(&mut self, key: KeyPath, d: &DeviceConfig, joint: &str, v: Radians) {
        if let Some((lo, hi)) = self.joint(key.clone(), d, joint) {
            if !v.0.is_finite() || v.0 < lo || v.0 > hi {
                self.err(
                    key,
                    format!(
                        "{} is outside the {} {} hardware range [{lo}, {hi}] rad",
                        v.0, d.side, d.kind
                    ),
                );
            }
        }
    }

    fn device(&mut self, k: &KeyPath, d: &DeviceConfig) {
        use Backend::*;
        use DeviceKind::*;
        let ok_backends: &[Backend] = match d.kind {
            Dex3 => &[Usb, Dds, Emulator],
            Dex1 => &[Dds, Emulator],
            Ezgripper => &[Serial, Emulator],
            HandSdk => &[Dds, Emulator],
        };
        if !ok_backends.contains(&d.backend) {
            let names: Vec<&str> = ok_backends.iter().map(|b| b.as_str()).collect();
            self.err(
                k.key("backend"),
                format!(
                    "{} cannot use backend {} (valid: {})",
                    a(d.kind.as_str()),
                    d.backend,
                    names.join(", ")
                ),
            );
        }
        if d.kind == Dex3 && d.side == Side::Center {
            self.err(k.key("side"), "a dex3 is a left or a right hand, not center");
        }
        if let Some(r) = d.rate_hz {
            self.rate(k.key("rate_hz"), r, MAX_RATE_HZ);
        }

        // limits
        let lk = k.key("limits");
        if let Some(s) = d.limits.max_step {
            if !(s.0.is_finite() && s.0 > 0.0) {
                self.err(lk.key("max_step"), format!("must be above 0 rad, got {}", s.0));
            }
        }
        for (j, lim) in &d.limits.joints {
            let jk = lk.key("joints").key(j.clone());
            let Some((lo, hi)) = self.joint(jk.clone(), d, j) else {
                continue;
            };
            for (which, v) in [("min", lim.min), ("max", lim.max)] {
                if let Some(v) = v {
                    if !v.0.is_finite() || v.0 < lo || v.0 > hi {
                        self.err(
                            jk.key(which),
                            format!(
                                "{} is outside the {} {} hardware range [{lo}, {hi}] rad",
                                v.0, d.side, d.kind
                            ),
                        );
                    }
                }
            }
            let min = lim.min.map_or(lo, |r| r.0);
            let max = lim.max.map_or(hi, |r| r.0);
            if min >= max {
                self.err(jk.clone(), format!("min ({min}) must be below max ({max})"));
            }
        }

        // watchdog
        let (wlo, whi) = WATCHDOG_MS_RANGE;
        if !(wlo..=whi).contains(&d.watchdog.timeout_ms.0) {
            self.err(
                k.key("watchdog").key("timeout_ms"),
                format!("must be between {wlo} and {whi}, got {}", d.watchdog.timeout_ms.0),
            );
        }

        // closure
        let ck = k.key("closure");
        if d.kind == Dex3 {
            for (which, m) in [("open", &d.closure.open), ("closed", &d.closure.closed)] {
                for (j, v) in m {
                    self.position(ck.key(which).key(j.clone()), d, j, *v);
                }
            }
        } else {
            for (which, m) in [("open", &d.closure.open), ("closed", &d.closure.closed)] {
                if !m.is_empty() {
                    self.err(
                        ck.key(which),
                        format!("only a dex3 has closure postures, this is {}", a(d.kind.as_str())),
                    );
                }
            }
        }
        for (which, v) in [("tau_open", d.closure.tau_open), ("tau_closed", d.closure.tau_closed)] {
            let Some(v) = v else { continue };
            if d.kind != HandSdk {
                self.err(
                    ck.key(which),
                    format!(
                        "only a hand_sdk device maps closure to torque, this is {}",
                        a(d.kind.as_str())
                    ),
                );
            } else if !v.is_finite() || v.abs() > 5.0 {
                self.err(ck.key(which), format!("must be a torque within +-5 N*m, got {v}"));
            }
        }
        if let (HandSdk, Some(o), Some(c)) = (d.kind, d.closure.tau_open, d.closure.tau_closed) {
            if o >= c {
                self.err(
                    ck.key("tau_open"),
                    format!("must be below tau_closed ({o} >= {c}): positive torque closes"),
                );
            }
        }

        // sections that must match kind and backend
        let section = |this: &mut Self, name: &str, present: bool, ok: bool, why: &str| {
            if present && !ok {
                this.err(
                    k.key(name),
                    format!(
                        "[{name}] {why}, this is {} on backend {}",
                        a(d.kind.as_str()),
                        d.backend
                    ),
                );
            }
        };
        section(
            self,
            "usb",
            d.usb.is_some(),
            d.kind == Dex3 && matches!(d.backend, Usb | Emulator),
            "applies to a dex3 on backend usb or emulator",
        );
        section(
            self,
            "dds",
            d.dds.is_some(),
            matches!(d.kind, Dex3 | Dex1) && d.backend == Dds,
            "applies to a dex3 or dex1 on backend dds",
        );
        section(
            self,
            "hand_sdk",
            d.hand_sdk.is_some(),
            d.kind == HandSdk,
            "applies to a hand_sdk device",
        );
        section(
            self,
            "ezgripper",
            d.ezgripper.is_some(),
            d.kind == Ezgripper && matches!(d.backend, Serial | Emulator),
            "applies to an ezgripper on backend serial or emulator",
        );
        section(
            self,
            "emulator",
            d.emulator.is_some(),
            d.backend == Emulator,
            "applies to backend emulator",
        );

        if let Some(u) = &d.usb {
            self.usb(&k.key("usb"), d, u);
        }
        if let Some(x) = &d.dds {
            let xk = k.key("dds");
            if let Some(t) = &x.cmd_topic {
                self.topic(xk.key("cmd_topic"), t);
            }
            if let Some(t) = &x.state_topic {
                self.topic(xk.key("state_topic"), t);
            }
            if x.state_source.is_some() && d.kind != Dex3 {
                self.err(xk.key("state_source"), "only a dex3 has a low-frequency state topic");
            }
            if x.variant.is_some() && d.kind != Dex1 {
                self.err(xk.key("variant"), "only a dex1 has wire variants");
            }
            if let Some(r) = x.range_rad {
                if d.kind != Dex1 {
                    self.err(xk.key("range_rad"), "only a dex1 has an open range");
                } else if !(r.0.is_finite() && r.0 > 0.0 && r.0 <= std::f64::consts::TAU) {
                    self.err(
                        xk.key("range_rad"),
                        format!("must be above 0 and at most 2pi rad, got {}", r.0),
                    );
                }
            }
        }
        if d.backend == Dds && matches!(d.kind, Dex3 | Dex1) && d.side == Side::Center {
            if let Some((cmd, state)) = d.dds_topics() {
                if cmd.is_none() || state.is_none() {
                    self.err(
                        k.key("side"),
                        format!(
                            "{} on backend dds with side center needs dds.cmd_topic and dds.state_topic",
                            a(d.kind.as_str())
                        ),
                    );
                }
            }
        }
        if d.kind == Dex1 && d.backend == Dds && d.dex1_variant() == Dex1Variant::Actuator && d.side == Side::Center {
            self.err(
                k.key("side"),
                "the actuator variant addresses element 0 = right, 1 = left: side must be left or right",
            );
        }
        if let Some(h) = &d.hand_sdk {
            let hk = k.key("hand_sdk");
            self.topic(hk.key("topic"), &h.topic);
            if !(h.weight.is_finite() && (0.0..=1.0).contains(&h.weight)) {
                self.err(hk.key("weight"), format!("must be between 0 and 1, got {}", h.weight));
            }
            if !(h.ramp_per_s.is_finite() && h.ramp_per_s > 0.0 && h.ramp_per_s <= 100.0) {
                self.err(
                    hk.key("ramp_per_s"),
                    format!("must be above 0 and at most 100 per second, got {}", h.ramp_per_s),
                );
            }
            if let Some(r) = h.publish_hz {
                self.rate(hk.key("publish_hz"), r, MAX_RATE_HZ);
            }
        }
        if let Some(e) = &d.ezgripper {
            let ek = k.key("ezgripper");
            if e.port.trim().is_empty() {
                self.err(ek.key("port"), "must name a serial port, e.g. /dev/ttyUSB0");
            }
            if !DYNAMIXEL_BAUDS.contains(&e.baud) {
                let v: Vec<String> = DYNAMIXEL_BAUDS.iter().map(|b| b.to_string()).collect();
                self.err(
                    ek.key("baud"),
                    format!("{} is not a Dynamixel baud rate ({})", e.baud, v.join(", ")),
                );
            }
            if let Some(id) = e.servo_id {
                if id > 252 {
                    self.err(
                        ek.key("servo_id"),
                        format!("must be between 0 and 252 (253+ are reserved/broadcast), got {id}"),
                    );
                }
            }
            if !(1..=100).contains(&e.max_open_percent) {
                self.err(
                    ek.key("max_open_percent"),
                    format!("must be between 1 and 100, got {}", e.max_open_percent),
                );
            }
            if let Some(f) = e.force_limit_percent {
                if !(1..=100).contains(&f) {
                    self.err(
                        ek.key("force_limit_percent"),
                        format!("must be between 1 and 100, got {f}"),
                    );
                }
            }
        }
        if let Some(e) = &d.emulator {
            let ek = k.key("emulator");
            for (which, m) in [("initial", &e.initial), ("object_at", &e.object_at)] {
                for (j, v) in m {
                    self.position(ek.key(which).key(j.clone()), d, j, *v);
                }
            }
            for (key, v, max) in [
                (
                    "position_noise_rad",
                    e.position_noise_rad,
                    handgate_adapters::sim::NOISE_MAX_Q,
                ),
                (
                    "velocity_noise_rad_s",
                    e.velocity_noise_rad_s,
                    handgate_adapters::sim::NOISE_MAX_DQ,
                ),
                (
                    "torque_noise_nm",
                    e.torque_noise_nm,
                    handgate_adapters::sim::NOISE_MAX_TAU,
                ),
            ] {
                if let Some(v) = v {
                    if !(v.is_finite() && (0.0..=f64::from(max)).contains(&v)) {
                        self.err(
                            ek.key(key),
                            format!("must be between 0 and {max} (measurement noise, one standard deviation), got {v}"),
                        );
                    }
                }
            }
            let overrides =
                e.position_noise_rad.is_some() || e.velocity_noise_rad_s.is_some() || e.torque_noise_nm.is_some();
            if e.noise == Some(false) && (overrides || e.seed.is_some()) {
                self.err(
                    ek.key("noise"),
                    "is false: seed and *_noise_* keys would have no effect, remove them",
                );
            }
        }
    }

    fn usb(&mut self, uk: &KeyPath, d: &DeviceConfig, u: &UsbConfig) {
        if let Some(s) = &u.serial {
            if s.trim().is_empty() {
                self.err(
                    uk.key("serial"),
                    "must not be empty (omit it to take any hand of this side)",
                );
            }
        }
        if let Some(w) = &u.wiring {
            let wk = uk.key("wiring");
            let mut used: HashMap<(u8, u8, bool), String> = HashMap::new();
            for (j, slot) in &w.joints {
                let jk = wk.key("joints").key(j.clone());
                self.joint(jk.clone(), d, j);
                self.slot(&jk, *slot, 15);
                if let Some(o) = used.insert((slot.bus, slot.id, true), j.clone()) {
                    self.err(jk, format!("bus {} id {} is also wired to {o}", slot.bus, slot.id));
                }
            }
            for (pad, slot) in &w.pads {
                let pk = wk.key("pads").key(pad.clone());
                let valid = pad
                    .strip_prefix("pad_")
                    .and_then(|n| n.parse::<usize>().ok())
                    .is_some_and(|n| n < DEX3_PADS && pad == &format!("pad_{n}"));
                if !valid {
                    self.err(
                        pk.clone(),
                        format!("unknown pad `{pad}` (pads: pad_0 .. pad_{})", DEX3_PADS - 1),
                    );
                }
                self.slot(&pk, *slot, 14);
                if let Some(o) = used.insert((slot.bus, slot.id, false), pad.clone()) {
                    self.err(pk, format!("bus {} id {} is also wired to {o}", slot.bus, slot.id));
                }
            }
        }
        if let Some(s) = &u.scalings {
            if let Err(e) = s.validate() {
                self.err(
                    uk.key("scalings").key(e.field),
                    format!("must be a finite number above 0, got {}", e.value),
                );
            }
        }
    }

    fn slot(&mut self, k: &KeyPath, s: BusSlot, max_id: u8) {
        if s.bus >= DEX3_USB_BUSES {
            self.err(
                k.key("bus"),
                format!("must be between 0 and {}, got {}", DEX3_USB_BUSES - 1, s.bus),
            );
        }
        if s.id > max_id {
            self.err(k.key("id"), format!("must be between 0 and {max_id}, got {}", s.id));
        }
    }

    /// Checks across devices that share hardware: two USB hands of one side need serials,
    /// EZGrippers on one port need distinct ids and one baud.
    fn fleet_buses(&mut self, p: &Profile) {
        let mut usb_sides: HashMap<(Side, Option<String>), usize> = HashMap::new();
        let mut ports: HashMap<String, (usize, u32)> = HashMap::new();
        let mut servo_ids: HashMap<(String, u8), usize> = HashMap::new();
        let mut dds_cmd: HashMap<Topic, usize> = HashMap::new();
        for (i, d) in p.devices.iter().enumerate() {
            let k = root().key("devices").index(i);
            if let Some((Some(cmd), _)) = d.dds_topics() {
                if let Some(j) = dds_cmd.insert(cmd.clone(), i) {
                    self.err(
                        k.key("dds"),
                        format!("devices[{j}] also sends commands on `{cmd}`: two devices would fight over one"),
                    );
                }
            }
            if d.kind == DeviceKind::Dex3 && d.backend == Backend::Usb {
                let serial = d.usb.as_ref().and_then(|u| u.serial.clone());
                if let Some(j) = usb_sides.insert((d.side, serial.clone()), i) {
                    self.err(
                        k.key("usb").key("serial"),
                        format!(
                            "devices[{j}] is also a {} dex3 on usb{}: give each hand its USB serial",
                            d.side,
                            serial.map(|s| format!(" with serial {s}")).unwrap_or_default()
                        ),
                    );
                }
            }
            if d.kind == DeviceKind::Ezgripper && d.backend == Backend::Serial {
                let e = d.ezgripper.clone().unwrap_or_default();
                match ports.get(&e.port) {
                    Some(&(j, baud)) if baud != e.baud => self.err(
                        k.key("ezgripper").key("baud"),
                        format!("devices[{j}] uses {} at {baud} baud; one bus has one baud rate", e.port),
                    ),
                    Some(_) => {}
                    None => {
                        ports.insert(e.port.clone(), (i, e.baud));
                    }
                }
                let id = e.servo_id_for(d.side);
                if let Some(j) = servo_ids.insert((e.port.clone(), id), i) {
                    self.err(
                        k.key("ezgripper").key("servo_id"),
                        format!("servo id {id} on {} is also devices[{j}]", e.port),
                    );
                }
            }
        }
    }

    fn front(&mut self, k: &KeyPath, f: &FrontConfig, dev: Option<&DeviceConfig>, dangling: bool) {
        let kind = f.kind;
        let only = |this: &mut Self, name: &str, present: bool, ok: bool, what: &str| {
            if present && !ok {
                this.err(k.key(name), format!("only {what}, this is {} front", a(kind.as_str())));
            }
        };
        let dex = matches!(kind, FrontKind::Dex3 | FrontKind::Dex1);
        only(self, "side", f.side.is_some(), dex, "dex3 and dex1 fronts serve a side");
        only(
            self,
            "lf_state_topic",
            f.lf_state_topic.is_some(),
            kind == FrontKind::Dex3,
            "dex3 fronts have a low-frequency state topic",
        );
        only(
            self,
            "lf_state_hz",
            f.lf_state_hz.is_some(),
            kind == FrontKind::Dex3,
            "dex3 fronts have a low-frequency state topic",
        );
        only(
            self,
            "variant",
            f.variant.is_some(),
            kind == FrontKind::Dex1,
            "dex1 fronts have wire variants",
        );
        only(
            self,
            "topic",
            f.topic.is_some(),
            kind == FrontKind::JointState,
            "joint_state fronts take `topic`",
        );
        only(
            self,
            "urdf_names",
            f.urdf_names.is_some(),
            kind == FrontKind::JointState,
            "joint_state fronts take `urdf_names`",
        );
        only(
            self,
            "cmd_topic",
            f.cmd_topic.is_some(),
            kind != FrontKind::JointState,
            "fronts that take commands have a command topic",
        );
        only(
            self,
            "state_topic",
            f.state_topic.is_some(),
            kind != FrontKind::JointState,
            "non-joint_state fronts take `state_topic` (joint_state: `topic`)",
        );

        for (name, t) in [
            ("cmd_topic", &f.cmd_topic),
            ("state_topic", &f.state_topic),
            ("lf_state_topic", &f.lf_state_topic),
            ("topic", &f.topic),
        ] {
            if let Some(t) = t {
                self.topic(k.key(name), t);
            }
        }
        if kind == FrontKind::JointState && f.silence != Silence::default() {
            self.err(
                k.key("silence"),
                "a joint_state front takes no commands, so has no silence to handle",
            );
        }
        if let Some(w) = f.watchdog_ms {
            let (wlo, whi) = WATCHDOG_MS_RANGE;
            if !(wlo..=whi).contains(&w.0) {
                self.err(
                    k.key("watchdog_ms"),
                    format!("must be between {wlo} and {whi}, got {}", w.0),
                );
            } else if f.silence != Silence::Watchdog {
                self.err(
                    k.key("watchdog_ms"),
                    format!(
                        "applies with silence = \"watchdog\" (this front's silence is \"{}\")",
                        f.silence
                    ),
                );
            }
        }
        if let Some(r) = f.state_hz {
            self.rate(k.key("state_hz"), r, MAX_RATE_HZ);
            if kind == FrontKind::Dex1 && r.0.is_finite() && r.0 < DEX1_MIN_STATE_HZ {
                self.err(
                    k.key("state_hz"),
                    format!("a dex1 front publishes state at {DEX1_MIN_STATE_HZ} Hz or faster (xr_teleoperate's loop rate), got {}", r.0),
                );
            }
        }
        if let Some(r) = f.lf_state_hz {
            self.rate(k.key("lf_state_hz"), r, MAX_RATE_HZ);
        }
        if dangling {
            return;
        }
        // A dex3/dex1 front needs a left/right side unless every topic is overridden.
        if dex {
            let side = f.served_side(dev);
            let actuator = kind == FrontKind::Dex1 && f.dex1_variant() == Dex1Variant::Actuator;
            let topics_given = f.cmd_topic.is_some()
                && f.state_topic.is_some()
                && (kind != FrontKind::Dex3 || f.lf_state_topic.is_some());
            if side == Some(Side::Center) && (actuator || !topics_given) {
                let why = if actuator {
                    "the actuator variant addresses element 0 = right, 1 = left"
                } else {
                    "its topics are rt/.../{left,right}/...; set the topics explicitly to serve another"
                };
                self.err(
                    k.key("side"),
                    format!(
                        "{} front serves side left or right ({why}); set `side` (the device's side is center)",
                        a(kind.as_str())
                    ),
                );
            }
        }
    }
}
