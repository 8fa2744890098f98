//! A keystore made by `handgate security` (the real binary) works with CycloneDDS 0.10.2's DDS
//! Security plugins on DDS domain 108 (docs/development.md): a gateway identity (this test's
//! process, holding the lab's revocation list) receives a command from an operator identity;
//! an observer identity may read the command topic but not create a writer on it; an identity
//! of another lab's CA and a revoked identity match nothing, and the gateway counts both
//! refusals (`dds_security::refusals`). docs/security-keystore.md.
//!
//! Each identity but the gateway's runs in its own process (this test binary again, running
//! the ignored test `identity_process`): CycloneDDS 0.10.2's access control plugin holds ONE
//! set of local permissions per domain in a process (built with
//! ACCESS_CONTROL_USE_ONE_PERMISSION: the first secured participant's apply to every later
//! one; measured here: an observer created after a gateway in one process could create a
//! command writer), and participants of one process match each other locally, without a
//! handshake.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_security::{self, Refusal, Security};
use handgate_idl::handgate::HandCmd_;
use handgate_tests::{handgate_bin, poll};

const DOMAIN: u32 = 108;
const TOPIC: &str = "rt/handgate/left_hand/cmd";
/// The environment variable that makes `identity_process` act: `ACTION|ENCLAVE_DIR|CRL`.
const CHILD_ENV: &str = "HANDGATE_SECURITY_TEST_CHILD";

