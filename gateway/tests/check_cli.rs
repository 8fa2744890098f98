//! Runs the real `handgate` binary: `handgate check` exit codes and messages.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn handgate(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_handgate"));
    c.args(args)
        // Run from the repository root, where profiles/ lives, with no stray overrides.
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .env_remove("HANDGATE_PROFILE_DIR");
    for (k, _) in std::env::vars() {
        if k.starts_with("HANDGATE_") {
            c.env_remove(k);
        }
    }
    for (k, v) in envs {
        c.env(k, v);
    }
    c.output().expect("handgate runs")
}

fn write(name: &str, text: &str) -> PathBuf {
    let p = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn check_default_exits_0_and_prints_the_fleet() {
    let o = handgate(&["check", "default"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("dds: domain 1"), "{out}");
    assert!(out.contains("dex3_left"), "{out}");
    assert!(out.contains("cmd rt/dex1/right/cmd"), "{out}");
    // Without a profile: the embedded default.
    let o = handgate(&["check"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("(embedded default)"), "{}", stdout(&o));
}

#[test]
fn check_bad_file_exits_2_naming_file_and_key() {
    let p = write(
        "bad-watchdog.toml",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n\
         watchdog = { timeout_ms = 20000 }\n[[fronts]]\nkind = \"dex1\"\ndevice = \"ghost\"\n",
    );
    let o = handgate(&["check", p.to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(
        lines,
        [
            format!(
                "{}: devices[0].watchdog.timeout_ms: must be between 10 and 10000, got 20000",
                p.display()
            ),
            format!(
                "{}: fronts[0].device: no device named `ghost` (devices: g)",
                p.display()
            ),
        ],
        "{err}"
    );
    assert!(stdout(&o).is_empty(), "nothing printed as if valid");
}

#[test]
fn check_unknown_key_exits_2() {
    let p = write("bad-key.toml", "[dds]\ndomain = 1\nport = 7400\n");
    let o = handgate(&["check", p.to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with(&format!("{}: dds.port: unknown key", p.display())),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_env_var_and_flag_exit_2_naming_their_origin() {
    let o = handgate(&["check"], &[("HANDGATE_DDS__DOMAIN", "lots")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with("environment (HANDGATE_DDS__DOMAIN): dds.domain: invalid type"),
        "{}",
        stderr(&o)
    );
    let o = handgate(&["check", "--domain", "233"], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o).trim_end(),
        "command line (--domain): dds.domain: must be between 0 and 232, got 233"
    );
}

#[test]
fn overrides_show_in_the_resolved_fleet() {
    let o = handgate(
        &["check", "g1-dex3", "--domain", "9", "--log-format", "human"],
        &[("HANDGATE_DDS__DOMAIN", "5"), ("HANDGATE_DDS__INTERFACE", "lo")],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("dds: domain 9, interface lo"), "{out}");
    assert!(out.contains("log: human"), "{out}");
}

#[test]
fn unknown_profile_exits_2_listing_the_available_ones() {
    let o = handgate(&["check", "no-such-robot"], &[]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("unknown profile `no-such-robot`"), "{err}");
    assert!(err.contains("g1-ezgripper"), "{err}");
}

#[test]
fn every_shipped_profile_checks_and_list_shows_them() {
    let o = handgate(&["check", "--list"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let listed = stdout(&o);
    for name in [
        "default",
        "dex3-usb-lab",
        "g1-dex3",
        "g1-ezgripper",
        "g1-hand-sdk",
        "mixed-lab",
    ] {
        assert!(listed.lines().any(|l| l.starts_with(name)), "{listed}");
        let o = handgate(&["check", name], &[]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
    }
}

#[test]
fn run_with_an_invalid_profile_exits_2_before_starting() {
    let p = write("bad-run.toml", "[dds]\ndomain = 1000\n");
    let o = handgate(&["run", "--profile", p.to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with(&format!("{}: dds.domain:", p.display())),
        "{}",
        stderr(&o)
    );
}

/// `check` and `run` take the profile either way, `PROFILE` or `--profile PROFILE`, and
/// refuse both at once.
#[test]
fn check_and_run_take_the_profile_as_argument_or_flag() {
    let p = write("bad-either-way.toml", "[dds]\ndomain = 1000\n");
    let path = p.to_str().unwrap();
    let first_line = format!("{}: dds.domain: must be between 0 and 232, got 1000", p.display());
    for args in [
        ["check", path, ""],
        ["check", "--profile", path],
        ["run", path, ""],
        ["run", "--profile", path],
    ] {
        let args: Vec<&str> = args.into_iter().filter(|a| !a.is_empty()).collect();
        let o = handgate(&args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert_eq!(stderr(&o).lines().next(), Some(first_line.as_str()), "{args:?}");
    }
    // A valid one by name, either way.
    for args in [["check", "default", ""], ["check", "--profile", "default"]] {
        let args: Vec<&str> = args.into_iter().filter(|a| !a.is_empty()).collect();
        let o = handgate(&args, &[]);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        assert!(stdout(&o).contains("dds: domain 1"), "{args:?}: {}", stdout(&o));
    }
    // Both at once: which one? Refused before loading anything.
    for cmd in ["check", "run"] {
        let o = handgate(&[cmd, "default", "--profile", path], &[]);
        assert_eq!(o.status.code(), Some(2), "{cmd}");
        assert!(stderr(&o).contains("cannot be used with"), "{cmd}: {}", stderr(&o));
    }
    let o = handgate(&["check", "--list", "--profile", "default"], &[]);
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
}

#[test]
fn check_shows_the_foxglove_section_or_how_to_build_it_in() {
    let o = handgate(&["check"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    let p = write(
        "foxglove.toml",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n\
         [foxglove]\nport = 9001\ntopics = [\"/dex1/*\"]\n",
    );
    let with = handgate(&["check", p.to_str().unwrap()], &[]);
    if cfg!(feature = "foxglove") {
        assert!(
            out.contains("foxglove: ws://127.0.0.1:8765 (state topics and status)"),
            "{out}"
        );
        assert_eq!(with.status.code(), Some(0), "{}", stderr(&with));
        assert!(
            stdout(&with).contains("foxglove: ws://127.0.0.1:9001 (/dex1/*)"),
            "{}",
            stdout(&with)
        );
    } else {
        assert!(out.contains("foxglove: not built in"), "{out}");
        assert_eq!(with.status.code(), Some(2), "{}", stdout(&with));
        let err = stderr(&with);
        assert!(err.contains("foxglove") && err.contains("--features foxglove"), "{err}");
    }
}
