//! Byte-stream fronts: a device's own interface served over TCP or on a pseudo-terminal (a
//! Modbus register map, a Dynamixel bus, a vendor's text socket), so its unmodified clients
//! connect to handgate instead of the port handgate owns.
//!
//! A protocol is a [`Session`] (one per connection or pty): it takes the bytes received,
//! answers complete requests from the front's state image and hands commands to the front's
//! [`Inbox`], where the runtime's front task checks them like any front's (tables, limits,
//! one commanding client, silence). The servers here only move bytes: a thread per connection
//! (capped), idle connections closed, garbage and overflows discarded, every refusal logged
//! once per client and counted per front and reason ([`StreamCounters`], in `/metrics`).
//! Each connection is its own writer for the ownership rules ([`WriterInfo::label`] names it).

use std::collections::BTreeMap;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::serve::Inbox;
use crate::dds::WriterInfo;
use crate::serial::Pty;

/// Why a session refused its input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StreamError {
    /// The counter key (`bad_crc`, `wrong_slave`, `garbage`, ...).
    pub reason: &'static str,
    /// What was wrong, for the log line.
    pub detail: String,
    /// Bytes to discard (the bad request, where the protocol can tell where it ends: a line);
    /// `None`: everything buffered.
    pub skip: Option<usize>,
}

impl StreamError {
    /// Garbage whose end is unknown: every buffered byte is discarded.
    pub fn new(reason: &'static str, detail: impl Into<String>) -> Self {
        Self {
            reason,
            detail: detail.into(),
            skip: None,
        }
    }

    /// A bad request `len` bytes long: discarded, and what follows it is read on.
    pub fn skipping(len: usize, reason: &'static str, detail: impl Into<String>) -> Self {
        Self {
            skip: Some(len),
            ..Self::new(reason, detail)
        }
    }
}

impl std::fmt::Display for StreamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.reason, self.detail)
    }
}

/// A protocol served over one byte stream.
pub trait Session: Send + 'static {
    /// What its commands become: the front's `TypedIo::Msg` (front/serve.rs).
    type Msg: Send + 'static;
    /// `input`: the bytes received and not yet consumed. Answers complete requests into `out`,
    /// hands each command to `sink`, returns how many bytes it consumed (called again while
    /// it consumes and bytes remain; the rest stays buffered for the next read). `Err`: the
    /// input is garbage (counted, logged once per client and reason); the server discards
    /// what the error says ([`StreamError::skip`]) and goes on.
    fn on_bytes(
        &mut self,
        input: &[u8],
        now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(Self::Msg),
    ) -> Result<usize, StreamError>;
    /// No byte arrived for this long after a partial request: the request is abandoned
    /// (Modbus RTU's 3.5 characters). `None`: keep waiting (a line protocol).
    fn gap(&self) -> Option<Duration> {
        None
    }
}

/// What a stream server allows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamLimits {
    /// Clients served at once; one more is refused (closed at once, counted).
    pub max_clients: usize,
    /// A connection that sends nothing for this long is closed (counted).
    pub idle: Duration,
    /// Bytes buffered for one unfinished request at most; beyond, they are discarded.
    pub max_buffer: usize,
}

impl Default for StreamLimits {
    fn default() -> Self {
        Self {
            max_clients: 16,
            idle: Duration::from_secs(60),
            max_buffer: 4096,
        }
    }
}

/// A stream front's counters (one per front, in `/metrics` as `handgate_stream_*`).
#[derive(Debug, Default)]
pub struct StreamCounters {
    /// Connections accepted (a pty counts once).
    pub accepted: AtomicU64,
    /// Connections open now.
    pub open: AtomicU64,
    /// Requests a session answered or took (counted by the server per `on_bytes` consumption).
    pub bytes_in: AtomicU64,
    /// Commands handed to the front (and dropped because its queue was full).
    pub commands: AtomicU64,
    pub commands_dropped: AtomicU64,
    /// Refusals by reason: `garbage`, `bad_crc`, `partial_frame`, `overlong`, `idle`,
    /// `too_many_clients`, and the sessions' own.
    refused: Mutex<BTreeMap<&'static str, u64>>,
}

impl StreamCounters {
    pub fn refuse(&self, reason: &'static str) {
        *self
            .refused
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .entry(reason)
            .or_default() += 1;
    }

