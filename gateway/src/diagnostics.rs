//! Discovery diagnostics for the running gateway (issue #14): what every front and DDS-client
//! device of a plan serves on DDS ([`served`]), asked of their kinds; the diagnostics task
//! that watches discovery and reports findings lives here too (docs/discovery.md).

use handgate_adapters::discovery::diagnose::Served;

use crate::plan::Plan;

/// Who serves an endpoint: a front or a device, by its name in the plan.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Owner {
    Front(String),
    Device(String),
}

impl Owner {
    /// The owner's name in the plan.
    pub fn name(&self) -> &str {
        match self {
            Owner::Front(n) | Owner::Device(n) => n,
        }
    }

    /// `front NAME` / `device NAME`.
    pub fn describe(&self) -> String {
        match self {
            Owner::Front(n) => format!("front {n}"),
            Owner::Device(n) => format!("device {n}"),
        }
    }
}

impl std::fmt::Display for Owner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}

/// One endpoint the gateway serves, and who serves it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServedBy {
    pub owner: Owner,
    pub served: Served,
}

/// Everything `plan` serves on DDS: each front's endpoints (its kind's
/// [`handgate_adapters::front::kind::FrontFactory::served`]), then each device's as a client
/// of a robot service ([`handgate_adapters::kind::KindFactory::served`]; none for devices that
/// reach their hardware without DDS). Plan order.
pub fn served(plan: &Plan) -> Vec<ServedBy> {
    let fronts = plan.fronts.iter().flat_map(|f| {
        f.kind.factory().served(f).into_iter().map(|served| ServedBy {
            owner: Owner::Front(f.name.clone()),
            served,
        })
    });
    let devices = plan.devices.iter().flat_map(|d| {
        d.kind.factory().served(&d.spec()).into_iter().map(|served| ServedBy {
            owner: Owner::Device(d.name.clone()),
            served,
        })
    });
    fronts.chain(devices).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_adapters::discovery::Role;
    use handgate_idl::{handgate, inspire, ros2, unitree_go, unitree_hg, DdsTypeName};

    fn sim_all() -> Plan {
        let loaded = crate::profile::load(&crate::profile::LoadOptions {
            profile: Some(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../profiles/sim-all.toml")
                    .display()
                    .to_string(),
            ),
            overrides: Default::default(),
            env: crate::profile::EnvLayer::Ignore,
            search_dirs: Some(vec![]),
        })
        .expect("sim-all loads");
        crate::resolve::plan(&loaded.profile).expect("sim-all resolves")
    }

    /// (topic, type, role) of what `owner` serves.
    fn of(all: &[ServedBy], owner: &Owner) -> Vec<(String, String, Role)> {
        all.iter()
            .filter(|s| &s.owner == owner)
            .map(|s| (s.served.topic.clone(), s.served.type_name.clone(), s.served.role))
            .collect()
    }

    fn t<T: DdsTypeName>() -> String {
        T::DDS_TYPE_NAME.to_string()
    }

    #[test]
    fn every_front_of_sim_all_serves_its_topics_with_the_idl_type_names() {
        let plan = sim_all();
        let all = served(&plan);
        for f in &plan.fronts {
            let got = of(&all, &Owner::Front(f.name.clone()));
            let (cmd, state): (Option<String>, String) = match f.kind.as_str() {
                "dex3" => (Some(t::<unitree_hg::HandCmd_>()), t::<unitree_hg::HandState_>()),
                "dex1" | "inspire_dfx" | "brainco" => {
                    (Some(t::<unitree_go::MotorCmds_>()), t::<unitree_go::MotorStates_>())
                }
                "inspire_ftp" => (Some(t::<inspire::InspireHandCtrl>()), t::<inspire::InspireHandState>()),
                "canonical" => (Some(t::<handgate::HandCmd_>()), t::<handgate::HandState_>()),
                "joint_state" => (None, t::<ros2::JointState_>()),
                other => panic!("front kind {other} of sim-all has no expectation here"),
            };
            match cmd {
                Some(ty) => {
                    let topic = f.cmd_topic.clone().expect("a commanded front has a command topic");
                    assert!(got.contains(&(topic, ty, Role::Reader)), "{}: {got:?}", f.name);
                }
                None => assert!(got.iter().all(|g| g.2 == Role::Writer), "{}: {got:?}", f.name),
            }
            assert!(
                got.contains(&(f.state_topic.clone(), state.clone(), Role::Writer)),
                "{}: {got:?}",
                f.name
            );
            if let Some((lf, _)) = &f.lf_state {
                assert!(got.contains(&(lf.clone(), state, Role::Writer)), "{}: {got:?}", f.name);
            }
            if f.kind.as_str() == "inspire_ftp" {
                assert!(
                    got.iter()
                        .any(|g| g.1 == t::<inspire::InspireHandTouch>() && g.2 == Role::Writer),
                    "{}: {got:?}",
                    f.name
                );
            }
        }
    }

    #[test]
    fn a_go_dex1_front_names_the_hg_type_and_the_actuator_topics_with_their_fixes() {
        let plan = sim_all();
        let all = served(&plan);
        let f = plan
            .fronts
            .iter()
            .find(|f| f.kind.as_str() == "dex1" && f.cmd_topic.as_deref() == Some("rt/dex1/left/cmd"))
            .expect("sim-all serves rt/dex1/left/cmd");
        let cmd = all
            .iter()
            .find(|s| s.owner == Owner::Front(f.name.clone()) && s.served.role == Role::Reader)
            .unwrap();
        let alt = cmd
            .served
            .alternatives
            .iter()
            .find(|a| a.type_name == t::<unitree_hg::HandCmd_>())
            .expect("hg HandCmd_ is an alternative");
        assert!(
            alt.hint.contains(&format!("set variant = \"hg\" on front {}", f.name)),
            "{}",
            alt.hint
        );
        assert!(cmd
            .served
            .related_topics
            .iter()
            .any(|r| r.topic == "rt/unitree_actuator/cmd" && r.hint.contains("variant = \"actuator\"")));
    }

    #[test]
    fn dds_client_devices_serve_their_peer_topics_and_others_nothing() {
        let plan = sim_all();
        let all = served(&plan);
        for d in &plan.devices {
            let got = of(&all, &Owner::Device(d.name.clone()));
            let kind = d.kind.as_str();
            match kind {
                // USB and serial hands: nothing on DDS.
                "dex3" | "ezgripper" => assert!(got.is_empty(), "{}: {got:?}", d.name),
                _ => {
                    // On the emulator backend: the in-process peer's private topics.
                    assert!(
                        got.iter()
                            .any(|g| g.2 == Role::Writer && g.0.starts_with("rt/handgate/emu/")),
                        "{}: {got:?}",
                        d.name
                    );
                    let cmd = got.iter().find(|g| g.2 == Role::Writer).unwrap();
                    let want = match kind {
                        "inspire_ftp" => t::<inspire::InspireHandCtrl>(),
                        _ => t::<unitree_go::MotorCmds_>(),
                    };
                    assert_eq!(cmd.1, want, "{}", d.name);
                    if kind != "hand_sdk" {
                        assert!(got.iter().any(|g| g.2 == Role::Reader), "{}: {got:?}", d.name);
                    }
                }
            }
        }
    }
}
