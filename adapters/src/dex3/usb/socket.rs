//! The emulator as a separate process behind a Unix domain socket, and the matching client
//! transport, so end-to-end tests can kill and restart "the hand".
//!
//! Wire format on the socket (ours, not Unitree's): client → server `u32 seq (LE)` + the
//! 1234-byte command frame; server → client `u32 seq (LE)` + the 1270-byte state frame. The
//! sequence number lets the client discard a reply that arrives after its exchange timed out.

use super::codec::{CMD_FRAME_LEN, STATE_FRAME_LEN};
use super::emulator::{lock, Dex3Emulator, EmulatorConfig, Reply, SharedEmulator};
use super::transport::{Dex3Transport, TransportError, TransportFactory};
use crate::dex3::Side;
use std::io::{ErrorKind, Read, Write};
use std::os::unix::fs::FileTypeExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use thiserror::Error;

const REQ_LEN: usize = 4 + CMD_FRAME_LEN;
const REP_LEN: usize = 4 + STATE_FRAME_LEN;

/// Client side: a [`Dex3Transport`] over a Unix socket.
pub struct UnixSocketTransport {
    path: PathBuf,
    stream: UnixStream,
    seq: u32,
    rx: Vec<u8>,
}

impl UnixSocketTransport {
    pub fn connect(path: &Path) -> Result<Self, TransportError> {
        let stream = UnixStream::connect(path).map_err(|e| match e.kind() {
            ErrorKind::NotFound | ErrorKind::ConnectionRefused => {
                TransportError::NotFound(format!("no emulator listening on {}", path.display()))
            }
            ErrorKind::PermissionDenied => TransportError::PermissionDenied(path.display().to_string()),
            _ => TransportError::Io(e),
        })?;
        Ok(Self {
            path: path.to_owned(),
            stream,
            seq: 0,
            rx: Vec::with_capacity(2 * REP_LEN),
        })
    }

    /// A factory for the device loop.
    pub fn factory(path: PathBuf) -> TransportFactory {
        Box::new(move || Ok(Box::new(UnixSocketTransport::connect(&path)?) as Box<dyn Dex3Transport>))
    }
}

fn io_to_transport(e: std::io::Error, timeout: Duration) -> TransportError {
    match e.kind() {
        ErrorKind::WouldBlock | ErrorKind::TimedOut => TransportError::Timeout(timeout),
        ErrorKind::BrokenPipe
        | ErrorKind::ConnectionReset
        | ErrorKind::ConnectionAborted
        | ErrorKind::UnexpectedEof => TransportError::Disconnected,
        _ => TransportError::Io(e),
    }
}

impl Dex3Transport for UnixSocketTransport {
    fn exchange(
        &mut self,
        cmd: &[u8; CMD_FRAME_LEN],
        state: &mut [u8; STATE_FRAME_LEN],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let deadline = Instant::now() + timeout;
        self.seq = self.seq.wrapping_add(1);
        let mut req = [0u8; REQ_LEN];
        req[..4].copy_from_slice(&self.seq.to_le_bytes());
        req[4..].copy_from_slice(cmd);
        self.stream
            .set_write_timeout(Some(timeout.max(Duration::from_millis(1))))
            .map_err(TransportError::Io)?;
        self.stream.write_all(&req).map_err(|e| io_to_transport(e, timeout))?;
        let mut buf = [0u8; REP_LEN];
        loop {
            // Whole replies already buffered: take ours, drop late ones.
            while self.rx.len() >= REP_LEN {
                let seq = u32::from_le_bytes([self.rx[0], self.rx[1], self.rx[2], self.rx[3]]);
                if seq == self.seq {
                    state.copy_from_slice(&self.rx[4..REP_LEN]);
                    self.rx.drain(..REP_LEN);
                    return Ok(());
                }
                self.rx.drain(..REP_LEN);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(TransportError::Timeout(timeout));
            }
            self.stream.set_read_timeout(Some(left)).map_err(TransportError::Io)?;
            match self.stream.read(&mut buf) {
                Ok(0) => return Err(TransportError::Disconnected),
                Ok(n) => self.rx.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(io_to_transport(e, timeout)),
            }
        }
    }