    /// Refusals by reason.
    pub fn refused(&self) -> BTreeMap<&'static str, u64> {
        self.refused.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Refusals of one reason.
    pub fn refused_of(&self, reason: &str) -> u64 {
        self.refused().get(reason).copied().unwrap_or(0)
    }
}

/// A running stream front, as `/metrics` and `status` list it.
#[derive(Debug, Clone)]
pub struct StreamEntry {
    /// The front's name (its log name).
    pub front: String,
    /// Where it serves: `tcp 127.0.0.1:54321`, `pty /tmp/...`.
    pub at: String,
    pub counters: Arc<StreamCounters>,
}

fn registry() -> &'static Mutex<Vec<StreamEntry>> {
    static R: OnceLock<Mutex<Vec<StreamEntry>>> = OnceLock::new();
    R.get_or_init(Mutex::default)
}

/// The stream fronts running in this process.
pub fn running() -> Vec<StreamEntry> {
    registry().lock().unwrap_or_else(|p| p.into_inner()).clone()
}

static NEXT_CLIENT: AtomicU64 = AtomicU64::new(1);

/// A stream client's writer handle: never a DDS instance handle nor a dashboard page's
/// (those carry the top bit; stream clients the next one).
fn next_client_handle() -> u64 {
    (1 << 62) | NEXT_CLIENT.fetch_add(1, Ordering::Relaxed)
}

/// A running server; dropping it stops it (the listener closed, the pty link removed) and
/// joins its threads.
#[derive(Debug)]
pub struct StreamServer {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    /// Where it serves (the bound address or the pty link).
    pub at: String,
    /// The bound TCP address (port 0 in a profile resolves here).
    pub local_addr: Option<SocketAddr>,
    /// The pty link clients open.
    pub link: Option<PathBuf>,
    pub counters: Arc<StreamCounters>,
    front: String,
}

impl Drop for StreamServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        if let Some(link) = &self.link {
            let _ = std::fs::remove_file(link);
        }
        let mut r = registry().lock().unwrap_or_else(|p| p.into_inner());
        r.retain(|e| !(e.front == self.front && e.at == self.at));
    }
}

/// How often blocked threads look at the stop flag.
const POLL: Duration = Duration::from_millis(50);

/// One client's byte loop state: its buffer, the time of its last byte, its identity.
struct Client<S: Session> {
    session: S,
    buf: Vec<u8>,
    out: Vec<u8>,
    last_byte: Instant,
    writer: Arc<WriterInfo>,
    /// Reasons already logged for this client (each once).
    logged: Vec<&'static str>,
}

impl<S: Session> Client<S> {
    fn new(session: S, label: String, limits: &StreamLimits) -> Self {
        Self {
            session,
            buf: Vec::with_capacity(limits.max_buffer),
            out: Vec::with_capacity(1024),
            last_byte: Instant::now(),
            writer: Arc::new(WriterInfo {
                handle: next_client_handle(),
                label: Some(label),
                ..WriterInfo::default()
            }),
            logged: Vec::new(),
        }
    }

    fn refuse(&mut self, front: &str, counters: &StreamCounters, reason: &'static str, detail: &str) {
        counters.refuse(reason);
        if !self.logged.contains(&reason) {
            self.logged.push(reason);
            tracing::warn!(
                front,
                client = self.writer.label.as_deref().unwrap_or("?"),
                reason,
                "refused input: {detail} (logged once per client and reason; counted in /metrics)"
            );
        }
    }

    /// Takes `bytes` (just received at `now`); returns the reply bytes to send (in `self.out`).
    fn take(
        &mut self,
        bytes: &[u8],
        now: Instant,
        front: &str,
        counters: &StreamCounters,
        inbox: &Inbox<S::Msg>,
        limits: &StreamLimits,
    ) {
        self.out.clear();
        if let Some(gap) = self.session.gap() {
            if !self.buf.is_empty() && now.duration_since(self.last_byte) > gap {
                let n = self.buf.len();
                self.buf.clear();
                self.refuse(
                    front,
                    counters,
                    "partial_frame",
                    &format!("{n} bytes of an unfinished request, then silence"),
                );
            }
        }
        self.last_byte = now;
        counters.bytes_in.fetch_add(bytes.len() as u64, Ordering::Relaxed);
        self.buf.extend_from_slice(bytes);
        loop {
            let writer = &self.writer;
            let mut sink = |m: S::Msg| {
                counters.commands.fetch_add(1, Ordering::Relaxed);
                if !inbox.deliver(writer, m) {
                    counters.commands_dropped.fetch_add(1, Ordering::Relaxed);
                }
            };
            match self.session.on_bytes(&self.buf, now, &mut self.out, &mut sink) {
                Ok(0) => break,
                Ok(n) => {
                    self.buf.drain(..n.min(self.buf.len()));
                    if self.buf.is_empty() {
                        break;
                    }
                }
                Err(e) => {
                    self.refuse(front, counters, e.reason, &e.detail);
                    match e.skip {
                        Some(n) if n > 0 && n < self.buf.len() => {
                            self.buf.drain(..n);
                        }
                        _ => {
                            self.buf.clear();
                            break;
                        }
                    }
                }
            }
        }
        if self.buf.len() > limits.max_buffer {
            let n = self.buf.len();
            self.buf.clear();
            self.refuse(
                front,
                counters,
                "overlong",
                &format!("{n} bytes without a complete request"),
            );
        }
    }

