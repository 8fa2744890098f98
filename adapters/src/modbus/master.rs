//! Blocking masters (clients): [`RtuMaster`] over a serial [`Transport`] (one per RS-485
//! line: it is the line's arbiter, every slave on the line goes through it, one transaction at
//! a time; share it between devices as a [`Line`]), RTU over TCP (the same master over a
//! [`TcpTransport`]), and [`TcpMaster`] for Modbus TCP (MBAP, transaction ids).
//!
//! Timing on the serial line (Modbus over Serial Line V1.02, 2.5.1.1 and 2.4.1): the master
//! keeps the line silent for the frame gap (3.5 characters, 1.75 ms above 19200 baud) before
//! each request, waits at most the response timeout (counted from the end of its own
//! transmission) for a unicast answer, and the turnaround delay after a broadcast. Every
//! failure is counted per slave ([`SlaveCounters`]) and leaves the line clean for the next
//! transaction: the rest of a bad answer is waited out and discarded, so one slave that
//! misbehaves does not corrupt the next slave's answer.
//!
//! No allocation per transaction: the frame buffers are allocated once and reused.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::serial::transport::poll_readable;
use crate::serial::{Transport, TransportError};

use super::pdu::{Exception, PduError, Regs, Request, Response};
use super::{rtu, tcp};

/// What one slave (or TCP unit) did, counted by the master.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SlaveCounters {
    /// Requests sent.
    pub requests: u64,
    /// Valid responses that matched their request (exceptions included).
    pub responses: u64,
    /// No byte of an answer within the response timeout.
    pub timeouts: u64,
    /// An answer whose CRC did not match.
    pub bad_crc: u64,
    /// A valid frame from another slave id (TCP: another unit id).
    pub wrong_slave: u64,
    /// Exception responses.
    pub exceptions: u64,
    /// Short (cut off before its end), overlong (bytes after its end), of another function,
    /// or not matching the request (count, echo, transaction id).
    pub malformed: u64,
    /// Bytes that arrived between transactions (after this slave's last answer), discarded.
    pub stray_bytes: u64,
}

impl SlaveCounters {
    /// Every failure counted.
    pub fn errors(&self) -> u64 {
        self.timeouts + self.bad_crc + self.wrong_slave + self.exceptions + self.malformed
    }
}

/// Why a transaction failed.
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    #[error("slave {slave}: no answer within {timeout:?}")]
    Timeout { slave: u8, timeout: Duration },
    #[error("slave {slave}: answer with a bad CRC")]
    BadCrc { slave: u8 },
    #[error("slave {expected}: answered by slave {got}")]
    WrongSlave { expected: u8, got: u8 },
    #[error("slave {slave}: function 0x{function:02X} refused: {code}")]
    Exception { slave: u8, function: u8, code: Exception },
    #[error("slave {slave}: malformed answer: {reason}")]
    Malformed { slave: u8, reason: &'static str },
    /// The request itself cannot be encoded (a quantity the spec does not allow).
    #[error("request not sent: {0}")]
    Request(#[from] PduError),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("Modbus TCP connection: {0}")]
    Io(#[from] io::Error),
}

impl MasterError {
    /// A short key for counters and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            MasterError::Timeout { .. } => "timeout",
            MasterError::BadCrc { .. } => "bad_crc",
            MasterError::WrongSlave { .. } => "wrong_slave",
            MasterError::Exception { .. } => "exception",
            MasterError::Malformed { .. } => "malformed",
            MasterError::Request(_) => "bad_request",
            MasterError::Transport(TransportError::Disconnected) => "disconnected",
            MasterError::Transport(_) | MasterError::Io(_) => "io",
        }
    }

    /// The link itself failed (reconnect), as opposed to one slave's answer.
    pub fn is_link_error(&self) -> bool {
        matches!(self, MasterError::Transport(_) | MasterError::Io(_))
    }
}

