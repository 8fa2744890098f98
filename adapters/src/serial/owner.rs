//! Who holds a serial port: the process holding its advisory lock (`/proc/locks`, the lock
//! [`super::SerialPort::open`] takes) or, failing that, every process with the device node
//! open (`/proc/<pid>/fd`, what `fuser` reads), named by pid and command line; and an FTDI
//! adapter's latency timer (`/sys/bus/usb-serial/devices/<tty>/latency_timer`, 16 ms by
//! default, 1 ms for a bus polled at hundreds of Hz). Read by the port's open error and by
//! `handgate doctor`.

use std::fmt;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// A process holding a port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortHolder {
    pub pid: u32,
    /// Its command line (arguments joined by spaces), or its `comm` when that is unreadable.
    pub command: String,
    /// It holds the port's lock (another handgate, pyserial's `exclusive=True`, `flock`);
    /// `false`: it only has the device open.
    pub locked: bool,
}

impl fmt::Display for PortHolder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "pid {} ({})", self.pid, self.command)
    }
}

/// The device node a port path names (`/dev/serial/by-id/...` is a symlink).
pub fn node(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

fn command_of(pid: u32) -> String {
    let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
    let words: Vec<String> = cmdline
        .split(|b| *b == 0)
        .filter(|w| !w.is_empty())
        .map(|w| String::from_utf8_lossy(w).into_owned())
        .collect();
    if words.is_empty() {
        std::fs::read_to_string(format!("/proc/{pid}/comm"))
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "?".into())
    } else {
        words.join(" ")
    }
}

/// Pids holding an advisory lock on the inode `(dev, ino)`, from `/proc/locks` (lines like
/// `1: FLOCK  ADVISORY  WRITE 4242 00:05:123 0 EOF`; the device as `major:minor` in hex).
pub fn lock_holders_in(locks: &str, dev: u64, ino: u64) -> Vec<u32> {
    let (major, minor) = (libc::major(dev), libc::minor(dev));
    let mut out = Vec::new();
    for line in locks.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        // "1:" FLOCK ADVISORY WRITE pid dev:ino ...; a blocked waiter has "->" after the id.
        let f: Vec<&str> = f.into_iter().filter(|w| *w != "->").collect();
        if f.len() < 6 {
            continue;
        }
        let Ok(pid) = f[4].parse::<u32>() else {
            continue;
        };
        let parts: Vec<&str> = f[5].split(':').collect();
        if parts.len() != 3 {
            continue;
        }
        let (Ok(ma), Ok(mi), Ok(i)) = (
            u32::from_str_radix(parts[0], 16),
            u32::from_str_radix(parts[1], 16),
            parts[2].parse::<u64>(),
        ) else {
            continue;
        };
        if ma == major && mi == minor && i == ino && !out.contains(&pid) {
            out.push(pid);
        }
    }
    out
}

/// The processes other than this one holding the port at `path`: its lock holder first,
/// then every other process with the node open. Empty: nobody (or /proc is unreadable).
pub fn holders(path: &Path) -> Vec<PortHolder> {
    let node = node(path);
    let me = std::process::id();
    let mut out: Vec<PortHolder> = Vec::new();
    if let Ok(meta) = std::fs::metadata(&node) {
        let locks = std::fs::read_to_string("/proc/locks").unwrap_or_default();
        for pid in lock_holders_in(&locks, meta.dev(), meta.ino()) {
            if pid != me {
                out.push(PortHolder {
                    pid,
                    command: command_of(pid),
                    locked: true,
                });
            }
        }
    }
    let Ok(procs) = std::fs::read_dir("/proc") else {
        return out;
    };
    for p in procs.flatten() {
        let Some(pid) = p.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
            continue;
        };
        if pid == me || out.iter().any(|h| h.pid == pid) {
            continue;
        }
        let Ok(fds) = std::fs::read_dir(p.path().join("fd")) else {
            continue;
        };
        if fds
            .flatten()
            .any(|fd| std::fs::read_link(fd.path()).is_ok_and(|t| t == node))
        {
            out.push(PortHolder {
                pid,
                command: command_of(pid),
                locked: false,
            });
        }
    }
    out
}

/// The port's holders in words, for an error: "held by pid 42 (handgate run ...)".
pub fn describe(holders: &[PortHolder]) -> String {
    if holders.is_empty() {
        return "held by another process (not visible in /proc: another user's or container's)".into();
    }
    let list: Vec<String> = holders.iter().map(|h| h.to_string()).collect();
    format!("held by {}", list.join(", "))
}

/// The latency timer of the USB serial adapter behind `path`, ms, where its driver has one
/// (FTDI: `/sys/bus/usb-serial/devices/ttyUSB0/latency_timer`); `None`: not such an adapter.
pub fn latency_timer_ms(path: &Path) -> Option<u32> {
    let node = node(path);
    let tty = node.file_name()?.to_str()?;
    let s = std::fs::read_to_string(format!("/sys/bus/usb-serial/devices/{tty}/latency_timer")).ok()?;
    s.trim().parse().ok()
}

/// The udev rule that sets an FTDI adapter's latency timer to 1 ms on plug-in (shipped as
/// profiles/udev/99-handgate-ftdi-latency.rules).
pub const LATENCY_RULE: &str = "profiles/udev/99-handgate-ftdi-latency.rules";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lock_lines_name_the_pid_holding_the_inode() {
        let dev = libc::makedev(0, 5);
        let locks = "1: FLOCK  ADVISORY  WRITE 4242 00:05:123 0 EOF\n\
                     1: -> FLOCK  ADVISORY  WRITE 4343 00:05:123 0 EOF\n\
                     2: POSIX  ADVISORY  WRITE 99 fd:01:123 0 EOF\n\
                     3: FLOCK  ADVISORY  WRITE 77 00:05:124 0 EOF\n";
        assert_eq!(lock_holders_in(locks, dev, 123), vec![4242, 4343]);
        assert_eq!(lock_holders_in(locks, dev, 124), vec![77]);
        assert!(lock_holders_in("garbage\n1: FLOCK", dev, 123).is_empty());
    }

    #[test]
    fn a_pty_held_by_this_process_and_a_child_names_the_child() {
        let pty = super::super::Pty::open().unwrap();
        let mut child = std::process::Command::new("sleep")
            .arg("30")
            .stdin(std::fs::File::open(pty.slave_path()).unwrap())
            .spawn()
            .unwrap();
        // The child holds the slave on its stdin once it runs: wait for /proc to show it.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        let found = loop {
            let h = holders(pty.slave_path());
            if h.iter().any(|h| h.pid == child.id()) || std::time::Instant::now() > deadline {
                break h;
            }
            std::thread::yield_now();
        };
        child.kill().unwrap();
        child.wait().unwrap();
        let h = found
            .iter()
            .find(|h| h.pid == child.id())
            .expect("the child is a holder");
        assert!(h.command.starts_with("sleep 30"), "{h}");
        assert!(!h.locked);
        assert!(found.iter().all(|h| h.pid != std::process::id()), "never this process");
    }
}
