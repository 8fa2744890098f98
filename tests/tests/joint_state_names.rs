//! Every shipped profile publishes each joint name once per JointState topic (a ROS reader
//! keys JointState by name: a name published twice hides one of the two joints). Each
//! profile runs in the real binary and every JointState topic its `handgate check` lists is
//! read from DDS. The profile check refusing a duplicate is tested with the profile tests
//! (gateway/src/profile/tests.rs). Domain 220, one gateway at a time.
//!
//! Devices on `serial` or `usb` backends run on their emulators (no hardware here; a device's
//! joint names come from its kind's table, whatever reaches it); `dds` devices keep their
//! backend and wait for a service that is not there, which publishes their joints all the same.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::ros2;
use handgate_tests::{handgate_cmd, interop_interface, repo_root, temp_profile, Gateway, Latest};

const DOMAIN: u32 = 220;
/// The devices' domain of a profile with `[export]` (its fronts on [`DOMAIN`]).
const EXPORT_DEVICES: u32 = 224;
const DEADLINE: Duration = Duration::from_secs(30);

/// The shipped profiles (profiles/*.toml), by name.
fn shipped() -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = std::fs::read_dir(repo_root().join("profiles"))
        .expect("profiles/")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    out.sort();
    out
}

/// `text` with every `serial` and `usb` backend replaced by `emulator`.
fn on_emulators(text: &str) -> String {
    text.lines()
        .map(|l| {
            let t = l.trim_start();
            if t.starts_with("backend") && (t.contains("\"serial\"") || t.contains("\"usb\"")) {
                let indent = &l[..l.len() - t.len()];
                format!("{indent}backend = \"emulator\"")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The state topics of `profile`'s joint_state fronts, as `handgate check` resolves them.
fn joint_state_topics(profile: &PathBuf) -> Vec<String> {
    let out = handgate_cmd(None)
        .arg("check")
        .arg(profile)
        .output()
        .expect("handgate check");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    text.lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            if w.get(1) != Some(&"joint_state") {
                return None;
            }
            let at = w.iter().position(|x| *x == "state")?;
            w.get(at + 1).map(|t| t.to_string())
        })
        .collect()
}

#[test]
fn every_shipped_profile_publishes_each_joint_name_once_per_topic() {
    let iface = interop_interface().unwrap_or_else(|| "lo".into());
    let n = Node::new(DOMAIN, Some(&iface)).expect("DDS participant");
    let mut seen: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (name, text) in shipped() {
        let path = temp_profile("joint-state-names", &name, &on_emulators(&text));
        let topics = joint_state_topics(&path);
        if topics.is_empty() {
            seen.insert(name, vec![]);
            continue;
        }
        // A profile with `[export]` serves its fronts there: on DOMAIN here, its devices on a
        // domain of their own (EXPORT_DEVICES), so every profile's JointState is read on one.
        let domain = DOMAIN.to_string();
        let (devices_domain, args) = if text.contains("\n[export]") {
            let export = ["--export-domain", &domain, "--export-interface", &iface];
            (EXPORT_DEVICES, export.to_vec())
        } else {
            (DOMAIN, vec![])
        };
        let args = [["--profile", path.to_str().unwrap()].as_slice(), &args].concat();
        let gw = Gateway::try_start_on(devices_domain, &args, Some(&iface)).unwrap_or_else(|e| panic!("{name}: {e}"));
        for topic in &topics {
            let mut js = Latest::<ros2::JointState_>::new(&n, topic, Qos::Reliable { depth: 1 });
            let m = js
                .next(DEADLINE)
                .unwrap_or_else(|| panic!("{name}: nothing on {topic}\n{}", gw.transcript()));
            assert!(!m.name.is_empty(), "{name}: {topic} names no joint");
            let mut count: BTreeMap<&str, usize> = BTreeMap::new();
            for j in &m.name {
                *count.entry(j.as_str()).or_default() += 1;
            }
            let twice: Vec<_> = count.iter().filter(|(_, c)| **c > 1).collect();
            assert!(
                twice.is_empty(),
                "{name}: {topic} names joints more than once: {twice:?}"
            );
            seen.entry(name.clone())
                .or_default()
                .push(format!("{topic}: {} names", m.name.len()));
        }
        drop(gw);
    }
    eprintln!("joint_state topics per shipped profile: {seen:#?}");
    assert!(
        seen.get("sim-all").is_some_and(|t| t.len() == 3),
        "sim-all has three JointState topics: {seen:?}"
    );
}
