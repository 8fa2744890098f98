//! Loader and validation tests: bad profiles, layering, shipped profiles.

// figment::Jail's closures return figment's (large) error type.
#![allow(clippy::result_large_err)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use super::*;

/// Writes `text` to a fresh file under the system temp dir and returns its path.
fn temp_profile(text: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!("handgate-profile-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("p{}.toml", N.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&p, text).unwrap();
    p
}

fn opts(profile: Option<String>) -> LoadOptions {
    LoadOptions {
        profile,
        overrides: CliOverrides::default(),
        env: EnvLayer::Ignore,
        search_dirs: Some(vec![]),
    }
}

fn load_text(text: &str) -> (PathBuf, Result<Loaded, ProfileError>) {
    let p = temp_profile(text);
    let r = load(&opts(Some(p.display().to_string())));
    (p, r)
}

fn repo_profiles_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../profiles")
}

const DEX3: &str = r#"
[[devices]]
name = "l"
kind = "dex3"
side = "left"
backend = "emulator"
"#;

/// (case, profile text, expected key path, expected message fragment). Each must give
/// exactly one line `<file>: <key>: <message>`.
const BAD: &[(&str, &str, &str, &str)] = &[
    ("unknown key", "[dds]\ndomian = 3\n", "dds.domian", "unknown key"),
    ("unknown top-level key", "devcies = []\n", "devcies", "unknown key"),
    (
        "unknown key in an array element",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\nwatchdg = { timeout_ms = 100 }\n",
        "devices[0].watchdg",
        "unknown key",
    ),
    ("wrong type", "[dds]\ndomain = \"three\"\n", "dds.domain", "invalid type"),
    (
        "namespace token starting with a digit",
        "[dds]\nnamespace = \"fleet/1robot\"\n",
        "dds.namespace",
        "`fleet/1robot` is not a ROS namespace: it token `1robot` starts with a digit",
    ),
    (
        "namespace with a dash",
        "[dds]\nnamespace = \"robot-1\"\n",
        "dds.namespace",
        "is not a ROS namespace",
    ),
    ("empty namespace", "[dds]\nnamespace = \"/\"\n", "dds.namespace", "is empty"),
    (
        "wrong type deep",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\nwatchdog = { timeout_ms = \"soon\" }\n",
        "devices[0].watchdog.timeout_ms",
        "invalid type",
    ),
    (
        "unknown enum value",
        "[[devices]]\nname = \"l\"\nkind = \"dex9\"\nside = \"left\"\nbackend = \"emulator\"\n",
        "devices[0].kind",
        "dex9",
    ),
    (
        "missing required key",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\n",
        "devices[0].backend",
        "missing",
    ),
    ("domain too high", "[dds]\ndomain = 233\n", "dds.domain", "between 0 and 232"),
    (
        "unknown foreign writer policy",
        "[dds]\nforeign_state_writers = \"ignore\"\n",
        "dds.foreign_state_writers",
        "unknown variant: found `ignore`, expected ``refuse` or `warn``",
    ),
    (
        "discovery wait too long",
        "[dds]\ndiscovery_max_wait_ms = 60000\n",
        "dds.discovery_max_wait_ms",
        "at most 10000 ms",
    ),
    (
        "discovery settle longer than the wait",
        "[dds]\ndiscovery_settle_ms = 800\n",
        "dds.discovery_settle_ms",
        "at most dds.discovery_max_wait_ms (500 ms)",
    ),
    (
        "emulator noise on a kind that publishes no state",
        "[[devices]]\nname = \"s\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"emulator\"\n[devices.emulator]\nposition_noise_rad = 0.001\n",
        "devices[0].emulator.position_noise_rad",
        "has no effect on a hand_sdk: its emulator (the ai_sport blend) publishes no state",
    ),
    (
        "unknown device in a front",
        "[[fronts]]\nkind = \"canonical\"\ndevice = \"nope\"\n",
        "fronts[0].device",
        "no device named `nope`",
    ),
    (
        "front without device",
        "[[fronts]]\nkind = \"dex3\"\n",
        "fronts[0].device",
        "must name its device",
    ),
    (
        "duplicate device names",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\n",
        "devices[1].name",
        "duplicate device name `g`",
    ),
    (
        "bad device name",
        "[[devices]]\nname = \"Left Hand\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n",
        "devices[0].name",
        "not a device name",
    ),
    (
        "limits min >= max",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.limits.joints]\nthumb_0 = { min = 0.5, max = 0.2 }\n",
        "devices[0].limits.joints.thumb_0",
        "must be below max",
    ),
    (
        "limit outside the hardware range",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.limits.joints]\nindex_0 = { max = 1.9 }\n",
        "devices[0].limits.joints.index_0.max",
        "outside the left dex3 hardware range",
    ),
    (
        "unknown joint for the kind",
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.limits.joints]\njaw = { max = 1.0 }\n",
        "devices[0].limits.joints.jaw",
        "unknown joint `jaw` for a dex3",
    ),
    (
        "gripper joint name",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\ninitial = { thumb_0 = 1.0 }\n",
        "devices[0].emulator.initial.thumb_0",
        "unknown joint",
    ),
    (
        "negative max_step",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nlimits = { max_step = -0.1 }\n",
        "devices[0].limits.max_step",
        "above 0",
    ),
    (
        "rate zero",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nrate_hz = 0\n",
        "devices[0].rate_hz",
        "at most 2000",
    ),
    (
        "rate too high",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nrate_hz = 2001\n",
        "devices[0].rate_hz",
        "at most 2000",
    ),
    (
        "max_send_hz below the loop rate",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nrate_hz = 500\nmax_send_hz = 400\n",
        "devices[0].max_send_hz",
        "below the device's loop rate",
    ),
    (
        "forward_on_arrival not a bool",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nforward_on_arrival = \"yes\"\n",
        "devices[0].forward_on_arrival",
        "bool",
    ),
    (
        "watchdog too short",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\nwatchdog = { timeout_ms = 5 }\n",
        "devices[0].watchdog.timeout_ms",
        "between 10 and 10000",
    ),
    (
        "backend not valid for kind",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"usb\"\n",
        "devices[0].backend",
        "a dex1 cannot use backend usb (valid: dds, emulator)",
    ),
    (
        "ezgripper on dds",
        "[[devices]]\nname = \"g\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"dds\"\n",
        "devices[0].backend",
        "valid: serial, emulator",
    ),
    (
        "dex3 center",
        "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"center\"\nbackend = \"emulator\"\n",
        "devices[0].side",
        "not center",
    ),
    (
        "section for another kind",
        "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.ezgripper]\nport = \"/dev/ttyUSB0\"\n",
        "devices[0].ezgripper",
        "applies to an ezgripper",
    ),
    (
        "dds option for another kind",
        "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"dds\"\n[devices.dds]\nvariant = \"go\"\n",
        "devices[0].dds.variant",
        "only a dex1",
    ),
    (
        "duplicate command topics",
        "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"h\"\ncmd_topic = \"rt/dex3/left/cmd\"\n",
        "fronts[1].cmd_topic",
        "already served by fronts[0]",
    ),
    (
        "front serving the resident service's topics",
        "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"dds\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\n",
        "fronts[0]",
        "uses to reach the real device",
    ),
    (
        "actuator front on a center device",
        "[[devices]]\nname = \"g\"\nkind = \"ezgripper\"\nside = \"center\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nvariant = \"actuator\"\n",
        "fronts[0].side",
        "element 0 = right, 1 = left",
    ),
    (
        "two actuator fronts for the same side",
        "[[devices]]\nname = \"a\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"b\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"a\"\nvariant = \"actuator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"b\"\nvariant = \"actuator\"\n",
        "fronts[1].cmd_topic",
        "rt/unitree_actuator/cmd",
    ),
    (
        "devices on a non-actuator front",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevices = { left = \"g\" }\n",
        "fronts[0].devices",
        "only an actuator dex1 front",
    ),
    (
        "actuator element bound to a missing device",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\nvariant = \"actuator\"\ndevices = { left = \"g\", right = \"nope\" }\n",
        "fronts[0].devices.right",
        "no device named `nope`",
    ),
    (
        "unknown silence",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nsilence = \"never\"\n",
        "fronts[0].silence",
        "never",
    ),
    (
        "unknown control",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\ncontrol = \"latest\"\n",
        "fronts[0].control",
        "latest",
    ),
    (
        "control on a front that takes no commands",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\ncontrol = \"shared\"\n",
        "fronts[0].control",
        "takes no commands",
    ),
    (
        "watchdog_ms without the watchdog",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nwatchdog_ms = 100\n",
        "fronts[0].watchdog_ms",
        "silence = \"watchdog\"",
    ),
    (
        "an emulator fault that is none",
        "[[devices]]\nname = \"g\"\nkind = \"brainco\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\nfault = \"slow\"\n",
        "devices[0].emulator.fault",
        "stuck=<joint>, frozen or ignore-commands",
    ),
    (
        "an emulator fault on a joint the kind does not have",
        "[[devices]]\nname = \"g\"\nkind = \"brainco\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\nfault = \"stuck=index_0\"\n",
        "devices[0].emulator.fault",
        "no such joint",
    ),
    (
        "a fault on an emulator that cannot inject it (every emulator that injects one takes all three forms)",
        "[[devices]]\nname = \"g\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"emulator\"\n[devices.emulator]\nfault = \"frozen\"\n",
        "devices[0].emulator.fault",
        "has no effect on a hand_sdk",
    ),
    (
        "motion tolerance of zero",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\ntolerance = 0.0\n",
        "devices[0].motion.tolerance",
        "above 0 and at most 1 rad",
    ),
    (
        "contact by effort without the effort",
        "[[devices]]\nname = \"g\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\ncontact = \"effort\"\n",
        "devices[0].motion.contact",
        "needs `contact_effort`",
    ),
    (
        "a contact effort that is no effort",
        "[[devices]]\nname = \"g\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\ncontact_effort = -1.0\n",
        "devices[0].motion.contact_effort",
        "must be above 0",
    ),
    (
        "a contact effort with contact the device reports",
        "[[devices]]\nname = \"g\"\nkind = \"inspire_ftp\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\ncontact = \"reported\"\ncontact_effort = 1.0\n",
        "devices[0].motion.contact_effort",
        "applies to contact = \"effort\"",
    ),
    (
        "motion hold too long to report within a second",
        "[[devices]]\nname = \"g\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\nhold_ms = 2000\n",
        "devices[0].motion.hold_ms",
        "between 50 and 900 ms",
    ),
    (
        "an unknown motion key",
        "[[devices]]\nname = \"g\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.motion]\nholdms = 200\n",
        "devices[0].motion.holdms",
        "unknown",
    ),
    (
        "max_command_age_ms of zero",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nmax_command_age_ms = 0\n",
        "fronts[0].max_command_age_ms",
        "between 1 and 60000",
    ),
    (
        "max_command_age_ms on a front that takes no commands",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\nmax_command_age_ms = 100\n",
        "fronts[0].max_command_age_ms",
        "takes no commands",
    ),
    (
        "two fronts with one name",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nname = \"grip\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"g\"\nname = \"grip\"\n",
        "fronts[1].name",
        "front name `grip` is also fronts[0]'s",
    ),
    (
        "dex1 front state too slow",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nstate_hz = 100\n",
        "fronts[0].state_hz",
        "200 Hz or faster",
    ),
    (
        "front option for another front kind",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"g\"\nvariant = \"hg\"\n",
        "fronts[0].variant",
        "only dex1 fronts",
    ),
    (
        "two ezgrippers, one servo id",
        "[[devices]]\nname = \"a\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"serial\"\nezgripper = { servo_id = 1 }\n[[devices]]\nname = \"b\"\nkind = \"ezgripper\"\nside = \"right\"\nbackend = \"serial\"\nezgripper = { servo_id = 1 }\n",
        "devices[1].ezgripper.servo_id",
        "servo id 1 on /dev/ttyUSB0 is also devices[0]",
    ),
    (
        "two usb hands of one side without serials",
        "[[devices]]\nname = \"a\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n[[devices]]\nname = \"b\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n",
        "devices[1].usb.serial",
        "give each hand its USB serial",
    ),
    (
        "usb wiring bus out of range",
        "[[devices]]\nname = \"a\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n[devices.usb.wiring.joints]\nthumb_0 = { bus = 5, id = 0 }\n",
        "devices[0].usb.wiring.joints.thumb_0.bus",
        "between 0 and 4",
    ),
    (
        "hand_sdk weight",
        "[[devices]]\nname = \"h\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"dds\"\nhand_sdk = { weight = 1.5 }\n",
        "devices[0].hand_sdk.weight",
        "between 0 and 1",
    ),
    (
        "two dds devices on one command topic",
        "[[devices]]\nname = \"a\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"dds\"\n[[devices]]\nname = \"b\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"dds\"\n",
        "devices[1].dds",
        "also sends commands on `rt/dex3/left/cmd`",
    ),
    (
        "two devices publishing one joint name on one JointState topic",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"e\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\n",
        "fronts[0].devices",
        "`g` and `e` would both publish `left_gripper_joint` on `rt/joint_states`",
    ),
    (
        "a device list on a front taking commands",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevices = [\"g\"]\n",
        "fronts[0].devices",
        "a list of devices is for fronts that publish state only",
    ),
    (
        "a joint_state device list naming a missing device",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\ndevices = [\"g\", \"nope\"]\n",
        "fronts[0].devices[1]",
        "no device named `nope`",
    ),
    (
        "a joint_state device list naming a device twice",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\ndevices = [\"g\", \"g\"]\n",
        "fronts[0].devices[1]",
        "listed twice",
    ),
    (
        "an empty joint_state device list",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\ndevices = []\n",
        "fronts[0].devices",
        "list at least one device",
    ),
    (
        "two devices with one joint name on one JointState command front",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"e\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\n",
        "fronts[0].devices",
        "`g` and `e` both have `left_gripper_joint`: a command on `rt/robot_joint_commands` naming it would be ambiguous",
    ),
    (
        "a state rate on a front that publishes no state",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\nstate_hz = 50\n",
        "fronts[0].state_hz",
        "a joint_state_command front publishes no state",
    ),
    (
        "a JointState command front bound by element",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\ndevices = { left = \"g\" }\n",
        "fronts[0].devices",
        "binds devices by element; use `device`, or list them",
    ),
    (
        "a JointState command front listing a torque-driven device (hand_sdk)",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"sdk\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\ndevices = [\"g\", \"sdk\"]\n",
        "fronts[0].devices[1]",
        "`sdk`: a joint_state_command front holds each joint it is given at that position with the device's position gains, and a hand_sdk has none (kp = kd = 0: its closure is a torque, N*m), so a position would move nothing; command it through a canonical front (closure, or joint targets with their own kp, kd and tau); leave it out of `devices`",
    ),
    (
        "a JointState command front on a torque-driven device (hand_sdk)",
        "[[devices]]\nname = \"sdk\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\ndevice = \"sdk\"\n",
        "fronts[0].device",
        "`sdk`: a joint_state_command front holds each joint it is given at that position with the device's position gains, and a hand_sdk has none",
    ),
    (
        "a JointState command front binding every device, a torque-driven one among them",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"sdk\"\nkind = \"hand_sdk\"\nside = \"center\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\n",
        "fronts[0]",
        "so a position would move nothing; command it through a canonical front (closure, or joint targets with their own kp, kd and tau); this front binds every device by default: list the others (`devices = [..]`)",
    ),
    (
        "a JointState command front listing a missing device",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state_command\"\ndevices = [\"g\", \"nope\"]\n",
        "fronts[0].devices[1]",
        "no device named `nope`",
    ),
    (
        "unknown front key",
        "[[fronts]]\nkind = \"canonical\"\ndevice = \"g\"\ncmd_topc = \"rt/x\"\n",
        "fronts[0].cmd_topc",
        "unknown key (expected one of: kind, name, device, devices, state_hz, silence, control, watchdog_ms, max_command_age_ms, cmd_topic, state_topic)",
    ),
    (
        "topic key of another front kind",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"joint_state\"\ncmd_topic = \"rt/x/cmd\"\n",
        "fronts[0].cmd_topic",
        "only dex3, dex1, inspire_dfx, brainco, inspire_ftp, dex5 and canonical fronts take `cmd_topic`, this is a joint_state front",
    ),
    (
        "front topic not a topic name",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"g\"\ntouch_topic = \"rt/a b\"\n",
        "fronts[0].touch_topic",
        "not a topic name",
    ),
    (
        "an object on a joint that closes nothing",
        "[[devices]]\nname = \"h\"\nkind = \"dex5\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\nobject_at = { index_0 = 0.1 }\n",
        "devices[0].emulator.object_at.index_0",
        "closes nothing",
    ),
    (
        "a start position for a joint without a motor",
        "[[devices]]\nname = \"h\"\nkind = \"dex5\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\ninitial = { ring_3 = 0.1 }\n",
        "devices[0].emulator.initial.ring_3",
        "set ring_2",
    ),
    (
        "a coupling out of range",
        "[[devices]]\nname = \"h\"\nkind = \"dex5\"\nside = \"left\"\nbackend = \"dds\"\n[devices.dex5]\ncoupling = 3.0\n",
        "devices[0].dex5.coupling",
        "at most 2",
    ),
    (
        "a dex5 convention with no such value",
        "[[devices]]\nname = \"h\"\nkind = \"dex5\"\nside = \"left\"\nbackend = \"dds\"\n[devices.dex5]\ngains = \"mine\"\n",
        "devices[0].dex5.gains",
        "xr_teleoperate",
    ),
    ("status rate", "[status]\nrate_hz = 50\n", "status.rate_hz", "at most 10 Hz"),
    (
        "export on the devices' domain through another interface",
        "[dds]\ndomain = 0\ninterface = \"eth0\"\n[export]\ninterface = \"eth1\"\n",
        "export.interface",
        "CycloneDDS holds one configuration per domain id in a process, so one domain cannot be on two interfaces",
    ),
    (
        "export naming the devices' domain through another interface",
        "[dds]\ndomain = 3\n[export]\ndomain = 3\ninterface = \"eth1\"\n",
        "export.domain",
        "puts the export side on domain 3 like the devices, on interface eth1 while the devices are on (any)",
    ),
    (
        "two namespaces",
        "[dds]\nnamespace = \"a\"\n[export]\ndomain = 2\nnamespace = \"b\"\n",
        "export.namespace",
        "and dds.namespace are both set",
    ),
    (
        "fronts in no namespace",
        "[export]\ndomain = 2\nnamespace_fronts = true\n",
        "export.namespace_fronts",
        "set export.namespace",
    ),
    ("export domain", "[export]\ndomain = 300\n", "export.domain", "must be between 0 and 232"),
    ("unknown export key", "[export]\ndomian = 3\n", "export.domian", "unknown key"),
    ("bad topic", "[status]\ntopic = \"rt/a b\"\n", "status.topic", "not a topic name"),
];

#[test]
fn every_bad_profile_gives_one_error_naming_file_and_key() {
    for (case, text, key, fragment) in BAD {
        let (path, r) = load_text(text);
        let err = match r {
            Ok(_) => panic!("{case}: profile was accepted"),
            Err(e) => e,
        };
        let lines = err.lines();
        assert_eq!(lines.len(), 1, "{case}: expected one error, got {lines:#?}");
        let prefix = format!("{}: {key}: ", path.display());
        assert!(
            lines[0].starts_with(&prefix),
            "{case}: `{}` does not start with `{prefix}`",
            lines[0]
        );
        assert!(
            lines[0].contains(fragment),
            "{case}: `{}` does not mention `{fragment}`",
            lines[0]
        );
    }
}

#[test]
fn toml_syntax_error_is_one_line_naming_the_file() {
    let (path, r) = load_text("[dds\ndomain = 1\n");
    let lines = r.unwrap_err().lines();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(
        lines[0].starts_with(&format!("{}: not valid TOML", path.display())),
        "{}",
        lines[0]
    );
    assert!(lines[0].contains("line 1"), "{}", lines[0]);
    assert!(!lines[0].contains('\n'));
}

#[test]
fn all_semantic_errors_are_collected() {
    let text = format!(
        "[dds]\ndomain = 500\n{DEX3}rate_hz = 0\nwatchdog = {{ timeout_ms = 1 }}\n[[fronts]]\nkind = \"dex3\"\ndevice = \"nobody\"\n"
    );
    let (path, r) = load_text(&text);
    let lines = r.unwrap_err().lines();
    let want = [
        "dds.domain",
        "devices[0].rate_hz",
        "devices[0].watchdog.timeout_ms",
        "fronts[0].device",
    ];
    assert_eq!(lines.len(), want.len(), "{lines:#?}");
    for (line, key) in lines.iter().zip(want) {
        assert!(line.starts_with(&format!("{}: {key}: ", path.display())), "{line}");
    }
}

#[test]
fn missing_file_is_an_error_naming_it() {
    let p = std::env::temp_dir().join("handgate-no-such-profile/absent.toml");
    let err = load(&opts(Some(p.display().to_string()))).unwrap_err();
    assert!(matches!(err, ProfileError::Unreadable { .. }), "{err:?}");
    let lines = err.lines();
    assert_eq!(lines.len(), 1);
    assert!(
        lines[0].starts_with(&format!("{}: cannot read profile", p.display())),
        "{}",
        lines[0]
    );
}

#[test]
fn unknown_profile_name_lists_the_available_ones() {
    let err = load(&opts(Some("no-such-robot".into()))).unwrap_err();
    let lines = err.lines();
    assert_eq!(lines.len(), 1);
    assert!(lines[0].contains("unknown profile `no-such-robot`"), "{}", lines[0]);
    for (name, _) in SHIPPED {
        assert!(lines[0].contains(name), "{} does not list {name}", lines[0]);
    }
}

#[test]
fn every_shipped_profile_validates_embedded_and_on_disk() {
    for (name, _) in SHIPPED {
        let l = load(&opts(Some((*name).to_string()))).unwrap_or_else(|e| panic!("embedded {name}: {e}"));
        assert_eq!(l.origin, Origin::Embedded((*name).to_string()));
        assert_eq!(l.profile.name, *name);
        assert!(!l.profile.description.is_empty(), "{name} has no description");
        assert!(!l.profile.devices.is_empty(), "{name} has no devices");
        assert!(!l.profile.fronts.is_empty(), "{name} has no fronts");
        let path = repo_profiles_dir().join(format!("{name}.toml"));
        let f = load(&opts(Some(path.display().to_string()))).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(f.profile, l.profile, "{name}: file and embedded copy differ");
    }
}

#[test]
fn every_file_in_profiles_is_shipped() {
    assert!(
        SHIPPED.iter().any(|(n, _)| *n == "default"),
        "the default profile is shipped"
    );
    for e in std::fs::read_dir(repo_profiles_dir()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            assert!(
                SHIPPED.iter().any(|(n, _)| *n == stem),
                "{} is not in profile::SHIPPED",
                p.display()
            );
        }
    }
}

#[test]
fn no_profile_means_the_embedded_default_simulated_fleet() {
    let l = load(&opts(None)).unwrap();
    assert_eq!(l.origin, Origin::Embedded("default".into()));
    assert_eq!(l.origin.to_string(), "embedded default");
    let p = &l.profile;
    assert_eq!(p.dds.domain, DomainId(1), "the simulated fleet must stay off domain 0");
    assert!(p.devices.iter().all(|d| d.backend == Backend::Emulator));
    let kinds: Vec<(DeviceKind, Side)> = p.devices.iter().map(|d| (d.kind, d.side)).collect();
    assert_eq!(
        kinds,
        [
            (DeviceKind::Dex3, Side::Left),
            (DeviceKind::Dex3, Side::Right),
            (DeviceKind::Dex1, Side::Left),
            (DeviceKind::Dex1, Side::Right)
        ]
    );
    let cmd_topics: Vec<String> = p
        .fronts
        .iter()
        .filter_map(|f| {
            let dev = f.device.as_ref().and_then(|n| p.devices.iter().find(|d| &d.name == n));
            f.topics(dev).cmd().map(|t| t.0.clone())
        })
        .collect();
    for t in [
        "rt/dex3/left/cmd",
        "rt/dex3/right/cmd",
        "rt/dex1/left/cmd",
        "rt/dex1/right/cmd",
        "rt/handgate/dex3_left/cmd",
        "rt/handgate/dex1_right/cmd",
    ] {
        assert!(cmd_topics.iter().any(|c| c == t), "default serves no {t}");
    }
    assert_eq!(p.fronts.iter().filter(|f| f.kind() == FrontKind::JointState).count(), 1);
}

#[test]
fn a_profile_file_replaces_the_default_fleet() {
    let (path, r) = load_text(&format!("{DEX3}[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n"));
    let l = r.unwrap();
    assert_eq!(l.profile.devices.len(), 1, "devices were merged with the default's");
    assert_eq!(l.profile.fronts.len(), 1);
    // Omitted keys take the struct defaults.
    assert_eq!(l.profile.dds, DdsConfig::default());
    assert_eq!(l.profile.status, StatusConfig::default());
    assert_eq!(l.profile.devices[0].watchdog, WatchdogConfig::default());
    assert_eq!(
        l.profile.name,
        path.file_stem().unwrap().to_string_lossy(),
        "an unnamed profile is named after its file"
    );
}

#[test]
fn cli_flags_override_the_file() {
    let p = temp_profile(&format!("[dds]\ndomain = 2\ninterface = \"eth0\"\n{DEX3}"));
    let l = load(&LoadOptions {
        overrides: CliOverrides {
            domain: Some(4),
            interface: None,
            log_format: Some(LogFormat::Json),
            http_port: Some(0),
            ..Default::default()
        },
        ..opts(Some(p.display().to_string()))
    })
    .unwrap();
    assert_eq!(l.profile.dds.domain, DomainId(4));
    assert_eq!(l.profile.http.port, 0);
    assert_eq!(l.profile.http.bind, "127.0.0.1", "untouched key kept");
    assert_eq!(l.profile.dds.interface.as_deref(), Some("eth0"), "untouched key kept");
    assert_eq!(l.profile.log.format, LogFormat::Json);
    assert_eq!(l.profile.devices.len(), 1);
}

#[test]
fn bad_cli_value_is_attributed_to_the_flag() {
    let err = load(&LoadOptions {
        overrides: CliOverrides {
            domain: Some(300),
            ..CliOverrides::default()
        },
        ..opts(None)
    })
    .unwrap_err();
    assert_eq!(
        err.lines(),
        ["command line (--domain): dds.domain: must be between 0 and 232, got 300"]
    );
}

#[test]
fn precedence_file_then_env_then_cli() {
    figment::Jail::expect_with(|jail| {
        let p = temp_profile(&format!("[dds]\ndomain = 2\n[log]\nlevel = \"warn\"\n{DEX3}"));
        let o = |cli: Option<u32>| LoadOptions {
            profile: Some(p.display().to_string()),
            overrides: CliOverrides {
                domain: cli,
                ..CliOverrides::default()
            },
            env: EnvLayer::Process,
            search_dirs: Some(vec![]),
        };
        assert_eq!(load(&o(None)).unwrap().profile.dds.domain, DomainId(2));
        jail.set_env("HANDGATE_DDS__DOMAIN", 3);
        jail.set_env("HANDGATE_DDS__INTERFACE", "lo");
        let l = load(&o(None)).unwrap();
        assert_eq!(l.profile.dds.domain, DomainId(3), "env beats file");
        assert_eq!(l.profile.dds.interface.as_deref(), Some("lo"));
        assert_eq!(l.profile.log.level, "warn", "file keys not in env are kept");
        assert_eq!(
            load(&o(Some(4))).unwrap().profile.dds.domain,
            DomainId(4),
            "CLI beats env"
        );
        // HANDGATE_PROFILE_DIR is the search path, not a profile key.
        jail.set_env("HANDGATE_PROFILE_DIR", "/nonexistent");
        assert!(load(&o(None)).is_ok());
        Ok(())
    });
}

#[test]
fn bad_env_vars_are_attributed_to_the_environment() {
    figment::Jail::expect_with(|jail| {
        let p = temp_profile(DEX3);
        let o = LoadOptions {
            profile: Some(p.display().to_string()),
            env: EnvLayer::Process,
            search_dirs: Some(vec![]),
            ..LoadOptions::default()
        };
        jail.set_env("HANDGATE_DDS__DOMAIN", "three");
        assert_eq!(
            load(&o).unwrap_err().lines(),
            [r#"environment (HANDGATE_DDS__DOMAIN): dds.domain: invalid type: found string "three", expected u32"#]
        );
        jail.set_env("HANDGATE_DDS__DOMAIN", 999);
        assert_eq!(
            load(&o).unwrap_err().lines(),
            ["environment (HANDGATE_DDS__DOMAIN): dds.domain: must be between 0 and 232, got 999"]
        );
        jail.set_env("HANDGATE_DDS__DOMAIN", 5);
        jail.set_env("HANDGATE_DDS__DOMAN", 5);
        let lines = load(&o).unwrap_err().lines();
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(
            lines[0].starts_with("environment (HANDGATE_DDS__DOMAN): dds.doman: unknown key"),
            "{}",
            lines[0]
        );
        Ok(())
    });
}

#[test]
fn semantic_errors_name_the_layer_that_set_the_value() {
    figment::Jail::expect_with(|jail| {
        // The file sets a bad rate; the environment sets a fine domain: the rate error
        // names the file, not the environment.
        let p = temp_profile(&format!("[status]\nrate_hz = 99\n{DEX3}"));
        jail.set_env("HANDGATE_DDS__DOMAIN", 3);
        let lines = load(&LoadOptions {
            profile: Some(p.display().to_string()),
            env: EnvLayer::Process,
            search_dirs: Some(vec![]),
            ..LoadOptions::default()
        })
        .unwrap_err()
        .lines();
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(
            lines[0].starts_with(&format!("{}: status.rate_hz: ", p.display())),
            "{}",
            lines[0]
        );
        Ok(())
    });
}

#[test]
fn profile_names_resolve_in_search_dirs_then_shipped() {
    figment::Jail::expect_with(|jail| {
        // ./profiles in the working directory (the Jail's temp dir).
        jail.create_dir("profiles")?;
        jail.create_file("profiles/bench.toml", &format!("name = \"bench\"\n{DEX3}"))?;
        // A file shadows the shipped profile of the same name.
        jail.create_file(
            "profiles/g1-dex3.toml",
            &format!("description = \"local copy\"\n{DEX3}"),
        )?;
        let o = |name: &str| LoadOptions {
            profile: Some(name.into()),
            env: EnvLayer::Ignore,
            ..LoadOptions::default()
        };
        let l = load(&o("bench")).unwrap();
        assert_eq!(l.origin, Origin::File("profiles/bench.toml".into()));
        let l = load(&o("g1-dex3")).unwrap();
        assert_eq!(l.profile.description, "local copy");
        let l = load(&o("g1-ezgripper")).unwrap();
        assert_eq!(l.origin, Origin::Embedded("g1-ezgripper".into()));

        // $HANDGATE_PROFILE_DIR is searched before ./profiles.
        jail.create_dir("elsewhere")?;
        jail.create_file(
            "elsewhere/bench.toml",
            &format!("description = \"from the env dir\"\n{DEX3}"),
        )?;
        jail.set_env(PROFILE_DIR_ENV, "elsewhere");
        let l = load(&o("bench")).unwrap();
        assert_eq!(l.profile.description, "from the env dir");

        let names: Vec<String> = list_profiles(&default_search_dirs())
            .into_iter()
            .map(|p| p.name)
            .collect();
        for n in ["bench", "default", "g1-dex3", "mixed-lab"] {
            assert!(names.contains(&n.to_string()), "{names:?} lacks {n}");
        }
        assert_eq!(names.iter().filter(|n| *n == "g1-dex3").count(), 1);
        Ok(())
    });
}

#[test]
fn one_actuator_front_binds_both_grippers_by_element() {
    let two = "[[devices]]\nname = \"a\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"b\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\n";
    let (_, r) = load_text(&format!(
        "{two}[[fronts]]\nkind = \"dex1\"\nvariant = \"actuator\"\ndevices = {{ right = \"b\", left = \"a\" }}\n"
    ));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    let f = &plan.fronts[0];
    assert_eq!(f.cmd_topic(), Some("rt/unitree_actuator/cmd"));
    assert_eq!(f.state_topic(), "rt/unitree_actuator/state");
    assert_eq!(f.name, "dex1_actuator");
    let b: Vec<(&str, Side, usize)> = f
        .bindings
        .iter()
        .map(|b| (b.device.as_str(), b.side, b.element))
        .collect();
    assert_eq!(b, [("b", Side::Right, 0), ("a", Side::Left, 1)]);
    let text = render_fleet(&l.profile, &l.origin);
    assert!(text.contains("right=b, left=a"), "{text}");
    assert!(!text.contains("no device bound"), "{text}");

    // One side bound: `handgate check` says what the other element does.
    let (_, r) = load_text(&format!(
        "{two}[[fronts]]\nkind = \"dex1\"\nvariant = \"actuator\"\ndevices = {{ left = \"a\" }}\n"
    ));
    let l = r.unwrap();
    let text = render_fleet(&l.profile, &l.origin);
    assert!(
        text.contains("element 0 (right): no device bound; reported as never measured"),
        "{text}"
    );

    // Two actuator fronts (the old one-front-per-gripper shape) would publish the same state
    // topic: refused, naming the file and the key.
    let (path, r) = load_text(&format!(
        "{two}[[fronts]]\nkind = \"dex1\"\ndevice = \"a\"\nvariant = \"actuator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"b\"\nvariant = \"actuator\"\n"
    ));
    let lines = r.unwrap_err().lines();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(
        lines[0].starts_with(&format!("{}: fronts[1].cmd_topic: ", path.display())),
        "{lines:?}"
    );
    assert!(
        lines[0].contains("one actuator front serves both grippers"),
        "{lines:?}"
    );
}

/// A JointState command front binds every device by default, each on its own side in its own
/// table, or the devices it lists; its silence keeps the last target unless `watchdog` is set.
#[test]
fn a_joint_state_command_front_binds_a_list_of_devices_each_on_its_side() {
    let two = "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\n";
    let bound = |extra: &str| {
        let (_, r) = load_text(&format!("{two}[[fronts]]\nkind = \"joint_state_command\"\n{extra}"));
        let plan = crate::resolve::plan(&r.unwrap().profile).unwrap();
        let f = &plan.fronts[0];
        assert_eq!(f.cmd_topic(), Some("rt/robot_joint_commands"));
        f.bindings
            .iter()
            .map(|b| (b.device.clone(), b.side, b.table.is_none(), b.silence.after))
            .collect::<Vec<_>>()
    };
    let dog = Some((std::time::Duration::from_millis(200), SafeAction::Hold));
    assert_eq!(
        bound(""),
        [
            ("l".to_string(), Side::Left, true, None),
            ("g".to_string(), Side::Right, true, None)
        ]
    );
    assert_eq!(
        bound("devices = [\"g\"]\n"),
        [("g".to_string(), Side::Right, true, None)]
    );
    assert_eq!(bound("device = \"l\"\n"), [("l".to_string(), Side::Left, true, None)]);
    assert_eq!(
        bound("devices = [\"g\"]\nsilence = \"watchdog\"\n"),
        [("g".to_string(), Side::Right, true, dog)]
    );
    let (_, r) = load_text(&format!("{two}[[fronts]]\nkind = \"joint_state_command\"\n"));
    let l = r.unwrap();
    let text = render_fleet(&l.profile, &l.origin);
    let line = text
        .lines()
        .find(|l| l.contains("joint_state_command ->"))
        .unwrap_or_default();
    assert!(line.contains("-> all devices "), "{text}");
    assert!(
        line.contains(" cmd rt/robot_joint_commands, joints by URDF name, positions in rad, silence: service: keeps the last target"),
        "{text}"
    );
}

/// Devices whose joints share URDF names publish on JointState topics of their own (or under
/// `<device>/` names): the plan's fronts list exactly the devices each publishes.
#[test]
fn joint_state_fronts_split_devices_sharing_joint_names() {
    let two = "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"e\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"emulator\"\n";
    let (_, r) = load_text(&format!(
        "{two}[[fronts]]\nkind = \"joint_state\"\ndevices = [\"g\"]\n[[fronts]]\nkind = \"joint_state\"\ntopic = \"rt/grip/joint_states\"\ndevices = [\"e\"]\n"
    ));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    let fronts: Vec<(&str, Vec<String>)> = plan
        .fronts
        .iter()
        .map(|f| (f.state_topic(), f.devices.clone()))
        .collect();
    assert_eq!(
        fronts,
        [
            ("rt/joint_states", vec!["g".to_string()]),
            ("rt/grip/joint_states", vec!["e".to_string()])
        ]
    );
    assert!(render_fleet(&l.profile, &l.origin).contains("joint_state -> g "));
    // Names under the device's: no two devices can share one.
    let (_, r) = load_text(&format!(
        "{two}[[fronts]]\nkind = \"joint_state\"\nurdf_names = false\n"
    ));
    assert_eq!(
        crate::resolve::plan(&r.unwrap().profile).unwrap().fronts[0].devices,
        ["g", "e"]
    );
}

#[test]
fn devices_sharing_one_command_message_by_element_are_accepted_same_element_refused() {
    // The Dex1 actuator variant carries both grippers in one message (0 right, 1 left): a
    // left and a right device share `rt/unitree_actuator/cmd`, each writing its element.
    let dev = |name: &str, side: &str| {
        format!("[[devices]]\nname = \"{name}\"\nkind = \"dex1\"\nside = \"{side}\"\nbackend = \"dds\"\n[devices.dds]\nvariant = \"actuator\"\n")
    };
    let (_, r) = load_text(&format!("{}{}", dev("l", "left"), dev("r", "right")));
    r.unwrap();
    // Two on the same element would fight over it.
    let (path, r) = load_text(&format!("{}{}", dev("l", "left"), dev("l2", "left")));
    let lines = r.unwrap_err().lines();
    assert_eq!(
        lines,
        [format!(
            "{}: devices[1].dds: devices[0] also sends commands on `rt/unitree_actuator/cmd`: two devices would fight over one",
            path.display()
        )]
    );
}

#[test]
fn two_fronts_publishing_one_state_topic_are_refused() {
    let (path, r) = load_text(
        "[[devices]]\nname = \"a\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"a\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"a\"\ncmd_topic = \"rt/other/cmd\"\n",
    );
    let lines = r.unwrap_err().lines();
    let p = path.display();
    assert_eq!(
        lines,
        [
            format!("{p}: fronts[1].state_topic: state topic `rt/dex3/left/state` is already published by fronts[0]: two fronts would interleave their state on it"),
            format!("{p}: fronts[1].lf_state_topic: state topic `rt/lf/dex3/left/state` is already published by fronts[0]: two fronts would interleave their state on it"),
        ]
    );
}

#[test]
fn silence_defaults_to_the_served_service_and_watchdog_is_the_device_watchdog() {
    use crate::plan::SilencePlan;
    use handgate_adapters::model::SafeAction;
    let text = "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\nwatchdog = { timeout_ms = 300, safe_action = \"limp\" }\n[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"h\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\nname = \"strict\"\nsilence = \"watchdog\"\ncmd_topic = \"rt/x/cmd\"\nstate_topic = \"rt/x/state\"\nlf_state_topic = \"rt/x/lf\"\n";
    let (_, r) = load_text(text);
    let plan = crate::resolve::plan(&r.unwrap().profile).unwrap();
    let s: Vec<SilencePlan> = plan.fronts.iter().map(|f| f.bindings[0].silence).collect();
    let ms = std::time::Duration::from_millis;
    // Dex3 service: keeps the last target; with the RIS timeout bit, limp after 1 s.
    assert_eq!(s[0].armed(false), None);
    assert_eq!(s[0].armed(true), Some((ms(1000), SafeAction::Limp)));
    // Dex1 service: brakes (hold) 1 s after the last command.
    assert_eq!(s[1].armed(false), Some((ms(1000), SafeAction::Hold)));
    // Canonical: the device's watchdog.
    assert_eq!(s[2].armed(false), Some((ms(300), SafeAction::Limp)));
    // silence = "watchdog": the device's watchdog; the timeout bit cannot lengthen it.
    assert_eq!(s[3].armed(false), Some((ms(300), SafeAction::Limp)));
    assert_eq!(s[3].armed(true), Some((ms(300), SafeAction::Limp)));
    assert_eq!(plan.fronts[3].name, "strict");
    assert_eq!(plan.fronts[0].name, "dex3_left");
    assert_eq!(plan.fronts[2].name, "canonical_h");
}

#[test]
fn the_hold_of_an_exclusive_front_is_when_its_silence_acts_or_the_watchdog_time() {
    use handgate_adapters::front::config::Control;
    let text = "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\nwatchdog = { timeout_ms = 300, safe_action = \"limp\" }\n[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"r\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\nwatchdog = { timeout_ms = 700, safe_action = \"hold\" }\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\ncontrol = \"shared\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"h\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"h\"\nname = \"strict\"\nsilence = \"watchdog\"\nwatchdog_ms = 50\ncmd_topic = \"rt/x/cmd\"\nstate_topic = \"rt/x/state\"\nlf_state_topic = \"rt/x/lf\"\n[[fronts]]\nkind = \"dex1\"\nvariant = \"actuator\"\ndevices = { left = \"g\", right = \"r\" }\nsilence = \"watchdog\"\n";
    let (_, r) = load_text(text);
    let plan = crate::resolve::plan(&r.unwrap().profile).unwrap();
    let ms = std::time::Duration::from_millis;
    let holds: Vec<_> = plan.fronts.iter().map(|f| f.hold()).collect();
    // Dex3 service keeps the last target: the device's watchdog time. Dex1 service brakes
    // after 1 s: that. Canonical: the device's watchdog. A front's own shorter watchdog_ms.
    // Two devices with silence = "watchdog": the longer of their watchdogs (200, 700).
    assert_eq!(holds, [ms(300), ms(1000), ms(300), ms(50), ms(700)]);
    let controls: Vec<_> = plan.fronts.iter().map(|f| f.config.control).collect();
    assert_eq!(
        controls,
        [
            Control::Exclusive,
            Control::Shared,
            Control::Exclusive,
            Control::Exclusive,
            Control::Exclusive
        ]
    );
}

#[test]
fn usb_socket_points_the_device_at_the_emulator_process() {
    // Regression: `usb.socket` was validated but ignored, so the device looked for USB hardware.
    let text = "[[devices]]\nname = \"h\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n[devices.usb]\nsocket = \"/tmp/h.sock\"\n";
    let (_, r) = load_text(text);
    let plan = crate::resolve::plan(&r.unwrap().profile).unwrap();
    let d = &plan.devices[0];
    let profile = d.config.get::<handgate_adapters::dex3::config::Dex3Profile>().unwrap();
    match handgate_adapters::dex3::open::usb_source(&d.spec(), profile) {
        handgate_adapters::dex3::usb::adapter::UsbSource::Socket(p) => assert_eq!(p, Path::new("/tmp/h.sock")),
        _ => panic!("usb.socket must select the socket transport"),
    }
}

#[test]
fn any_front_kind_binds_any_device_kind() {
    // The migration shim: a dex1 front driving an EZGripper, a dex3 front on a Dex1.
    let text = "[[devices]]\nname = \"g\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"d\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"d\"\n";
    let (_, r) = load_text(text);
    r.unwrap();
}

#[test]
fn front_defaults_follow_kind_side_and_device_rate() {
    use handgate_adapters::dex3::serve::{Dex3Front, Dex3FrontConfig};
    use handgate_adapters::front::kind::FrontOwn;
    let mut d = DeviceConfig {
        rate_hz: Some(RateHz(300.0)),
        ..DeviceConfig::default()
    };
    let f = FrontConfig {
        device: Some(d.name.clone()),
        ..FrontConfig::new(FrontKind::Dex3)
    };
    let t = f.topics(Some(&d));
    assert_eq!(t.cmd(), Some(&Topic::new("rt/dex3/left/cmd")));
    assert_eq!(t.state(), Some(&Topic::new("rt/dex3/left/state")));
    assert_eq!(t.lf_state(), Some(&Topic::new("rt/lf/dex3/left/state")));
    assert_eq!(
        t.state_hz,
        RateHz(300.0),
        "dex3 state rate is capped by the device rate"
    );
    assert_eq!(t.lf_state_hz, Some(RateHz(50.0)));
    d.rate_hz = None;
    assert_eq!(f.topics(Some(&d)).state_hz, RateHz(500.0));
    let right = FrontConfig {
        own: FrontOwn::new::<Dex3Front>(Dex3FrontConfig {
            side: Some(Side::Right),
            ..Default::default()
        }),
        ..f.clone()
    };
    assert_eq!(right.topics(Some(&d)).cmd(), Some(&Topic::new("rt/dex3/right/cmd")));

    let js = FrontConfig::new(FrontKind::JointState);
    let t = js.topics(None);
    assert_eq!((t.cmd(), t.state()), (None, Some(&Topic::new("rt/joint_states"))));
}

/// A front's table as it serializes reads back as the same front: its common keys and its
/// kind's own, in one flat table.
#[test]
fn a_front_table_round_trips_through_its_kinds_keys() {
    let (_, r) = load_text(&format!(
        "{DEX3}[[fronts]]\nkind = \"dex3\"\ndevice = \"l\"\nname = \"x\"\nside = \"right\"\nlf_state_hz = 20\nsilence = \"watchdog\"\nstate_hz = 100\n"
    ));
    let f = r.unwrap().profile.fronts[0].clone();
    let v = f.to_value().unwrap();
    let keys: Vec<String> = v
        .deserialize::<std::collections::BTreeMap<String, figment::value::Value>>()
        .unwrap()
        .into_keys()
        .collect();
    assert_eq!(
        keys,
        [
            "control",
            "device",
            "kind",
            "lf_state_hz",
            "name",
            "side",
            "silence",
            "state_hz"
        ]
    );
    assert_eq!(FrontConfig::from_value(&v).unwrap(), f);
    assert_eq!(f.side(), Some(Side::Right));
    assert_eq!(f.lf_state_hz(), Some(20.0));
}

#[test]
fn device_rate_defaults_per_kind() {
    let rate = |kind, backend| {
        DeviceConfig {
            kind,
            backend,
            ..DeviceConfig::default()
        }
        .rate()
    };
    assert_eq!(rate(DeviceKind::Dex3, Backend::Usb), DeviceRate::Hz(RateHz(1000.0)));
    assert_eq!(rate(DeviceKind::Dex1, Backend::Dds), DeviceRate::Hz(RateHz(500.0)));
    assert_eq!(rate(DeviceKind::Ezgripper, Backend::Serial), DeviceRate::AsFastAsBus);
    assert_eq!(rate(DeviceKind::HandSdk, Backend::Dds), DeviceRate::Hz(RateHz(200.0)));
}

#[test]
fn dds_device_topics_follow_variant_and_state_source() {
    // The kinds' own keys, as a profile sets them.
    let device = |text: &str| load_text(text).1.unwrap().profile.devices[0].clone();
    let d = device("[[devices]]\nname = \"d\"\nkind = \"dex3\"\nside = \"right\"\nbackend = \"dds\"\n[devices.dds]\nstate_source = \"lf\"\n");
    assert_eq!(
        d.dds_topics(),
        Some((
            Some(Topic::new("rt/dex3/right/cmd")),
            Some(Topic::new("rt/lf/dex3/right/state"))
        ))
    );
    let mut d = device("[[devices]]\nname = \"d\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"dds\"\n[devices.dds]\nvariant = \"actuator\"\n");
    assert_eq!(d.dds_topics().unwrap().0, Some(Topic::new("rt/unitree_actuator/cmd")));
    let dex1 = d.config.get::<handgate_adapters::dex1::config::Dex1Profile>().unwrap();
    assert_eq!(Radians(dex1.range_rad()), Radians(5.4));
    d.backend = Backend::Emulator;
    assert_eq!(d.dds_topics(), None);
}

#[test]
fn default_structs_validate() {
    let p = Profile {
        devices: vec![DeviceConfig::default()],
        fronts: vec![FrontConfig {
            device: Some(DeviceConfig::default().name),
            ..FrontConfig::default()
        }],
        ..Profile::default()
    };
    assert_eq!(validate(&p), vec![]);
}

#[test]
fn the_example_in_the_docs_validates() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/profiles.md")).unwrap();
    let example = doc
        .split("## Example")
        .nth(1)
        .and_then(|s| s.split("```toml\n").nth(1))
        .and_then(|s| s.split("```").next())
        .expect("docs/profiles.md has an Example section with a toml block");
    let (_, r) = load_text(example);
    let l = r.unwrap_or_else(|e| panic!("docs example: {e}"));
    assert_eq!(l.profile.name, "bench-2");
    assert_eq!(l.profile.devices.len(), 2);
}

#[test]
fn fronts_on_missing_devices_report_only_the_missing_devices() {
    // Without a device their default topics would coincide; that is not reported twice.
    let (path, r) = load_text(
        "[[fronts]]\nkind = \"canonical\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"x\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"y\"\n",
    );
    let lines = r.unwrap_err().lines();
    let p = path.display();
    assert_eq!(
        lines,
        [
            format!("{p}: fronts[0].device: a canonical front must name its device"),
            format!("{p}: fronts[1].device: no device named `x` (devices: none)"),
            format!("{p}: fronts[2].device: no device named `y` (devices: none)"),
        ]
    );
}

#[test]
fn emulator_noise_keys_are_validated_and_default_on() {
    let dev =
        "[[devices]]\nname = \"l\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"emulator\"\n[devices.emulator]\n";
    for (keys, key, fragment) in [
        (
            "position_noise_rad = -0.001\n",
            "devices[0].emulator.position_noise_rad",
            "between 0 and",
        ),
        (
            "velocity_noise_rad_s = 100.0\n",
            "devices[0].emulator.velocity_noise_rad_s",
            "between 0 and",
        ),
        (
            "torque_noise_nm = nan\n",
            "devices[0].emulator.torque_noise_nm",
            "between 0 and",
        ),
        ("noise = false\nseed = 3\n", "devices[0].emulator.noise", "no effect"),
    ] {
        let (_, r) = load_text(&format!("{dev}{keys}"));
        let e = r.expect_err(keys).to_string();
        assert!(e.contains(key) && e.contains(fragment), "{keys}: {e}");
    }
    let kind_default = handgate_adapters::dex3::physical::HG_MOTOR_NOISE;
    // Default: on, the kind's figures, seeded per device.
    let (_, r) = load_text(DEX3);
    let p = r.unwrap().profile;
    let e = p.devices[0].emulator.clone().unwrap_or_default();
    let n = e.noise_for("l", kind_default);
    assert_eq!((n.q, n.dq, n.tau), (kind_default.q, kind_default.dq, kind_default.tau));
    assert_eq!(n, e.noise_for("l", kind_default), "deterministic");
    assert_ne!(
        n.seed,
        e.noise_for("r", kind_default).seed,
        "devices get their own stream"
    );
    // Off, and overrides.
    let (_, r) = load_text(&format!("{dev}noise = false\n"));
    let e = r.unwrap().profile.devices[0].emulator.clone().unwrap();
    assert!(e.noise_for("l", kind_default).is_off());
    let (_, r) = load_text(&format!("{dev}seed = 7\nposition_noise_rad = 0.001\n"));
    let e = r.unwrap().profile.devices[0].emulator.clone().unwrap();
    let n = e.noise_for("l", kind_default);
    assert_eq!((n.q, n.dq), (0.001, kind_default.dq));
    assert_ne!(n.seed, EmulatorConfig::default().noise_for("l", kind_default).seed);
}

/// The hardware range a profile's Dex3 limits are checked against (the kind's, through the
/// registry).
fn joint_range(kind: DeviceKind, side: Side, joint: &str) -> Option<(f64, f64)> {
    kind.factory().hardware_range(side, joint)
}

/// Where a Dex3 joint is at closure 1 when the profile's `closure.closed` does not say: the
/// kind's table's closed posture.
fn dex3_closed_default(joint: &str) -> Option<f64> {
    let id = DeviceKind::Dex3.joint(joint)?;
    let t = DeviceKind::Dex3
        .table(Side::Left, &handgate_adapters::mapping::TableOverrides::default())
        .ok()?;
    match t.closure {
        handgate_adapters::mapping::ClosureMap::Postures { closed, .. } => closed.get(id.index()).map(|v| *v as f64),
        _ => None,
    }
}

#[test]
fn dex3_ranges_are_canonical_and_equal_on_both_hands() {
    for j in DeviceKind::Dex3.joint_names() {
        let l = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
        let r = joint_range(DeviceKind::Dex3, Side::Right, j).unwrap();
        assert_eq!(l, r, "{j}");
        assert!(l.0 < l.1, "{j}");
    }
    // Fingers close positive in the canonical frame.
    let (lo, hi) = joint_range(DeviceKind::Dex3, Side::Right, "index_1").unwrap();
    assert!(lo.abs() < 1e-9 && (hi - 1.7453).abs() < 1e-6);
    assert_eq!(joint_range(DeviceKind::Dex3, Side::Center, "index_1"), None);
    assert_eq!(joint_range(DeviceKind::Dex3, Side::Left, "jaw"), None);
}

#[test]
fn closed_default_is_inside_the_range() {
    for j in DeviceKind::Dex3.joint_names() {
        let c = dex3_closed_default(j).unwrap();
        let (lo, hi) = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
        assert!(lo <= c && c <= hi, "{j}");
    }
    assert!(dex3_closed_default("index_0").unwrap() > 0.0);
}

/// The key column of every table of docs/profiles.md under `[[devices]]` and `[[fronts]]`,
/// as `devices.usb.timeout_bit`, `fronts.variant`, `devices.limits.joints.NAME` (rows that
/// only name sub-tables are left out: their keys have rows of their own).
fn documented_device_and_front_keys() -> Vec<String> {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/profiles.md")).unwrap();
    let mut out = Vec::new();
    let mut section: Option<String> = None;
    for line in doc.lines() {
        if line.starts_with('#') {
            section = match line.split('`').nth(1) {
                Some("[[devices]]") => Some("devices".into()),
                Some("[[fronts]]") => Some("fronts".into()),
                Some(s) if s.starts_with("[devices.") => Some(s.trim_matches(['[', ']']).to_string()),
                _ => None,
            };
            continue;
        }
        let Some(sec) = &section else { continue };
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 || !cells[1].starts_with('`') || cells[1].contains(',') {
            continue;
        }
        if (cells[2] == "table" || cells[2] == "tables") && !cells[1].contains('.') {
            continue;
        }
        out.push(format!("{sec}.{}", cells[1].trim_matches('`')));
    }
    out
}

/// One device named `d` of `kind` (its table ends the text, so `extra` may open sub-tables).
fn one_device(kind: &str, side: &str, backend: &str, extra: &str) -> String {
    format!("[[devices]]\nname = \"d\"\nkind = \"{kind}\"\nside = \"{side}\"\nbackend = \"{backend}\"\n{extra}\n")
}

/// What the fleet of `text` is built with: each device's plan and what its kind opens it
/// with (`KindFactory::configured`), and each front's plan.
fn built(text: &str) -> String {
    let (path, r) = load_text(text);
    let l = r.unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()));
    let plan = crate::resolve::plan(&l.profile).unwrap_or_else(|e| panic!("{e:?}"));
    let mut out = String::new();
    for d in &plan.devices {
        // Not the parsed keys themselves (`config`, `emulator`): what is built from them.
        let opened = d
            .kind
            .factory()
            .configured(&d.spec())
            .unwrap_or_else(|e| panic!("{e}\n{text}"));
        out.push_str(&format!(
            "{} {} {} {} {:?} {} {:?} {}\n{opened:?}\n",
            d.name, d.kind, d.side, d.backend, d.table, d.rate_hz, d.stale_after, d.safe_action
        ));
    }
    for f in &plan.fronts {
        out.push_str(&format!("{f:?}\n"));
    }
    out
}

/// Every documented `[devices.emulator]` key, on every kind's emulated device: either it
/// changes what the device is built with (its emulator's settings), or the kind refuses it
/// with one error naming the file and the key. A kind that accepts a key and ignores it
/// fails here; so does a documented emulator key without a sample value below.
#[test]
fn every_emulator_key_changes_each_kind_or_is_refused() {
    let documented: Vec<String> = documented_device_and_front_keys()
        .into_iter()
        .filter_map(|k| k.strip_prefix("devices.emulator.").map(str::to_string))
        .collect();
    assert!(documented.len() >= 7, "{documented:?}");
    // (kind, the keys it refuses): the rest must change what is built.
    let refused: &[(&str, &[&str])] = &[
        (
            "hand_sdk",
            &[
                "initial",
                "object_at",
                "noise",
                "seed",
                "position_noise_rad",
                "velocity_noise_rad_s",
                "torque_noise_nm",
                "fault",
            ],
        ),
        // DFX_inspire_service reports only q (docs/sources.md §7).
        ("inspire_dfx", &["velocity_noise_rad_s", "torque_noise_nm"]),
        // Inspire's driver reports no velocity and no torque in N·m.
        ("inspire_ftp", &["velocity_noise_rad_s", "torque_noise_nm"]),
        // A Robotiq reports a position byte and a current byte; its emulator injects no fault.
        ("robotiq", &["velocity_noise_rad_s", "torque_noise_nm", "fault"]),
        // The emulated RH56's registers carry no noise, and it injects no fault.
        (
            "inspire_rh56",
            &[
                "noise",
                "seed",
                "position_noise_rad",
                "velocity_noise_rad_s",
                "torque_noise_nm",
                "fault",
            ],
        ),
        // The emulated LEAP Hand injects no fault (docs/leap.md, "What is emulated").
        ("leap", &["fault"]),
        // The ROHand's emulated registers carry no noise.
        (
            "rohand",
            &[
                "noise",
                "seed",
                "position_noise_rad",
                "velocity_noise_rad_s",
                "torque_noise_nm",
                "fault",
            ],
        ),
    ];
    for kind in DeviceKind::all() {
        let f = kind.factory();
        if !f.backends().contains(&handgate_adapters::device::Backend::Emulator) {
            continue;
        }
        let side = [Side::Left, Side::Right, Side::Center]
            .into_iter()
            .find(|s| f.check_side(*s).is_ok())
            .unwrap();
        // A Dex5's first joint is a spread, which closes nothing: no object can stop it (its
        // emulator refuses one there), so its keys go on a flex joint.
        let joint = match kind.as_str() {
            "dex5" => "index_1",
            _ => kind.joint_names()[0],
        };
        let (lo, hi) = f.hardware_range(side, joint).unwrap();
        let at = |frac: f64| lo + frac * (hi - lo);
        let device = |extra: &str| one_device(kind.as_str(), side.as_str(), "emulator", extra);
        for key in &documented {
            let value = match key.as_str() {
                "initial" => format!("{{ {joint} = {} }}", at(0.3)),
                "object_at" => format!("{{ {joint} = {} }}", at(0.6)),
                "noise" => "false".into(),
                "seed" => "9".into(),
                "position_noise_rad" => "0.001".into(),
                "velocity_noise_rad_s" => "0.01".into(),
                "torque_noise_nm" => "0.01".into(),
                "fault" => "\"ignore-commands\"".into(),
                other => panic!("docs/profiles.md documents devices.emulator.{other}: add a sample value here"),
            };
            let with = device(&format!("[devices.emulator]\n{key} = {value}"));
            let refuses = refused
                .iter()
                .any(|(k, keys)| *k == kind.as_str() && keys.contains(&key.as_str()));
            let (path, r) = load_text(&with);
            if refuses {
                let lines = match r {
                    Ok(_) => panic!("a {kind} accepted emulator.{key}, which it cannot honour\n{with}"),
                    Err(e) => e.lines(),
                };
                assert_eq!(lines.len(), 1, "{kind} {key}: {lines:#?}");
                let prefix = format!("{}: devices[0].emulator.{key}: ", path.display());
                assert!(
                    lines[0].starts_with(&prefix),
                    "{kind}: `{}` does not name {prefix}",
                    lines[0]
                );
                assert!(lines[0].contains("no effect"), "{kind}: `{}` says why", lines[0]);
            } else {
                if let Err(e) = r {
                    panic!("{kind}: emulator.{key} refused: {e}\n{with}");
                }
                assert_ne!(
                    built(&device("")),
                    built(&with),
                    "a {kind} ignores emulator.{key}: it changes nothing its emulator is built with\n{with}"
                );
            }
        }
    }
}

#[test]
fn every_documented_device_and_front_key_changes_what_is_built() {
    let dex3 = |backend: &str, extra: &str| one_device("dex3", "left", backend, extra);
    let dex1 = |backend: &str, extra: &str| one_device("dex1", "left", backend, extra);
    let ez = |extra: &str| one_device("ezgripper", "left", "serial", extra);
    let sdk = |extra: &str| one_device("hand_sdk", "center", "dds", extra);
    let dfx = |extra: &str| one_device("inspire_dfx", "left", "dds", extra);
    let ftp = |extra: &str| one_device("inspire_ftp", "left", "dds", extra);
    let dex5 = |backend: &str, extra: &str| one_device("dex5", "left", backend, extra);
    let front = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"dex3\"\ndevice = \"d\"\n{extra}\n",
            dex3("emulator", "")
        )
    };
    let dex1_front = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"dex1\"\ndevice = \"d\"\n{extra}\n",
            dex1("emulator", "")
        )
    };
    let pair = "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[devices]]\nname = \"h\"\nkind = \"dex1\"\nside = \"right\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\nvariant = \"actuator\"\n";
    let js = |extra: &str| format!("{}[[fronts]]\nkind = \"joint_state\"\n{extra}\n", dex3("emulator", ""));
    let rq = |extra: &str| {
        one_device(
            "robotiq",
            "center",
            "serial",
            &format!("[devices.robotiq]\nport = \"/dev/ttyUSB0\"\n{extra}"),
        )
    };
    let rq_front = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"robotiq\"\ndevice = \"d\"\n{extra}\n",
            dex3("emulator", "")
        )
    };
    let ftp_front = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"d\"\n{extra}\n",
            dex3("emulator", "")
        )
    };
    let canonical = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"canonical\"\ndevice = \"d\"\n",
            dex3("emulator", extra)
        )
    };
    let rh56 = |extra: &str| one_device("inspire_rh56", "left", "serial", extra);
    let rh56_front = |extra: &str| {
        format!(
            "{}[[fronts]]\nkind = \"inspire_rh56\"\ndevice = \"d\"\n{extra}\n",
            dex3("emulator", "")
        )
    };
    let rh56_tcp = |extra: &str| rh56_front(&format!("serve = \"modbus_tcp\"\n{extra}"));
    // (documented key, a profile without it, the same profile setting it)
    let cases: Vec<(&str, String, String)> = vec![
        (
            "devices.name",
            dex3("emulator", ""),
            dex3("emulator", "").replace("\"d\"", "\"e\""),
        ),
        ("devices.kind", dex3("emulator", ""), dex1("emulator", "")),
        (
            "devices.side",
            dex3("emulator", ""),
            one_device("dex3", "right", "emulator", ""),
        ),
        ("devices.backend", dex3("emulator", ""), dex3("usb", "")),
        (
            "devices.rate_hz",
            dex3("emulator", ""),
            dex3("emulator", "rate_hz = 700"),
        ),
        (
            "devices.forward_on_arrival",
            dex1("emulator", ""),
            dex1("emulator", "forward_on_arrival = false"),
        ),
        (
            "devices.max_send_hz",
            dex1("emulator", ""),
            dex1("emulator", "max_send_hz = 1500"),
        ),
        (
            "devices.limits.max_step",
            dex3("emulator", ""),
            dex3("emulator", "limits = { max_step = 0.1 }"),
        ),
        (
            "devices.limits.joints.NAME",
            dex3("emulator", ""),
            dex3("emulator", "limits = { joints = { index_0 = { max = 1.0 } } }"),
        ),
        (
            "devices.motion.tolerance",
            dex3("emulator", ""),
            dex3("emulator", "motion = { tolerance = 0.1 }"),
        ),
        (
            "devices.motion.hold_ms",
            dex1("emulator", ""),
            dex1("emulator", "motion = { hold_ms = 300 }"),
        ),
        (
            "devices.motion.contact",
            dex3("emulator", ""),
            dex3("emulator", "motion = { contact = \"unmeasured\" }"),
        ),
        (
            "devices.motion.contact_effort",
            dex3("emulator", ""),
            dex3("emulator", "motion = { contact_effort = 0.2 }"),
        ),
        (
            "devices.watchdog.timeout_ms",
            canonical(""),
            canonical("watchdog = { timeout_ms = 300 }"),
        ),
        (
            "devices.watchdog.safe_action",
            dex3("emulator", ""),
            dex3("emulator", "watchdog = { safe_action = \"limp\" }"),
        ),
        (
            "devices.closure.open",
            dex3("emulator", ""),
            dex3("emulator", "closure = { open = { index_0 = 0.2 } }"),
        ),
        (
            "devices.closure.closed",
            dex3("emulator", ""),
            dex3("emulator", "closure = { closed = { index_0 = 1.0 } }"),
        ),
        (
            "devices.closure.tau_open",
            sdk(""),
            sdk("closure = { tau_open = -0.5 }"),
        ),
        (
            "devices.closure.tau_closed",
            sdk(""),
            sdk("closure = { tau_closed = 0.5 }"),
        ),
        (
            "devices.usb.serial",
            dex3("usb", ""),
            dex3("usb", "[devices.usb]\nserial = \"X1\""),
        ),
        (
            "devices.usb.socket",
            dex3("usb", ""),
            dex3("usb", "[devices.usb]\nsocket = \"/tmp/x.sock\""),
        ),
        (
            "devices.usb.timeout_bit",
            dex3("usb", ""),
            dex3("usb", "[devices.usb]\ntimeout_bit = false"),
        ),
        (
            "devices.usb.align",
            dex3("usb", ""),
            dex3("usb", "[devices.usb]\nalign = \"off\""),
        ),
        (
            "devices.usb.align_min_gap_us",
            dex3("usb", "[devices.usb]\nalign = \"early\""),
            dex3("usb", "[devices.usb]\nalign = \"early\"\nalign_min_gap_us = 250"),
        ),
        (
            "devices.usb.align_max_shift_us",
            dex3("usb", "[devices.usb]\nalign = \"phase\""),
            dex3("usb", "[devices.usb]\nalign = \"phase\"\nalign_max_shift_us = 30"),
        ),
        (
            "devices.usb.align_lead_us",
            dex3("usb", "[devices.usb]\nalign = \"phase\""),
            dex3("usb", "[devices.usb]\nalign = \"phase\"\nalign_lead_us = 80"),
        ),
        (
            "devices.usb.wiring.joints.NAME",
            dex3("usb", ""),
            dex3("usb", "[devices.usb.wiring.joints]\nthumb_0 = { bus = 3, id = 5 }"),
        ),
        (
            "devices.usb.wiring.pads.pad_N",
            dex3("usb", ""),
            dex3("usb", "[devices.usb.wiring.pads]\npad_0 = { bus = 4, id = 5 }"),
        ),
        (
            "devices.usb.scalings.KEY",
            dex3("usb", ""),
            dex3("usb", "[devices.usb.scalings]\ncmd_kp_per_unit = 100.0"),
        ),
        (
            "devices.dds.cmd_topic",
            dex3("dds", ""),
            dex3("dds", "[devices.dds]\ncmd_topic = \"rt/x/cmd\""),
        ),
        (
            "devices.dds.state_topic",
            dex3("dds", ""),
            dex3("dds", "[devices.dds]\nstate_topic = \"rt/x/state\""),
        ),
        (
            "devices.dds.cmd_topic",
            dfx(""),
            dfx("[devices.dds]\ncmd_topic = \"rt/inspire_b/cmd\""),
        ),
        (
            "devices.dds.state_topic",
            dfx(""),
            dfx("[devices.dds]\nstate_topic = \"rt/inspire_b/state\""),
        ),
        (
            "devices.dds.state_source",
            dex3("dds", ""),
            dex3("dds", "[devices.dds]\nstate_source = \"lf\""),
        ),
        (
            "devices.dds.variant",
            dex1("dds", ""),
            dex1("dds", "[devices.dds]\nvariant = \"hg\""),
        ),
        (
            "devices.dds.range_rad",
            dex1("dds", ""),
            dex1("dds", "[devices.dds]\nrange_rad = 6.0"),
        ),
        ("devices.dds.touch", ftp(""), ftp("[devices.dds]\ntouch = false")),
        (
            "devices.dds.touch_topic",
            ftp(""),
            ftp("[devices.dds]\ntouch_topic = \"rt/x/touch\""),
        ),
        (
            "devices.dds.force_limit",
            ftp(""),
            ftp("[devices.dds]\nforce_limit = 300"),
        ),
        ("devices.dds.speed", ftp(""), ftp("[devices.dds]\nspeed = 500")),
        (
            "devices.driver.rate_hz",
            one_device("inspire_ftp", "left", "emulator", ""),
            one_device("inspire_ftp", "left", "emulator", "[devices.driver]\nrate_hz = 30"),
        ),
        (
            "devices.dds.speed",
            one_device("brainco", "left", "dds", ""),
            one_device("brainco", "left", "dds", "[devices.dds]\nspeed = 0.5"),
        ),
        (
            "devices.dex5.gains",
            dex5("dds", ""),
            dex5("dds", "[devices.dex5]\ngains = \"unitree_dds_wrapper\""),
        ),
        (
            "devices.dex5.command_layout",
            dex5("emulator", ""),
            dex5("emulator", "[devices.dex5]\ncommand_layout = \"motors\""),
        ),
        (
            "devices.dex5.urdf_names",
            dex5("dds", ""),
            dex5("dds", "[devices.dex5]\nurdf_names = \"xr_teleoperate\""),
        ),
        (
            "devices.dex5.coupling",
            dex5("emulator", ""),
            dex5("emulator", "[devices.dex5]\ncoupling = 1.0"),
        ),
        (
            "devices.dds.cmd_topic",
            dex5("dds", ""),
            dex5("dds", "[devices.dds]\ncmd_topic = \"rt/x/cmd\""),
        ),
        (
            "devices.closure.closed",
            dex5("emulator", ""),
            dex5("emulator", "closure = { closed = { index_1 = 1.0 } }"),
        ),
        (
            "devices.hand_sdk.topic",
            sdk(""),
            sdk("[devices.hand_sdk]\ntopic = \"rt/x\""),
        ),
        (
            "devices.hand_sdk.weight",
            sdk(""),
            sdk("[devices.hand_sdk]\nweight = 0.5"),
        ),
        (
            "devices.hand_sdk.ramp_per_s",
            sdk(""),
            sdk("[devices.hand_sdk]\nramp_per_s = 2.0"),
        ),
        (
            "devices.hand_sdk.publish_hz",
            sdk(""),
            sdk("[devices.hand_sdk]\npublish_hz = 100"),
        ),
        (
            "devices.ezgripper.port",
            ez(""),
            ez("[devices.ezgripper]\nport = \"/dev/ttyUSB1\""),
        ),
        (
            "devices.ezgripper.baud",
            ez(""),
            ez("[devices.ezgripper]\nbaud = 57600"),
        ),
        (
            "devices.ezgripper.servo_id",
            ez(""),
            ez("[devices.ezgripper]\nservo_id = 7"),
        ),
        (
            "devices.ezgripper.max_open_percent",
            ez(""),
            ez("[devices.ezgripper]\nmax_open_percent = 80"),
        ),
        (
            "devices.ezgripper.force_limit_percent",
            ez(""),
            ez("[devices.ezgripper]\nforce_limit_percent = 50"),
        ),
        (
            "devices.ezgripper.calibrate_on_start",
            ez(""),
            ez("[devices.ezgripper]\ncalibrate_on_start = true"),
        ),
        (
            "devices.ezgripper.zero_ticks",
            ez(""),
            ez("[devices.ezgripper]\nzero_ticks = 1234"),
        ),
        (
            "devices.ezgripper.response_timeout_ms",
            ez(""),
            ez("[devices.ezgripper]\nresponse_timeout_ms = 40"),
        ),
        (
            "devices.ezgripper.params.KEY",
            ez(""),
            ez("[devices.ezgripper.params]\ngrip_max_ticks = 2400"),
        ),
        (
            "devices.emulator.initial",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\ninitial = { index_0 = 0.5 }"),
        ),
        (
            "devices.emulator.object_at",
            dex1("emulator", ""),
            dex1("emulator", "[devices.emulator]\nobject_at = { jaw = 2.0 }"),
        ),
        (
            "devices.emulator.noise",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\nnoise = false"),
        ),
        (
            "devices.emulator.seed",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\nseed = 9"),
        ),
        (
            "devices.emulator.position_noise_rad",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\nposition_noise_rad = 0.001"),
        ),
        (
            "devices.emulator.velocity_noise_rad_s",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\nvelocity_noise_rad_s = 0.01"),
        ),
        (
            "devices.emulator.torque_noise_nm",
            dex3("emulator", ""),
            dex3("emulator", "[devices.emulator]\ntorque_noise_nm = 0.01"),
        ),
        (
            "devices.emulator.fault",
            dex1("emulator", ""),
            dex1("emulator", "[devices.emulator]\nfault = \"stuck=jaw\""),
        ),
        (
            "fronts.kind",
            front(""),
            front("").replace("kind = \"dex3\"\ndevice", "kind = \"canonical\"\ndevice"),
        ),
        ("fronts.name", front(""), front("name = \"x\"")),
        (
            "fronts.device",
            format!(
                "{}{}",
                one_device("dex3", "left", "emulator", "").replace("\"d\"", "\"e\""),
                front("")
            ),
            format!(
                "{}{}",
                one_device("dex3", "left", "emulator", "").replace("\"d\"", "\"e\""),
                front("").replace("device = \"d\"", "device = \"e\"")
            ),
        ),
        (
            "fronts.devices",
            format!("{pair}devices = {{ left = \"g\" }}\n"),
            format!("{pair}devices = {{ left = \"g\", right = \"h\" }}\n"),
        ),
        (
            "fronts.devices",
            format!("{}{}", dex1("emulator", "").replace("\"d\"", "\"e\""), js("")),
            format!(
                "{}{}",
                dex1("emulator", "").replace("\"d\"", "\"e\""),
                js("devices = [\"d\"]")
            ),
        ),
        ("fronts.side", front(""), front("side = \"right\"")),
        ("fronts.cmd_topic", front(""), front("cmd_topic = \"rt/x/cmd\"")),
        ("fronts.state_topic", front(""), front("state_topic = \"rt/x/state\"")),
        (
            "fronts.lf_state_topic",
            front(""),
            front("lf_state_topic = \"rt/x/lf\""),
        ),
        ("fronts.state_hz", front(""), front("state_hz = 400")),
        ("fronts.lf_state_hz", front(""), front("lf_state_hz = 20")),
        ("fronts.variant", dex1_front(""), dex1_front("variant = \"hg\"")),
        ("fronts.silence", front(""), front("silence = \"watchdog\"")),
        ("fronts.control", front(""), front("control = \"shared\"")),
        (
            "fronts.max_command_age_ms",
            front(""),
            front("max_command_age_ms = 250"),
        ),
        (
            "fronts.watchdog_ms",
            front("silence = \"watchdog\""),
            front("silence = \"watchdog\"\nwatchdog_ms = 50"),
        ),
        ("fronts.topic", js(""), js("topic = \"rt/x/joints\"")),
        ("fronts.urdf_names", js(""), js("urdf_names = false")),
        (
            "fronts.touch_topic",
            ftp_front(""),
            ftp_front("touch_topic = \"rt/x/touch\""),
        ),
        ("devices.robotiq.variant", rq(""), rq("variant = \"hand-e\"")),
        (
            "devices.robotiq.port",
            rq(""),
            rq("").replace("/dev/ttyUSB0", "/dev/ttyUSB1"),
        ),
        (
            "devices.robotiq.tcp",
            rq(""),
            rq("").replace("port = \"/dev/ttyUSB0\"", "tcp = \"192.168.1.10:54321\""),
        ),
        ("devices.robotiq.baud", rq(""), rq("baud = 57600")),
        ("devices.robotiq.slave", rq(""), rq("slave = 10")),
        ("devices.robotiq.speed", rq(""), rq("speed = 100")),
        ("devices.robotiq.force", rq(""), rq("force = 10")),
        (
            "devices.robotiq.response_timeout_ms",
            rq(""),
            rq("response_timeout_ms = 80"),
        ),
        ("fronts.slave", rq_front(""), rq_front("slave = 10")),
        ("fronts.rtu_tcp", rq_front(""), rq_front("rtu_tcp = \"127.0.0.1:1502\"")),
        ("fronts.urcap_tcp", rq_front(""), rq_front("urcap_tcp = \"\"")),
        ("fronts.pty", rq_front(""), rq_front("pty = \"/tmp/robotiq-x\"")),
        ("fronts.max_clients", rq_front(""), rq_front("max_clients = 4")),
        ("fronts.idle_ms", rq_front(""), rq_front("idle_ms = 1000")),
        (
            "devices.inspire_rh56.protocol",
            rh56(""),
            rh56("[devices.inspire_rh56]\nprotocol = \"modbus_rtu\""),
        ),
        (
            "devices.inspire_rh56.port",
            rh56(""),
            rh56("[devices.inspire_rh56]\nport = \"/dev/ttyUSB1\""),
        ),
        (
            "devices.inspire_rh56.baud",
            rh56(""),
            rh56("[devices.inspire_rh56]\nbaud = 57600"),
        ),
        (
            "devices.inspire_rh56.id",
            rh56(""),
            rh56("[devices.inspire_rh56]\nid = 2"),
        ),
        (
            "devices.inspire_rh56.force_set",
            rh56(""),
            rh56("[devices.inspire_rh56]\nforce_set = 300"),
        ),
        (
            "devices.inspire_rh56.speed_set",
            rh56(""),
            rh56("[devices.inspire_rh56]\nspeed_set = 500"),
        ),
        (
            "devices.inspire_rh56.response_timeout_ms",
            rh56(""),
            rh56("[devices.inspire_rh56]\nresponse_timeout_ms = 40"),
        ),
        (
            "devices.inspire_rh56.slow_every",
            rh56(""),
            rh56("[devices.inspire_rh56]\nslow_every = 5"),
        ),
        (
            "devices.inspire_rh56.tactile",
            rh56(""),
            rh56("[devices.inspire_rh56]\ntactile = true"),
        ),
        ("fronts.serve", rh56_front(""), rh56_front("serve = \"modbus_tcp\"")),
        ("fronts.id", rh56_front(""), rh56_front("id = 2")),
        ("fronts.pty", rh56_front(""), rh56_front("pty = \"/tmp/x\"")),
        ("fronts.listen", rh56_tcp(""), rh56_tcp("listen = \"127.0.0.1:16000\"")),
        ("fronts.max_clients", rh56_tcp(""), rh56_tcp("max_clients = 4")),
        ("fronts.idle_s", rh56_tcp(""), rh56_tcp("idle_s = 5.0")),
    ];
    let documented = documented_device_and_front_keys();
    assert!(
        documented.len() > 40,
        "docs/profiles.md tables not found: {documented:?}"
    );
    for key in &documented {
        assert!(
            cases.iter().any(|(k, _, _)| k == key),
            "docs/profiles.md documents `{key}`: add a case that sets it"
        );
    }
    for (key, without, with) in &cases {
        assert!(
            documented.contains(&key.to_string()),
            "`{key}` is not documented in docs/profiles.md"
        );
        assert_ne!(
            built(without),
            built(with),
            "setting `{key}` changes nothing the device or front is built with\n{with}"
        );
    }
}

