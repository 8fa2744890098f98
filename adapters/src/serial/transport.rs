//! The byte-pipe seam between a bus driver and hardware: a [`Transport`] writes bytes and
//! reads bytes with a timeout; a [`Connector`] (re)opens one. [`SerialPort`] is the real
//! implementation (raw termios on a tty via `libc`, 8N1, no flow control), owning its device:
//! `TIOCEXCL` keeps other unprivileged openers out and an advisory `flock` (what pyserial's
//! `exclusive=True` and another handgate take) keeps out everyone who asks, root included; a
//! second opener gets [`TransportError::Busy`] naming the holder. The emulators'
//! pseudo-terminals are opened through the very same code path.

use std::ffi::CString;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Transport failures.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("serial port {path} does not exist (adapter unplugged or wrong path)")]
    NotFound { path: PathBuf },
    /// The OS refused to open the port: EACCES (file permissions: the user lacks the tty's
    /// group, `dialout` on Debian) or EPERM (a device cgroup, e.g. systemd's DevicePolicy=).
    /// `node` is the device node `path` resolves to (`/dev/serial/by-id/...` is a symlink);
    /// `fix` says what to change. Never needs root.
    #[error("permission denied opening serial port {path}{}: {fix}", node_suffix(.path, .node))]
    PermissionDenied {
        path: PathBuf,
        node: PathBuf,
        fix: String,
        #[source]
        source: io::Error,
    },
    /// Another process owns the port (its lock, or `TIOCEXCL` for an unprivileged opener).
    #[error("serial port {path} is in use, {}: one program owns a serial bus; stop it, or let handgate own the port and connect that program to one of handgate's fronts (docs/fronts.md)", super::owner::describe(.holders))]
    Busy {
        path: PathBuf,
        holders: Vec<super::owner::PortHolder>,
    },
    #[error("cannot open serial port {path}: {source}")]
    Open { path: PathBuf, source: io::Error },
    #[error("cannot configure serial port {path}: {source}")]
    Configure { path: PathBuf, source: io::Error },
    #[error("baud rate {0} is not supported by this serial driver")]
    UnsupportedBaud(u32),
    #[error("serial port disconnected")]
    Disconnected,
    #[error("serial I/O error: {0}")]
    Io(#[from] io::Error),
}

/// The group Debian gives USB serial adapters (`/dev/ttyUSB*`, `/dev/ttyACM*`) to.
pub const SERIAL_GROUP: &str = "dialout";

fn node_suffix(path: &Path, node: &Path) -> String {
    if node == path {
        String::new()
    } else {
        format!(" (-> {})", node.display())
    }
}

/// The name of group `gid`, or its number when it has none.
fn group_name(gid: libc::gid_t) -> String {
    // SAFETY: struct group is plain old data; getgrgid_r fills it.
    let mut grp: libc::group = unsafe { std::mem::zeroed() };
    let mut buf = vec![0 as libc::c_char; 4096];
    let mut out: *mut libc::group = std::ptr::null_mut();
    // SAFETY: every pointer is valid for the call; buf outlives the use of grp's strings.
    let rc = unsafe { libc::getgrgid_r(gid, &mut grp, buf.as_mut_ptr(), buf.len(), &mut out) };
    if rc == 0 && !out.is_null() && !grp.gr_name.is_null() {
        // SAFETY: gr_name points into buf, NUL-terminated by getgrgid_r.
        unsafe { std::ffi::CStr::from_ptr(grp.gr_name) }
            .to_string_lossy()
            .into_owned()
    } else {
        gid.to_string()
    }
}

/// Builds the permission error for `path`: what was refused and how to fix it without root.
fn permission_error(path: &Path, source: io::Error) -> TransportError {
    use std::os::unix::fs::MetadataExt;
    let node = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    // SAFETY: geteuid cannot fail.
    let uid = unsafe { libc::geteuid() };
    let fix = if source.raw_os_error() == Some(libc::EPERM) {
        format!(
            "the device is not allowed to this process (a device cgroup: systemd's DevicePolicy=closed; the \
             shipped unit allows char-ttyUSB and char-ttyACM only). Fix: add a `DeviceAllow=char-<driver> rw` \
             line for {} to the unit (e.g. char-ttyS for a built-in UART), then `systemctl daemon-reload`",
            node.display()
        )
    } else {
        let (group, mode) = match std::fs::metadata(&node) {
            Ok(m) => (
                Some(group_name(m.gid())),
                format!("group {}, mode {:04o}", group_name(m.gid()), m.mode() & 0o7777),
            ),
            Err(_) => (None, "not readable and writable".to_string()),
        };
        let member = format!(
            "the user a member of {SERIAL_GROUP} (`sudo usermod -aG {SERIAL_GROUP} <user>`, then log in again; \
             the systemd unit has SupplementaryGroups={SERIAL_GROUP})"
        );
        let fix = if group.as_deref() == Some(SERIAL_GROUP) {
            format!("make {member}")
        } else {
            format!(
                "give the port to group {SERIAL_GROUP} (Debian's udev does for ttyUSB/ttyACM; a udev rule with \
                 GROUP=\"{SERIAL_GROUP}\" for other adapters) and make {member}"
            )
        };
        format!("{mode}; handgate runs as uid {uid}, which may not read and write it. Fix: {fix}; root is not needed")
    };
    TransportError::PermissionDenied {
        path: path.to_path_buf(),
        node,
        fix,
        source,
    }
}

