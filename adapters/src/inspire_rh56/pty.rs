//! An emulated RH56 line on a pseudo-terminal (`handgate emulate inspire_rh56`): a program
//! opens the link as it opens /dev/ttyUSB0 and talks the serial protocol to the hands on it.
//! Garbage and bad checksums are skipped to the next header byte and counted; a request for
//! an id nobody has gets no answer, as on a real line.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use super::emulator::Line;
use super::proto::{self, FrameError};
use crate::serial::{replace_symlink, Pty};

/// What the pty line refused, by reason.
#[derive(Debug, Default)]
pub struct PtyCounters {
    pub requests: AtomicU64,
    pub answered: AtomicU64,
    pub bad_checksum: AtomicU64,
    pub garbage: AtomicU64,
    pub malformed: AtomicU64,
    /// Requests for an id no hand on the line has (or reads outside the register file).
    pub unanswered: AtomicU64,
}

/// A running emulated line behind a pty; stops when dropped.
pub struct PtyLine {
    link: PathBuf,
    pub line: Arc<Mutex<Line>>,
    pub counters: Arc<PtyCounters>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl PtyLine {
    /// Starts `line` on a new pty linked at `link`.
    pub fn start(link: &Path, line: Line) -> std::io::Result<Self> {
        let pty = Pty::open()?;
        replace_symlink(pty.slave_path(), link)?;
        let line = Arc::new(Mutex::new(line));
        let counters = Arc::new(PtyCounters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (l, c, s) = (line.clone(), counters.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("rh56-emu".into())
            .spawn(move || serve(pty, l, c, s))?;
        Ok(PtyLine {
            link: link.to_path_buf(),
            line,
            counters,
            stop,
            thread: Some(thread),
        })
    }

    pub fn path(&self) -> &Path {
        &self.link
    }
}

impl Drop for PtyLine {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = std::fs::remove_file(&self.link);
    }
}

fn serve(pty: Pty, line: Arc<Mutex<Line>>, c: Arc<PtyCounters>, stop: Arc<AtomicBool>) {
    let mut inbox: Vec<u8> = Vec::with_capacity(1024);
    let mut out: Vec<u8> = Vec::with_capacity(512);
    let mut buf = [0u8; 512];
    let mut logged = false;
    while !stop.load(Ordering::Relaxed) {
        let mut pfd = libc::pollfd {
            fd: pty.master_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        let r = unsafe { libc::poll(&mut pfd, 1, 50) };
        if r <= 0 {
            continue;
        }
        let n = match pty.read(&mut buf) {
            Ok(n) => n,
            Err(_) => {
                // EIO while nobody holds the slave: wait for the next opener.
                std::thread::sleep(std::time::Duration::from_millis(20));
                continue;
            }
        };
        inbox.extend_from_slice(&buf[..n]);
        loop {
            match proto::decode_request(&inbox) {
                Ok((req, used)) => {
                    c.requests.fetch_add(1, Ordering::Relaxed);
                    let answered = line
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .answer(&req, Instant::now(), &mut out);
                    if answered {
                        c.answered.fetch_add(1, Ordering::Relaxed);
                        let _ = pty.write_all(&out);
                    } else {
                        c.unanswered.fetch_add(1, Ordering::Relaxed);
                    }
                    inbox.drain(..used);
                }
                Err(FrameError::Incomplete { .. }) => break,
                Err(e) => {
                    match e {
                        FrameError::BadChecksum { .. } => &c.bad_checksum,
                        FrameError::Malformed(_) => &c.malformed,
                        _ => &c.garbage,
                    }
                    .fetch_add(1, Ordering::Relaxed);
                    if !logged {
                        tracing::warn!(reason = e.reason(), error = %e, "RH56 emulator: bad input skipped (logged once)");
                        logged = true;
                    }
                    let skip = proto::resync(&inbox);
                    inbox.drain(..skip);
                }
            }
        }
    }
}