/// `[dds] namespace` moves handgate's own topics (canonical, joint_state, status) into the
/// ROS namespace and names the node's namespace; the device-compatible fronts' topics stay.
#[test]
fn namespace_moves_handgates_own_topics_only() {
    let fronts = "[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n[[fronts]]\nkind = \"dex3\"\ndevice = \"l\"\n[[fronts]]\nkind = \"joint_state\"\n[[fronts]]\nkind = \"joint_state\"\ntopic = \"rt/hands/joint_states\"\n";
    let (_, r) = load_text(&format!("[dds]\nnamespace = \"/fleet/robot1\"\n{DEX3}{fronts}"));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    let topics: Vec<(Option<&str>, &str)> = plan.fronts.iter().map(|f| (f.cmd_topic(), f.state_topic())).collect();
    assert_eq!(
        topics,
        [
            (
                Some("rt/fleet/robot1/handgate/l/cmd"),
                "rt/fleet/robot1/handgate/l/state"
            ),
            (Some("rt/dex3/left/cmd"), "rt/dex3/left/state"),
            (None, "rt/fleet/robot1/joint_states"),
            // A topic set in the profile is a ROS name relative to the namespace too.
            (None, "rt/fleet/robot1/hands/joint_states"),
        ]
    );
    assert_eq!(plan.status_topic, "rt/fleet/robot1/handgate/status");
    assert_eq!(
        plan.namespace.as_ref().map(|n| n.ros()).as_deref(),
        Some("/fleet/robot1")
    );
    let text = render_fleet(&l.profile, &l.origin);
    assert!(text.contains("ROS node /fleet/robot1/handgate"), "{text}");
    assert!(text.contains("status: rt/fleet/robot1/handgate/status"), "{text}");
    assert!(text.contains("rt/fleet/robot1/joint_states"), "{text}");

    // No namespace: the topics as they were, node `/handgate`; `ros_node = false`: no node.
    let (_, r) = load_text(&format!("{DEX3}{fronts}"));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    assert_eq!(plan.fronts[2].state_topic(), "rt/joint_states");
    assert_eq!(plan.status_topic, "rt/handgate/status");
    assert_eq!(plan.namespace.as_ref().map(|n| n.ros()).as_deref(), Some("/"));
    assert!(render_fleet(&l.profile, &l.origin).contains("ROS node /handgate"));
    let (_, r) = load_text(&format!("[dds]\nros_node = false\n{DEX3}{fronts}"));
    let l = r.unwrap();
    assert_eq!(crate::resolve::plan(&l.profile).unwrap().namespace, None);
    assert!(render_fleet(&l.profile, &l.origin).contains("ROS node off"));
}

