//! Commands in order (docs/fronts.md, "Commands in order"), end to end through the real
//! `handgate` binary: a client writes Dex3 commands with explicit source timestamps
//! (`dds_write_ts`, `Writer::write_ts`), as a bridge would deliver them:
//!
//! - out of order and twice: the older ones and the copy are dropped and counted in the
//!   status topic (`reordered_cmd`, `duplicate_cmd`), in `handgate status --once` and in
//!   `/metrics`, and the hand ends at the newest target (each dropped command aims elsewhere);
//! - with `max_command_age_ms` on the front: a command stamped 2 s ago is dropped as late
//!   (`late_cmd`), a fresh one is taken; a second writer whose clock runs 1 s ahead is named
//!   once in the log and its commands are taken.
//!
//! Domains 166-167 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness or a received sample, with a deadline. Needs the binary (built by the helpers).

use std::process::{Command, Stdio};
use std::time::Duration;

use handgate_adapters::dds::{Qos, Writer};
use handgate_adapters::front::serve::wall_ns;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_hg;
use handgate_tests::{
    default_profile_edited, device_metrics, dex3_cmd, handgate_bin, http_get, interop_interface, node, poll, repo_root,
    serial, status_device, Gateway, Latest, DEX3_INDEX_0 as INDEX_0,
};

const DEADLINE: Duration = Duration::from_secs(20);
/// "At a target", rad.
const TOL: f32 = 0.05;
const MS: i64 = 1_000_000;

/// The default profile's left Dex3 front (the line that binds it).
const DEX3_LEFT_FRONT: &str = "device = \"dex3_left\"      # rt/dex3/left/{cmd,state}, rt/lf/dex3/left/state";

/// A client's writer on the left Dex3 front, matched by the gateway's reader. Reliable with a
/// history deep enough that every command written reaches the gateway.
fn client(n: &handgate_adapters::dds::Node) -> Writer<unitree_hg::HandCmd_> {
    let w = n
        .writer::<unitree_hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 64 })
        .expect("writer");
    w.wait_matched(1, DEADLINE)
        .expect("the gateway's command reader matched");
    w
}

/// Waits until the left hand's wire index_0 is within [`TOL`] of `target`; then, over
/// `samples` more state samples, it must stay there. Returns the largest deviation seen then.
fn ends_at(state: &mut Latest<unitree_hg::HandState_>, gw: &Gateway, target: f32, samples: u64) -> f32 {
    poll(DEADLINE, || {
        state
            .update()
            .map(|s| s.motor_state[INDEX_0].q)
            .filter(|q| (q - target).abs() < TOL)
    })
    .unwrap_or_else(|| {
        panic!(
            "index_0 never reached {target}: {:?}\n{}",
            state.last.as_ref().map(|s| s.motor_state[INDEX_0].q),
            gw.transcript()
        )
    });
    let (start, mut worst) = (state.count, 0.0f32);
    poll(DEADLINE, || {
        state.update_with(|s| worst = worst.max((s.motor_state[INDEX_0].q - target).abs()));
        (state.count >= start + samples).then_some(())
    })
    .expect("state samples keep coming");
    worst
}

/// The status of `dex3_left` once `cond` holds on it.
fn status_until(
    status: &mut Latest<hg::GatewayStatus_>,
    gw: &Gateway,
    cond: impl Fn(&hg::DeviceStatus_) -> bool,
) -> hg::DeviceStatus_ {
    poll(DEADLINE, || {
        status
            .update()
            .map(|s| status_device(s, "dex3_left").clone())
            .filter(&cond)
    })
    .unwrap_or_else(|| panic!("status never showed it: {:?}\n{}", status.last, gw.transcript()))
}

