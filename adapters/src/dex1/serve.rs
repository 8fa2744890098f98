//! The Dex1 service front's registry entry and endpoints; its codec is
//! `crate::dex1::front`. One variant (`go`, `hg`, `actuator`) is a codec on the generic
//! endpoint ([`DdsFront`]); `auto` follows its clients across the three wire types
//! (`crate::dex1::follow`), opening readers and writers as they appear, so it keeps an
//! endpoint of its own ([`AutoIo`]) on the same typed queue ([`Inbox`]).

use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use handgate_idl::{unitree_go, unitree_hg};

use crate::dex1::adapter::{actuator_index, Variant};
pub use crate::dex1::front::MIN_STATE_HZ;
use crate::dex1::front::{decode_actuator, decode_go, decode_hg, encode_go, encode_hg, go_state, unbound_state};
use crate::front::config::{side_rule, FrontConfig, Silence, TopicKey};
use crate::front::endpoint::{DdsFront, FrontCodec, OpenCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{
    commands, elements, routed, routed_each, Bound, Endpoints, FrontEnv, Inbox, Queue, Routed, TypedIo, STATE_QOS,
};
use crate::front::Rejection;
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

crate::side_topics_config! {
    /// The Dex1 front's own keys.
    pub struct Dex1FrontConfig {
        /// The wire variant (default `auto`: follows its clients, `crate::dex1::follow`).
        pub variant: Option<Variant>,
    }
}

impl Dex1FrontConfig {
    /// The wire variant (default `auto`).
    pub fn variant(&self) -> Variant {
        self.variant.unwrap_or(Variant::Auto)
    }
}

/// The `go` variant: unitree_go `MotorCmds_` / `MotorStates_` of one gripper.
#[derive(Default)]
pub struct GoCodec;

impl FrontCodec for GoCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn decode(&self, bound: &[Bound<'_>], m: &unitree_go::MotorCmds_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let b0 = &bound[0];
        let c = decode_go(m, Variant::Go, Side::Left, &b0.route.front)?;
        Ok(vec![(0, routed(b0.route, c))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<unitree_go::MotorStates_> {
        let b0 = bound.first()?;
        let now = std::time::Instant::now();
        Some(encode_go(&b0.route.front, &b0.routed_state()[0], b0.state, now))
    }
}

/// The `hg` (seed-spec) variant: unitree_hg `HandCmd_` / `HandState_` of one gripper.
#[derive(Default)]
pub struct HgCodec;

impl FrontCodec for HgCodec {
    type Cmd = unitree_hg::HandCmd_;
    type State = unitree_hg::HandState_;

    fn decode(&self, bound: &[Bound<'_>], m: &unitree_hg::HandCmd_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let b0 = &bound[0];
        Ok(vec![(0, routed(b0.route, decode_hg(m, &b0.route.front)?))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<unitree_hg::HandState_> {
        let b0 = bound.first()?;
        let now = std::time::Instant::now();
        Some(encode_hg(&b0.route.front, &b0.routed_state()[0], b0.state, now))
    }
}

/// The `actuator` variant: both grippers in one 2-element `MotorCmds_` / `MotorStates_`,
/// each bound device on its element.
pub struct ActuatorCodec {
    /// Elements of its messages.
    elements: usize,
}

/// The elements of the front's messages.
impl OpenCodec for ActuatorCodec {
    fn open(_env: &FrontEnv, plan: &FrontPlan) -> Result<Self, crate::dds::DdsError> {
        Ok(ActuatorCodec {
            elements: plan.elements(),
        })
    }
}

impl FrontCodec for ActuatorCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn decode(&self, bound: &[Bound<'_>], m: &unitree_go::MotorCmds_) -> Result<Vec<(usize, Routed)>, Rejection> {
        Ok(routed_each(bound, decode_actuator(m, &elements(bound))?))
    }

    /// Every element measured: each from its own gripper; an unbound one as never measured.
    fn encode(&self, bound: &[Bound<'_>]) -> Option<unitree_go::MotorStates_> {
        let b0 = bound.first()?;
        let now = std::time::Instant::now();
        let mut m = unitree_go::MotorStates_ {
            states: vec![unbound_state(&b0.route.front); self.elements],
        };
        for b in bound {
            m.states[b.element] = go_state(&b.route.front, &b.routed_state()[0], b.state, now);
        }
        Some(m)
    }
}

/// What an `auto` front's readers take: its own topic's go commands, the hg commands of a
/// client that appeared with them, and the actuator pair's 2-element commands.
pub enum AutoCmd {
    Go(unitree_go::MotorCmds_),
    Hg(unitree_hg::HandCmd_),
    Pair(unitree_go::MotorCmds_),
}

/// Where the `auto` fronts of one runtime serve the actuator pair (`rt/unitree_actuator/*`)
/// together: one state writer, each element from its side's front, an element whose side
/// has no `auto` front reported unbound as the actuator variant does. An explicit
/// `variant = "actuator"` front owns the pair instead: once one opens, the `auto` fronts
/// leave it alone.
#[derive(Default)]
pub struct ActuatorPair {
    inner: std::sync::Mutex<PairInner>,
}

#[derive(Default)]
struct PairInner {
    /// Elements an `auto` front serves.
    sides: [bool; 2],
    /// An explicit actuator front serves the pair.
    explicit: bool,
    writer: Option<crate::dds::Writer<unitree_go::MotorStates_>>,
    /// The element whose front writes the message (at its state rate): the first to serve
    /// an actuator client.
    leader: Option<usize>,
    /// Each element's latest state, as its front last published it.
    states: [Option<unitree_go::MotorState_>; 2],
}

/// The key of [`ActuatorPair`] in [`crate::front::serve::FrontShared`].
const PAIR_KEY: &str = "dex1 actuator pair";

impl ActuatorPair {
    fn lock(&self) -> std::sync::MutexGuard<'_, PairInner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// An `auto` front serves element `element`.
    fn register(&self, element: usize) {
        self.lock().sides[element] = true;
    }

    /// An explicit actuator front serves the pair: the `auto` fronts stop writing it.
    fn claim_explicit(&self) {
        let mut g = self.lock();
        g.explicit = true;
        g.writer = None;
        g.leader = None;
    }

    fn explicit(&self) -> bool {
        self.lock().explicit
    }

    /// Front of `element` serves an actuator client: opens the pair's state writer unless
    /// open. `false`: an explicit actuator front serves the pair.
    fn join(&self, node: &crate::dds::Node, element: usize) -> Result<bool, crate::dds::DdsError> {
        let mut g = self.lock();
        if g.explicit {
            return Ok(false);
        }
        if g.writer.is_none() {
            let state = Variant::Actuator.topics(Side::Left).1;
            g.writer = Some(node.writer(&state, STATE_QOS)?);
            g.leader = Some(element);
        }
        Ok(true)
    }

    /// Element `element`'s state; its front's publish, which writes the pair when it leads.
    fn publish(&self, element: usize, front: &DeviceTable, state: impl FnOnce() -> unitree_go::MotorState_) {
        let mut g = self.lock();
        if g.writer.is_none() {
            return;
        }
        g.states[element] = Some(state());
        if g.leader != Some(element) {
            return;
        }
        let m = unitree_go::MotorStates_ {
            states: (0..2)
                .map(|e| {
                    g.states[e]
                        .filter(|_| g.sides[e])
                        .unwrap_or_else(|| unbound_state(front))
                })
                .collect(),
        };
        if let Some(w) = g.writer.as_mut() {
            let _ = w.write(m);
        }
    }
}

/// What an `auto` front's follower opened for a variant a client appeared with.
enum Followed {
    /// hg on the front's own topics: its reader (kept alive) and state writer.
    Hg(
        crate::dds::Reader<unitree_hg::HandCmd_>,
        crate::dds::Writer<unitree_hg::HandState_>,
    ),
    /// Its element of the actuator pair: the pair's reader (kept alive; the pair writes).
    Pair(crate::dds::Reader<unitree_go::MotorCmds_>),
}

/// What opening a followed variant's endpoints needs.
#[derive(Clone)]
struct OpenCtx {
    node: crate::dds::Node,
    cmd_topic: String,
    state_topic: String,
    inbox: Inbox<AutoCmd>,
    /// `auto` fronts of a left or right gripper: the pair and its element.
    pair: Option<(Arc<ActuatorPair>, usize)>,
}

impl OpenCtx {
    /// What an `auto` front opens for a client of `variant`; `None`: nothing (go is open
    /// from the start; the front serves no element of the pair, or an explicit actuator
    /// front serves it).
    fn open_followed(&self, variant: Variant) -> Result<Option<Followed>, crate::dds::DdsError> {
        match variant {
            Variant::Hg => Ok(Some(Followed::Hg(
                self.inbox.reader(&self.node, &self.cmd_topic, AutoCmd::Hg)?,
                self.node.writer(&self.state_topic, STATE_QOS)?,
            ))),
            Variant::Actuator => {
                let Some((pair, element)) = &self.pair else {
                    return Ok(None);
                };
                if !pair.join(&self.node, *element)? {
                    return Ok(None);
                }
                let cmd = Variant::Actuator.topics(Side::Left).0;
                Ok(Some(Followed::Pair(self.inbox.reader(
                    &self.node,
                    &cmd,
                    AutoCmd::Pair,
                )?)))
            }
            Variant::Go | Variant::Auto => Ok(None),
        }
    }
}

/// An `auto` Dex1 front's endpoints: go on its own topics from the start, then those of
/// every variant its clients speak (opened by its follower task as they appear).
pub struct AutoIo {
    _go_reader: crate::dds::Reader<unitree_go::MotorCmds_>,
    go: crate::dds::Writer<unitree_go::MotorStates_>,
    /// hg's state writer, once an hg client appeared.
    hg: Option<crate::dds::Writer<unitree_hg::HandState_>>,
    /// The followed variants' readers (kept alive).
    readers: Vec<Box<dyn Send>>,
    /// The endpoints its follower task opened, taken at the next publish.
    added: tokio::sync::mpsc::UnboundedReceiver<Followed>,
    /// A left or right gripper's front: the actuator pair and its element.
    pair: Option<(Arc<ActuatorPair>, usize)>,
}

impl TypedIo for AutoIo {
    type Msg = AutoCmd;

    fn decode(&self, bound: &[Bound<'_>], msg: &AutoCmd) -> Result<Vec<(usize, Routed)>, Rejection> {
        match msg {
            AutoCmd::Go(m) => GoCodec.decode(bound, m),
            AutoCmd::Hg(m) => HgCodec.decode(bound, m),
            AutoCmd::Pair(m) => {
                let Some((_, element)) = self.pair.as_ref().filter(|(p, _)| !p.explicit()) else {
                    return Ok(Vec::new());
                };
                let b0 = &bound[0];
                let c = decode_actuator(m, &[(*element, &*b0.route.front)])?;
                Ok(c.into_iter().map(|c| (0, routed(b0.route, c))).collect())
            }
        }
    }

    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        while let Ok(f) = self.added.try_recv() {
            match f {
                Followed::Hg(r, w) => {
                    self.readers.push(Box::new(r));
                    self.hg = Some(w);
                }
                Followed::Pair(r) => self.readers.push(Box::new(r)),
            }
        }
        let Some(b0) = bound.first() else {
            return;
        };
        if let Some((pair, element)) = &self.pair {
            let now = std::time::Instant::now();
            pair.publish(*element, &b0.route.front, || {
                go_state(&b0.route.front, &b0.routed_state()[0], b0.state, now)
            });
        }
        // A message no reader would receive is not built.
        let _ = self.go.write_with(|| GoCodec.encode(bound));
        if let Some(w) = &mut self.hg {
            let _ = w.write_with(|| HgCodec.encode(bound));
        }
    }
}

/// The `auto` front's follower: watches discovery from a task of its own, opens the
/// endpoints of each variant a client appears with (once, in a blocking-pool thread, never
/// on a device path), logs it once and hands them to the front through `added`. Ends when the
/// front is dropped.
fn spawn_follower(
    env: &FrontEnv,
    name: String,
    watched: crate::dex1::follow::Watched,
    ctx: OpenCtx,
    added: tokio::sync::mpsc::UnboundedSender<Followed>,
) -> Result<(), crate::dds::DdsError> {
    let handle = tokio::runtime::Handle::try_current().map_err(|e| {
        crate::dds::DdsError::Thread(format!("an auto dex1 front follows its clients from a tokio task: {e}"))
    })?;
    let mut rx = env.discovery.clone();
    handle.spawn(async move {
        // Go is open from the start.
        let mut tried = std::collections::BTreeSet::from([Variant::Go]);
        loop {
            let snapshot = rx.borrow_and_update().clone();
            let clients = crate::dex1::follow::clients(&snapshot, &watched);
            for v in crate::dex1::follow::to_serve(&clients) {
                if !tried.insert(v) {
                    continue;
                }
                let Some(c) = clients.get(&v) else { continue };
                let ctx = ctx.clone();
                let opened = tokio::task::spawn_blocking(move || ctx.open_followed(v)).await;
                let (topic, ty, who) = (&*c.endpoint.topic, &*c.endpoint.type_name, &c.who);
                let role = match c.endpoint.role {
                    crate::discovery::Role::Writer => "writes",
                    crate::discovery::Role::Reader => "reads",
                };
                match opened {
                    Ok(Ok(Some(served))) => {
                        tracing::info!(front = %name, variant = %v, "dex1 front {name} serves {v} clients too: {who} {role} {ty} on {topic}");
                        if added.send(served).is_err() {
                            return;
                        }
                    }
                    Ok(Ok(None)) => tracing::info!(front = %name, "dex1 front {name}: {who} {role} {ty} on {topic}; an actuator front serves that pair"),
                    Ok(Err(e)) => tracing::warn!(front = %name, "dex1 front {name} cannot serve {v} clients ({who} {role} {ty} on {topic}): {e}"),
                    Err(e) => tracing::warn!(front = %name, "dex1 front {name}: opening {v} endpoints failed: {e}"),
                }
            }
            tokio::select! {
                r = rx.changed() => if r.is_err() { return },
                _ = added.closed() => return,
            }
        }
    });
    Ok(())
}

/// Opens an `auto` front: go on its own topics, its element of the actuator pair registered
/// (a left or right gripper's), and its follower.
fn open_auto(
    env: &FrontEnv,
    f: &FrontPlan,
    tx: Queue,
    dropped: Arc<AtomicU64>,
) -> Result<Endpoints, crate::dds::DdsError> {
    let pair = env.shared.get::<ActuatorPair>(PAIR_KEY);
    // An auto front of a left or right gripper serves that element of the actuator pair.
    let element = f
        .bindings
        .first()
        .filter(|b| b.side != Side::Center)
        .map(|b| actuator_index(b.side));
    commands(tx, dropped, |inbox| {
        let ctx = OpenCtx {
            node: env.node.clone(),
            cmd_topic: f.cmd_topic().unwrap_or_default().to_string(),
            state_topic: f.state_topic().to_string(),
            inbox,
            pair: element.map(|e| (pair.clone(), e)),
        };
        let (added_tx, added) = tokio::sync::mpsc::unbounded_channel();
        let io = AutoIo {
            _go_reader: ctx.inbox.reader(&env.node, &ctx.cmd_topic, AutoCmd::Go)?,
            go: env.node.writer(&ctx.state_topic, STATE_QOS)?,
            hg: None,
            readers: Vec::new(),
            added,
            pair: ctx.pair.clone(),
        };
        if let Some(e) = element {
            pair.register(e);
        }
        let watched = crate::dex1::follow::Watched {
            cmd: ctx.cmd_topic.clone(),
            state: ctx.state_topic.clone(),
            actuator: element.map(|_| Variant::Actuator.topics(Side::Left)),
        };
        spawn_follower(env, f.name.clone(), watched, ctx, added_tx)?;
        Ok(io)
    })
}

/// What Dex1 front `f` serves: its variant's types on its topics (`auto`: go and hg both); the
/// other variant's types and the other interface's topics (per side vs actuator) named with
/// the profile change that serves them (`auto` of a left or right gripper: the actuator pair,
/// which it serves once a client appears).
fn served(c: &Dex1FrontConfig, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
    use crate::dds::type_name;
    use crate::discovery::diagnose::Served;
    use crate::front::serve::{served_command, served_state};
    let v = c.variant();
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
            served_command::<unitree_hg::HandCmd_>(f.cmd_topic().unwrap_or_default()),
            served_state::<unitree_hg::HandState_>(f.state_topic()),
        ),
        Variant::Go | Variant::Actuator => (
            served_command::<unitree_go::MotorCmds_>(f.cmd_topic().unwrap_or_default()),
            served_state::<unitree_go::MotorStates_>(f.state_topic()),
        ),
        // Go from the start, hg once a client speaks it: a client of either matches.
        Variant::Auto => (
            served_command::<unitree_go::MotorCmds_>(f.cmd_topic().unwrap_or_default()).also_serving(hg_cmd.clone()),
            served_state::<unitree_go::MotorStates_>(f.state_topic()).also_serving(hg_state.clone()),
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
        Variant::Auto => s,
    }
    };
    let (mut cmd, mut state) = (
        other_type(cmd, &go_cmd, &hg_cmd),
        other_type(state, &go_state, &hg_state),
    );
    // The other interface's topics.
    let pair_side = f.bindings.first().is_some_and(|b| b.side != Side::Center);
    match v {
        Variant::Auto if pair_side => {
            let (c, s) = Variant::Actuator.topics(Side::Left);
            let hint = format!(
                "the client uses the actuator interface (both grippers in one message): front {name} (auto) serves its element of the pair once the client's endpoints are discovered, unless a dex1 front with variant = \"{}\" serves the pair",
                Variant::Actuator
            );
            cmd = cmd.related_on_demand(c, hint.clone());
            state = state.related_on_demand(s, hint);
        }
        Variant::Go | Variant::Hg | Variant::Auto => {
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
    if f.cmd_topic().is_some() {
        out.push(cmd);
    }
    out.push(state);
    out
}

/// The Dex1-1 service interface, in its wire variants.
#[derive(Debug)]
pub struct Dex1Front;

impl Front for Dex1Front {
    type Config = Dex1FrontConfig;
    type Wire = Dex1Wire;
    const KIND: FrontKind = FrontKind::of(&Dex1Front);
    const FACTS: FrontFacts = FrontFacts {
        binds_elements: Some("an actuator dex1 front"),
        ..FrontFacts::serving("dex1", Some(DeviceKind::Dex1))
    };
    /// The variant's topics of the served side; the actuator variant's carry both sides.
    const TOPICS: &'static [TopicKey<Dex1FrontConfig>] = &[
        TopicKey::cmd_topic(
            |c| c.cmd_topic.as_ref(),
            |c, at| variant_topics(c, at).map(|t| Topic(t.0)),
        ),
        TopicKey::state_topic(
            |c| c.state_topic.as_ref(),
            |c, at| variant_topics(c, at).map(|t| Topic(t.1)),
        ),
    ];

    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        super::SERVICE_HZ
    }
    fn default_name(c: &Dex1FrontConfig, _f: &FrontConfig, side: &str) -> String {
        if c.variant() == Variant::Actuator {
            "dex1_actuator".into()
        } else {
            format!("dex1_{side}")
        }
    }
    fn silence(mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        let after = match mode {
            Silence::Watchdog => dog,
            // dex1_1_service brakes: holds the measured position 1 s after the last command.
            Silence::Service => (crate::dex1::SERVICE_BRAKE_AFTER, SafeAction::Hold),
        };
        SilencePlan {
            mode,
            after: Some(after),
            timeout_bit: None,
        }
    }
    fn elements(c: &Dex1FrontConfig) -> usize {
        if c.variant() == Variant::Actuator {
            2
        } else {
            1
        }
    }
    fn element(c: &Dex1FrontConfig, side: Side) -> usize {
        if c.variant() == Variant::Actuator {
            actuator_index(side)
        } else {
            0
        }
    }
    fn validate(
        c: &Dex1FrontConfig,
        f: &FrontConfig,
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
            let given = c.cmd_topic.is_some() && c.state_topic.is_some();
            out.extend(side_rule("dex1", served, given, c.variant() == Variant::Actuator));
        }
        out
    }
    fn describe_unbound(c: &Dex1FrontConfig, bound: &[Side]) -> Vec<String> {
        if c.variant() != Variant::Actuator {
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
    fn clash_hint(c: &Dex1FrontConfig, other: Option<&Dex1FrontConfig>) -> &'static str {
        if c.variant() == Variant::Actuator && other.is_some_and(|o| o.variant() == Variant::Actuator) {
            ": one actuator front serves both grippers, `devices = { right = \"..\", left = \"..\" }`"
        } else {
            ""
        }
    }
    fn describe(c: &Dex1FrontConfig) -> Option<String> {
        Some(match c.variant() {
            Variant::Auto => " (auto: go until a client appears, then each client's variant: go, hg, and its side's element of rt/unitree_actuator unless an actuator front serves it)".into(),
            v => format!(" ({v})"),
        })
    }
}

/// The Dex1 front's wire side: one variant's codec on the generic endpoint, or `auto`'s own.
pub struct Dex1Wire;

impl FrontWire<Dex1FrontConfig> for Dex1Wire {
    fn served(c: &Dex1FrontConfig, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        served(c, f)
    }
    fn open(
        c: &Dex1FrontConfig,
        env: &FrontEnv,
        f: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        match c.variant() {
            Variant::Auto => open_auto(env, f, tx, dropped),
            Variant::Go => DdsFront::<GoCodec>::open(env, f, tx, dropped),
            Variant::Hg => DdsFront::<HgCodec>::open(env, f, tx, dropped),
            Variant::Actuator => {
                env.shared.get::<ActuatorPair>(PAIR_KEY).claim_explicit();
                DdsFront::<ActuatorCodec>::open(env, f, tx, dropped)
            }
        }
    }
}

/// The standard (command, state) topics of front config `c` at `at`: its variant's of the
/// served side; the actuator variant's carry both sides.
fn variant_topics(c: &Dex1FrontConfig, at: &crate::front::config::TopicAt<'_>) -> Option<(String, String)> {
    let v = c.variant();
    (v == Variant::Actuator)
        .then_some(Side::Left)
        .or(at.side)
        .map(|s| v.topics(s))
}

impl FrontKind {
    /// The Dex1-1 DDS interface (`rt/dex1/{side}/*` or `rt/unitree_actuator/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex1: FrontKind = Dex1Front::KIND;
}