/// A namespaced canonical command topic that is also the (namespaced) status topic is refused
/// like the plain clash.
#[test]
fn namespaced_topics_are_checked_for_clashes() {
    let (path, r) = load_text(&format!(
        "[dds]\nnamespace = \"robot1\"\n{DEX3}[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\ncmd_topic = \"rt/handgate/status\"\n"
    ));
    let lines = r.unwrap_err().lines();
    assert_eq!(
        lines,
        [format!(
            "{}: fronts[0].cmd_topic: command topic `rt/robot1/handgate/status` is the status topic or its extension",
            path.display()
        )]
    );
    // And its extension's topic (docs/wire-types.md, "Status: frozen, and its extension").
    let (path, r) = load_text(&format!(
        "[dds]\nnamespace = \"robot1\"\n{DEX3}[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\nstate_topic = \"rt/handgate/status_ext\"\n"
    ));
    assert_eq!(
        r.unwrap_err().lines(),
        [format!(
            "{}: fronts[0].state_topic: state topic `rt/robot1/handgate/status_ext` is the status topic or its extension",
            path.display()
        )]
    );
}

#[test]
fn record_section_errors_name_their_keys() {
    let text = format!("{DEX3}[record]\ndir = \"\"\nmax_mb = 0\nmax_seconds = -1\n");
    let (path, r) = load_text(&text);
    let lines = r.unwrap_err().lines();
    let want = ["record.dir", "record.max_mb", "record.max_seconds"];
    assert_eq!(lines.len(), want.len(), "{lines:#?}");
    for (line, key) in lines.iter().zip(want) {
        assert!(line.starts_with(&format!("{}: {key}: ", path.display())), "{line}");
    }
    let (_, r) = load_text(&format!(
        "{DEX3}[record]\ndir = \"rec\"\ntopics = [\"/x/*\"]\nmax_mb = 5\n"
    ));
    let p = r.unwrap().profile;
    let rec = p.record.expect("[record] parsed");
    assert_eq!(
        (rec.dir.as_str(), rec.topics.len(), rec.max_mb, rec.zstd),
        ("rec", 1, Some(5.0), false)
    );
}