/// Checks that `resp` answers `req` (function, quantities, echo). An exception is returned as
/// `Err(code)` with `Ok(())` meaning a normal, matching answer.
fn matches_request(req: &Request<'_>, resp: &Response<'_>) -> Result<(), Result<Exception, &'static str>> {
    let ok = match (*req, *resp) {
        (_, Response::Exception { function, code }) if function == req.function() => return Err(Ok(code)),
        (Request::ReadHolding { count, .. }, Response::ReadHolding(r))
        | (Request::ReadInput { count, .. }, Response::ReadInput(r))
        | (Request::ReadWrite { read_count: count, .. }, Response::ReadWrite(r)) => r.len() == count as usize,
        (Request::WriteSingle { addr, value }, Response::WriteSingle { addr: a, value: v }) => a == addr && v == value,
        (Request::WriteMultiple { addr, values }, Response::WriteMultiple { addr: a, count }) => {
            a == addr && count as usize == values.len()
        }
        _ => return Err(Err("answer of another function")),
    };
    if ok {
        Ok(())
    } else {
        Err(Err("answer does not match the request (quantity or echo)"))
    }
}

/// Copies a read answer's words into `out` (`out.len()` = the count asked for).
fn copy_words(resp: &Response<'_>, out: &mut [u16]) {
    if let Response::ReadHolding(r) | Response::ReadInput(r) | Response::ReadWrite(r) = resp {
        r.copy_to(out);
    }
}

fn count(out: &[u16]) -> u16 {
    u16::try_from(out.len()).unwrap_or(u16::MAX)
}

/// The convenience calls both masters share, over their `transact`.
macro_rules! register_calls {
    () => {
        /// FC03: reads `out.len()` holding registers from `addr`.
        pub fn read_holding(&mut self, slave: u8, addr: u16, out: &mut [u16]) -> Result<(), MasterError> {
            let req = Request::ReadHolding {
                addr,
                count: count(out),
            };
            let resp = self.transact(slave, &req)?;
            copy_words(&resp, out);
            Ok(())
        }

        /// FC04: reads `out.len()` input registers from `addr`.
        pub fn read_input(&mut self, slave: u8, addr: u16, out: &mut [u16]) -> Result<(), MasterError> {
            let req = Request::ReadInput {
                addr,
                count: count(out),
            };
            let resp = self.transact(slave, &req)?;
            copy_words(&resp, out);
            Ok(())
        }

        /// FC06.
        pub fn write_single(&mut self, slave: u8, addr: u16, value: u16) -> Result<(), MasterError> {
            self.transact(slave, &Request::WriteSingle { addr, value })
                .map(drop)
        }

        /// FC16.
        pub fn write_multiple(&mut self, slave: u8, addr: u16, values: &[u16]) -> Result<(), MasterError> {
            let req = Request::WriteMultiple {
                addr,
                values: Regs::from_words(values),
            };
            self.transact(slave, &req).map(drop)
        }

        /// FC23: writes `values` from `write_addr`, then reads `out.len()` holding registers
        /// from `read_addr`, in one exchange.
        pub fn read_write(
            &mut self,
            slave: u8,
            read_addr: u16,
            out: &mut [u16],
            write_addr: u16,
            values: &[u16],
        ) -> Result<(), MasterError> {
            let req = Request::ReadWrite {
                read_addr,
                read_count: count(out),
                write_addr,
                values: Regs::from_words(values),
            };
            let resp = self.transact(slave, &req)?;
            copy_words(&resp, out);
            Ok(())
        }

        /// What `slave` did so far.
        pub fn counters(&self, slave: u8) -> SlaveCounters {
            self.counters[slave as usize]
        }
    };
}

// ------------------------------------------------------------------ RTU

/// Timing of an RTU master.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtuTiming {
    /// Line speed: the wire time of a frame (for the response deadline) follows from it.
    pub baud: u32,
    /// Longest wait for the first byte of an answer after the request left.
    pub response_timeout: Duration,
    /// Silence kept before each request (3.5 characters; zero for RTU over TCP).
    pub gap: Duration,
    /// Wait after a broadcast before the next request (the spec suggests 100 to 200 ms).
    pub turnaround: Duration,
}

