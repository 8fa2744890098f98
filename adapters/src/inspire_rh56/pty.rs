//! An emulated RH56 line on a pseudo-terminal (`handgate emulate inspire_rh56`): a program
//! opens the link as it opens /dev/ttyUSB0 and talks the serial protocol (or Modbus RTU,
//! `--modbus`) to the hands on it. Garbage and bad checksums are skipped and counted; a request
//! for an id nobody has gets no answer, as on a real line. [`TcpLine`]: the hands over Modbus
//! TCP (`--tcp`), as a DFTP's Ethernet port serves them.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use super::config::Protocol;
use super::emulator::Line;
use super::modbus::{answer_tcp, HandMap};
use super::proto::{self, FrameError};
use crate::modbus::{rtu, RtuError};
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
    /// Starts `line` on a new pty linked at `link`, answering the serial protocol.
    pub fn start(link: &Path, line: Line) -> std::io::Result<Self> {
        Self::start_with(link, line, Protocol::Serial)
    }

    /// Starts `line` on a new pty linked at `link`, answering `protocol` (serial or Modbus RTU).
    pub fn start_with(link: &Path, line: Line, protocol: Protocol) -> std::io::Result<Self> {
        let pty = Pty::open()?;
        replace_symlink(pty.slave_path(), link)?;
        let line = Arc::new(Mutex::new(line));
        let counters = Arc::new(PtyCounters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (l, c, s) = (line.clone(), counters.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("rh56-emu".into())
            .spawn(move || serve(pty, l, c, s, protocol))?;
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

fn serve(pty: Pty, line: Arc<Mutex<Line>>, c: Arc<PtyCounters>, stop: Arc<AtomicBool>, protocol: Protocol) {
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
        if protocol == Protocol::ModbusRtu {
            modbus_rtu(&mut inbox, &line, &c, &pty, &mut out);
            continue;
        }
        loop {
            match proto::decode_request(&inbox) {
                Ok((req, used)) => {
                    c.requests.fetch_add(1, Ordering::Relaxed);
                    let answered =
                        line.lock()
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

/// Answers the Modbus RTU requests in `inbox` (a frame with a bad CRC is dropped, counted).
fn modbus_rtu(inbox: &mut Vec<u8>, line: &Mutex<Line>, c: &PtyCounters, pty: &Pty, out: &mut Vec<u8>) {
    loop {
        match rtu::decode_request(inbox) {
            Ok(f) => {
                c.requests.fetch_add(1, Ordering::Relaxed);
                out.clear();
                let mut line = line.lock().unwrap_or_else(|p| p.into_inner());
                match line.hand_mut(f.slave) {
                    Some(h) => {
                        h.step(Instant::now());
                        let begin = rtu::begin(out, f.slave);
                        let _ = crate::modbus::server::respond(&mut HandMap(h), f.pdu, true, out, &mut |_| {});
                        rtu::finish(out, begin);
                        c.answered.fetch_add(1, Ordering::Relaxed);
                        let _ = pty.write_all(out);
                    }
                    None => {
                        c.unanswered.fetch_add(1, Ordering::Relaxed);
                    }
                }
                let n = f.len;
                inbox.drain(..n);
            }
            Err(RtuError::Incomplete { .. }) => return,
            Err(RtuError::BadCrc { len, .. }) => {
                c.bad_checksum.fetch_add(1, Ordering::Relaxed);
                inbox.drain(..len.min(inbox.len()));
            }
            Err(_) => {
                c.garbage.fetch_add(1, Ordering::Relaxed);
                inbox.clear();
                return;
            }
        }
    }
}

/// Emulated hands over Modbus TCP (one listener, a thread per client); each unit id is the
/// hand with that id. Stops when dropped.
pub struct TcpLine {
    pub addr: std::net::SocketAddr,
    pub line: Arc<Mutex<Line>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl TcpLine {
    pub fn start(bind: std::net::SocketAddr, line: Line) -> std::io::Result<Self> {
        let listener = std::net::TcpListener::bind(bind)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let line = Arc::new(Mutex::new(line));
        let stop = Arc::new(AtomicBool::new(false));
        let (l, s) = (line.clone(), stop.clone());
        let thread = std::thread::Builder::new().name("rh56-emu-tcp".into()).spawn(move || {
            while !s.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let (l, s) = (l.clone(), s.clone());
                        let _ = std::thread::Builder::new()
                            .name("rh56-emu-client".into())
                            .spawn(move || tcp_client(stream, &l, &s));
                    }
                    Err(_) => std::thread::sleep(std::time::Duration::from_millis(20)),
                }
            }
        })?;
        Ok(TcpLine {
            addr,
            line,
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for TcpLine {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn tcp_client(mut stream: std::net::TcpStream, line: &Mutex<Line>, stop: &AtomicBool) {
    use std::io::{Read, Write};
    let _ = stream.set_nodelay(true);
    let _ = stream.set_read_timeout(Some(std::time::Duration::from_millis(100)));
    let (mut inbox, mut out, mut buf) = (Vec::with_capacity(512), Vec::with_capacity(512), [0u8; 512]);
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => inbox.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => continue,
            Err(_) => return,
        }
        loop {
            out.clear();
            let unit = inbox.get(6).copied().unwrap_or(0);
            let mut l = line.lock().unwrap_or_else(|p| p.into_inner());
            let used = match l.hand_mut(unit) {
                Some(h) => {
                    h.step(Instant::now());
                    answer_tcp(&mut HandMap(h), &inbox, &mut out)
                }
                // No hand with this unit id: the frame is not answered.
                None => match crate::modbus::tcp::decode(&inbox) {
                    Ok(adu) => Ok(adu.len),
                    Err(crate::modbus::TcpError::Incomplete { .. }) => Ok(0),
                    Err(e) => Err(crate::front::stream::StreamError::new(e.reason(), e.to_string())),
                },
            };
            drop(l);
            match used {
                Ok(0) => break,
                Ok(n) => {
                    inbox.drain(..n);
                }
                Err(e) => {
                    let n = e.skip.unwrap_or(inbox.len());
                    inbox.drain(..n.min(inbox.len()));
                }
            }
            if !out.is_empty() && stream.write_all(&out).is_err() {
                return;
            }
        }
    }
}