/// `handgate security ARGS` succeeds; its output.
fn security(args: &[&str]) -> String {
    let out = Command::new(handgate_bin())
        .arg("security")
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("handgate runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "handgate security {args:?}: {text}");
    text
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("handgate-security-keystore-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// One identity's participant in a process of its own, its output lines read as they come.
struct IdentityProcess {
    child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl IdentityProcess {
    /// Runs `identity_process` with `action` for the enclave `enclave` of `keystore`, given
    /// the keystore's revocation list when `crl`.
    fn spawn(action: &str, keystore: &Path, enclave: &str, crl: bool) -> Self {
        let exe = std::env::current_exe().expect("test executable");
        let crl = if crl {
            keystore.join("public/crl.pem").display().to_string()
        } else {
            String::new()
        };
        let spec = format!("{action}|{}|{crl}", keystore.join("enclaves").join(enclave).display());
        let mut child = Command::new(exe)
            .args([
                "identity_process",
                "--exact",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .env(CHILD_ENV, spec)
            .env("RUST_BACKTRACE", "0")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("the identity's process starts");
        let (tx, lines) = mpsc::channel();
        let out = child.stdout.take().expect("stdout");
        std::thread::spawn(move || {
            for l in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        IdentityProcess {
            child,
            lines,
            seen: Vec::new(),
        }
    }

    /// The first line holding `prefix` within `timeout`, from `prefix` on (the test harness
    /// prints `test identity_process ... ` before the first line).
    fn wait_line(&mut self, prefix: &str, timeout: Duration) -> String {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(l) = self.seen.iter().find_map(|l| l.find(prefix).map(|i| &l[i..])) {
                return l.to_string();
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) => self.seen.push(l),
                Err(_) => panic!("no line {prefix:?} within {timeout:?}; output: {:?}", self.seen),
            }
        }
    }
}

impl IdentityProcess {
    /// Whether a line holding `what` came (reads what has come, without waiting).
    fn has_line(&mut self, what: &str) -> bool {
        while let Ok(l) = self.lines.try_recv() {
            self.seen.push(l);
        }
        self.seen.iter().any(|l| l.contains(what))
    }
}

impl Drop for IdentityProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A participant of one identity, for `keystore_identities_on_a_secured_domain`; does
/// nothing unless that test runs it (`CHILD_ENV`: `ACTION|ENCLAVE_DIR|CRL`, CRL possibly
/// empty). Actions: `write SEQ`: a writer on the
/// command topic; prints `MATCHED` once it matches a reader, then writes commands with `SEQ`
/// until killed. `observe`: a reader on the command topic (prints `READER ok` or
/// `READER refused: ...`, then `READER matched` once it matches a writer), then a writer on
/// it (prints `WRITER refused: <error>` or `WRITER created`).
#[test]
#[ignore = "run by keystore_identities_on_a_secured_domain in a process of its own"]
fn identity_process() {
    let Ok(spec) = std::env::var(CHILD_ENV) else {
        return;
    };
    let mut parts = spec.split('|');
    let (action, enclave, crl) = (
        parts.next().unwrap_or_default().to_string(),
        PathBuf::from(parts.next().unwrap_or_default()),
        parts.next().filter(|c| !c.is_empty()).map(PathBuf::from),
    );
    let sec = Security::from_enclave(&enclave, crl);
    let node = match Node::with_security(DOMAIN, None, Some(&sec)) {
        Ok(n) => n,
        Err(e) => {
            println!("JOIN refused: {e}");
            return;
        }
    };
    println!("JOINED");
    let qos = Qos::Reliable { depth: 8 };
    if let Some(seq) = action.strip_prefix("write ") {
        let seq: u64 = seq.parse().expect("seq");
        let mut w = node.writer::<HandCmd_>(TOPIC, qos).expect("writer");
        let mut told = 0;
        loop {
            // This process's refusals (the handshake's initiator is whichever participant has
            // the lower GUID: a certificate of another CA is refused by the side that verifies
            // it, which may be this one).
            let r = dds_security::refusals(DOMAIN);
            if r.total() > told {
                told = r.total();
                for k in Refusal::ALL.iter().filter(|k| r.participants.contains_key(k)) {
                    println!("REFUSAL {}", k.label());
                }
            }
            if w.matched() > 0 {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        println!("MATCHED");
        loop {
            let _ = w.write(HandCmd_ {
                seq,
                ..Default::default()
            });
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    assert_eq!(action, "observe");
    match node.reader::<HandCmd_>(TOPIC, qos) {
        Ok(r) => {
            println!("READER ok");
            if r.wait_matched(1, Duration::from_secs(30)).is_ok() {
                println!("READER matched");
            }
        }
        Err(e) => println!("READER refused: {e}"),
    }
    match node.writer::<HandCmd_>(TOPIC, qos) {
        Ok(_) => println!("WRITER created"),
        Err(e) => println!("WRITER refused: {e}"),
    }
    println!("DONE");
}

#[test]
fn keystore_identities_on_a_secured_domain() {
    let dir = scratch();
    let lab = dir.join("lab");
    let other = dir.join("other");
    let lab_s = lab.to_str().unwrap();
    let other_s = other.to_str().unwrap();
    security(&["init", "--keystore", lab_s, "--name", "test lab CA"]);
    security(&[
        "issue",
        "--keystore",
        lab_s,
        "robot_a",
        "--role",
        "gateway",
        "--robot",
        "108",
    ]);
    security(&[
        "issue",
        "--keystore",
        lab_s,
        "ops/alice",
        "--role",
        "operator",
        "--robot",
        "108",
    ]);
    security(&[
        "issue",
        "--keystore",
        lab_s,
        "watcher",
        "--role",
        "observer",
        "--robot",
        "108",
    ]);
    security(&[
        "issue",
        "--keystore",
        lab_s,
        "ops/eve",
        "--role",
        "operator",
        "--robot",
        "108",
    ]);
    let revoked = security(&["revoke", "--keystore", lab_s, "ops/eve"]);
    assert!(revoked.contains("revoked certificate serial"), "{revoked}");
    security(&["init", "--keystore", other_s, "--name", "other lab CA"]);
    security(&[
        "issue",
        "--keystore",
        other_s,
        "mallory",
        "--role",
        "operator",
        "--robot",
        "108",
    ]);
    let list = security(&["list", "--keystore", lab_s]);
    assert!(
        list.lines()
            .any(|l| l.starts_with("/ops/eve ") && l.ends_with("revoked")),
        "{list}"
    );

    // The gateway, holding the lab's revocation list.
    let gateway_id = Security::from_enclave(&lab.join("enclaves/robot_a"), Some(lab.join("public/crl.pem")));
    let gateway = Node::with_security(DOMAIN, None, Some(&gateway_id)).expect("the gateway joins");
    let reader = gateway
        .reader::<HandCmd_>(TOPIC, Qos::Reliable { depth: 64 })
        .expect("gateway reader");

    // The operator's command crosses.
    let mut operator = IdentityProcess::spawn("write 7", &lab, "ops/alice", true);
    operator.wait_line("MATCHED", Duration::from_secs(30));
    let got = poll(Duration::from_secs(10), || {
        reader.take().into_iter().find(|c| c.seq == 7)
    });
    assert_eq!(
        got.map(|c| c.seq),
        Some(7),
        "the operator's command reached the gateway"
    );

    // The observer reads the command topic; it may not write it.
    let mut observer = IdentityProcess::spawn("observe", &lab, "watcher", true);
    observer.wait_line("READER matched", Duration::from_secs(30));
    let w = observer.wait_line("WRITER", Duration::from_secs(30));
    assert!(
        w.starts_with("WRITER refused: ") && w.contains("Not allowed by security"),
        "{w}"
    );
    drop(observer);

    // Another CA's identity and a revoked one (whose process does not have the new list: a
    // participant given a list that revokes its own certificate refuses to start): refused by
    // the gateway, counted.
    let before = dds_security::refusals(DOMAIN);
    let count = |r: &dds_security::DomainRefusals, k| r.participants.get(&k).copied().unwrap_or(0);
    let mut mallory = IdentityProcess::spawn("write 66", &other, "mallory", false);
    let mut eve = IdentityProcess::spawn("write 67", &lab, "ops/eve", false);
    mallory.wait_line("JOINED", Duration::from_secs(30));
    eve.wait_line("JOINED", Duration::from_secs(30));
    // The gateway refuses the revoked certificate when it verifies it: in either order of the
    // handshake. Another CA's certificate is refused by whichever side verifies the other's
    // first: the gateway (it counts `unknown_ca`) when mallory's participant starts the
    // handshake, mallory's participant (the gateway's certificate is of a CA it does not
    // know) when the gateway does; which one starts is the order of their GUIDs.
    let refused = poll(Duration::from_secs(30), || {
        let r = dds_security::refusals(DOMAIN);
        let revoked = count(&r, Refusal::Revoked) > count(&before, Refusal::Revoked);
        let foreign = count(&r, Refusal::UnknownCa) > count(&before, Refusal::UnknownCa)
            || mallory.has_line("REFUSAL unknown_ca");
        (revoked && foreign).then_some(r)
    });
    assert!(
        refused.is_some(),
        "refusals on domain {DOMAIN}: {:?}, in mallory's process: {:?} (wanted unknown_ca and revoked)",
        dds_security::refusals(DOMAIN),
        mallory.seen
    );
    // They match nothing: the gateway's reader still has the operator's writer only, and the
    // operator's commands keep arriving, none of theirs.
    assert_eq!(
        reader.matched(),
        1,
        "the gateway's reader matches the operator's writer only"
    );
    let mut seen = Vec::new();
    poll(Duration::from_secs(5), || {
        seen.extend(reader.take().into_iter().map(|c| c.seq));
        (seen.iter().filter(|&&s| s == 7).count() >= 20).then_some(())
    })
    .expect("the operator's commands keep arriving");
    assert!(
        seen.iter().all(|&s| s == 7),
        "only the operator's commands arrive: {seen:?}"
    );
    assert!(!mallory.seen.iter().chain(&eve.seen).any(|l| l.contains("MATCHED")));

    drop((mallory, eve, operator));
    drop((reader, gateway));
    let _ = std::fs::remove_dir_all(&dir);
}