impl RtuTiming {
    /// The spec's gap at `baud`, a 100 ms response timeout and a 100 ms turnaround.
    pub fn serial(baud: u32) -> Self {
        Self {
            baud,
            response_timeout: Duration::from_millis(100),
            gap: rtu::frame_gap(baud),
            turnaround: Duration::from_millis(100),
        }
    }

    /// RTU frames over TCP (a UR tool forwarder, a serial-to-Ethernet gateway): no gap, wire
    /// time nil, a longer timeout.
    pub fn over_tcp() -> Self {
        Self {
            baud: 0,
            response_timeout: Duration::from_millis(500),
            gap: Duration::ZERO,
            turnaround: Duration::ZERO,
        }
    }

    /// Wire time of `len` bytes (11 bits each, the spec's character).
    pub fn wire_time(&self, len: usize) -> Duration {
        if self.baud == 0 {
            Duration::ZERO
        } else {
            rtu::char_time(self.baud) * len as u32
        }
    }
}

/// A Modbus RTU master on one line.
pub struct RtuMaster {
    transport: Box<dyn Transport>,
    timing: RtuTiming,
    tx: Vec<u8>,
    rx: Vec<u8>,
    counters: Box<[SlaveCounters; 256]>,
    /// When the line last carried a byte (ours or a slave's).
    quiet_since: Option<Instant>,
    /// The slave whose transaction came last (stray bytes are counted on it).
    last_slave: u8,
}

impl RtuMaster {
    pub fn new(transport: Box<dyn Transport>, timing: RtuTiming) -> Self {
        Self {
            transport,
            timing,
            tx: Vec::with_capacity(rtu::MAX_ADU),
            rx: Vec::with_capacity(2 * rtu::MAX_ADU),
            counters: Box::new([SlaveCounters::default(); 256]),
            quiet_since: None,
            last_slave: 0,
        }
    }

    pub fn timing(&self) -> RtuTiming {
        self.timing
    }

    pub fn set_timing(&mut self, timing: RtuTiming) {
        self.timing = timing;
    }

    /// Swaps in a new transport (after a reconnect); the counters stay.
    pub fn replace_transport(&mut self, transport: Box<dyn Transport>) {
        self.transport = transport;
        self.quiet_since = None;
    }

