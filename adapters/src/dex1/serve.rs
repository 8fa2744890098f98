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

/// A 2-element message of the actuator pair (`rt/unitree_actuator/cmd`) taken by an `auto`
/// front, told apart from the go commands of its own topic.
struct PairCmd(unitree_go::MotorCmds_);

/// The Dex1 front's state writer, of one variant's type.
enum Dex1Writer {
    Go(crate::dds::Writer<unitree_go::MotorStates_>),
    Hg(crate::dds::Writer<unitree_hg::HandState_>),
    /// An `auto` front's element of the actuator pair: the pair writes both elements.
    Pair,
}

/// The endpoints of one variant a Dex1 front serves.
struct VariantIo {
    variant: Variant,
    /// The command reader (kept alive).
    _reader: Box<dyn Send>,
    writer: Dex1Writer,
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
            g.writer = Some(node.writer(&state, crate::front::serve::STATE_QOS)?);
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

/// What opening one variant's endpoints needs.
#[derive(Clone)]
struct OpenCtx {
    node: crate::dds::Node,
    cmd_topic: String,
    state_topic: String,
    tx: crate::front::serve::Queue,
    dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    /// `auto` fronts of a left or right gripper: the pair and its element.
    pair: Option<(std::sync::Arc<ActuatorPair>, usize)>,
}

impl OpenCtx {
    /// The endpoints of `variant` on the front's own topics (`Auto`: its go ones; `Actuator`:
    /// the explicit actuator front's).
    fn open_own(&self, variant: Variant) -> Result<VariantIo, crate::dds::DdsError> {
        use crate::front::serve::{reader, STATE_QOS};
        let (node, tx, dropped) = (&self.node, self.tx.clone(), self.dropped.clone());
        let (reader, writer): (Box<dyn Send>, _) = match variant {
            Variant::Hg => (
                Box::new(reader::<unitree_hg::HandCmd_>(node, &self.cmd_topic, tx, dropped)?),
                Dex1Writer::Hg(node.writer(&self.state_topic, STATE_QOS)?),
            ),
            Variant::Go | Variant::Actuator | Variant::Auto => (
                Box::new(reader::<unitree_go::MotorCmds_>(node, &self.cmd_topic, tx, dropped)?),
                Dex1Writer::Go(node.writer(&self.state_topic, STATE_QOS)?),
            ),
        };
        Ok(VariantIo {
            variant,
            _reader: reader,
            writer,
        })
    }

    /// An `auto` front's endpoints for the actuator pair: its reader of the pair (the pair's
    /// state writer opened by the first front to join). `None`: the front serves no element
    /// of the pair, or an explicit actuator front serves it.
    fn open_pair(&self) -> Result<Option<VariantIo>, crate::dds::DdsError> {
        let Some((pair, element)) = &self.pair else {
            return Ok(None);
        };
        if !pair.join(&self.node, *element)? {
            return Ok(None);
        }
        let (tx, dropped) = (self.tx.clone(), self.dropped.clone());
        let cmd = Variant::Actuator.topics(Side::Left).0;
        let r = crate::front::serve::reader_wrapping(&self.node, &cmd, tx, dropped, |s: unitree_go::MotorCmds_| {
            Box::new(PairCmd(s)) as crate::front::serve::Message
        })?;
        Ok(Some(VariantIo {
            variant: Variant::Actuator,
            _reader: Box::new(r),
            writer: Dex1Writer::Pair,
        }))
    }

