//! The list of front kinds: every device kind's own fronts (`KindFactory::fronts`, registered
//! with the kind's line in [`crate::kinds::KINDS`]), then handgate's own interfaces, which
//! belong to no device kind. Adding a front for a new kind is part of that kind's folder
//! (docs/adapters.md, "Adding a front").

use crate::front::kind::FrontKind;
use crate::kinds::KINDS;

/// handgate's own fronts: its canonical messages, ROS 2 `joint_states` and ROS 2 JointState
/// commands.
pub const OWN: &[FrontKind] = &[
    FrontKind::Canonical,
    FrontKind::JointState,
    FrontKind::JointStateCommand,
];

/// Every front kind, in the order `handgate check` and errors list them: the device kinds'
/// (in [`KINDS`] order), then [`OWN`].
pub fn all() -> &'static [FrontKind] {
    static ALL: std::sync::OnceLock<Vec<FrontKind>> = std::sync::OnceLock::new();
    ALL.get_or_init(|| {
        KINDS
            .iter()
            .flat_map(|k| k.factory().fronts().iter().copied())
            .chain(OWN.iter().copied())
            .collect()
    })
}

/// (command, state) topics of handgate's own interface for `device` (`handgate send`).
pub fn own_topics(device: &str) -> (String, String) {
    crate::front::canonical::topics(device)
}

/// The ROS 2 bookkeeping topics a ROS node writes whatever it does (rmw_cyclonedds's graph
/// `ros_discovery_info`, rcl's `/rosout` and `/parameter_events`), as DDS topic names: what a
/// read-only identity of the lab's keystore may still publish (`handgate security issue
/// --role observer`).
pub const ROS_BOOKKEEPING_TOPICS: &[&str] = &[
    handgate_idl::ros2::DISCOVERY_INFO_TOPIC,
    "rt/rosout",
    "rt/parameter_events",
];

/// The command topics of every front kind that takes commands, as DDS Security topic
/// patterns (fnmatch: `*` matches any characters, `/` included): each kind's default command
/// topic on either side and at no side, the device's name a `*` where the topic names it
/// (handgate's own `rt/handgate/{device}/cmd`), and the same under any ROS namespace
/// (`rt/*/...`: `[dds] namespace`, `[export] namespace_fronts`). What an operator identity
/// may publish (`handgate security issue --role operator`, docs/security-keystore.md); a
/// profile that moves a command topic with `cmd_topic` is not covered. Sorted, no
/// duplicates.
pub fn command_topic_patterns() -> Vec<String> {
    use crate::front::config::{FrontConfig, TopicAt, TopicRole};
    use crate::model::Side;
    let mut out = std::collections::BTreeSet::new();
    for kind in all().iter().copied().filter(|k| k.takes_commands()) {
        let config = FrontConfig::new(kind);
        for side in [Some(Side::Left), Some(Side::Right), None] {
            let at = TopicAt { side, device: "*" };
            for t in config.kind_topics(&at) {
                let Some(topic) = t.topic.filter(|_| t.role == TopicRole::Command) else {
                    continue;
                };
                if let Some(rest) = topic.as_str().strip_prefix(crate::ros::TOPIC_PREFIX) {
                    out.insert(format!("{}*/{rest}", crate::ros::TOPIC_PREFIX));
                }
                out.insert(topic.as_str().to_string());
            }
        }
    }
    out.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_topics_cover_every_commanding_front() {
        let p = command_topic_patterns();
        for t in [
            "rt/dex3/left/cmd",
            "rt/dex3/right/cmd",
            "rt/handgate/*/cmd",
            "rt/*/handgate/*/cmd",
            crate::front::joint_state_command::DEFAULT_TOPIC,
            crate::inspire_dfx::CMD_TOPIC,
        ] {
            assert!(p.iter().any(|x| x == t), "{t} missing from {p:?}");
        }
        // State topics are not commands.
        assert!(!p.iter().any(|x| x.contains("state")), "{p:?}");
        assert!(
            !p.iter().any(|x| x == crate::front::joint_state::DEFAULT_TOPIC),
            "{p:?}"
        );
    }
}