#[test]
fn http_defaults_to_a_read_only_loopback_server() {
    let l = load(&opts(None)).unwrap();
    let h = &l.profile.http;
    assert!(h.enabled && !h.commands, "{h:?}");
    assert_eq!(
        (h.bind.as_str(), h.port),
        ("127.0.0.1", super::schema::HTTP_DEFAULT_PORT)
    );
    let plan = crate::resolve::plan(&l.profile).unwrap();
    let hp = plan.http.expect("on by default");
    assert!(hp.addr.ip().is_loopback(), "{hp:?}");
}

#[test]
fn http_section_errors_name_file_and_key() {
    let p = temp_profile(&format!(
        "[http]\nbind = \"localhost\"\nsample_hz = 500\ncommand_watchdog_ms = 50\n{DEX3}"
    ));
    let err = load(&opts(Some(p.display().to_string()))).unwrap_err();
    let lines = err.lines();
    let file = p.display().to_string();
    for key in ["http.bind", "http.sample_hz", "http.command_watchdog_ms"] {
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with(&file) && l.contains(&format!(": {key}: "))),
            "{key}: {lines:?}"
        );
    }
    let off = temp_profile(&format!("[http]\nenabled = false\n{DEX3}"));
    let l = load(&opts(Some(off.display().to_string()))).unwrap();
    assert!(crate::resolve::plan(&l.profile).unwrap().http.is_none());
}