    /// A partial request abandoned after the session's gap, checked while no byte comes.
    fn check_gap(&mut self, now: Instant, front: &str, counters: &StreamCounters) {
        if let Some(gap) = self.session.gap() {
            if !self.buf.is_empty() && now.duration_since(self.last_byte) > gap {
                let n = self.buf.len();
                self.buf.clear();
                self.refuse(
                    front,
                    counters,
                    "partial_frame",
                    &format!("{n} bytes of an unfinished request, then silence"),
                );
            }
        }
    }
}

fn register(front: &str, at: &str, counters: &Arc<StreamCounters>) {
    registry().lock().unwrap_or_else(|p| p.into_inner()).push(StreamEntry {
        front: front.to_string(),
        at: at.to_string(),
        counters: counters.clone(),
    });
}

/// Serves sessions made by `make` to TCP clients on `bind`.
pub fn serve_tcp<S: Session>(
    bind: SocketAddr,
    limits: StreamLimits,
    make: impl Fn() -> S + Send + Sync + 'static,
    inbox: Inbox<S::Msg>,
    front: &str,
    label: &'static str,
) -> io::Result<StreamServer> {
    let listener = TcpListener::bind(bind)?;
    listener.set_nonblocking(true)?;
    let local = listener.local_addr()?;
    let at = format!("tcp {local}");
    let stop = Arc::new(AtomicBool::new(false));
    let counters = Arc::new(StreamCounters::default());
    register(front, &at, &counters);
    let make = Arc::new(make);
    let thread = {
        let (stop, counters, front) = (stop.clone(), counters.clone(), front.to_string());
        std::thread::Builder::new()
            .name(format!("{label}-accept"))
            .spawn(move || {
                let mut clients: Vec<JoinHandle<()>> = Vec::new();
                while !stop.load(Ordering::Relaxed) {
                    clients.retain(|c| !c.is_finished());
                    if !crate::serial::transport::poll_readable(listener.as_raw_fd(), POLL).unwrap_or(false) {
                        continue;
                    }
                    let Ok((stream, peer)) = listener.accept() else {
                        continue;
                    };
                    if counters.open.load(Ordering::Relaxed) as usize >= limits.max_clients {
                        counters.refuse("too_many_clients");
                        tracing::warn!(
                            front = front.as_str(),
                            %peer,
                            max = limits.max_clients,
                            "refused a client: {} clients connected already (counted in /metrics)",
                            limits.max_clients
                        );
                        drop(stream);
                        continue;
                    }
                    counters.accepted.fetch_add(1, Ordering::Relaxed);
                    counters.open.fetch_add(1, Ordering::Relaxed);
                    let client = Client::new(make(), format!("{label} {peer}"), &limits);
                    let (stop, counters, name, inbox) = (stop.clone(), counters.clone(), front.clone(), inbox.clone());
                    match std::thread::Builder::new()
                        .name(format!("{label}-client"))
                        .spawn(move || {
                            serve_connection(stream, client, &stop, &counters, &name, &inbox, &limits);
                            counters.open.fetch_sub(1, Ordering::Relaxed);
                        }) {
                        Ok(h) => clients.push(h),
                        Err(e) => {
                            tracing::warn!(front = front.as_str(), "no thread for a client: {e}");
                        }
                    }
                }
                for c in clients {
                    let _ = c.join();
                }
            })?
    };
    tracing::info!(front, "serving {label} on {at}");
    Ok(StreamServer {
        stop,
        threads: vec![thread],
        at,
        local_addr: Some(local),
        link: None,
        counters,
        front: front.to_string(),
    })
}