    /// Sends `req` to `slave` (1..=247) and returns its answer, checked against the request;
    /// an exception answer is `Err(MasterError::Exception)`. The response borrows the master's
    /// buffer.
    pub fn transact(&mut self, slave: u8, req: &Request<'_>) -> Result<Response<'_>, MasterError> {
        self.send(slave, req)?;
        let c = &mut self.counters[slave as usize];
        c.requests += 1;
        let sent_at = Instant::now();
        let deadline = sent_at + self.timing.wire_time(self.tx.len()) + self.timing.response_timeout;
        let len = match self.receive(slave, req.function(), deadline) {
            Ok(len) => len,
            Err(e) => {
                let c = &mut self.counters[slave as usize];
                match &e {
                    MasterError::Timeout { .. } => c.timeouts += 1,
                    MasterError::BadCrc { .. } => c.bad_crc += 1,
                    MasterError::WrongSlave { .. } => c.wrong_slave += 1,
                    MasterError::Malformed { .. } => c.malformed += 1,
                    _ => {}
                }
                if !e.is_link_error() {
                    self.settle(deadline)?;
                }
                return Err(e);
            }
        };
        let resp = Response::decode(&self.rx[1..len - 2]);
        let c = &mut self.counters[slave as usize];
        let resp = match resp {
            Ok(r) => r,
            Err(_) => {
                c.malformed += 1;
                return Err(MasterError::Malformed {
                    slave,
                    reason: "answer PDU does not decode",
                });
            }
        };
        match matches_request(req, &resp) {
            Ok(()) => {
                c.responses += 1;
                Ok(resp)
            }
            Err(Ok(code)) => {
                c.responses += 1;
                c.exceptions += 1;
                Err(MasterError::Exception {
                    slave,
                    function: req.function(),
                    code,
                })
            }
            Err(Err(reason)) => {
                c.malformed += 1;
                Err(MasterError::Malformed { slave, reason })
            }
        }
    }

    /// Sends a write to every slave (address 0); nobody answers. Waits the turnaround delay
    /// before returning so that the slaves have acted on it.
    pub fn broadcast(&mut self, req: &Request<'_>) -> Result<(), MasterError> {
        if matches!(
            req,
            Request::ReadHolding { .. } | Request::ReadInput { .. } | Request::ReadWrite { .. }
        ) {
            return Err(MasterError::Request(PduError::Function(req.function())));
        }
        self.send(rtu::BROADCAST, req)?;
        self.counters[rtu::BROADCAST as usize].requests += 1;
        let end = Instant::now() + self.timing.wire_time(self.tx.len()) + self.timing.turnaround;
        sleep_until(end);
        self.quiet_since = Some(Instant::now());
        Ok(())
    }

    register_calls!();

    /// Waits for the gap, discards (and counts) stray bytes, sends the request.
    fn send(&mut self, slave: u8, req: &Request<'_>) -> Result<(), MasterError> {
        self.tx.clear();
        let start = rtu::begin(&mut self.tx, slave);
        req.encode(&mut self.tx)?;
        rtu::finish(&mut self.tx, start);
        if let Some(t) = self.quiet_since {
            sleep_until(t + self.timing.gap);
        }
        let stray = self.drain(Duration::ZERO)?;
        if stray > 0 {
            self.counters[self.last_slave as usize].stray_bytes += stray as u64;
        }
        self.last_slave = slave;
        self.transport.write_all(&self.tx)?;
        self.quiet_since = Some(Instant::now() + self.timing.wire_time(self.tx.len()));
        Ok(())
    }

    /// Reads until the answer to `function` is complete; returns its length in `rx`.
    fn receive(&mut self, slave: u8, function: u8, deadline: Instant) -> Result<usize, MasterError> {
        self.rx.clear();
        let mut chunk = [0u8; rtu::MAX_ADU];
        loop {
            match rtu::decode_response(&self.rx, function) {
                Ok(frame) => {
                    let (got, len) = (frame.slave, frame.len);
                    // Bytes after the end, in the same burst: an overlong frame (a slave that
                    // delimits by silence would see one frame with a bad CRC).
                    let extra = self.rx.len() > len || self.transport.read(&mut chunk, Duration::ZERO)? > 0;
                    if extra {
                        return Err(MasterError::Malformed {
                            slave,
                            reason: "overlong frame (bytes after its CRC)",
                        });
                    }
                    if got != slave {
                        return Err(MasterError::WrongSlave { expected: slave, got });
                    }
                    return Ok(len);
                }
                Err(rtu::RtuError::Incomplete { .. }) => {}
                Err(rtu::RtuError::BadCrc { .. }) => return Err(MasterError::BadCrc { slave }),
                Err(rtu::RtuError::Malformed { reason }) => return Err(MasterError::Malformed { slave, reason }),
            }
            let now = Instant::now();
            if now >= deadline || self.rx.len() >= 2 * rtu::MAX_ADU {
                return Err(if self.rx.is_empty() {
                    MasterError::Timeout {
                        slave,
                        timeout: self.timing.response_timeout,
                    }
                } else {
                    MasterError::Malformed {
                        slave,
                        reason: "short frame (cut off before its end)",
                    }
                });
            }
            let n = self.transport.read(&mut chunk, deadline - now)?;
            if n > 0 {
                self.rx.extend_from_slice(&chunk[..n]);
                self.quiet_since = Some(Instant::now());
            }
        }
    }

    /// After a failed transaction: waits until the line has been silent for the gap (at most
    /// until `deadline` plus one more timeout), discarding what arrives.
    fn settle(&mut self, deadline: Instant) -> Result<(), MasterError> {
        let quiet = self.timing.gap.max(Duration::from_millis(2));
        let limit = deadline.max(Instant::now()) + self.timing.response_timeout;
        while Instant::now() < limit {
            if self.drain(quiet)? == 0 {
                break;
            }
        }
        self.transport.clear_input()?;
        self.quiet_since = Some(Instant::now());
        Ok(())
    }

    /// Reads and discards what arrives within `wait`; returns the bytes discarded.
    fn drain(&mut self, wait: Duration) -> Result<usize, MasterError> {
        let mut chunk = [0u8; rtu::MAX_ADU];
        let mut total = 0;
        let mut wait = wait;
        loop {
            let n = self.transport.read(&mut chunk, wait)?;
            if n == 0 {
                return Ok(total);
            }
            total += n;
            self.quiet_since = Some(Instant::now());
            wait = Duration::ZERO;
        }
    }
}

fn sleep_until(t: Instant) {
    let now = Instant::now();
    if t > now {
        std::thread::sleep(t - now);
    }
}

/// An RTU master shared by the devices on one line: each transaction holds the line.
#[derive(Clone)]
pub struct Line(Arc<Mutex<RtuMaster>>);

impl Line {
    pub fn new(master: RtuMaster) -> Self {
        Self(Arc::new(Mutex::new(master)))
    }

