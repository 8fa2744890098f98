//! `handgate record` / `replay` / `export` end to end (issue #15; docs/recording.md), on DDS
//! domains 153–156. The recordings are read back with the independent Python readers
//! (`mcap`, `mcap-ros2-support`: tests/python/read_recording.py) and decoded to the values
//! sent.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::handgate;
use handgate_idl::unitree_hg as hg;
use handgate_record::bag::Bag;
use handgate_tests::{handgate_bin, handgate_cmd, node, poll, python_script, repo_root, venv_python, Gateway, Latest};

/// A temporary directory for recordings (removed first).
fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("handgate-rec-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `handgate record DIR --domain D [args]` as a child process.
fn record(dir: &Path, domain: u32, args: &[&str]) -> Child {
    handgate_cmd(None)
        .arg("record")
        .arg(dir)
        .args(["--domain", &domain.to_string()])
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn handgate record")
}

fn signal(child: &Child, sig: i32) {
    // SAFETY: kill(2) on our own child's pid.
    let rc = unsafe { libc::kill(child.id() as i32, sig) };
    assert_eq!(rc, 0, "kill({}, {sig})", child.id());
}

/// Stops a recorder with SIGINT and returns its output.
fn stop(child: Child) -> String {
    signal(&child, libc::SIGINT);
    let out = child.wait_with_output().expect("recorder exits");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "recorder failed: {text}");
    text
}

/// The number of messages of the recording so far (files being written are read up to
/// their last complete chunk).
fn recorded(dir: &Path) -> usize {
    Bag::open(dir).map(|b| b.messages.len()).unwrap_or(0)
}

/// Waits until the recorder subscribed (its readers are matched to the gateway's writers:
/// state messages arrive in the file).
fn wait_recording(dir: &Path, min: usize) {
    assert!(
        poll(Duration::from_secs(20), || (recorded(dir) >= min).then_some(())).is_some(),
        "no {min} messages recorded in {}",
        dir.display()
    );
}

