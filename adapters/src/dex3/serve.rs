//! The Dex3 service front's registry entry and codec glue; its codec is
//! `crate::dex3::front`.

use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use crate::dex3::dds_client::{topics, StateSource};
use crate::dex3::front::{decode_cmd, encode_state};
use crate::front::config::{side_rule, FrontConfig, Silence, TopicKey, TopicRole};
use crate::front::endpoint::{DdsFront, FrontCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{routed, Bound, Routed};
use crate::front::Rejection;
use crate::kind::{check_rate, MAX_RATE_HZ};
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::{RateHz, Topic};

crate::side_topics_config! {
    /// The Dex3 front's own keys.
    pub struct Dex3FrontConfig {
        /// The low-frequency state copy (default `rt/lf/dex3/{side}/state`).
        pub lf_state_topic: Option<Topic>,
        /// Rate of the low-frequency copy (default [`super::SERVICE_LF_HZ`]).
        pub lf_state_hz: Option<RateHz>,
    }
}

/// unitree_hg `HandCmd_` in, `HandState_` out (and its low-frequency copy).
#[derive(Default)]
pub struct Dex3Codec;

impl FrontCodec for Dex3Codec {
    type Cmd = HandCmd_;
    type State = HandState_;

    fn decode(&self, bound: &[Bound<'_>], m: &HandCmd_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let b0 = &bound[0];
        let c = decode_cmd(m, &b0.route.front, &b0.routed_state())?;
        Ok(vec![(0, routed(b0.route, c))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<HandState_> {
        let b0 = bound.first()?;
        Some(encode_state(&b0.route.front, &b0.routed_state(), b0.state))
    }

    /// Its endpoints, each with the other interfaces' types a client may use there.
    fn served(f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::dds::type_name;
        use crate::discovery::Role;
        use handgate_idl::{handgate, unitree_go};
        DdsFront::<Self>::endpoints(f)
            .into_iter()
            .map(|s| match s.role {
                Role::Reader => s
                    .with_sample_check(super::front::sample_mistake)
                    .alternative(
                        type_name::<unitree_go::MotorCmds_>(),
                        format!("the client speaks the Dex1 / hand-service interface (unitree_go MotorCmds_), not the Dex3 service's unitree_hg HandCmd_: point it at a dex1 front, or send HandCmd_ to front {}", f.name),
                    )
                    .alternative(
                        type_name::<handgate::HandCmd_>(),
                        format!("the client speaks handgate's canonical interface: send it to a canonical front, or send unitree_hg HandCmd_ to front {}", f.name),
                    ),
                Role::Writer => s.alternative(
                    type_name::<unitree_go::MotorStates_>(),
                    format!("the client reads unitree_go MotorStates_ (Dex1 / hand-service interface); front {} publishes the Dex3 service's unitree_hg HandState_", f.name),
                ),
            })
            .collect()
    }
}

/// The Dex3-1 service interface.
#[derive(Debug)]
pub struct Dex3Front;

impl Front for Dex3Front {
    type Config = Dex3FrontConfig;
    type Wire = DdsFront<Dex3Codec>;
    const KIND: FrontKind = FrontKind::of(&Dex3Front);
    const FACTS: FrontFacts = FrontFacts::serving("dex3", Some(DeviceKind::Dex3));
    /// The service's topics of the served side (none for center).
    const TOPICS: &'static [TopicKey<Dex3FrontConfig>] = &[
        TopicKey::cmd_topic(
            |c| c.cmd_topic.as_ref(),
            |_, at| at.side.map(|s| Topic(topics(s, StateSource::State).0)),
        ),
        TopicKey::state_topic(
            |c| c.state_topic.as_ref(),
            |_, at| at.side.map(|s| Topic(topics(s, StateSource::State).1)),
        ),
        TopicKey {
            key: "lf_state_topic",
            role: TopicRole::LowFrequencyState,
            set: |c| c.lf_state_topic.as_ref(),
            default: |_, at| at.side.map(|s| Topic(topics(s, StateSource::Lf).1)),
        },
    ];

    fn default_state_hz(device_hz: Option<f64>) -> f64 {
        device_hz.map_or(super::SERVICE_HZ, |d| d.min(super::SERVICE_HZ))
    }
    fn lf_state_hz(c: &Dex3FrontConfig) -> Option<f64> {
        Some(c.lf_state_hz.map_or(super::SERVICE_LF_HZ, |r| r.0))
    }
    fn default_name(_c: &Dex3FrontConfig, _f: &FrontConfig, side: &str) -> String {
        format!("dex3_{side}")
    }
    fn silence(mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        use crate::dex3::RIS_TIMEOUT;
        let (after, timeout_bit) = match mode {
            // The Dex3 front honours the RIS timeout bit either way: in watchdog mode it
            // shortens the watchdog to at most the motors' own timeout.
            Silence::Watchdog => (Some(dog), Some((dog.0.min(RIS_TIMEOUT), dog.1))),
            // The G1 Dex3 service forwards commands to motors that keep their last target; a
            // motor whose last command set the timeout bit stops (goes limp) 1 s later.
            Silence::Service => (None, Some((RIS_TIMEOUT, SafeAction::Limp))),
        };
        SilencePlan {
            mode,
            after,
            timeout_bit,
        }
    }
    fn validate(
        c: &Dex3FrontConfig,
        _f: &FrontConfig,
        served: Option<Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        let mut out = vec![];
        if let Some(r) = c.lf_state_hz {
            if let Err(m) = check_rate(r.0, MAX_RATE_HZ) {
                out.push(("lf_state_hz", m));
            }
        }
        if !dangling {
            let given = c.cmd_topic.is_some() && c.state_topic.is_some() && c.lf_state_topic.is_some();
            out.extend(side_rule("dex3", served, given, false));
        }
        out
    }
}

impl FrontKind {
    /// The Dex3-1 DDS interface (`rt/dex3/{side}/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex3: FrontKind = Dex3Front::KIND;
}