#[test]
fn http_allowed_hosts_are_names_or_addresses_resolved_once() {
    let (_, r) = load_text(&format!(
        "[http]\nallowed_hosts = [\"Robot.LAN.\", \"10.0.0.5\", \"[fd00::5]\"]\n{DEX3}"
    ));
    let plan = crate::resolve::plan(&r.unwrap().profile).unwrap();
    let h = plan.http.expect("on");
    let shown: Vec<String> = h.allowed_hosts.iter().map(ToString::to_string).collect();
    assert_eq!(shown, ["robot.lan", "10.0.0.5", "[fd00::5]"]);

    let (path, r) = load_text(&format!(
        "[http]\nallowed_hosts = [\"robot.lan:8880\", \"http://robot.lan\", \"ok.lan\"]\n{DEX3}"
    ));
    let lines = r.unwrap_err().lines();
    let file = path.display().to_string();
    let bad: Vec<&String> = lines
        .iter()
        .filter(|l| l.starts_with(&file) && l.contains(": http.allowed_hosts: "))
        .collect();
    assert_eq!(bad.len(), 2, "one line per bad entry: {lines:?}");
    assert!(
        bad[0].contains("`robot.lan:8880`") && bad[0].contains("without scheme or port"),
        "{lines:?}"
    );
}