    fn describe(&self) -> String {
        format!("Dex3-1 emulator at {}", self.path.display())
    }
}

#[derive(Debug, Error)]
pub enum EmulatorServerError {
    #[error("cannot bind {path}: {source}")]
    Bind { path: String, source: std::io::Error },
    #[error("{0} exists and is not a socket; refusing to remove it")]
    NotASocket(String),
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
}

fn bind(path: &Path) -> Result<UnixListener, EmulatorServerError> {
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        if meta.file_type().is_socket() {
            std::fs::remove_file(path)?;
        } else {
            return Err(EmulatorServerError::NotASocket(path.display().to_string()));
        }
    }
    UnixListener::bind(path).map_err(|source| EmulatorServerError::Bind {
        path: path.display().to_string(),
        source,
    })
}

/// Serves one client until it disconnects or `stop` is set.
fn serve_client(mut stream: UnixStream, emu: &SharedEmulator, stop: &AtomicBool) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_millis(50)))?;
    let mut rx: Vec<u8> = Vec::with_capacity(2 * REQ_LEN);
    let mut buf = [0u8; REQ_LEN];
    let mut reply = [0u8; REP_LEN];
    let mut state = [0u8; STATE_FRAME_LEN];
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => rx.extend_from_slice(&buf[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => return Err(e),
        }
        while rx.len() >= REQ_LEN {
            let seq = [rx[0], rx[1], rx[2], rx[3]];
            let outcome = {
                let mut e = lock(emu);
                if !e.is_plugged() {
                    return Ok(()); // cable pulled: drop the link
                }
                if let Some(left) = e.stall_remaining() {
                    // Stalled: the command is lost, nothing comes back. Sleep in short steps so
                    // a stop request is still seen.
                    drop(e);
                    std::thread::sleep(left.min(Duration::from_millis(50)));
                    None
                } else {
                    Some(e.handle_frame(&rx[4..REQ_LEN], &mut state))
                }
            };
            rx.drain(..REQ_LEN);
            if outcome == Some(Reply::Frame) {
                reply[..4].copy_from_slice(&seq);
                reply[4..].copy_from_slice(&state);
                stream.write_all(&reply)?;
            }
        }
    }
    Ok(())
}

fn serve(listener: UnixListener, emu: SharedEmulator, stop: Arc<AtomicBool>) -> Result<(), EmulatorServerError> {
    for conn in listener.incoming() {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let stream = match conn {
            Ok(s) => s,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(e.into()),
        };
        if !lock(&emu).is_plugged() {
            continue; // unplugged: refuse
        }
        tracing::info!("dex3 emulator: client connected");
        if let Err(e) = serve_client(stream, &emu, &stop) {
            tracing::info!("dex3 emulator: client link ended: {e}");
        }
    }
    Ok(())
}

/// Runs the emulated hand on a Unix socket at `path` until the process ends (what
/// `handgate emulate dex3 --side SIDE --socket PATH` runs). Serves one client at a time; a new
/// client finds the hand as the previous one left it (as a still-powered hand after a USB
/// replug).
pub fn run_emulator_server(path: &Path, side: Side, config: EmulatorConfig) -> Result<(), EmulatorServerError> {
    let listener = bind(path)?;
    let emu = Arc::new(Mutex::new(Dex3Emulator::new(side, config)));
    serve(listener, emu, Arc::new(AtomicBool::new(false)))
}

/// An emulator server on a background thread (for tests and embedding).
pub struct EmulatorServer {
    path: PathBuf,
    emu: SharedEmulator,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), EmulatorServerError>>>,
}