/// A half-duplex byte pipe to a Dynamixel bus.
pub trait Transport: Send {
    /// Writes all bytes (blocking until the OS took them).
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError>;
    /// Reads what is available, waiting at most `timeout` for the first byte.
    /// `Ok(0)` means the timeout expired with nothing to read.
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError>;
    /// Discards bytes received but not read yet.
    fn clear_input(&mut self) -> Result<(), TransportError>;
}

/// Opens a [`Transport`]; called again after a disconnect.
pub trait Connector: Send {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError>;
    /// What this connects to, for messages.
    fn describe(&self) -> String;
}

/// A serial device path (`/dev/ttyUSB0`, `/dev/serial/by-id/...`, or an emulator's link).
#[derive(Debug, Clone)]
pub struct SerialConnector {
    pub path: PathBuf,
    pub baud: u32,
}

impl Connector for SerialConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(SerialPort::open(&self.path, self.baud)?))
    }
    fn describe(&self) -> String {
        format!("{} @ {} baud", self.path.display(), self.baud)
    }
}

/// A tty in raw 8N1 mode.
#[derive(Debug)]
pub struct SerialPort {
    fd: OwnedFd,
}

fn baud_constant(baud: u32) -> Option<libc::speed_t> {
    Some(match baud {
        9600 => libc::B9600,
        57600 => libc::B57600,
        115200 => libc::B115200,
        1_000_000 => libc::B1000000,
        2_000_000 => libc::B2000000,
        3_000_000 => libc::B3000000,
        4_000_000 => libc::B4000000,
        _ => return None,
    })
}

impl SerialPort {
    /// Opens `path` non-blocking, exclusive, raw, 8N1 at `baud`.
    pub fn open(path: &Path, baud: u32) -> Result<Self, TransportError> {
        let speed = baud_constant(baud).ok_or(TransportError::UnsupportedBaud(baud))?;
        let cpath = CString::new(path.as_os_str().as_encoded_bytes()).map_err(|_| TransportError::Open {
            path: path.to_path_buf(),
            source: io::Error::new(io::ErrorKind::InvalidInput, "path contains NUL"),
        })?;
        // SAFETY: cpath is a valid NUL-terminated string; open has no other preconditions.
        let fd = unsafe {
            libc::open(
                cpath.as_ptr(),
                libc::O_RDWR | libc::O_NOCTTY | libc::O_NONBLOCK | libc::O_CLOEXEC,
            )
        };
        if fd < 0 {
            let e = io::Error::last_os_error();
            return Err(if e.kind() == io::ErrorKind::NotFound {
                TransportError::NotFound {
                    path: path.to_path_buf(),
                }
            } else if e.raw_os_error() == Some(libc::EBUSY) {
                TransportError::Busy {
                    path: path.to_path_buf(),
                    holders: super::owner::holders(path),
                }
            } else if matches!(e.raw_os_error(), Some(libc::EACCES) | Some(libc::EPERM)) {
                permission_error(path, e)
            } else {
                TransportError::Open {
                    path: path.to_path_buf(),
                    source: e,
                }
            });
        }
        // SAFETY: fd was just returned by open and is owned by nobody else.
        let fd = unsafe { OwnedFd::from_raw_fd(fd) };
        let cfg_err = |source| TransportError::Configure {
            path: path.to_path_buf(),
            source,
        };
        // The lock first: a port someone else owns is not reconfigured under them.
        // SAFETY: valid fd; flock has no memory preconditions.
        if unsafe { libc::flock(fd.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
                return Err(TransportError::Busy {
                    path: path.to_path_buf(),
                    holders: super::owner::holders(path),
                });
            }
            return Err(cfg_err(e));
        }
        set_raw(fd.as_raw_fd(), Some(speed)).map_err(cfg_err)?;
        // SAFETY: valid fd; TIOCEXCL takes no argument. Keeps a second unprivileged process
        // off the bus (root is let through: the lock above stops it).
        unsafe { libc::ioctl(fd.as_raw_fd(), libc::TIOCEXCL) };
        let port = SerialPort { fd };
        port.flush_both();
        Ok(port)
    }

