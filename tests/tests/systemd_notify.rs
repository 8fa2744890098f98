//! `Type=notify` through the binary (docs/deployment.md): run as systemd would run it
//! (`$NOTIFY_SOCKET`, `$WATCHDOG_USEC`), handgate says READY once its devices and fronts are
//! up, then feeds the watchdog while its device loops run, and says STOPPING on SIGTERM.
//! Domain 189 (docs/development.md).

use std::os::unix::net::UnixDatagram;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use handgate_tests::handgate_cmd;

#[test]
fn ready_then_watchdog_feeds_then_stopping() {
    let dir = std::env::temp_dir().join(format!("handgate-sd-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sock_path = dir.join("notify.sock");
    let _ = std::fs::remove_file(&sock_path);
    let sock = UnixDatagram::bind(&sock_path).unwrap();
    sock.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let profile = dir.join("sd.toml");
    std::fs::write(
        &profile,
        "name = \"sd\"\n[[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n",
    )
    .unwrap();
    let mut child = handgate_cmd(None)
        .args(["run", "--domain", "189", "--http-port", "0", "--profile"])
        .arg(&profile)
        .env("NOTIFY_SOCKET", &sock_path)
        .env("WATCHDOG_USEC", "400000")
        .env_remove("WATCHDOG_PID")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let recv = || {
        let mut buf = [0u8; 512];
        let n = sock.recv(&mut buf).expect("a notification within 20 s");
        String::from_utf8_lossy(&buf[..n]).into_owned()
    };
    let ready = recv();
    assert!(ready.starts_with("READY=1\nSTATUS=serving 1 devices"), "{ready:?}");
    // Fed every WATCHDOG_USEC / 2 = 200 ms while the loop runs.
    let t0 = Instant::now();
    let mut feeds = 0;
    while feeds < 3 {
        let m = recv();
        if m.starts_with("WATCHDOG=1") {
            feeds += 1;
        }
    }
    assert!(t0.elapsed() >= Duration::from_millis(300), "{:?}", t0.elapsed());
    terminate(child.id());
    loop {
        let m = recv();
        if m.starts_with("STOPPING=1") {
            break;
        }
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn terminate(pid: u32) {
    let _ = Command::new("kill").args(["-TERM", &pid.to_string()]).status();
}
