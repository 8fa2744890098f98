//! A grasp is not a fault (issue #37): every kind whose state carries an effort (Dex3 and Dex5
//! torque, Dex1 torque, EZGripper effort, BrainCo current, Inspire FTP force and status),
//! emulated with an object in a closing joint's path (`[devices.emulator] object_at`) and
//! closed on it through its canonical front, reads `holding` in the status (motion 4, the joint
//! named) and OK in `/diagnostics` (no WARN, no ERROR), through the real binary; so does an
//! Inspire DFX, whose service publishes positions only, with `[devices.motion] contact =
//! "unmeasured"`. The faults of
//! #29 (a stuck joint with no effort, a frozen stream, commands ignored) are tests/tests/motion.rs's.
//!
//! Domain 118 (docs/development.md). Needs the binary (`cargo build -p handgate`) and `.venv`.

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::ros2::diagnostic_level as level;
use handgate_tests::{health_peer, node, serial, stream_closure, temp_profile, Gateway, Latest};
use serde_json::Value;

const DOMAIN: u32 = 118;
const DEADLINE: Duration = Duration::from_secs(60);

/// (device, kind, the emulated object: joint = canonical rad on the way to the closed posture,
/// more of the device's table)
const HANDS: &[(&str, &str, &str, &str)] = &[
    ("dex3", "dex3", "{ index_0 = 0.6, middle_0 = 0.6, thumb_2 = 0.5 }", ""),
    ("dex1", "dex1", "{ jaw = 2.0 }", ""),
    ("ezgripper", "ezgripper", "{ jaw = 2.0 }", ""),
    ("brainco", "brainco", "{ index = 0.5, middle = 0.5 }", ""),
    ("ftp", "inspire_ftp", "{ index = 1.0 }", ""),
    ("dex5", "dex5", "{ index_2 = 0.5 }", ""),
    // Positions only through its service: a grasp only where the profile says so.
    (
        "dfx",
        "inspire_dfx",
        "{ index = 1.0 }",
        "[devices.motion]\ncontact = \"unmeasured\"\n",
    ),
];

fn profile() -> std::path::PathBuf {
    let mut text =
        String::from("name = \"grasp\"\n[status]\nrate_hz = 10\n[log]\nformat = \"human\"\nlevel = \"info\"\n");
    for (name, kind, object, extra) in HANDS {
        text.push_str(&format!(
            "[[devices]]\nname = \"{name}\"\nkind = \"{kind}\"\nside = \"left\"\nbackend = \"emulator\"\n"
        ));
        if *kind == "ezgripper" {
            text.push_str("[devices.ezgripper]\nport = \"grasp-bus\"\nservo_id = 1\nresponse_timeout_ms = 100\n");
        }
        text.push_str(&format!("[devices.emulator]\nobject_at = {object}\n{extra}"));
    }
    for (name, _, _, _) in HANDS {
        text.push_str(&format!("[[fronts]]\nkind = \"canonical\"\ndevice = \"{name}\"\n"));
    }
    temp_profile("grasp", "grasp", &text)
}

#[test]
fn closing_on_an_object_reads_holding_and_ok_in_diagnostics_for_every_kind_with_effort() {
    let _g = serial();
    let gw = Gateway::start(DOMAIN, &["--profile", profile().to_str().unwrap()]);
    let py = health_peer(DOMAIN);
    let n = node(DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let streams: Vec<_> = HANDS
        .iter()
        .map(|(name, _, _, _)| stream_closure(DOMAIN, name, 1.0))
        .collect();

    // Every hand holding (and nothing else reported on the way: a grasp never reads as a fault).
    let start = Instant::now();
    let mut seen: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let mut holding: BTreeMap<String, String> = BTreeMap::new();
    while holding.len() < HANDS.len() {
        assert!(
            start.elapsed() < DEADLINE,
            "not every hand holds: {holding:?}; verdicts seen {seen:?}\n{:?}\n{}",
            status.last,
            gw.transcript()
        );
        status.update_with(|s| {
            for d in &s.devices {
                let v = seen.entry(d.device.clone()).or_default();
                if !v.contains(&d.motion) {
                    v.push(d.motion);
                }
                if d.motion == hg::MOTION_HOLDING {
                    holding.insert(d.device.clone(), d.motion_joint.clone());
                }
            }
        });
        std::thread::sleep(Duration::from_millis(20));
    }
    println!("holding after {:?}: {holding:?}", start.elapsed());
    for (name, verdicts) in &seen {
        assert!(
            verdicts.iter().all(|m| *m == hg::MOTION_OK || *m == hg::MOTION_HOLDING),
            "{name} reported a fault while closing on its object: {verdicts:?}\n{}",
            gw.transcript()
        );
    }
    // /diagnostics: two samples after every hand holds, each hand OK, its motion `holding`.
    let mut ok_samples = 0;
    let until = Instant::now() + DEADLINE;
    let mut after = Instant::now() + Duration::from_millis(1100);
    while ok_samples < 2 {
        let left = until.saturating_duration_since(Instant::now());
        let line = py
            .wait_line("DIAG ", left)
            .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
        let d: Value = serde_json::from_str(&line).unwrap();
        if Instant::now() < after {
            continue; // published before every hand held
        }
        for (name, _, _, _) in HANDS {
            let s = d["status"]
                .as_array()
                .and_then(|a| a.iter().find(|s| s["name"] == format!("handgate: {name}")))
                .unwrap_or_else(|| panic!("no status of {name}: {d:#}"));
            assert_eq!(s["level"], level::OK, "{name} is not OK while holding: {s:#}");
            assert_eq!(s["values"]["motion"], "holding", "{name}: {s:#}");
        }
        ok_samples += 1;
        after = Instant::now();
    }
    for (stop, t) in streams {
        stop.store(true, Ordering::Relaxed);
        let _ = t.join();
    }
}