    /// The master, for one or more transactions; the other devices wait meanwhile.
    pub fn lock(&self) -> MutexGuard<'_, RtuMaster> {
        // A panic while holding the line leaves the master usable (its buffers are reset per
        // transaction).
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

// ------------------------------------------------------------------ TCP

/// A TCP stream as a [`Transport`], for RTU frames over TCP.
pub struct TcpTransport {
    stream: TcpStream,
}

impl TcpTransport {
    pub fn connect(addr: SocketAddr, timeout: Duration) -> io::Result<Self> {
        let stream = TcpStream::connect_timeout(&addr, timeout)?;
        stream.set_nodelay(true)?;
        Ok(Self { stream })
    }

    pub fn from_stream(stream: TcpStream) -> io::Result<Self> {
        stream.set_nodelay(true)?;
        Ok(Self { stream })
    }
}

fn tcp_read(stream: &mut TcpStream, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
    if !poll_readable(stream.as_raw_fd(), timeout)? {
        return Ok(0);
    }
    match stream.read(buf) {
        Ok(0) => Err(TransportError::Disconnected),
        Ok(n) => Ok(n),
        Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted) => Ok(0),
        Err(e) if matches!(e.kind(), io::ErrorKind::ConnectionReset | io::ErrorKind::BrokenPipe) => {
            Err(TransportError::Disconnected)
        }
        Err(e) => Err(TransportError::Io(e)),
    }
}

impl Transport for TcpTransport {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.stream.write_all(bytes).map_err(|e| match e.kind() {
            io::ErrorKind::ConnectionReset | io::ErrorKind::BrokenPipe => TransportError::Disconnected,
            _ => TransportError::Io(e),
        })
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        tcp_read(&mut self.stream, buf, timeout)
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        let mut chunk = [0u8; 256];
        while tcp_read(&mut self.stream, &mut chunk, Duration::ZERO)? > 0 {}
        Ok(())
    }
}

/// A Modbus TCP master (client) on one connection. Each request carries a new transaction
/// id; an answer with an older id (the late answer to a request that timed out) is counted
/// and skipped.
pub struct TcpMaster {
    stream: TcpStream,
    response_timeout: Duration,
    transaction: u16,
    tx: Vec<u8>,
    rx: Vec<u8>,
    counters: Box<[SlaveCounters; 256]>,
}

impl TcpMaster {
    pub fn connect(addr: SocketAddr, timeout: Duration) -> io::Result<Self> {
        Self::from_stream(TcpStream::connect_timeout(&addr, timeout)?, timeout)
    }