    fn flush_both(&self) {
        // SAFETY: valid fd.
        unsafe { libc::tcflush(self.fd.as_raw_fd(), libc::TCIOFLUSH) };
    }
}

/// Puts a tty into raw 8N1 mode without flow control, optionally setting the speed.
pub(crate) fn set_raw(fd: libc::c_int, speed: Option<libc::speed_t>) -> io::Result<()> {
    // SAFETY: termios is plain old data; tcgetattr fills it for a valid fd.
    let mut t: libc::termios = unsafe { std::mem::zeroed() };
    // SAFETY: fd is valid for the duration of the call, t is a valid out pointer.
    if unsafe { libc::tcgetattr(fd, &mut t) } != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: t is a valid termios.
    unsafe { libc::cfmakeraw(&mut t) };
    t.c_cflag |= libc::CLOCAL | libc::CREAD;
    t.c_cflag &= !(libc::CSTOPB | libc::PARENB | libc::CRTSCTS);
    t.c_iflag &= !(libc::IXON | libc::IXOFF | libc::IXANY);
    t.c_cc[libc::VMIN] = 0;
    t.c_cc[libc::VTIME] = 0;
    if let Some(speed) = speed {
        // SAFETY: t is a valid termios.
        if unsafe { libc::cfsetspeed(&mut t, speed) } != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    // SAFETY: fd valid, t valid.
    if unsafe { libc::tcsetattr(fd, libc::TCSANOW, &t) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// Waits until `fd` is readable or `timeout` passes. Ok(true) = readable.
pub(crate) fn poll_readable(fd: libc::c_int, timeout: Duration) -> Result<bool, TransportError> {
    let mut pfd = libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    };
    // Round up so a sub-millisecond timeout still waits.
    let ms = timeout.as_micros().div_ceil(1000).min(i32::MAX as u128) as libc::c_int;
    loop {
        // SAFETY: pfd is a valid pollfd array of length 1.
        let r = unsafe { libc::poll(&mut pfd, 1, ms) };
        if r < 0 {
            let e = io::Error::last_os_error();
            if e.kind() == io::ErrorKind::Interrupted {
                continue;
            }
            return Err(TransportError::Io(e));
        }
        if r == 0 {
            return Ok(false);
        }
        if pfd.revents & libc::POLLIN != 0 {
            return Ok(true);
        }
        if pfd.revents & (libc::POLLHUP | libc::POLLERR | libc::POLLNVAL) != 0 {
            return Err(TransportError::Disconnected);
        }
        return Ok(false);
    }
}

fn map_io(e: io::Error) -> TransportError {
    match e.raw_os_error() {
        Some(libc::EIO) | Some(libc::ENXIO) | Some(libc::ENODEV) | Some(libc::EBADF) => TransportError::Disconnected,
        _ => TransportError::Io(e),
    }
}

impl Transport for SerialPort {
    fn write_all(&mut self, mut bytes: &[u8]) -> Result<(), TransportError> {
        let fd = self.fd.as_raw_fd();
        while !bytes.is_empty() {
            // SAFETY: bytes is a valid readable buffer of the given length.
            let n = unsafe { libc::write(fd, bytes.as_ptr().cast(), bytes.len()) };
            if n < 0 {
                let e = io::Error::last_os_error();
                match e.kind() {
                    io::ErrorKind::Interrupted => continue,
                    io::ErrorKind::WouldBlock => {
                        let mut pfd = libc::pollfd {
                            fd,
                            events: libc::POLLOUT,
                            revents: 0,
                        };
                        // SAFETY: valid pollfd.
                        let r = unsafe { libc::poll(&mut pfd, 1, 100) };
                        if r > 0 && pfd.revents & (libc::POLLHUP | libc::POLLERR) != 0 {
                            return Err(TransportError::Disconnected);
                        }
                        continue;
                    }
                    _ => return Err(map_io(e)),
                }
            }
            bytes = &bytes[n as usize..];
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        let fd = self.fd.as_raw_fd();
        if !poll_readable(fd, timeout)? {
            return Ok(0);
        }
        loop {
            // SAFETY: buf is a valid writable buffer of the given length.
            let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
            if n < 0 {
                let e = io::Error::last_os_error();
                match e.kind() {
                    io::ErrorKind::Interrupted => continue,
                    io::ErrorKind::WouldBlock => return Ok(0),
                    _ => return Err(map_io(e)),
                }
            }
            if n == 0 {
                // Readable but end of file: the device went away.
                return Err(TransportError::Disconnected);
            }
            return Ok(n as usize);
        }
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        // SAFETY: valid fd.
        if unsafe { libc::tcflush(self.fd.as_raw_fd(), libc::TCIFLUSH) } != 0 {
            return Err(map_io(io::Error::last_os_error()));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_port_is_a_clear_error() {
        let e = SerialPort::open(Path::new("/nonexistent/ttyUSB9"), 1_000_000).unwrap_err();
        assert!(matches!(e, TransportError::NotFound { .. }), "{e}");
        assert!(e.to_string().contains("/nonexistent/ttyUSB9"));
    }

    #[test]
    fn permission_errors_name_the_node_and_the_fix() {
        use std::error::Error as _;
        // Built directly: as root (CI) open() never returns EACCES. The binary-level check
        // as an unprivileged user is tests/tests/least_privilege.rs.
        let e = permission_error(Path::new("/dev/null"), io::Error::from_raw_os_error(libc::EACCES));
        let msg = e.to_string();
        for want in [
            "permission denied opening serial port /dev/null",
            "group root, mode 0666; handgate runs as uid",
            "give the port to group dialout",
            "usermod -aG dialout",
            "SupplementaryGroups=dialout",
        ] {
            assert!(msg.contains(want), "missing {want:?} in: {msg}");
        }
        let src = e
            .source()
            .and_then(|s| s.downcast_ref::<io::Error>())
            .map(|s| s.raw_os_error());
        assert_eq!(src, Some(Some(libc::EACCES)));

        let e = permission_error(Path::new("/dev/null"), io::Error::from_raw_os_error(libc::EPERM));
        let msg = e.to_string();
        assert!(
            msg.contains("DevicePolicy=closed") && msg.contains("DeviceAllow=char-"),
            "{msg}"
        );
    }

    #[test]
    fn symlinked_port_names_the_device_node() {
        let dir = std::env::temp_dir().join(format!("handgate-perm-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("by-id-link");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let msg = permission_error(&link, io::Error::from_raw_os_error(libc::EACCES)).to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(msg.contains(&format!("{} (-> /dev/null)", link.display())), "{msg}");
    }

    #[test]
    fn a_second_opener_is_told_the_port_is_busy_and_by_whom() {
        let pty = super::super::Pty::open().unwrap();
        let first = SerialPort::open(pty.slave_path(), 115_200).unwrap();
        // Another process takes the lock the way pyserial's exclusive=True does (flock).
        let e = SerialPort::open(pty.slave_path(), 115_200).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, TransportError::Busy { .. }), "{msg}");
        assert!(
            msg.contains(&format!("serial port {} is in use", pty.slave_path().display())),
            "{msg}"
        );
        drop(first);
        // Closed: the port is free again (the lock goes with the descriptor).
        SerialPort::open(pty.slave_path(), 115_200).unwrap();
    }

    #[test]
    fn a_port_locked_by_another_process_names_that_process() {
        let pty = super::super::Pty::open().unwrap();
        let path = pty.slave_path().to_path_buf();
        // flock(1) from util-linux holds the lock on the port while `sleep` runs.
        let mut child = match std::process::Command::new("flock")
            .arg("--exclusive")
            .arg(&path)
            .args(["sleep", "30"])
            .spawn()
        {
            Ok(c) => c,
            Err(e) => panic!("flock(1) (util-linux) is needed: {e}"),
        };
        let deadline = std::time::Instant::now() + Duration::from_secs(10);
        let e = loop {
            match SerialPort::open(&path, 115_200) {
                Err(e @ TransportError::Busy { .. }) => break e,
                Ok(p) if std::time::Instant::now() < deadline => {
                    drop(p);
                    std::thread::yield_now();
                }
                other => panic!("the lock never showed: {other:?}"),
            }
        };
        child.kill().unwrap();
        child.wait().unwrap();
        let TransportError::Busy { holders, .. } = &e else {
            unreachable!()
        };
        assert!(holders.iter().any(|h| h.locked && h.pid == child.id()), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("held by pid {} (flock --exclusive", child.id())),
            "{e}"
        );
    }

    #[test]
    fn unsupported_baud_is_rejected() {
        let e = SerialPort::open(Path::new("/dev/null"), 12345).unwrap_err();
        assert!(matches!(e, TransportError::UnsupportedBaud(12345)));
    }
}