/// A token file of `text` with `mode`, next to the test profiles.
fn token_file(text: &str, mode: u32) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let p = temp_profile(text).with_extension("token");
    std::fs::write(&p, text).unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
    p
}

#[test]
fn http_off_loopback_requires_a_token_file_that_is_private_and_long_enough() {
    let line_for = |r: Result<Loaded, ProfileError>, path: &PathBuf| -> Vec<String> {
        let file = path.display().to_string();
        r.unwrap_err()
            .lines()
            .into_iter()
            .filter(|l| l.starts_with(&file) && l.contains(": http.token_file: "))
            .collect()
    };
    for bind in ["0.0.0.0", "::", "192.168.1.10", "fd00::5"] {
        let (path, r) = load_text(&format!("[http]\nbind = \"{bind}\"\n{DEX3}"));
        let bad = line_for(r, &path);
        assert_eq!(bad.len(), 1, "{bind}: {bad:?}");
        assert!(bad[0].contains("required") && bad[0].contains(bind), "{bad:?}");
    }
    // Off, it needs none.
    let (_, r) = load_text(&format!("[http]\nenabled = false\nbind = \"0.0.0.0\"\n{DEX3}"));
    assert!(r.is_ok(), "{r:?}");

    let good = token_file("0123456789abcdef0123456789abcdef\n", 0o600);
    let (_, r) = load_text(&format!(
        "[http]\nbind = \"0.0.0.0\"\ncommands = true\ntoken_file = \"{}\"\n{DEX3}",
        good.display()
    ));
    let h = crate::resolve::plan(&r.unwrap().profile).unwrap().http.unwrap();
    assert_eq!(h.token_file.as_deref(), Some(good.as_path()));
    assert!(h.commands && !h.commands_need_token, "{h:?}");

    for (text, mode, why) in [
        ("0123456789abcdef0123456789abcdef\n", 0o640, "chmod 600"),
        ("0123456789abcdef0123456789abcdef\n", 0o604, "chmod 600"),
        ("short\n", 0o600, "fewer than 16"),
        ("\n", 0o600, "0 bytes"),
    ] {
        let f = token_file(text, mode);
        let (path, r) = load_text(&format!(
            "[http]\nbind = \"127.0.0.1\"\ntoken_file = \"{}\"\n{DEX3}",
            f.display()
        ));
        let bad = line_for(r, &path);
        assert_eq!(bad.len(), 1, "{mode:o} {text:?}: {bad:?}");
        assert!(
            bad[0].contains(why) && bad[0].contains(&f.display().to_string()),
            "{bad:?}"
        );
    }
    let missing = temp_profile("").with_extension("absent");
    let (path, r) = load_text(&format!("[http]\ntoken_file = \"{}\"\n{DEX3}", missing.display()));
    let bad = line_for(r, &path);
    assert!(bad.len() == 1 && bad[0].contains("cannot read"), "{bad:?}");
}

