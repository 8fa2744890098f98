//! What a plan records: every endpoint it serves on DDS ([`crate::diagnostics::served`]:
//! each front's command and state topics, each DDS-client device's topics, the canonical
//! state and `rt/joint_states` fronts) plus the status topic and the health messages
//! ([`crate::health::topics`]), filtered by topic globs.

use handgate_adapters::dds::Qos;
use handgate_idl::{handgate, DdsTypeName};
use handgate_record::TopicSpec;

use crate::plan::Plan;

/// Every topic `plan` serves (each (topic, type) once, plan order, then status and the health
/// messages), with
/// whether it carries commands: what fronts read from clients and what DDS-client devices
/// write to their robot service.
fn served_topics(plan: &Plan) -> Vec<(TopicSpec, bool)> {
    use crate::diagnostics::Owner;
    use handgate_adapters::discovery::Role;
    let mut out: Vec<(TopicSpec, bool)> = Vec::new();
    // A front that follows its clients' types (a variant `auto`) serves several types on one
    // topic: each is a channel of its own.
    let served = crate::diagnostics::served(plan).into_iter().flat_map(|s| {
        let command = matches!(
            (&s.owner, s.served.role),
            (Owner::Front(_), Role::Reader) | (Owner::Device(_), Role::Writer)
        );
        let s = s.served;
        std::iter::once(s.type_name)
            .chain(s.also)
            .map(|ty| {
                (
                    TopicSpec {
                        dds_topic: s.topic.clone(),
                        dds_type: ty,
                        qos: s.qos,
                    },
                    command,
                )
            })
            .collect::<Vec<_>>()
    });
    let status = TopicSpec {
        dds_topic: plan.status_topic.clone(),
        dds_type: handgate::GatewayStatus_::DDS_TYPE_NAME.to_string(),
        qos: Qos::Reliable { depth: 1 }.served(),
    };
    // The health messages (`[dds] ros_node`): states, after status.
    let health = crate::health::topics(plan).into_iter().map(|(topic, ty)| {
        (
            TopicSpec {
                dds_topic: topic,
                dds_type: ty.to_string(),
                qos: crate::health::QOS.served(),
            },
            false,
        )
    });
    for (t, command) in served.chain(std::iter::once((status, false))).chain(health) {
        if !out
            .iter()
            .any(|(o, _)| o.dds_topic == t.dds_topic && o.dds_type == t.dds_type)
        {
            out.push((t, command));
        }
    }
    out
}

/// The topics of `plan` selected by `globs` (DDS or ROS 2 names; none: all).
pub fn topics(plan: &Plan, globs: &[String]) -> Vec<TopicSpec> {
    served_topics(plan)
        .into_iter()
        .filter(|(t, _)| handgate_record::selected(globs, &t.dds_topic))
        .map(|(t, _)| t)
        .collect()
}

/// The topics `[foxglove]` serves live: those selected by `globs` (DDS or ROS 2 names, over
/// every topic, commands included), or with none every topic that is not a command topic
/// (each front's state, the canonical states, `rt/joint_states`, a DDS-client device's robot
/// state) and status.
pub fn live_topics(plan: &Plan, globs: &[String]) -> Vec<TopicSpec> {
    served_topics(plan)
        .into_iter()
        .filter(|(t, command)| {
            if globs.is_empty() {
                !command
            } else {
                handgate_record::selected(globs, &t.dds_topic)
            }
        })
        .map(|(t, _)| t)
        .collect()
}

/// Recording options from the CLI's / profile's values.
pub fn options(
    dir: &std::path::Path,
    max_mb: Option<f64>,
    max_seconds: Option<f64>,
    zstd: bool,
) -> handgate_record::RecordOptions {
    let mut o = handgate_record::RecordOptions::new(dir);
    o.max_bytes = max_mb.filter(|m| *m > 0.0).map(|m| (m * 1e6) as u64);
    o.max_duration = max_seconds.filter(|s| *s > 0.0).map(std::time::Duration::from_secs_f64);
    if zstd {
        o.compression = handgate_record::Compression::Zstd;
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_fleet_records_every_front_topic_and_status() {
        let plan = crate::resolve::default_plan();
        let all = topics(&plan, &[]);
        let names: Vec<&str> = all.iter().map(|t| t.dds_topic.as_str()).collect();
        for f in &plan.fronts {
            if let Some(c) = f.cmd_topic() {
                assert!(names.contains(&c), "{c}: {names:?}");
            }
        }
        assert!(
            names.contains(&"rt/joint_states") && names.contains(&plan.status_topic.as_str()),
            "{names:?}"
        );
        let cmds = topics(&plan, &["/dex3/*/cmd".into()]);
        assert_eq!(cmds.len(), 2, "{cmds:?}");
        // The `auto` Dex1 fronts: go and hg on each topic.
        let dex1 = topics(&plan, &["/dex1/left/*".into()]);
        let types: Vec<&str> = dex1.iter().map(|t| t.dds_type.as_str()).collect();
        assert_eq!(
            types,
            [
                "unitree_go::msg::dds_::MotorCmds_",
                "unitree_hg::msg::dds_::HandCmd_",
                "unitree_go::msg::dds_::MotorStates_",
                "unitree_hg::msg::dds_::HandState_"
            ],
            "{dex1:?}"
        );
    }

    #[test]
    fn live_topics_are_the_states_and_status_unless_globs_say_otherwise() {
        let plan = crate::resolve::default_plan();
        let live = live_topics(&plan, &[]);
        let names: Vec<&str> = live.iter().map(|t| t.dds_topic.as_str()).collect();
        for f in &plan.fronts {
            if let Some(c) = f.cmd_topic() {
                assert!(!names.contains(&c), "{c} is a command topic: {names:?}");
            }
            assert!(names.contains(&f.state_topic()), "{}: {names:?}", f.state_topic());
        }
        assert!(!names.contains(&"rt/unitree_actuator/cmd"), "{names:?}");
        for want in [
            "rt/joint_states",
            "rt/dex3/left/state",
            "rt/lf/dex3/left/state",
            "rt/handgate/dex3_left/state",
            "rt/dex1/right/state",
            plan.status_topic.as_str(),
            "rt/diagnostics",
            "rt/hardware_status",
        ] {
            assert!(names.contains(&want), "{want}: {names:?}");
        }
        // Globs choose among every topic, commands included.
        let cmds = live_topics(&plan, &["/dex3/*/cmd".into(), "/joint_states".into()]);
        let names: Vec<&str> = cmds.iter().map(|t| t.dds_topic.as_str()).collect();
        assert_eq!(names, ["rt/dex3/left/cmd", "rt/dex3/right/cmd", "rt/joint_states"]);
    }
}
