//! A pseudo-terminal pair whose slave is reachable through a stable symlink, so the driver
//! opens "a serial port" exactly as it would open /dev/ttyUSB0, and an unplug (closing the
//! master and removing the link) and a replug (a new pair, the same link) look to the driver
//! like a USB adapter going away and coming back.

use std::ffi::CStr;
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::path::{Path, PathBuf};

use super::transport::set_raw;

/// One open pty pair. Dropping it closes both ends held here (the driver may still hold the
/// slave; it then reads EOF/EIO).
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    /// Held open so the master never sees EIO while the driver has the slave closed.
    _slave: OwnedFd,
    slave_path: PathBuf,
}

impl Pty {
    /// Opens a new pair with the slave in raw mode.
    pub fn open() -> io::Result<Self> {
        // SAFETY: posix_openpt has no memory preconditions.
        let m = unsafe { libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC) };
        if m < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: m is a fresh fd owned by nobody else.
        let master = unsafe { OwnedFd::from_raw_fd(m) };
        // SAFETY: valid master fd.
        if unsafe { libc::grantpt(m) } != 0 || unsafe { libc::unlockpt(m) } != 0 {
            return Err(io::Error::last_os_error());
        }
        let mut buf = [0 as libc::c_char; 128];
        // SAFETY: buf is writable for buf.len() bytes.
        let r = unsafe { libc::ptsname_r(m, buf.as_mut_ptr(), buf.len()) };
        if r != 0 {
            return Err(io::Error::from_raw_os_error(r));
        }
        // SAFETY: ptsname_r wrote a NUL-terminated string into buf.
        let name = unsafe { CStr::from_ptr(buf.as_ptr()) }.to_owned();
        // SAFETY: name is NUL-terminated.
        let s = unsafe { libc::open(name.as_ptr(), libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC) };
        if s < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: s is a fresh fd.
        let slave = unsafe { OwnedFd::from_raw_fd(s) };
        set_raw(slave.as_raw_fd(), Some(libc::B1000000))?;
        set_nonblocking(master.as_raw_fd())?;
        Ok(Self {
            master,
            _slave: slave,
            slave_path: PathBuf::from(name.to_string_lossy().into_owned()),
        })
    }

    pub fn slave_path(&self) -> &Path {
        &self.slave_path
    }

    pub fn master_fd(&self) -> libc::c_int {
        self.master.as_raw_fd()
    }

    /// Writes all bytes to the master (they appear on the slave).
    pub fn write_all(&self, mut bytes: &[u8]) -> io::Result<()> {
        while !bytes.is_empty() {
            // SAFETY: bytes is valid for bytes.len().
            let n = unsafe { libc::write(self.master.as_raw_fd(), bytes.as_ptr().cast(), bytes.len()) };
            if n < 0 {
                let e = io::Error::last_os_error();
                match e.kind() {
                    io::ErrorKind::Interrupted => continue,
                    io::ErrorKind::WouldBlock => {
                        std::thread::yield_now();
                        continue;
                    }
                    _ => return Err(e),
                }
            }
            bytes = &bytes[n as usize..];
        }
        Ok(())
    }

    /// Reads what is there (non-blocking); Ok(0) when nothing is.
    pub fn read(&self, buf: &mut [u8]) -> io::Result<usize> {
        // SAFETY: buf is valid for buf.len().
        let n = unsafe { libc::read(self.master.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if n < 0 {
            let e = io::Error::last_os_error();
            if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) {
                return Ok(0);
            }
            return Err(e);
        }
        Ok(n as usize)
    }
}

fn set_nonblocking(fd: libc::c_int) -> io::Result<()> {
    // SAFETY: valid fd; F_GETFL/F_SETFL take int arguments.
    let fl = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    if fl < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, fl | libc::O_NONBLOCK) } < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// Points `link` at `target`, replacing an existing link atomically.
pub fn replace_symlink(target: &Path, link: &Path) -> io::Result<()> {
    let tmp = link.with_extension(format!("tmp{}", std::process::id()));
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp)?;
    std::fs::rename(&tmp, link)
}