#[test]
fn http_commands_without_a_token_stay_off_on_loopback_and_check_says_why() {
    let (path, r) = load_text(&format!("[http]\ncommands = true\n{DEX3}"));
    let l = r.unwrap();
    let h = crate::resolve::plan(&l.profile).unwrap().http.unwrap();
    assert!(!h.commands && h.commands_need_token, "{h:?}");
    let shown = render_fleet(&l.profile, &Origin::File(path));
    assert!(
        shown.contains("WARNING commands = true needs [http] token_file"),
        "{shown}"
    );
    let (_, r) = load_text(&format!("[http]\n{DEX3}"));
    let h = crate::resolve::plan(&r.unwrap().profile).unwrap().http.unwrap();
    assert!(!h.commands && !h.commands_need_token && h.token_file.is_none(), "{h:?}");
}

#[test]
fn foxglove_section_errors_name_their_keys_and_a_lean_build_names_the_feature() {
    // Keys checked in every build.
    let (path, r) = load_text(&format!(
        "{DEX3}[foxglove]\nenabled = false\nbind = \"localhost\"\ntopics = [\" \"]\n"
    ));
    let lines = r.unwrap_err().lines();
    let want = ["foxglove.bind", "foxglove.topics"];
    assert_eq!(lines.len(), want.len(), "{lines:#?}");
    for (line, key) in lines.iter().zip(want) {
        assert!(line.starts_with(&format!("{}: {key}: ", path.display())), "{line}");
    }
    // Turned off: valid with or without the feature, and not served.
    let (_, r) = load_text(&format!("{DEX3}[foxglove]\nenabled = false\n"));
    let p = r.unwrap().profile;
    assert!(!p.foxglove_enabled());
    assert_eq!(crate::resolve::plan(&p).unwrap().foxglove, None);

    // A section that enables it (explicitly, or by giving settings), and none at all.
    let cases = [
        ("[foxglove]\nenabled = true\nport = 9000\n", Some("foxglove.enabled")),
        ("[foxglove]\nport = 9000\nbind = \"::1\"\n", Some("foxglove")),
    ];
    for (section, key) in cases {
        let (path, r) = load_text(&format!("{DEX3}{section}"));
        if cfg!(feature = "foxglove") {
            let p = r.unwrap_or_else(|e| panic!("{section}: {e}")).profile;
            let plan = crate::resolve::plan(&p).unwrap();
            let f = plan.foxglove.expect("served");
            assert_eq!(f.addr.port(), 9000);
            assert!(f.required, "a section of the profile: its failure stops the start");
        } else {
            let lines = r.unwrap_err().lines();
            assert_eq!(lines.len(), 1, "{lines:#?}");
            let key = key.unwrap();
            assert!(
                lines[0].starts_with(&format!("{}: {key}: ", path.display()))
                    && lines[0].contains("--features foxglove"),
                "{}",
                lines[0]
            );
        }
    }
    let (_, r) = load_text(DEX3);
    let p = r.unwrap().profile;
    let plan = crate::resolve::plan(&p).unwrap();
    if cfg!(feature = "foxglove") {
        let f = plan.foxglove.expect("on by default when built in");
        assert_eq!(f.addr.to_string(), "127.0.0.1:8765");
        assert!(!f.required, "the defaults: a taken port is a warning");
        assert!(f.topics.is_empty());
    } else {
        assert_eq!(plan.foxglove, None, "not built in: off, and no error without a section");
    }
}