/// What read_recording.py says about `file`.
fn python_read(file: &Path, stream: bool) -> serde_json::Value {
    let mut cmd = Command::new(venv_python());
    cmd.arg(python_script("read_recording.py")).arg(file);
    if stream {
        cmd.arg("--stream");
    }
    let out = cmd.output().expect("run read_recording.py");
    assert!(
        out.status.success(),
        "read_recording.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("read_recording.py prints JSON")
}

/// The test client: a ramp of the left index_0 (IDL motor 5) from 0 to -1 rad in 100 steps at
/// 100 Hz, then 50 holds at -1. Returns the q values sent, in order.
fn drive_left_index(domain: u32) -> Vec<f32> {
    let n = node(domain);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    // The gateway's Dex3 front and the recorder.
    w.wait_matched(2, Duration::from_secs(10))
        .expect("the front and the recorder match");
    // This writer sees the front's reader matched, but the front may not know this writer yet,
    // and a volatile reader never gets what a writer sent before it discovered it: wait until
    // the gateway's status lists this writer among the front's matched writers.
    let mut status = Latest::<handgate::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    poll(Duration::from_secs(20), || {
        status
            .update()
            .filter(|s| {
                s.endpoints
                    .iter()
                    .any(|e| e.owner == "front dex3_left" && e.topic == "rt/dex3/left/cmd" && e.matched >= 1)
            })
            .map(|_| ())
    })
    .expect("the gateway lists the client among the front's matched writers");
    let mut sent = Vec::new();
    let start = Instant::now();
    for k in 0..150u32 {
        let mut cmd = hg::HandCmd_::sdk_default();
        for (i, m) in cmd.motor_cmd.iter_mut().enumerate() {
            m.mode = 0x10 | i as u8;
            m.kp = 1.5;
            m.kd = 0.1;
        }
        let q = -(k.min(100) as f32) / 100.0;
        cmd.motor_cmd[5].q = q;
        w.write(cmd).unwrap();
        sent.push(q);
        let due = start + Duration::from_millis(10 * (k as u64 + 1));
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
    }
    sent
}

fn mcap_file(dir: &Path) -> PathBuf {
    let name = dir.file_name().unwrap().to_string_lossy().to_string();
    dir.join(format!("{name}_0.mcap"))
}

#[test]
fn a_recording_of_the_default_fleet_decodes_with_the_python_readers_to_the_values_sent() {
    let domain = 153;
    let _gw = Gateway::start(domain, &[]);
    let dir = scratch("fleet").join("fleet");
    let rec = record(&dir, domain, &[]);
    wait_recording(&dir, 100);
    let sent = drive_left_index(domain);
    let out = stop(rec);
    assert!(out.contains("0 dropped"), "{out}");

    let r = python_read(&mcap_file(&dir), false);
    assert_eq!(r["profile"], "ros2");
    assert_eq!(r["schema_encodings"], serde_json::json!(["ros2msg"]));
    assert_eq!(r["message_encodings"], serde_json::json!(["cdr"]));
    assert_eq!(r["qos_on_every_channel"], true);
    // Every chunk but the first (schemas and channels only) indexes its messages.
    let chunks = r["chunks"].as_u64().unwrap();
    assert!(chunks >= 2, "{r}");
    assert!(r["chunks_with_message_indexes"].as_u64().unwrap() >= chunks - 1, "{r}");
    assert_eq!(r["statistics_messages"], r["decoded"]);
    assert_eq!(r["metadata"]["handgate"]["dropped_messages"], "0");
    let schemas: Vec<&str> = r["schemas"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    for s in [
        "unitree_hg/msg/HandCmd",
        "unitree_hg/msg/HandState",
        "unitree_go/msg/MotorStates",
        "handgate/msg/HandState",
        "handgate/msg/GatewayStatus",
        "sensor_msgs/msg/JointState",
    ] {
        assert!(schemas.contains(&s), "{s} missing from {schemas:?}");
    }
    let topics = r["topics"].as_object().unwrap();
    for t in [
        "/dex3/left/state",
        "/dex1/right/state",
        "/handgate/dex3_left/state",
        "/joint_states",
        "/handgate/status",
    ] {
        assert!(
            topics.get(t).and_then(|n| n.as_u64()).unwrap_or(0) > 0,
            "{t}: {topics:?}"
        );
    }
    // Every command the client sent, decoded by the independent reader, in order.
    let got: Vec<f32> = r["cmd_q5"]["/dex3/left/cmd"]
        .as_array()
        .expect("left commands recorded")
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    assert_eq!(got, sent);
    // rosbag2's metadata.yaml beside the file.
    let meta = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
    assert!(
        meta.contains("storage_identifier: mcap") && meta.contains("name: /dex3/left/cmd"),
        "{meta}"
    );
}

#[test]
fn sigkill_loses_at_most_the_last_chunk_and_the_file_stays_readable() {
    let domain = 154;
    let _gw = Gateway::start(domain, &[]);
    let dir = scratch("kill").join("killed");
    let mut rec = record(&dir, domain, &[]);
    // Several chunks (one per second at least) reach the disk.
    wait_recording(&dir, 3000);
    let before = recorded(&dir);
    signal(&rec, libc::SIGKILL);
    let _ = rec.wait();
    let bag = Bag::open(&dir).unwrap();
    assert!(bag.messages.len() >= before, "{} < {before}", bag.messages.len());
    assert_eq!(
        bag.truncated.len(),
        1,
        "the killed file has no footer: {:?}",
        bag.truncated
    );
    let r = python_read(&mcap_file(&dir), true);
    assert!(r["decoded"].as_u64().unwrap() as usize >= before, "{r}");
    assert!(r["topics"]["/dex3/left/state"].as_u64().unwrap() > 0, "{r}");
}

/// (time since the first command, left index_0 q) of the recording's `/dex3/left/state`.
fn trajectory(bag: &Bag) -> Vec<(f64, f64)> {
    let t0 = bag
        .messages
        .iter()
        .filter(|m| m.ros_topic == "/dex3/left/cmd")
        .map(|m| m.publish_time)
        .min()
        .expect("commands recorded");
    bag.messages
        .iter()
        .filter(|m| m.ros_topic == "/dex3/left/state" && m.publish_time >= t0)
        .map(|m| {
            let j = handgate_record::export::joints(m).unwrap().unwrap();
            ((m.publish_time - t0) as f64 / 1e9, j.q[5])
        })
        .collect()
}

fn q_at(t: &[(f64, f64)], at: f64) -> f64 {
    let i = t.partition_point(|(s, _)| *s <= at);
    t[i.saturating_sub(1)].1
}

#[test]
fn replaying_a_session_into_a_fresh_gateway_drives_its_device_like_the_client_did() {
    // The original session: a client drives the left hand; the recorder records its topics.
    let original = scratch("replay").join("original");
    {
        let _gw = Gateway::start(155, &[]);
        let rec = record(&original, 155, &["--topics", "/dex3/left/*"]);
        wait_recording(&original, 100);
        drive_left_index(155);
        // The hand settles at the last target.
        std::thread::sleep(Duration::from_millis(300));
        stop(rec);
    }
    // A fresh gateway on another domain, driven by the replay alone.
    let replayed = original.parent().unwrap().join("replayed");
    {
        let _gw = Gateway::start(156, &[]);
        let rec = record(&replayed, 156, &["--topics", "/dex3/left/*"]);
        wait_recording(&replayed, 100);
        let out = Command::new(handgate_bin())
            .args([
                "replay",
                original.to_str().unwrap(),
                "--domain",
                "156",
                "--topics",
                "/dex3/left/cmd",
                "--readers",
                "2",
                "--wait",
                "30",
            ])
            .current_dir(repo_root())
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && text.contains("replayed 150 message(s) on 1 topic(s)"),
            "{text}"
        );
        std::thread::sleep(Duration::from_millis(300));
        stop(rec);
    }
    let (bag_a, bag_b) = (Bag::open(&original).unwrap(), Bag::open(&replayed).unwrap());
    // The replayed commands are the client's, value for value, in order and at the same
    // relative times (up to scheduling jitter).
    let cmds = |bag: &Bag| -> Vec<(f64, f32)> {
        let c: Vec<_> = bag
            .messages
            .iter()
            .filter(|m| m.ros_topic == "/dex3/left/cmd")
            .collect();
        let t0 = c[0].publish_time;
        c.iter()
            .map(|m| {
                let j = handgate_record::export::joints(m).unwrap().unwrap();
                ((m.publish_time - t0) as f64 / 1e9, j.q[5] as f32)
            })
            .collect()
    };
    let (ca, cb) = (cmds(&bag_a), cmds(&bag_b));
    assert_eq!(
        ca.iter().map(|c| c.1).collect::<Vec<_>>(),
        cb.iter().map(|c| c.1).collect::<Vec<_>>()
    );
    let mut shifts: Vec<f64> = ca.iter().zip(&cb).map(|(a, b)| (a.0 - b.0).abs()).collect();
    shifts.sort_by(f64::total_cmp);
    assert!(
        shifts[shifts.len() / 2] < 0.005,
        "median timing difference {} s",
        shifts[shifts.len() / 2]
    );
    // The device follows the same trajectory: every 20 ms of the 1.5 s session, the replayed
    // device is where the original was within 50 mrad, allowing 250 ms of time shift (this
    // machine is shared: a loaded scheduler stalls either run for 100-200 ms now and then; a
    // replay at the wrong speed or with other targets is off by far more).
    let (a, b) = (trajectory(&bag_a), trajectory(&bag_b));
    let near = |x: &[(f64, f64)], y: &[(f64, f64)], t: f64| {
        let q = q_at(x, t);
        (-12..=12).any(|k| (q_at(y, (t + k as f64 * 0.02).max(0.0)) - q).abs() < 0.05)
    };
    let mut t = 0.0;
    while t <= 1.5 {
        assert!(
            near(&a, &b, t) && near(&b, &a, t),
            "trajectories differ at {t:.2} s: {:.3} vs {:.3}",
            q_at(&a, t),
            q_at(&b, t)
        );
        t += 0.02;
    }
    let (ea, eb) = (a.last().unwrap().1, b.last().unwrap().1);
    assert!(
        (ea + 1.0).abs() < 0.05 && (eb - ea).abs() < 0.02,
        "final q {ea} vs {eb}"
    );

    // The export of the original session: the client's targets as the left hand's actions.
    let out = Command::new(handgate_bin())
        .args([
            "export",
            original.to_str().unwrap(),
            "--xr-teleoperate",
            "--only-left",
            "--rate",
            "30",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let frames = v["data"].as_array().unwrap();
    assert!(frames.len() >= 40, "{} frames", frames.len());
    let last = &frames[frames.len() - 1];
    assert_eq!(last["actions"]["left_ee"]["qpos"][5].as_f64().unwrap() as f32, -1.0);
    assert!(
        (last["states"]["left_ee"]["qpos"][5].as_f64().unwrap() + 1.0).abs() < 0.05,
        "{last}"
    );
    assert_eq!(last["states"]["left_ee"]["qpos"].as_array().unwrap().len(), 7);
}

#[test]
fn replay_refuses_the_robots_domain_without_allow_robot() {
    let dir = scratch("refuse").join("none");
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new(handgate_bin())
        .args(["replay", dir.to_str().unwrap(), "--domain", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--allow-robot"));
}

#[test]
fn a_gateway_with_a_record_section_records_from_start_up_and_says_so_in_status() {
    let domain = 157;
    let base = scratch("section");
    let profile = handgate_tests::default_profile_edited(
        "record_section",
        &[(
            "[status]",
            &format!(
                "[record]\ndir = \"{}\"\ntopics = [\"/dex3/*\", \"/handgate/status\"]\n\n[status]",
                base.display()
            ),
        )],
    );
    let mut gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let n = node(domain);
    let mut status = handgate_tests::Latest::<handgate_idl::handgate::GatewayStatus_>::new(
        &n,
        "rt/handgate/status",
        Qos::Reliable { depth: 1 },
    );
    let s = poll(Duration::from_secs(20), || {
        status.update().filter(|s| s.record_messages > 0).cloned()
    })
    .expect("status reports the recorder's messages");
    assert_eq!(s.record_dropped, 0);
    gw.signal(handgate_tests::Signal::Int).unwrap();
    assert!(gw.wait_exit(Duration::from_secs(10)).is_some_and(|s| s.success()));
    let dirs: Vec<PathBuf> = std::fs::read_dir(&base).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(dirs.len(), 1, "{dirs:?}");
    let name = dirs[0].file_name().unwrap().to_string_lossy().to_string();
    assert!(name.starts_with("default_"), "{name}");
    let r = python_read(&dirs[0].join(format!("{name}_0.mcap")), false);
    let topics = r["topics"].as_object().unwrap();
    assert!(
        topics.contains_key("/dex3/left/state") && topics.contains_key("/handgate/status"),
        "{r}"
    );
    assert!(
        !topics.contains_key("/dex1/left/state"),
        "only the selected topics: {r}"
    );
    assert_eq!(r["metadata"]["handgate"]["dropped_messages"], "0");
}