    pub fn from_stream(stream: TcpStream, response_timeout: Duration) -> io::Result<Self> {
        stream.set_nodelay(true)?;
        Ok(Self {
            stream,
            response_timeout,
            transaction: 0,
            tx: Vec::with_capacity(tcp::MAX_ADU),
            rx: Vec::with_capacity(2 * tcp::MAX_ADU),
            counters: Box::new([SlaveCounters::default(); 256]),
        })
    }

    pub fn set_response_timeout(&mut self, timeout: Duration) {
        self.response_timeout = timeout;
    }

    /// Sends `req` to `unit` and returns its answer, checked against the request.
    pub fn transact(&mut self, unit: u8, req: &Request<'_>) -> Result<Response<'_>, MasterError> {
        self.transaction = self.transaction.wrapping_add(1);
        self.tx.clear();
        let start = tcp::begin(&mut self.tx, self.transaction, unit);
        req.encode(&mut self.tx)?;
        tcp::finish(&mut self.tx, start);
        // Whatever is still buffered belongs to an earlier exchange.
        self.rx.clear();
        self.stream.write_all(&self.tx)?;
        self.counters[unit as usize].requests += 1;
        let deadline = Instant::now() + self.response_timeout;
        let (pdu_at, len) = match self.receive(unit, deadline) {
            Ok(r) => r,
            Err(e) => {
                let c = &mut self.counters[unit as usize];
                match &e {
                    MasterError::Timeout { .. } => c.timeouts += 1,
                    MasterError::WrongSlave { .. } => c.wrong_slave += 1,
                    MasterError::Malformed { .. } => c.malformed += 1,
                    _ => {}
                }
                return Err(e);
            }
        };
        let c = &mut self.counters[unit as usize];
        let Ok(resp) = Response::decode(&self.rx[pdu_at..len]) else {
            c.malformed += 1;
            return Err(MasterError::Malformed {
                slave: unit,
                reason: "answer PDU does not decode",
            });
        };
        match matches_request(req, &resp) {
            Ok(()) => {
                c.responses += 1;
                Ok(resp)
            }
            Err(Ok(code)) => {
                c.responses += 1;
                c.exceptions += 1;
                Err(MasterError::Exception {
                    slave: unit,
                    function: req.function(),
                    code,
                })
            }
            Err(Err(reason)) => {
                c.malformed += 1;
                Err(MasterError::Malformed { slave: unit, reason })
            }
        }
    }

    register_calls!();

    /// Reads until the answer with this transaction id is in; returns where its PDU starts
    /// and ends in `rx` (which is shifted so that the frame starts at 0).
    fn receive(&mut self, unit: u8, deadline: Instant) -> Result<(usize, usize), MasterError> {
        let mut chunk = [0u8; tcp::MAX_ADU];
        loop {
            match tcp::decode(&self.rx) {
                Ok(adu) => {
                    let (h, len) = (adu.header, adu.len);
                    if h.transaction != self.transaction {
                        // A late answer to an earlier request: skip it.
                        self.counters[unit as usize].stray_bytes += len as u64;
                        self.rx.drain(..len);
                        continue;
                    }
                    if h.unit != unit {
                        self.rx.drain(..len);
                        return Err(MasterError::WrongSlave {
                            expected: unit,
                            got: h.unit,
                        });
                    }
                    return Ok((tcp::MBAP_LEN, len));
                }
                Err(tcp::TcpError::Incomplete { .. }) => {}
                Err(e) => {
                    // The stream is out of step: nothing after this can be trusted.
                    self.rx.clear();
                    return Err(MasterError::Malformed {
                        slave: unit,
                        reason: e.reason(),
                    });
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(MasterError::Timeout {
                    slave: unit,
                    timeout: self.response_timeout,
                });
            }
            let n = tcp_read(&mut self.stream, &mut chunk, deadline - now)?;
            self.rx.extend_from_slice(&chunk[..n]);
        }
    }
}