#[test]
fn realtime_defaults_change_nothing() {
    let l = load(&opts(None)).unwrap();
    assert_eq!(l.profile.realtime, RealtimeConfig::default());
    let plan = crate::resolve::plan(&l.profile).unwrap();
    assert!(plan.realtime.is_default(), "{:?}", plan.realtime);
    assert!(!render_fleet(&l.profile, &l.origin).contains("realtime"));
}

#[test]
fn realtime_section_reaches_the_plan() {
    let cpu = *handgate_adapters::realtime::allowed_cpus().unwrap().last().unwrap();
    let (_, r) = load_text(&format!(
        "{DEX3}[realtime]\npolicy = \"rr\"\npriority = 20\ncpus = [{cpu}]\nmlockall = true\n"
    ));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    assert_eq!(
        plan.realtime,
        handgate_adapters::realtime::Settings {
            policy: RealtimePolicy::Rr,
            priority: 20,
            cpus: vec![cpu],
            mlockall: true,
        }
    );
    let shown = render_fleet(&l.profile, &l.origin);
    assert!(
        shown.contains(&format!(
            "realtime: device loops SCHED_RR priority 20, CPUs {cpu}, memory locked"
        )),
        "{shown}"
    );
}

#[test]
fn realtime_section_errors_name_file_and_key() {
    let allowed = handgate_adapters::realtime::allowed_cpus().unwrap();
    let shown = handgate_adapters::realtime::CpuList(&allowed).to_string();
    let outside = handgate_adapters::realtime::MAX_CPUS + 3;
    // (section, key, message fragment): each gives exactly this one line.
    let cases: Vec<(String, &str, String)> = vec![
        (
            "policy = \"fifo\"\n".into(),
            "realtime.priority",
            "required with policy = \"fifo\" (a real-time priority, 1..=99)".into(),
        ),
        (
            "policy = \"rr\"\npriority = 0\n".into(),
            "realtime.priority",
            "must be 1..=99, got 0".into(),
        ),
        (
            "policy = \"fifo\"\npriority = 100\n".into(),
            "realtime.priority",
            "must be 1..=99, got 100".into(),
        ),
        (
            "priority = 10\n".into(),
            "realtime.priority",
            "only applies to policy = \"fifo\" or \"rr\"".into(),
        ),
        (
            "policy = \"deadline\"\n".into(),
            "realtime.policy",
            "unknown variant: found `deadline`, expected `one of `other`, `fifo`, `rr``".into(),
        ),
        (
            format!("cpus = [{}, {outside}]\n", allowed[0]),
            "realtime.cpus[1]",
            format!("CPU {outside} is not one this process may run on (allowed: {shown})"),
        ),
        (
            format!("cpus = [{0}, {0}]\n", allowed[0]),
            "realtime.cpus[1]",
            format!("CPU {} is listed twice", allowed[0]),
        ),
        ("mlock = true\n".into(), "realtime.mlock", "unknown key".into()),
    ];
    for (section, key, want) in cases {
        let (path, r) = load_text(&format!("{DEX3}[realtime]\n{section}"));
        let lines = r.unwrap_err().lines();
        assert_eq!(lines.len(), 1, "{section}: {lines:#?}");
        assert!(
            lines[0].starts_with(&format!("{}: {key}: ", path.display())) && lines[0].contains(&want),
            "{section}: want {key}: {want}, got {}",
            lines[0]
        );
    }
}

#[test]
fn export_puts_the_clients_on_a_second_domain_from_file_env_or_flags() {
    use crate::profile::render::render_fleet;
    let fronts = "[[fronts]]\nkind = \"dex3\"\ndevice = \"l\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n";
    // Without [export]: one side, as before.
    let (_, r) = load_text(&format!("[dds]\ndomain = 0\ninterface = \"eth0\"\n{DEX3}{fronts}"));
    let l = r.unwrap();
    assert_eq!(l.profile.export_side(), None);
    let text = render_fleet(&l.profile, &l.origin);
    assert!(
        text.contains("dds: domain 0, interface eth0, ROS node /handgate"),
        "{text}"
    );
    // A second domain on the lab's interface, with a namespace.
    let (_, r) = load_text(&format!(
        "[dds]\ndomain = 0\ninterface = \"eth0\"\n[export]\ndomain = 10\ninterface = \"eth1\"\nnamespace = \"robot1\"\n{DEX3}{fronts}"
    ));
    let l = r.unwrap();
    let p = &l.profile;
    assert_eq!(p.export_side(), Some((DomainId(10), Some("eth1".into()))));
    assert_eq!(p.status_topic().0, "rt/robot1/handgate/status");
    let text = render_fleet(p, &l.origin);
    assert!(text.contains("dds (devices): domain 0, interface eth0\n"), "{text}");
    assert!(
        text.contains("export (fronts, status, ROS node /robot1/handgate): domain 10, interface eth1\n"),
        "{text}"
    );
    let topics = |p: &Profile, i: usize| {
        let t = p.front_topics(&p.fronts[i], p.devices.first());
        t.topics
            .iter()
            .filter_map(|t| t.topic.clone())
            .map(|t| t.0)
            .collect::<Vec<_>>()
    };
    // The unitree-style front keeps its standard names; handgate's own move into the namespace.
    assert_eq!(
        topics(p, 0),
        ["rt/dex3/left/cmd", "rt/dex3/left/state", "rt/lf/dex3/left/state"]
    );
    assert!(
        topics(p, 1).iter().all(|t| t.starts_with("rt/robot1/handgate/")),
        "{:?}",
        topics(p, 1)
    );
    let plan = crate::resolve::plan(p).unwrap();
    assert_eq!(
        plan.export,
        Some(crate::plan::ExportPlan {
            domain: 10,
            interface: Some("eth1".into()),
            security: None,
        })
    );
    assert_eq!(
        plan.namespace.as_ref().map(|n| n.ros().to_string()).as_deref(),
        Some("/robot1")
    );
    // Opt in: every front's topics in the namespace.
    let (_, r) = load_text(&format!(
        "[export]\ndomain = 10\nnamespace = \"robot1\"\nnamespace_fronts = true\n{DEX3}{fronts}"
    ));
    let p = r.unwrap().profile;
    assert_eq!(
        topics(&p, 0),
        [
            "rt/robot1/dex3/left/cmd",
            "rt/robot1/dex3/left/state",
            "rt/robot1/lf/dex3/left/state"
        ]
    );
    // Only a namespace: no second participant; the interface defaults to the devices'.
    let (_, r) = load_text(&format!(
        "[dds]\ninterface = \"eth0\"\n[export]\nnamespace = \"robot1\"\n{DEX3}"
    ));
    let p = r.unwrap().profile;
    assert_eq!(p.export_side(), None);
    assert_eq!(p.status_topic().0, "rt/robot1/handgate/status");
    // The flags, and the environment like every other key.
    let path = temp_profile(DEX3);
    let l = load(&LoadOptions {
        overrides: CliOverrides {
            export_domain: Some(7),
            export_interface: Some("eth1".into()),
            namespace: Some("robot2".into()),
            ..Default::default()
        },
        ..opts(Some(path.display().to_string()))
    })
    .unwrap();
    assert_eq!(l.profile.export_side(), Some((DomainId(7), Some("eth1".into()))));
    assert_eq!(l.profile.namespace().ros(), "/robot2");
    figment::Jail::expect_with(|jail| {
        jail.set_env("HANDGATE_EXPORT__DOMAIN", 9);
        jail.set_env("HANDGATE_EXPORT__NAMESPACE", "robot3");
        let l = load(&LoadOptions {
            env: EnvLayer::Process,
            ..opts(Some(path.display().to_string()))
        })
        .unwrap();
        assert_eq!(l.profile.export_side(), Some((DomainId(9), None)));
        assert_eq!(l.profile.status_topic().0, "rt/robot3/handgate/status");
        Ok(())
    });
}

/// `max_command_age_ms` reaches the plan the front task is built from and `handgate check`
/// names it; a front without it shows nothing of it (docs/fronts.md, "Commands in order").
#[test]
fn max_command_age_ms_reaches_the_plan_and_the_check_listing() {
    let fronts = "[[fronts]]\nkind = \"dex3\"\ndevice = \"l\"\nmax_command_age_ms = 250\n[[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n";
    let (_, r) = load_text(&format!("{DEX3}{fronts}"));
    let l = r.unwrap();
    let plan = crate::resolve::plan(&l.profile).unwrap();
    let ages: Vec<Option<u32>> = plan
        .fronts
        .iter()
        .map(|f| f.config.max_command_age_ms.map(|m| m.0))
        .collect();
    assert_eq!(ages, [Some(250), None]);
    let text = render_fleet(&l.profile, &l.origin);
    assert_eq!(text.matches("max command age 250 ms").count(), 1, "{text}");
}
