//! The joint_state_command front's registry entry and reader; its codec is
//! `crate::front::joint_state_command`.

use std::sync::atomic::AtomicU64;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use crate::front::config::{FrontConfig, Silence, TopicKey, TopicRole};
use crate::front::joint_state_command::{decode, position_gains, JointIndex, DEFAULT_TOPIC};
use crate::front::joint_state_serve::JointStateConfig;
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{commands, routed, served_command, Bound, Endpoints, FrontEnv, Queue, Routed, TypedIo};
use crate::front::Rejection;
use crate::kind::a;
use crate::mapping::DeviceTable;
use crate::model::SafeAction;
use crate::units::Topic;
use handgate_idl::ros2::JointState_;

/// ROS 2 JointState as a command (ros2_control's `joint_state_topic_hardware_interface`), over
/// the devices it lists, or every device: commands only, its client reads a joint_state front.
#[derive(Debug)]
pub struct JointStateCommandFront;

impl Front for JointStateCommandFront {
    type Config = JointStateConfig;
    type Wire = JointStateCommandIo;
    const KIND: FrontKind = FrontKind::of(&JointStateCommandFront);
    const FACTS: FrontFacts = FrontFacts {
        in_namespace: true,
        binds_list: true,
        ..FrontFacts::serving("joint_state_command", None)
    };
    const TOPICS: &'static [TopicKey<JointStateConfig>] = &[TopicKey {
        key: "topic",
        role: TopicRole::Command,
        set: |c| c.topic.as_ref(),
        default: |_, _| Some(Topic::new(DEFAULT_TOPIC)),
    }];

    /// It publishes no state; the rate only paces the front task's periodic bookkeeping (the
    /// queue-full report).
    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        10.0
    }
    fn default_name(_c: &JointStateConfig, _f: &FrontConfig, _side: &str) -> String {
        "joint_state_command".into()
    }
    /// The plugin stops publishing once the state is within its threshold of the command
    /// (`trigger_joint_command_threshold`, docs/sources.md §10): its silence means "stay
    /// there". `service` keeps the last target; `watchdog` is the device's watchdog.
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn joint_names(c: &JointStateConfig, device: &str, table: &DeviceTable) -> Vec<String> {
        c.joint_names(device, table)
    }
    /// It holds each named joint at its position with the device's position gains
    /// ([`position_gains`]): a device holding positions with none (a torque-driven blend,
    /// `rt/hand_sdk`: ai_sport blends the five fields, so a zero kp and kd with no torque take
    /// the hand's drive away instead of moving it) would take every command and move nothing.
    fn cannot_drive(_c: &JointStateConfig, table: &DeviceTable) -> Option<String> {
        let (kp, kd) = position_gains(table);
        (kp == 0.0 && kd == 0.0).then(|| {
            format!(
                "a joint_state_command front holds each joint it is given at that position with the device's \
                 position gains, and {} has none (kp = kd = 0: its closure is a torque, N*m), so a position \
                 would move nothing; command it through a canonical front (closure, or joint targets with \
                 their own kp, kd and tau)",
                a(table.kind.as_str())
            )
        })
    }
    fn validate(
        _c: &JointStateConfig,
        f: &FrontConfig,
        _served: Option<crate::model::Side>,
        _dangling: bool,
    ) -> Vec<(&'static str, String)> {
        match f.state_hz {
            Some(_) => vec![(
                "state_hz",
                "a joint_state_command front publishes no state (its client reads a joint_state front's topic); drop `state_hz`".into(),
            )],
            None => vec![],
        }
    }
    fn describe(c: &JointStateConfig) -> Option<String> {
        Some(if c.urdf_names() {
            ", joints by URDF name, positions in rad".into()
        } else {
            ", joints as <device>/<joint>, positions in rad".into()
        })
    }
}

/// The joint_state_command front's reader and where each name goes.
pub struct JointStateCommandIo {
    _reader: crate::dds::Reader<JointState_>,
    urdf_names: bool,
    /// Built from the bound devices at the first message (they never change for a front).
    index: OnceLock<JointIndex>,
}

/// Its reader: commands only.
impl FrontWire<JointStateConfig> for JointStateCommandIo {
    fn served(_c: &JointStateConfig, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        f.cmd_topic().map(served_command::<JointState_>).into_iter().collect()
    }
    fn open(
        c: &JointStateConfig,
        env: &FrontEnv,
        f: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        commands(tx, dropped, |inbox| {
            Ok(JointStateCommandIo {
                // A ROS-typed reader: its type hash, as a ROS 2 subscription's.
                _reader: inbox.reader_with(
                    &env.node,
                    f.cmd_topic().unwrap_or_default(),
                    &crate::ros::user_data::<JointState_>(),
                    std::convert::identity,
                )?,
                urdf_names: c.urdf_names(),
                index: OnceLock::new(),
            })
        })
    }
}

impl TypedIo for JointStateCommandIo {
    type Msg = JointState_;

    /// One command per device the message names, each a subset of its joints (the others keep
    /// their targets), routed to the device.
    fn decode(&self, bound: &[Bound<'_>], msg: &JointState_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let index = self
            .index
            .get_or_init(|| JointIndex::new(bound.iter().map(|b| (b.device, &*b.route.front)), self.urdf_names));
        let tables: Vec<&DeviceTable> = bound.iter().map(|b| &*b.route.front).collect();
        Ok(decode(index, &tables, msg)?
            .into_iter()
            .map(|(d, c)| (d, routed(bound[d].route, c)))
            .collect())
    }

    /// Nothing: its client reads the joint_state front's topic.
    fn publish(&mut self, _bound: &[Bound<'_>], _lf: bool) {}
}

impl FrontKind {
    /// ROS 2 sensor_msgs/JointState as a command.
    #[allow(non_upper_case_globals)]
    pub const JointStateCommand: FrontKind = JointStateCommandFront::KIND;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::kind::testing::assert_keeps_last_target;

    #[test]
    fn registered_with_its_keys_taking_commands_in_the_namespace_binding_a_list() {
        let k = FrontKind::JointStateCommand;
        assert_eq!(FrontKind::by_name("joint_state_command"), Some(k));
        let f = k.factory().facts();
        assert!(f.takes_commands && f.in_namespace && f.binds_list);
        assert_eq!(f.speaks, None);
        assert_eq!(f.binds_elements, None);
        assert_eq!(k.factory().keys(), ["topic", "urdf_names"]);
        // Not the default front kind (the canonical one is).
        assert_eq!(FrontKind::default(), FrontKind::Canonical);
    }

    #[test]
    fn silence_keeps_the_last_target_unless_watchdog_is_chosen() {
        assert_keeps_last_target(
            FrontKind::JointStateCommand,
            (Duration::from_millis(200), SafeAction::Hold),
        );
    }

    #[test]
    fn state_hz_is_refused_and_the_topic_defaults_to_the_plugins() {
        let mut f = FrontConfig::new(FrontKind::JointStateCommand);
        assert!(f.validate_own(None, false).is_empty());
        f.state_hz = Some(crate::units::RateHz(50.0));
        let e = f.validate_own(None, false);
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].0, "state_hz");
        let t = crate::front::kind::testing::topics_at(&f, None);
        assert_eq!(t, [("topic", Some(Topic::new(DEFAULT_TOPIC)))]);
    }
}
