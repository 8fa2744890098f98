//! The endpoints of a front served on DDS, for every front kind whose interface is one
//! command message in and one state message out (the Dex3 and BrainCo services, Inspire's
//! DFX service and FTP driver, the Dex1 service in one variant, handgate's canonical
//! messages): a reader of the codec's command type on the plan's command topic, a writer of
//! its state type on the plan's state topic and, where the plan has one, on its low-frequency
//! copy. A kind declares its codec ([`FrontCodec`]: the two types, the typed decode and
//! encode); the shell is here, once.

use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use super::config::TopicRole;
use super::kind::FrontWire;
use super::plan::FrontPlan;
use super::serve::{commands, served_command, served_state, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use super::Rejection;
use crate::dds::{DdsError, Reader, Writer};
use crate::discovery::diagnose::Served;

/// A front's wire codec: the message its reader takes, the one its writers publish, and the
/// typed decode and encode between them and the bound devices. A kind whose front is this
/// endpoint says so with `type Wire = DdsFront<TheCodec>;` (`Front::Wire`).
pub trait FrontCodec: OpenCodec + Send + 'static {
    /// The command message (its reader's type).
    type Cmd: Clone + handgate_idl::TopicType + Send + 'static;
    /// The state message (its state writer's type, and its low-frequency copy's).
    type State: handgate_idl::TopicType + Send + 'static;
    /// Decodes a command into commands per bound device (index into `bound`), or the reason
    /// it is rejected whole.
    fn decode(&self, bound: &[Bound<'_>], cmd: &Self::Cmd) -> Result<Vec<(usize, Routed)>, Rejection>;
    /// The state message over the bound devices; `None`: nothing to publish.
    fn encode(&self, bound: &[Bound<'_>]) -> Option<Self::State>;
    /// After each state sample (not the low-frequency copy): what the codec publishes beside
    /// it, on writers of its own (Inspire FTP's touch).
    fn beside(&mut self, _bound: &[Bound<'_>]) {}
    /// What the endpoint serves for `plan`, for discovery: by default its command reader and
    /// state writers ([`DdsFront::endpoints`]); a kind adds the other types a client may use
    /// there, or its own writers.
    fn served(plan: &FrontPlan) -> Vec<Served> {
        DdsFront::<Self>::endpoints(plan)
    }
}

/// How the generic endpoint gets a front's codec: a codec with no settings is its `Default`;
/// one with settings or writers of its own says how it opens for a front's plan.
pub trait OpenCodec: Sized {
    fn open(env: &FrontEnv, plan: &FrontPlan) -> Result<Self, DdsError>;
}

impl<C: Default> OpenCodec for C {
    fn open(_env: &FrontEnv, _plan: &FrontPlan) -> Result<Self, DdsError> {
        Ok(C::default())
    }
}

/// A front's endpoints over codec `C`: its reader (kept alive), its state writer and its
/// low-frequency copy's (with its rate).
pub struct DdsFront<C: FrontCodec> {
    codec: C,
    _reader: Reader<C::Cmd>,
    state: Writer<C::State>,
    lf: Option<(Writer<C::State>, f64)>,
}

impl<C: FrontCodec> DdsFront<C> {
    /// The endpoints of front `plan` over its codec, on the plan's topics.
    pub fn open(env: &FrontEnv, plan: &FrontPlan, tx: Queue, dropped: Arc<AtomicU64>) -> Result<Endpoints, DdsError> {
        use super::serve::STATE_QOS;
        let node = &env.node;
        let codec = C::open(env, plan)?;
        commands(tx, dropped, |inbox| {
            Ok(DdsFront {
                _reader: inbox.reader(node, plan.cmd_topic().unwrap_or_default(), std::convert::identity)?,
                state: node.writer(plan.state_topic(), STATE_QOS)?,
                lf: plan
                    .lf_state()
                    .map(|(t, hz)| node.writer(t, STATE_QOS).map(|w| (w, hz)))
                    .transpose()?,
                codec,
            })
        })
    }

    /// What [`DdsFront::open`] opens for `plan`: the command reader, the state writer and
    /// the low-frequency copy's, in the plan's topic order.
    pub fn endpoints(plan: &FrontPlan) -> Vec<Served> {
        plan.topics
            .iter()
            .filter_map(|t| match t.role {
                TopicRole::Command => Some(served_command::<C::Cmd>(&t.topic)),
                TopicRole::State | TopicRole::LowFrequencyState => Some(served_state::<C::State>(&t.topic)),
                TopicRole::Beside => None,
            })
            .collect()
    }
}

impl<C: FrontCodec> TypedIo for DdsFront<C> {
    type Msg = C::Cmd;

    fn decode(&self, bound: &[Bound<'_>], msg: &C::Cmd) -> Result<Vec<(usize, Routed)>, Rejection> {
        self.codec.decode(bound, msg)
    }

    /// A message no reader would receive (no client attached) is not built (`write_with`).
    fn publish(&mut self, bound: &[Bound<'_>], lf: bool) {
        let codec = &self.codec;
        if lf {
            if let Some((w, _)) = &mut self.lf {
                let _ = w.write_with(|| codec.encode(bound));
            }
            return;
        }
        let _ = self.state.write_with(|| codec.encode(bound));
        self.codec.beside(bound);
    }

    fn lf_hz(&self) -> f64 {
        self.lf.as_ref().map_or(0.0, |(_, hz)| *hz)
    }
}

/// The generic endpoint as a front kind's wire side.
impl<Cfg, C: FrontCodec> FrontWire<Cfg> for DdsFront<C> {
    fn served(_c: &Cfg, plan: &FrontPlan) -> Vec<Served> {
        C::served(plan)
    }
    fn open(
        _c: &Cfg,
        env: &FrontEnv,
        plan: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError> {
        Self::open(env, plan, tx, dropped)
    }
}
