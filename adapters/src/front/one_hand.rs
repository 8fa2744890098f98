//! The front of a hand service that runs one instance per hand on `rt/<service>/{left,right}/*`
//! (BrainCo's `brainco_hand_service`, the Dex5-1 service): one command message in and one state
//! message out for the one bound hand, the served side picking the topic pair, and the
//! service's silence rule (it re-sends its last command, no timeout). A kind says what differs,
//! its [`HandService`] (name, topics, rate, the pure decode and encode in its `front.rs`); the
//! [`Front`] and its endpoint are here, once.

use std::fmt;
use std::marker::PhantomData;
use std::time::{Duration, Instant};

use super::config::{side_rule, FrontConfig, SideTopics, Silence, TopicKey};
use super::endpoint::{DdsFront, FrontCodec, OpenCodec};
use super::kind::{Front, FrontFacts, FrontKind};
use super::plan::SilencePlan;
use super::serve::{routed, Bound, FrontEnv, Routed};
use super::{FrontCommand, Rejection};
use crate::dds::DdsError;
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, HandState, JointState, SafeAction, Side};
use crate::units::Topic;

/// What one hand service's front is: its name, wire types, topics, rate and pure codec.
pub trait HandService: Default + Send + Sync + 'static {
    /// The front's name (profile `kind = "..."`), the device kind's own.
    const NAME: &'static str;
    /// The device kind whose convention (table) the clients speak.
    const SPEAKS: DeviceKind;
    /// The service's state rate, Hz, whatever the bound device's.
    const STATE_HZ: f64;
    type Cmd: Clone + handgate_idl::TopicType + Send + 'static;
    type State: handgate_idl::TopicType + Send + 'static;

    /// The service's (command, state) topics for `side`; `None` for center.
    fn topics(side: Side) -> Option<(String, String)>;
    /// The command for the hand whose front table is `front`, or why it is rejected whole.
    fn decode(&self, front: &DeviceTable, cmd: &Self::Cmd) -> Result<FrontCommand, Rejection>;
    /// The state message for the routed canonical state `joints` (front order) of `state`.
    fn encode(&self, front: &DeviceTable, joints: &[JointState], state: &HandState, now: Instant) -> Self::State;
}

/// The front of hand service `S` (`Front` for [`OneHandFront`], codec of its endpoint).
pub struct OneHandFront<S>(PhantomData<S>);

impl<S> fmt::Debug for OneHandFront<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(std::any::type_name::<S>())
    }
}

/// Service `S`'s codec as the generic endpoint's (the one bound hand).
pub struct OneHandCodec<S>(S);

impl<S: HandService> OpenCodec for OneHandCodec<S> {
    fn open(_env: &FrontEnv, _plan: &super::plan::FrontPlan) -> Result<Self, DdsError> {
        Ok(OneHandCodec(S::default()))
    }
}

impl<S: HandService> FrontCodec for OneHandCodec<S> {
    type Cmd = S::Cmd;
    type State = S::State;

    fn decode(&self, bound: &[Bound<'_>], m: &S::Cmd) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        Ok(vec![(0, routed(b.route, self.0.decode(&b.route.front, m)?))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<S::State> {
        let b = bound.first()?;
        Some(
            self.0
                .encode(&b.route.front, &b.routed_state(), b.state, Instant::now()),
        )
    }
}

impl<S: HandService> Front for OneHandFront<S> {
    /// `side` (which hand's topics; default the device's) and the two topics.
    type Config = SideTopics;
    type Wire = DdsFront<OneHandCodec<S>>;
    const KIND: FrontKind = FrontKind::of(&OneHandFront::<S>(PhantomData));
    const FACTS: FrontFacts = FrontFacts::serving(S::NAME, Some(S::SPEAKS));
    /// The side's pair ([`HandService::topics`]); none for center.
    const TOPICS: &'static [TopicKey<SideTopics>] = &[
        TopicKey::cmd_topic(
            |c| c.cmd_topic.as_ref(),
            |_, at| at.side.and_then(S::topics).map(|t| Topic(t.0)),
        ),
        TopicKey::state_topic(
            |c| c.state_topic.as_ref(),
            |_, at| at.side.and_then(S::topics).map(|t| Topic(t.1)),
        ),
    ];

    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        S::STATE_HZ
    }
    fn default_name(_c: &SideTopics, _f: &FrontConfig, side: &str) -> String {
        format!("{}_{side}", S::NAME)
    }
    /// The service has no command timeout: it keeps sending its last command to the hand, so
    /// the device keeps its last target; `watchdog` mode: the device's watchdog.
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    /// A center device needs a side, or both topics.
    fn validate(c: &SideTopics, _f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        if dangling {
            return vec![];
        }
        side_rule(S::NAME, served, c.cmd_topic.is_some() && c.state_topic.is_some(), false)
    }
}