fn serve_connection<S: Session>(
    mut stream: TcpStream,
    mut client: Client<S>,
    stop: &AtomicBool,
    counters: &StreamCounters,
    front: &str,
    inbox: &Inbox<S::Msg>,
    limits: &StreamLimits,
) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_nonblocking(false);
    let wait = client.session.gap().map_or(POLL, |g| g.min(POLL));
    let _ = stream.set_read_timeout(Some(wait.max(Duration::from_millis(1))));
    let mut rx = [0u8; 1024];
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut rx) {
            Ok(0) => return,
            Ok(n) => {
                client.take(&rx[..n], Instant::now(), front, counters, inbox, limits);
                if !client.out.is_empty() && stream.write_all(&client.out).is_err() {
                    return;
                }
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {
                let now = Instant::now();
                client.check_gap(now, front, counters);
                if now.duration_since(client.last_byte) >= limits.idle {
                    client.refuse(
                        front,
                        counters,
                        "idle",
                        &format!("nothing received for {} s: closed", limits.idle.as_secs_f32()),
                    );
                    return;
                }
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return,
        }
    }
}

/// Serves one session made by `make` on a new pseudo-terminal whose slave is linked at `link`
/// (clients open the link as they would open /dev/ttyUSB0). The pty never idles out.
pub fn serve_pty<S: Session>(
    link: &Path,
    make: impl Fn() -> S + Send + 'static,
    inbox: Inbox<S::Msg>,
    front: &str,
    label: &'static str,
) -> io::Result<StreamServer> {
    let pty = Pty::open()?;
    crate::serial::replace_symlink(pty.slave_path(), link)?;
    let at = format!("pty {}", link.display());
    let stop = Arc::new(AtomicBool::new(false));
    let counters = Arc::new(StreamCounters::default());
    register(front, &at, &counters);
    counters.accepted.fetch_add(1, Ordering::Relaxed);
    counters.open.fetch_add(1, Ordering::Relaxed);
    let limits = StreamLimits::default();
    let mut client = Client::new(make(), format!("{label} on {}", link.display()), &limits);
    let thread = {
        let (stop, counters, front) = (stop.clone(), counters.clone(), front.to_string());
        std::thread::Builder::new()
            .name(format!("{label}-pty"))
            .spawn(move || {
                let wait = client.session.gap().map_or(POLL, |g| g.min(POLL));
                let mut rx = [0u8; 1024];
                while !stop.load(Ordering::Relaxed) {
                    match crate::serial::transport::poll_readable(pty.master_fd(), wait) {
                        Ok(true) => {}
                        Ok(false) => {
                            client.check_gap(Instant::now(), &front, &counters);
                            continue;
                        }
                        Err(_) => {
                            // The slave side hung up: no client has it open; wait for the next.
                            std::thread::sleep(POLL);
                            continue;
                        }
                    }
                    match pty.read(&mut rx) {
                        Ok(0) => {}
                        Ok(n) => {
                            client.take(&rx[..n], Instant::now(), &front, &counters, &inbox, &limits);
                            if !client.out.is_empty() {
                                let _ = pty.write_all(&client.out);
                            }
                        }
                        Err(_) => std::thread::sleep(POLL),
                    }
                }
                counters.open.fetch_sub(1, Ordering::Relaxed);
            })?
    };
    tracing::info!(front, "serving {label} on {at}");
    Ok(StreamServer {
        stop,
        threads: vec![thread],
        at,
        local_addr: None,
        link: Some(link.to_path_buf()),
        counters,
        front: front.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::serve::{Incoming, Queue};
    use tokio::sync::mpsc;

    /// A line protocol: `SET n` hands n to the front and answers `ack`, `GET` answers the
    /// last n, anything else is garbage.
    struct Lines {
        last: u32,
    }

    impl Session for Lines {
        type Msg = u32;
        fn on_bytes(
            &mut self,
            input: &[u8],
            _now: Instant,
            out: &mut Vec<u8>,
            sink: &mut dyn FnMut(u32),
        ) -> Result<usize, StreamError> {
            let Some(end) = input.iter().position(|b| *b == b'\n') else {
                return Ok(0);
            };
            let bad = |what: String| StreamError::skipping(end + 1, "garbage", what);
            let line = std::str::from_utf8(&input[..end]).map_err(|_| bad("not text".into()))?;
            match line.split_whitespace().collect::<Vec<_>>().as_slice() {
                ["SET", n] => {
                    let n = n.parse().map_err(|_| bad(format!("bad number {n:?}")))?;
                    self.last = n;
                    sink(n);
                    out.extend_from_slice(b"ack\n");
                }
                ["GET"] => out.extend_from_slice(format!("{}\n", self.last).as_bytes()),
                _ => return Err(bad(format!("{line:?}"))),
            }
            Ok(end + 1)
        }
    }

    fn inbox() -> (Inbox<u32>, mpsc::Receiver<Incoming>) {
        let (tx, rx) = mpsc::channel(64);
        (Inbox::for_tests(Queue::new(tx)), rx)
    }

    fn line(s: &mut std::io::BufReader<TcpStream>) -> String {
        let mut l = String::new();
        std::io::BufRead::read_line(s, &mut l).unwrap();
        l
    }

    #[test]
    fn tcp_clients_are_writers_of_their_own_and_garbage_is_counted() {
        let (inbox, mut rx) = inbox();
        let limits = StreamLimits {
            max_clients: 2,
            idle: Duration::from_millis(300),
            max_buffer: 64,
        };
        let server = serve_tcp(
            "127.0.0.1:0".parse().unwrap(),
            limits,
            || Lines { last: 0 },
            inbox,
            "t",
            "lines",
        )
        .unwrap();
        let addr = server.local_addr.unwrap();
        let a = TcpStream::connect(addr).unwrap();
        let mut ar = std::io::BufReader::new(a.try_clone().unwrap());
        (&a).write_all(b"SET 7\nGET\n").unwrap();
        assert_eq!(line(&mut ar), "ack\n");
        assert_eq!(line(&mut ar), "7\n");
        let first = rx.blocking_recv().unwrap();
        assert_eq!(first.msg.downcast_ref::<u32>(), Some(&7));
        let b = TcpStream::connect(addr).unwrap();
        let mut br = std::io::BufReader::new(b.try_clone().unwrap());
        (&b).write_all(b"nonsense\nSET 9\n").unwrap();
        assert_eq!(line(&mut br), "ack\n");
        let second = rx.blocking_recv().unwrap();
        assert_ne!(
            first.writer.handle, second.writer.handle,
            "each connection its own writer"
        );
        assert!(second.writer.label.as_deref().unwrap().starts_with("lines 127.0.0.1:"));
        assert_eq!(server.counters.refused_of("garbage"), 1);
        // A third client is refused while two are connected: it reads EOF at once.
        let mut c = TcpStream::connect(addr).unwrap();
        let mut buf = [0u8; 8];
        assert_eq!(c.read(&mut buf).unwrap_or(0), 0);
        assert_eq!(server.counters.refused_of("too_many_clients"), 1);
        // Overlong: 100 bytes with no newline.
        (&a).write_all(&[b'x'; 100]).unwrap();
        // Both go idle after 300 ms and are closed (EOF), counted.
        assert_eq!(ar.read(&mut buf).unwrap_or(0), 0);
        assert_eq!(br.read(&mut buf).unwrap_or(0), 0);
        assert_eq!(server.counters.refused_of("overlong"), 1);
        assert_eq!(server.counters.refused_of("idle"), 2);
        assert!(running().iter().any(|e| e.at == server.at));
        let at = server.at.clone();
        drop(server);
        assert!(!running().iter().any(|e| e.at == at), "unregistered when stopped");
    }

    #[test]
    fn a_pty_front_answers_what_is_written_on_its_link() {
        let (inbox, mut rx) = inbox();
        let link = std::env::temp_dir().join(format!("handgate-stream-test-{}", std::process::id()));
        let server = serve_pty(&link, || Lines { last: 0 }, inbox, "t", "lines").unwrap();
        let mut port = crate::serial::SerialPort::open(&link, 115_200).unwrap();
        use crate::serial::Transport;
        port.write_all(b"SET 3\n").unwrap();
        let mut got = Vec::new();
        let mut buf = [0u8; 16];
        while !got.ends_with(b"ack\n") {
            let n = port.read(&mut buf, Duration::from_secs(10)).unwrap();
            assert!(n > 0, "no answer");
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(rx.blocking_recv().unwrap().msg.downcast_ref::<u32>(), Some(&3));
        drop(port);
        drop(server);
        assert!(!link.exists(), "the link goes with the server");
    }
}