    /// What an `auto` front opens for a client of `variant`.
    fn open_followed(&self, variant: Variant) -> Result<Option<VariantIo>, crate::dds::DdsError> {
        match variant {
            Variant::Actuator => self.open_pair(),
            v => self.open_own(v).map(Some),
        }
    }
}

/// The Dex1 front's endpoints: its variant's, or for an `auto` front those of every
/// variant its clients speak (opened by its follower task as they appear).
pub struct Dex1Io {
    /// The profile's variant.
    variant: Variant,
    /// Elements of its messages (the actuator variant: 2).
    elements: usize,
    served: Vec<VariantIo>,
    /// `auto`: the endpoints its follower task opened, taken at the next publish.
    added: Option<tokio::sync::mpsc::UnboundedReceiver<VariantIo>>,
    /// `auto` fronts of a left or right gripper: the actuator pair and its element.
    pair: Option<(std::sync::Arc<ActuatorPair>, usize)>,
}

impl Dex1Io {
    fn new(variant: Variant, elements: usize, first: VariantIo) -> Self {
        Self {
            variant,
            elements,
            served: vec![first],
            added: None,
            pair: None,
        }
    }
}

/// The `auto` front's follower: watches discovery from a task of its own, opens the
/// endpoints of each variant a client appears with (once, in a blocking-pool thread, never
/// on a device path), logs it once and hands them to the front through `added`. Ends when the
/// front is dropped.
fn spawn_follower(
    env: &crate::front::serve::FrontEnv,
    name: String,
    watched: crate::dex1::follow::Watched,
    ctx: OpenCtx,
    added: tokio::sync::mpsc::UnboundedSender<VariantIo>,
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
        if let Some(PairCmd(m)) = msg.downcast_ref::<PairCmd>() {
            let Some((_, element)) = self.pair.as_ref().filter(|(p, _)| !p.explicit()) else {
                return Ok(Vec::new());
            };
            let c = decode_actuator(m, &[(*element, &*b0.route.front)])?;
            return Ok(c
                .into_iter()
                .map(|c| (0, crate::front::serve::routed(b0.route, c)))
                .collect());
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
        if let Some(added) = self.added.as_mut() {
            while let Ok(s) = added.try_recv() {
                self.served.push(s);
            }
        }
        let now = std::time::Instant::now();
        let b0 = &bound[0];
        let joint = b0.routed_state()[0];
        if let Some((pair, element)) = &self.pair {
            pair.publish(*element, &b0.route.front, || {
                go_state(&b0.route.front, &joint, &b0.state, now)
            });
        }
        for s in &mut self.served {
            let _ = match &mut s.writer {
                Dex1Writer::Go(w) if s.variant == Variant::Actuator => {
                    // Every element measured: each from its own gripper; an unbound one as
                    // never measured.
                    let mut m = unitree_go::MotorStates_ {
                        states: vec![unbound_state(&b0.route.front); self.elements],
                    };
                    for b in bound {
                        m.states[b.element] = go_state(&b.route.front, &b.routed_state()[0], &b.state, now);
                    }
                    w.write(m)
                }
                Dex1Writer::Go(w) => w.write(encode_go(&b0.route.front, &joint, &b0.state, now)),
                Dex1Writer::Hg(w) => w.write(encode_hg(&b0.route.front, &joint, &b0.state, now)),
                Dex1Writer::Pair => Ok(()),
            };
        }
    }
}

/// The wire variant of Dex1 front `f` (default `auto`).
fn variant(f: &crate::front::config::FrontConfig) -> Variant {
    f.variant.unwrap_or(Variant::Auto)
}

/// What Dex1 front `f` serves: its variant's types on its topics (`auto`: go and hg both); the
/// other variant's types and the other interface's topics (per side vs actuator) named with
/// the profile change that serves them (`auto` of a left or right gripper: the actuator pair,
/// which it serves once a client appears).
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
        // Go from the start, hg once a client speaks it: a client of either matches.
        Variant::Auto => (
            served_command::<unitree_go::MotorCmds_>(f.cmd_topic.as_deref().unwrap_or_default())
                .also_serving(hg_cmd.clone()),
            served_state::<unitree_go::MotorStates_>(&f.state_topic).also_serving(hg_state.clone()),
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
        super::SERVICE_HZ
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
        Some(match variant(f) {
            Variant::Auto => " (auto: go until a client appears, then each client's variant: go, hg, and its side's element of rt/unitree_actuator unless an actuator front serves it)".into(),
            v => format!(" ({v})"),
        })
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        served(f)
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        let variant = variant(&f.config);
        let pair = env.shared.get::<ActuatorPair>(PAIR_KEY);
        if variant == Variant::Actuator {
            pair.claim_explicit();
        }
        // An auto front of a left or right gripper serves that element of the actuator pair.
        let element = f
            .bindings
            .first()
            .filter(|b| variant == Variant::Auto && b.side != Side::Center)
            .map(|b| actuator_index(b.side));
        let ctx = OpenCtx {
            node: env.node.clone(),
            cmd_topic: f.cmd_topic.clone().unwrap_or_default(),
            state_topic: f.state_topic.clone(),
            tx,
            dropped,
            pair: element.map(|e| (pair.clone(), e)),
        };
        // Auto serves go until a client of another variant appears.
        let first = if variant == Variant::Auto { Variant::Go } else { variant };
        let mut io = Dex1Io::new(variant, f.elements(), ctx.open_own(first)?);
        if variant == Variant::Auto {
            if let Some(e) = element {
                pair.register(e);
            }
            let (added_tx, added_rx) = tokio::sync::mpsc::unbounded_channel();
            let actuator = Variant::Actuator.topics(Side::Left);
            let watched = crate::dex1::follow::Watched {
                cmd: ctx.cmd_topic.clone(),
                state: ctx.state_topic.clone(),
                actuator: element.map(|_| actuator),
            };
            io.pair = ctx.pair.clone();
            io.added = Some(added_rx);
            spawn_follower(env, f.name.clone(), watched, ctx, added_tx)?;
        }
        Ok(crate::front::serve::Endpoints::Commands(Box::new(io)))
    }
}

impl crate::front::kind::FrontKind {
    /// The Dex1-1 DDS interface (`rt/dex1/{side}/*` or `rt/unitree_actuator/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex1: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&Dex1Front);
}
