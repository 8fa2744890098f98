//! The Dex1 service front's registry entry and endpoints; its codec is
//! `crate::dex1::front`.

use crate::dex1::adapter::{actuator_index, Variant};
pub use crate::dex1::front::MIN_STATE_HZ;
use crate::dex1::front::{decode_actuator, decode_go, decode_hg, encode_go, encode_hg, go_state, unbound_state};
use crate::mapping::DeviceTable;
use crate::model::Side;
use handgate_idl::{unitree_go, unitree_hg};

use crate::front::Rejection;
use crate::units::Topic;

/// The Dex1 front's state writer, of the variant's type.
enum Dex1Writer {
    Go(crate::dds::Writer<unitree_go::MotorStates_>),
    Hg(crate::dds::Writer<unitree_hg::HandState_>),
}

/// The Dex1 front's endpoints in its wire variant.
pub struct Dex1Io {
    variant: Variant,
    /// Elements of its messages (the actuator variant: 2).
    elements: usize,
    /// The command reader, of the variant's type (kept alive).
    _reader: Box<dyn Send>,
    writer: Dex1Writer,
}

impl Dex1Io {
    pub fn open(
        node: &crate::dds::Node,
        variant: Variant,
        cmd_topic: &str,
        state_topic: &str,
        elements: usize,
        tx: tokio::sync::mpsc::Sender<crate::front::serve::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, crate::dds::DdsError> {
        use crate::front::serve::STATE_QOS;
        let (reader, writer): (Box<dyn Send>, _) = match variant {
            Variant::Hg => (
                Box::new(crate::front::serve::reader::<unitree_hg::HandCmd_>(
                    node, cmd_topic, tx, dropped,
                )?),
                Dex1Writer::Hg(node.writer(state_topic, STATE_QOS)?),
            ),
            Variant::Go | Variant::Actuator => (
                Box::new(crate::front::serve::reader::<unitree_go::MotorCmds_>(
                    node, cmd_topic, tx, dropped,
                )?),
                Dex1Writer::Go(node.writer(state_topic, STATE_QOS)?),
            ),
        };
        Ok(Self {
            variant,
            elements,
            _reader: reader,
            writer,
        })
    }
}

impl crate::front::serve::FrontIo for Dex1Io {
    fn decode(
        &self,
        bound: &[crate::front::serve::Bound<'_>],
        msg: &crate::front::serve::Message,
    ) -> Result<Vec<(usize, crate::front::serve::Routed)>, Rejection> {
        let b0 = &bound[0];
        if let Some(m) = msg.downcast_ref::<unitree_hg::HandCmd_>() {
            return Ok(vec![(
                0,
                crate::front::serve::routed(b0.route, decode_hg(m, &b0.route.front)?),
            )]);
        }
        let Some(m) = msg.downcast_ref::<unitree_go::MotorCmds_>() else {
            return Ok(Vec::new());
        };
        if self.variant == Variant::Actuator {
            let elems: Vec<(usize, &DeviceTable)> = bound.iter().map(|b| (b.element, &*b.route.front)).collect();
            return Ok(decode_actuator(m, &elems)?
                .into_iter()
                .zip(bound)
                .enumerate()
                .map(|(i, (c, b))| (i, crate::front::serve::routed(b.route, c)))
                .collect());
        }
        let c = decode_go(m, Variant::Go, Side::Left, &b0.route.front)?;
        Ok(vec![(0, crate::front::serve::routed(b0.route, c))])
    }

    fn publish(&mut self, bound: &[crate::front::serve::Bound<'_>], _lf: bool) {
        let now = std::time::Instant::now();
        let b0 = &bound[0];
        let _ = match &mut self.writer {
            Dex1Writer::Go(w) if self.variant == Variant::Actuator => {
                // Every element measured: each from its own gripper; an unbound one as never
                // measured.
                let mut m = unitree_go::MotorStates_ {
                    states: vec![unbound_state(&b0.route.front); self.elements],
                };
                for b in bound {
                    m.states[b.element] = go_state(&b.route.front, &b.routed_state()[0], &b.state, now);
                }
                w.write(m)
            }
            Dex1Writer::Go(w) => w.write(encode_go(&b0.route.front, &b0.routed_state()[0], &b0.state, now)),
            Dex1Writer::Hg(w) => w.write(encode_hg(&b0.route.front, &b0.routed_state()[0], &b0.state, now)),
        };
    }
}

/// The wire variant of Dex1 front `f` (default `go`).
fn variant(f: &crate::front::config::FrontConfig) -> Variant {
    f.variant.unwrap_or_default()
}

/// What Dex1 front `f` serves: its variant's types on its topics; the other variant's types
/// and the other interface's topics (per side vs actuator) named with the profile change that
/// serves them.
fn served(f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
    use crate::dds::type_name;
    use crate::discovery::diagnose::Served;
    use crate::front::serve::{served_command, served_state};
    let v = variant(&f.config);
    let name = &f.name;
    let (go_cmd, hg_cmd) = (
        type_name::<unitree_go::MotorCmds_>(),
        type_name::<unitree_hg::HandCmd_>(),
    );
    let (go_state, hg_state) = (
        type_name::<unitree_go::MotorStates_>(),
        type_name::<unitree_hg::HandState_>(),
    );
    // Another type on this topic: the variant that speaks it.
    let (cmd, state) = match v {
        Variant::Hg => (
            served_command::<unitree_hg::HandCmd_>(f.cmd_topic.as_deref().unwrap_or_default()),
            served_state::<unitree_hg::HandState_>(&f.state_topic),
        ),
        Variant::Go | Variant::Actuator => (
            served_command::<unitree_go::MotorCmds_>(f.cmd_topic.as_deref().unwrap_or_default()),
            served_state::<unitree_go::MotorStates_>(&f.state_topic),
        ),
    };
    let other_type = |s: Served, go: &str, hg: &str| {
        match v {
        Variant::Hg => s.alternative(
            go.to_string(),
            format!("the client speaks the unitree_go variant (dex1_1_service): set variant = \"{}\" on front {name}", Variant::Go),
        ),
        Variant::Go => s.alternative(
            hg.to_string(),
            format!("the client speaks the seed-spec unitree_hg variant: set variant = \"{}\" on front {name}", Variant::Hg),
        ),
        Variant::Actuator => s.alternative(
            hg.to_string(),
            format!(
                "the client speaks the seed-spec unitree_hg variant, which is per side ({} or {}): serve it with a dex1 front with variant = \"{}\"",
                Variant::Hg.topics(Side::Left).0,
                Variant::Hg.topics(Side::Right).0,
                Variant::Hg
            ),
        ),
    }
    };
    let (mut cmd, mut state) = (
        other_type(cmd, &go_cmd, &hg_cmd),
        other_type(state, &go_state, &hg_state),
    );
    // The other interface's topics.
    match v {
        Variant::Go | Variant::Hg => {
            let (c, s) = Variant::Actuator.topics(Side::Left);
            let hint = format!(
                "the client uses the actuator interface (both grippers in one message): serve it with a dex1 front with variant = \"{}\" instead of front {name}",
                Variant::Actuator
            );
            cmd = cmd.related(c, hint.clone());
            state = state.related(s, hint);
        }
        Variant::Actuator => {
            for side in [Side::Left, Side::Right] {
                let (c, s) = Variant::Go.topics(side);
                let hint = format!(
                    "the client uses the per-side dex1 interface: serve side {side} with a dex1 front with variant = \"{}\" (or \"{}\") instead of front {name}",
                    Variant::Go,
                    Variant::Hg
                );
                cmd = cmd.related(c, hint.clone());
                state = state.related(s, hint);
            }
        }
    }
    let mut out = Vec::new();
    if f.cmd_topic.is_some() {
        out.push(cmd);
    }
    out.push(state);
    out
}

/// The Dex1-1 service interface, in its wire variants.
#[derive(Debug)]
pub struct Dex1Front;

impl crate::front::kind::FrontFactory for Dex1Front {
    fn name(&self) -> &'static str {
        "dex1"
    }
    fn speaks(&self) -> Option<crate::model::DeviceKind> {
        Some(crate::model::DeviceKind::Dex1)
    }
    fn keys(&self) -> &'static [&'static str] {
        &["side", "variant"]
    }
    fn default_topics(
        &self,
        f: &crate::front::config::FrontConfig,
        lr: Option<Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        let variant = variant(f);
        // The actuator variant's topics carry both sides.
        let std = (variant == Variant::Actuator)
            .then_some(Side::Left)
            .or(lr)
            .map(|s| variant.topics(s));
        (std.as_ref().map(|t| Topic(t.0.clone())), std.map(|t| Topic(t.1)), None)
    }
    fn default_state_hz(&self, _device_hz: Option<f64>) -> f64 {
        500.0
    }
    fn default_name(&self, f: &crate::front::config::FrontConfig, side: &str) -> String {
        if variant(f) == Variant::Actuator {
            "dex1_actuator".into()
        } else {
            format!("dex1_{side}")
        }
    }
    fn silence(
        &self,
        mode: crate::front::config::Silence,
        dog: (std::time::Duration, crate::model::SafeAction),
    ) -> crate::front::plan::SilencePlan {
        let after = match mode {
            crate::front::config::Silence::Watchdog => dog,
            // dex1_1_service brakes: holds the measured position 1 s after the last command.
            crate::front::config::Silence::Service => {
                (crate::dex1::SERVICE_BRAKE_AFTER, crate::model::SafeAction::Hold)
            }
        };
        crate::front::plan::SilencePlan {
            mode,
            after: Some(after),
            timeout_bit: None,
        }
    }
    fn elements(&self, f: &crate::front::config::FrontConfig) -> usize {
        if variant(f) == Variant::Actuator {
            2
        } else {
            1
        }
    }
    fn binds_elements(&self) -> Option<&'static str> {
        Some("an actuator dex1 front")
    }
    fn element(&self, f: &crate::front::config::FrontConfig, side: Side) -> usize {
        if variant(f) == Variant::Actuator {
            actuator_index(side)
        } else {
            0
        }
    }
    fn validate(
        &self,
        f: &crate::front::config::FrontConfig,
        served: Option<Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        let mut out = vec![];
        if let Some(r) = f.state_hz {
            if r.0.is_finite() && r.0 < MIN_STATE_HZ {
                out.push((
                    "state_hz",
                    format!("a dex1 front publishes state at {MIN_STATE_HZ} Hz or faster (xr_teleoperate's loop rate), got {}", r.0),
                ));
            }
        }
        if !dangling {
            let given = f.cmd_topic.is_some() && f.state_topic.is_some();
            out.extend(crate::dex3::serve::side_rule(
                "dex1",
                served,
                given,
                variant(f) == Variant::Actuator,
            ));
        }
        out
    }
    fn describe_unbound(&self, f: &crate::front::config::FrontConfig, bound: &[Side]) -> Vec<String> {
        if variant(f) != Variant::Actuator {
            return vec![];
        }
        [(0, Side::Right), (1, Side::Left)]
            .into_iter()
            .filter(|(_, side)| !bound.contains(side))
            .map(|(element, side)| {
                format!("element {element} ({side}): no device bound; reported as never measured (lost 0xFFFFFFFE, reserve[1] = 1) at the open position, its commands ignored")
            })
            .collect()
    }
    fn clash_hint(
        &self,
        f: &crate::front::config::FrontConfig,
        other: &crate::front::config::FrontConfig,
    ) -> &'static str {
        if variant(f) == Variant::Actuator && other.kind == f.kind && variant(other) == Variant::Actuator {
            ": one actuator front serves both grippers, `devices = { right = \"..\", left = \"..\" }`"
        } else {
            ""
        }
    }
    fn describe(&self, f: &crate::front::config::FrontConfig) -> Option<String> {
        Some(format!(" ({})", variant(f)))
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        served(f)
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        tx: tokio::sync::mpsc::Sender<crate::front::serve::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        Ok(crate::front::serve::Endpoints::Commands(Box::new(Dex1Io::open(
            &env.node,
            variant(&f.config),
            &cmd,
            &f.state_topic,
            f.elements(),
            tx,
            dropped,
        )?)))
    }
}

impl crate::front::kind::FrontKind {
    /// The Dex1-1 DDS interface (`rt/dex1/{side}/*` or `rt/unitree_actuator/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex1: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&Dex1Front);
}