impl EmulatorServer {
    /// Binds `path` and serves on a thread.
    pub fn spawn(path: &Path, side: Side, config: EmulatorConfig) -> Result<Self, EmulatorServerError> {
        let listener = bind(path)?;
        let emu = Arc::new(Mutex::new(Dex3Emulator::new(side, config)));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (emu, stop) = (emu.clone(), stop.clone());
            std::thread::Builder::new()
                .name("dex3-emu-server".into())
                .spawn(move || serve(listener, emu, stop))?
        };
        Ok(Self {
            path: path.to_owned(),
            emu,
            stop,
            thread: Some(thread),
        })
    }

    /// The emulated hand (inspect it, inject faults).
    pub fn emulator(&self) -> &SharedEmulator {
        &self.emu
    }

    /// Stops serving and removes the socket file.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // Wake a blocking accept().
        let _ = UnixStream::connect(&self.path);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = std::fs::remove_file(&self.path);
    }
}

impl Drop for EmulatorServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex3::usb::codec::{LinuxToMcuCmd, McuToLinuxState};

    fn sock(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("hg-dex3-{}-{name}.sock", std::process::id()))
    }

    #[test]
    fn exchange_over_socket() {
        let path = sock("x");
        let server = EmulatorServer::spawn(&path, Side::Left, EmulatorConfig::default()).unwrap();
        let mut t = UnixSocketTransport::connect(&path).unwrap();
        let cmd = LinuxToMcuCmd::default().encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        for _ in 0..5 {
            t.exchange(&cmd, &mut out, Duration::from_secs(5)).unwrap();
            McuToLinuxState::decode(&out).unwrap();
        }
        assert_eq!(lock(server.emulator()).stats().frames_ok, 5);
        server.stop();
        assert!(!path.exists());
    }

    #[test]
    fn dropped_reply_times_out_then_resyncs() {
        let path = sock("drop");
        let server = EmulatorServer::spawn(&path, Side::Right, EmulatorConfig::default()).unwrap();
        let mut t = UnixSocketTransport::connect(&path).unwrap();
        let cmd = LinuxToMcuCmd::default().encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        t.exchange(&cmd, &mut out, Duration::from_secs(5)).unwrap();
        lock(server.emulator()).drop_replies(1);
        assert!(matches!(
            t.exchange(&cmd, &mut out, Duration::from_millis(30)),
            Err(TransportError::Timeout(_))
        ));
        t.exchange(&cmd, &mut out, Duration::from_secs(5)).unwrap();
        McuToLinuxState::decode(&out).unwrap();
    }

    #[test]
    fn server_gone_is_disconnect_and_not_found() {
        let path = sock("gone");
        let server = EmulatorServer::spawn(&path, Side::Right, EmulatorConfig::default()).unwrap();
        let mut t = UnixSocketTransport::connect(&path).unwrap();
        let cmd = LinuxToMcuCmd::default().encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        t.exchange(&cmd, &mut out, Duration::from_secs(5)).unwrap();
        server.stop();
        let err = t.exchange(&cmd, &mut out, Duration::from_secs(5)).unwrap_err();
        assert!(err.needs_reconnect(), "{err:?}");
        assert!(matches!(
            UnixSocketTransport::connect(&path),
            Err(TransportError::NotFound(_))
        ));
    }

    #[test]
    fn stalled_server_still_stops() {
        let path = sock("stall");
        let server = EmulatorServer::spawn(&path, Side::Right, EmulatorConfig::default()).unwrap();
        let mut t = UnixSocketTransport::connect(&path).unwrap();
        let cmd = LinuxToMcuCmd::default().encode();
        let mut out = [0u8; STATE_FRAME_LEN];
        lock(server.emulator()).stall_for(Duration::from_secs(3600));
        assert!(matches!(
            t.exchange(&cmd, &mut out, Duration::from_millis(20)),
            Err(TransportError::Timeout(_))
        ));
        server.stop();
    }

    #[test]
    fn refuses_to_remove_a_regular_file() {
        let path = sock("file");
        std::fs::write(&path, b"x").unwrap();
        assert!(matches!(
            EmulatorServer::spawn(&path, Side::Right, EmulatorConfig::default()),
            Err(EmulatorServerError::NotASocket(_))
        ));
        std::fs::remove_file(&path).unwrap();
    }
}
