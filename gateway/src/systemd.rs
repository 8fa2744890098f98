//! systemd integration (docs/deployment.md): `Type=notify` readiness and the service
//! watchdog, spoken directly over `$NOTIFY_SOCKET` (the sd_notify datagram protocol: a few
//! `KEY=VALUE` lines per datagram), so no libsystemd is linked.
//!
//! The watchdog is fed only while every device loop is alive: each loop counts its
//! iterations (`DeviceStats::cycles`); a loop whose count did not move since the previous
//! feed is hung, the feed stops, and systemd restarts the gateway after `WatchdogSec`.

use std::os::unix::net::UnixDatagram;
use std::path::Path;
use std::time::Duration;

/// Sends `msg` to the notification socket at `path` (`@name`: Linux abstract namespace).
pub fn notify_to(path: &str, msg: &str) -> std::io::Result<()> {
    let sock = UnixDatagram::unbound()?;
    if let Some(name) = path.strip_prefix('@') {
        use std::os::linux::net::SocketAddrExt;
        let addr = std::os::unix::net::SocketAddr::from_abstract_name(name.as_bytes())?;
        sock.send_to_addr(msg.as_bytes(), &addr)?;
    } else {
        sock.send_to(msg.as_bytes(), Path::new(path))?;
    }
    Ok(())
}

/// Sends `msg` to systemd when run as a `Type=notify` service (`$NOTIFY_SOCKET` set);
/// `Ok(false)` otherwise.
pub fn notify(msg: &str) -> std::io::Result<bool> {
    match std::env::var("NOTIFY_SOCKET") {
        Ok(p) if !p.is_empty() => notify_to(&p, msg).map(|_| true),
        _ => Ok(false),
    }
}

/// How often to feed the watchdog: half of `$WATCHDOG_USEC` when it is set for this process
/// (`$WATCHDOG_PID` absent or ours); `None` without a watchdog.
pub fn watchdog_interval() -> Option<Duration> {
    let usec: u64 = std::env::var("WATCHDOG_USEC").ok()?.parse().ok()?;
    if let Ok(pid) = std::env::var("WATCHDOG_PID") {
        if pid.parse::<u32>().ok()? != std::process::id() {
            return None;
        }
    }
    (usec > 0).then(|| Duration::from_micros(usec / 2))
}

/// Whether every device loop moved since the last check.
#[derive(Debug, Default)]
pub struct Liveness {
    last: Vec<u64>,
}

impl Liveness {
    /// `cycles[i]`: device `i`'s loop iterations now. `Err`: the indices of the loops that
    /// did not move (the first check only records).
    pub fn check(&mut self, cycles: &[u64]) -> Result<(), Vec<usize>> {
        let first = self.last.len() != cycles.len();
        let stalled: Vec<usize> = if first {
            Vec::new()
        } else {
            (0..cycles.len()).filter(|&i| cycles[i] == self.last[i]).collect()
        };
        self.last = cycles.to_vec();
        if stalled.is_empty() {
            Ok(())
        } else {
            Err(stalled)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_loop_that_stops_counting_stops_the_feed_and_one_that_resumes_restarts_it() {
        let mut l = Liveness::default();
        assert_eq!(l.check(&[10, 20]), Ok(()), "the first check records");
        assert_eq!(l.check(&[15, 21]), Ok(()));
        assert_eq!(l.check(&[15, 30]), Err(vec![0]), "device 0 hung");
        assert_eq!(l.check(&[16, 30]), Err(vec![1]));
        assert_eq!(l.check(&[17, 31]), Ok(()));
    }

    #[test]
    fn notifications_reach_a_path_and_an_abstract_socket() {
        let dir = std::env::temp_dir().join(format!("handgate-sd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("notify.sock");
        let _ = std::fs::remove_file(&path);
        let rx = UnixDatagram::bind(&path).unwrap();
        notify_to(path.to_str().unwrap(), "READY=1\nSTATUS=up").unwrap();
        let mut buf = [0u8; 64];
        let n = rx.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], b"READY=1\nSTATUS=up");
        let _ = std::fs::remove_dir_all(&dir);

        use std::os::linux::net::SocketAddrExt;
        let name = format!("handgate-sd-test-{}", std::process::id());
        let addr = std::os::unix::net::SocketAddr::from_abstract_name(name.as_bytes()).unwrap();
        let rx = UnixDatagram::bind_addr(&addr).unwrap();
        notify_to(&format!("@{name}"), "WATCHDOG=1").unwrap();
        let n = rx.recv(&mut buf).unwrap();
        assert_eq!(&buf[..n], b"WATCHDOG=1");
    }
}