#[test]
fn duplicated_and_reordered_commands_are_dropped_and_counted_and_the_hand_ends_at_the_newest() {
    let _serial = serial();
    let domain = 166;
    let gw = Gateway::start(domain, &[]);
    let n = node(domain);
    let mut state = Latest::<unitree_hg::HandState_>::new(&n, "rt/dex3/left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let mut w = client(&n);

    // Written in this order, stamped as a bridge might deliver them: the newest (-1.0 at
    // t + 30 ms) before an older one (-0.6 at t + 20 ms), a copy of its timestamp carrying
    // another target (-0.1), another older one (-0.6 at t + 25 ms).
    let t = wall_ns();
    for (q, at_ms) in [(-0.3, 10), (-1.0, 30), (-0.6, 20), (-0.1, 30), (-0.6, 25)] {
        w.write_ts(dex3_cmd(q, 0), t + at_ms * MS).expect("write_ts");
    }
    let d = status_until(&mut status, &gw, |d| d.reordered_cmd + d.duplicate_cmd >= 3);
    assert_eq!(
        (d.reordered_cmd, d.duplicate_cmd, d.late_cmd, d.bad_input, d.foreign_cmd),
        (2, 1, 0, 0, 0),
        "{d:?}"
    );
    let worst = ends_at(&mut state, &gw, -1.0, 50);
    println!("index_0 within {worst:.4} rad of the newest target over 50 state samples after the drops");
    assert!(
        worst < TOL,
        "the hand left the newest target: {worst}\n{}",
        gw.transcript()
    );
    let logged = gw
        .transcript()
        .lines()
        .filter(|l| l.contains("dropped a command of"))
        .count();
    assert!(logged >= 1, "{}", gw.transcript());

    // The same counts in `handgate status --once`, in their own table.
    let mut args = vec![
        "status".to_string(),
        "--once".into(),
        "--domain".into(),
        domain.to_string(),
    ];
    if let Some(i) = interop_interface() {
        args.extend(["--interface".to_string(), i]);
    }
    let o = Command::new(handgate_bin())
        .args(&args)
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .output()
        .expect("handgate status runs");
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let row: Vec<&str> = out
        .lines()
        .skip_while(|l| !l.starts_with("commands dropped by source timestamp"))
        .find(|l| l.trim_start().starts_with("dex3_left "))
        .unwrap_or_else(|| panic!("no dropped-commands row for dex3_left:\n{out}"))
        .split_whitespace()
        .collect();
    assert_eq!(row, ["dex3_left", "1", "2", "0"], "{out}");

    // And in `/metrics`.
    let (code, text) = http_get(&gw.http_url().expect("the dashboard's url"), "/metrics");
    assert_eq!(code, 200, "{text}");
    let m = device_metrics(&text);
    let get = |name: &str| m.get(&(name.to_string(), "dex3_left".to_string())).copied();
    assert_eq!(
        (
            get("handgate_device_duplicate_cmd_total"),
            get("handgate_device_reordered_cmd_total"),
            get("handgate_device_late_cmd_total")
        ),
        (Some(1.0), Some(2.0), Some(0.0)),
        "{text}"
    );
}

#[test]
fn with_max_command_age_a_stale_command_is_dropped_as_late_and_a_clock_ahead_is_named_once() {
    let _serial = serial();
    let domain = 167;
    // `shared`: the second writer is taken at once, not after the first's hold time.
    let profile = default_profile_edited(
        "command-order-late",
        &[(
            DEX3_LEFT_FRONT,
            &format!("{DEX3_LEFT_FRONT}\nmax_command_age_ms = 500\ncontrol = \"shared\""),
        )],
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let n = node(domain);
    let mut state = Latest::<unitree_hg::HandState_>::new(&n, "rt/dex3/left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });

    // Stamped 2 s ago: late. Then a fresh one: taken.
    let mut w = client(&n);
    w.write_ts(dex3_cmd(-0.2, 0), wall_ns() - 2000 * MS).expect("write_ts");
    w.write_ts(dex3_cmd(-0.8, 0), wall_ns()).expect("write_ts");
    let d = status_until(&mut status, &gw, |d| d.late_cmd >= 1);
    assert_eq!((d.late_cmd, d.reordered_cmd, d.duplicate_cmd), (1, 0, 0), "{d:?}");
    let worst = ends_at(&mut state, &gw, -0.8, 20);
    assert!(worst < TOL, "{worst}\n{}", gw.transcript());
    let late = gw
        .transcript()
        .lines()
        .filter(|l| l.contains("dropped a command of") && l.contains("old on arrival"))
        .count();
    assert_eq!(late, 1, "{}", gw.transcript());

    // A second writer whose clock runs 1 s ahead: named once, its commands taken.
    let mut ahead = client(&n);
    ahead
        .write_ts(dex3_cmd(-0.4, 0), wall_ns() + 1000 * MS)
        .expect("write_ts");
    ahead
        .write_ts(dex3_cmd(-0.5, 0), wall_ns() + 1010 * MS)
        .expect("write_ts");
    let worst = ends_at(&mut state, &gw, -0.5, 20);
    assert!(worst < TOL, "{worst}\n{}", gw.transcript());
    let named: Vec<String> = gw
        .transcript()
        .lines()
        .filter(|l| l.contains("ahead of this host's"))
        .map(str::to_string)
        .collect();
    assert_eq!(named.len(), 1, "{named:?}\n{}", gw.transcript());
    // A status sample published after its commands were taken.
    status.update();
    let s = status.next(DEADLINE).expect("a status sample");
    let d = status_device(&s, "dex3_left");
    assert_eq!(
        (d.late_cmd, d.reordered_cmd, d.duplicate_cmd),
        (1, 0, 0),
        "nothing of the writer ahead dropped: {d:?}"
    );
}
