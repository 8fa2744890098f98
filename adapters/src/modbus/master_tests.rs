//! The masters against [`server::respond`]: several slaves on one simulated RS-485 line with
//! the faults a real line has (a slave that never answers, bad CRCs, a wrong slave id, short
//! and overlong frames), the RTU master on a real pty, Modbus TCP and RTU over TCP on
//! loopback.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::serial::transport::poll_readable;
use crate::serial::{Pty, SerialPort, Transport, TransportError};

use super::master::{MasterError, RtuMaster, RtuTiming, TcpMaster, TcpTransport};
use super::pdu::*;
use super::server::{respond, Bank};
use super::{rtu, tcp};

/// What a simulated slave does to its answers.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    None,
    /// Never answers.
    Silent,
    /// Flips a bit of the CRC.
    BadCrc,
    /// Answers with another slave id (valid CRC).
    WrongId(u8),
    /// Stops 3 bytes before the end.
    Short,
    /// Appends 2 bytes after the CRC.
    Overlong,
    /// Answers as if asked another function (FC04 for FC03), valid CRC.
    OtherFunction,
}

struct SimSlave {
    id: u8,
    bank: Bank,
    fault: Fault,
    requests: u32,
}

#[derive(Default)]
struct LineState {
    slaves: Vec<SimSlave>,
    /// Bytes on their way to the master.
    queue: VecDeque<u8>,
    /// When each request was written.
    writes: Vec<Instant>,
}

/// An in-memory RS-485 line: a write is a request every slave sees; the addressed one
/// answers into the queue the master reads (7 bytes per read, as a USB adapter delivers in
/// bursts). Reading an empty queue waits the whole timeout, as a silent line does.
#[derive(Clone, Default)]
struct SimLine(Arc<Mutex<LineState>>);

fn bank(seed: u16) -> Bank {
    Bank {
        holding_base: 1000,
        holding: (0..16).map(|i| seed + i).collect(),
        input_base: 2000,
        input: (0..8).map(|i| seed + 0x100 + i).collect(),
    }
}

impl SimLine {
    fn with_slaves(ids: &[u8]) -> Self {
        let line = SimLine::default();
        line.0.lock().unwrap().slaves = ids
            .iter()
            .map(|&id| SimSlave {
                id,
                bank: bank(id as u16 * 100),
                fault: Fault::None,
                requests: 0,
            })
            .collect();
        line
    }

    fn set_fault(&self, id: u8, fault: Fault) {
        let mut s = self.0.lock().unwrap();
        s.slaves.iter_mut().find(|x| x.id == id).unwrap().fault = fault;
    }

    fn holding(&self, id: u8) -> Vec<u16> {
        let s = self.0.lock().unwrap();
        s.slaves.iter().find(|x| x.id == id).unwrap().bank.holding.clone()
    }

    fn requests(&self, id: u8) -> u32 {
        let s = self.0.lock().unwrap();
        s.slaves.iter().find(|x| x.id == id).unwrap().requests
    }
}

impl Transport for SimLine {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let mut s = self.0.lock().unwrap();
        s.writes.push(Instant::now());
        let frame = rtu::decode_request(bytes).expect("the master sends whole, valid frames");
        assert_eq!(frame.len, bytes.len(), "one frame per write");
        let mut answer = Vec::new();
        for slave in s.slaves.iter_mut() {
            if frame.slave != slave.id && frame.slave != rtu::BROADCAST {
                continue;
            }
            slave.requests += 1;
            let mut pdu = Vec::new();
            respond(&mut slave.bank, frame.pdu, true, &mut pdu, &mut |_| {});
            if frame.slave == rtu::BROADCAST || slave.fault == Fault::Silent {
                continue;
            }
            let id = match slave.fault {
                Fault::WrongId(other) => other,
                _ => slave.id,
            };
            if slave.fault == Fault::OtherFunction {
                pdu[0] ^= READ_HOLDING ^ READ_INPUT;
            }
            rtu::encode(id, &pdu, &mut answer);
            match slave.fault {
                Fault::BadCrc => *answer.last_mut().unwrap() ^= 0x04,
                Fault::Short => answer.truncate(answer.len() - 3),
                Fault::Overlong => answer.extend_from_slice(&[0x00, 0xFF]),
                _ => {}
            }
        }
        s.queue.extend(answer);
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        let mut s = self.0.lock().unwrap();
        if s.queue.is_empty() {
            drop(s);
            std::thread::sleep(timeout);
            return Ok(0);
        }
        let n = buf.len().min(7).min(s.queue.len());
        for b in buf.iter_mut().take(n) {
            *b = s.queue.pop_front().unwrap();
        }
        Ok(n)
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        self.0.lock().unwrap().queue.clear();
        Ok(())
    }
}

const TIMEOUT: Duration = Duration::from_millis(30);

fn master_on(line: &SimLine) -> RtuMaster {
    let mut timing = RtuTiming::serial(115_200);
    timing.response_timeout = TIMEOUT;
    timing.turnaround = Duration::from_millis(5);
    RtuMaster::new(Box::new(line.clone()), timing)
}

#[test]
fn several_slaves_share_one_line() {
    let line = SimLine::with_slaves(&[1, 2, 9]);
    let mut m = master_on(&line);
    let mut out = [0u16; 3];
    for id in [1u8, 2, 9] {
        m.read_holding(id, 1002, &mut out).unwrap();
        let base = id as u16 * 100;
        assert_eq!(out, [base + 2, base + 3, base + 4], "slave {id}");
        m.read_input(id, 2000, &mut out).unwrap();
        assert_eq!(out, [base + 0x100, base + 0x101, base + 0x102]);
    }
    m.write_multiple(2, 1000, &[7, 8]).unwrap();
    m.write_single(9, 1015, 0xBEEF).unwrap();
    // Robotiq-style FC23: command registers written, status registers read, one exchange.
    let mut status = [0u16; 2];
    m.read_write(9, 1014, &mut status, 1014, &[0x0900]).unwrap();
    assert_eq!(status, [0x0900, 0xBEEF]);
    assert_eq!(&line.holding(2)[..3], &[7, 8, 202]);
    assert_eq!(line.holding(1), bank(100).holding, "slave 1 untouched");
    for (id, n) in [(1u8, 2u64), (2, 3), (9, 4)] {
        let c = m.counters(id);
        assert_eq!((c.requests, c.responses, c.errors()), (n, n, 0), "slave {id}: {c:?}");
    }
    assert_eq!(m.counters(3).requests, 0);
}

#[test]
fn a_slave_that_never_answers_times_out_and_the_others_are_unaffected() {
    let line = SimLine::with_slaves(&[1, 2]);
    line.set_fault(2, Fault::Silent);
    let mut m = master_on(&line);
    let mut out = [0u16; 1];
    for _ in 0..3 {
        let t0 = Instant::now();
        let e = m.read_holding(2, 1000, &mut out).unwrap_err();
        assert!(matches!(e, MasterError::Timeout { slave: 2, .. }), "{e}");
        assert!(t0.elapsed() >= TIMEOUT, "gave up after {:?}", t0.elapsed());
        assert_eq!(e.reason(), "timeout");
        m.read_holding(1, 1000, &mut out).unwrap();
        assert_eq!(out, [100]);
    }
    assert_eq!(line.requests(2), 3, "the silent slave did receive every request");
    let c2 = m.counters(2);
    assert_eq!((c2.requests, c2.timeouts, c2.responses), (3, 3, 0));
    let c1 = m.counters(1);
    assert_eq!((c1.requests, c1.responses, c1.errors()), (3, 3, 0));
}

#[test]
fn each_fault_is_counted_on_its_slave_and_the_line_recovers() {
    let cases: [(Fault, &str); 5] = [
        (Fault::BadCrc, "bad_crc"),
        (Fault::WrongId(5), "wrong_slave"),
        (Fault::Short, "malformed"),
        (Fault::Overlong, "malformed"),
        // Refused after its first 7 bytes: the rest must be waited out, not left for the
        // next transaction.
        (Fault::OtherFunction, "malformed"),
    ];
    for (fault, reason) in cases {
        let line = SimLine::with_slaves(&[1, 2]);
        let mut m = master_on(&line);
        line.set_fault(2, fault);
        let mut out = [0u16; 2];
        let e = m.read_holding(2, 1000, &mut out).unwrap_err();
        assert_eq!(e.reason(), reason, "{fault:?}: {e}");
        match fault {
            Fault::WrongId(_) => assert!(matches!(e, MasterError::WrongSlave { expected: 2, got: 5 })),
            Fault::Short => assert!(e.to_string().contains("short frame"), "{e}"),
            Fault::Overlong => assert!(e.to_string().contains("overlong"), "{e}"),
            _ => {}
        }
        let c = m.counters(2);
        let counted = match fault {
            Fault::BadCrc => c.bad_crc,
            Fault::WrongId(_) => c.wrong_slave,
            _ => c.malformed,
        };
        assert_eq!((counted, c.errors(), c.responses), (1, 1, 0), "{fault:?}: {c:?}");
        assert_eq!(
            m.counters(5),
            Default::default(),
            "nothing counted on the id it claimed"
        );
        // The other slave, right after, on the same line.
        m.read_holding(1, 1000, &mut out).unwrap();
        assert_eq!(out, [100, 101], "{fault:?}");
        assert_eq!(m.counters(1).errors(), 0);
        assert_eq!(
            m.counters(1).stray_bytes + m.counters(2).stray_bytes,
            0,
            "{fault:?}: the bad answer was cleared away before the next request"
        );
        // And the faulty one once it behaves again.
        line.set_fault(2, Fault::None);
        m.read_holding(2, 1000, &mut out).unwrap();
        assert_eq!(out, [200, 201]);
    }
}

#[test]
fn exceptions_are_errors_with_their_code() {
    let line = SimLine::with_slaves(&[1]);
    let mut m = master_on(&line);
    let mut out = [0u16; 2];
    let e = m.read_holding(1, 1015, &mut out).unwrap_err();
    assert!(
        matches!(
            e,
            MasterError::Exception {
                slave: 1,
                function: READ_HOLDING,
                code: Exception::IllegalDataAddress
            }
        ),
        "{e}"
    );
    let c = m.counters(1);
    assert_eq!((c.requests, c.responses, c.exceptions), (1, 1, 1));
    // A quantity the spec forbids is refused before anything is sent.
    let mut big = [0u16; 126];
    assert!(matches!(
        m.read_holding(1, 1000, &mut big),
        Err(MasterError::Request(PduError::Quantity { .. }))
    ));
    assert_eq!(line.requests(1), 1);
}

#[test]
fn a_broadcast_reaches_every_slave_and_waits_the_turnaround() {
    let line = SimLine::with_slaves(&[1, 2, 3]);
    let mut m = master_on(&line);
    let t0 = Instant::now();
    m.broadcast(&Request::WriteSingle { addr: 1001, value: 42 }).unwrap();
    assert!(t0.elapsed() >= m.timing().turnaround);
    for id in [1, 2, 3] {
        assert_eq!(line.holding(id)[1], 42);
    }
    assert!(m.broadcast(&Request::ReadHolding { addr: 0, count: 1 }).is_err());
}

#[test]
fn the_master_keeps_the_frame_gap_between_requests() {
    let line = SimLine::with_slaves(&[1, 2]);
    let mut m = master_on(&line);
    let mut t = m.timing();
    t.gap = Duration::from_millis(4);
    m.set_timing(t);
    let mut out = [0u16; 1];
    for i in 0..6 {
        m.read_holding(1 + i % 2, 1000, &mut out).unwrap();
    }
    let writes = line.0.lock().unwrap().writes.clone();
    for w in writes.windows(2) {
        assert!(w[1] - w[0] >= t.gap, "requests {:?} apart", w[1] - w[0]);
    }
}

// ------------------------------------------------------------------ a real pty

/// Serves `slaves` on the master side of `pty` until `stop`: bytes are buffered and cut into
/// requests with `rtu::decode_request`, as a front does.
fn serve_pty(pty: Pty, mut slaves: Vec<(u8, Bank)>, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut buf = Vec::new();
        let mut chunk = [0u8; 256];
        let mut pdu = Vec::new();
        let mut frame = Vec::new();
        while !stop.load(Ordering::Relaxed) {
            if !poll_readable(pty.master_fd(), Duration::from_millis(10)).unwrap_or(false) {
                continue;
            }
            let n = pty.read(&mut chunk).unwrap();
            buf.extend_from_slice(&chunk[..n]);
            loop {
                match rtu::decode_request(&buf) {
                    Ok(f) => {
                        if let Some((_, b)) = slaves.iter_mut().find(|(id, _)| *id == f.slave) {
                            pdu.clear();
                            respond(b, f.pdu, true, &mut pdu, &mut |_| {});
                            frame.clear();
                            rtu::encode(f.slave, &pdu, &mut frame);
                            pty.write_all(&frame).unwrap();
                        }
                        let len = f.len;
                        buf.drain(..len);
                    }
                    Err(rtu::RtuError::Incomplete { .. }) => break,
                    Err(_) => {
                        buf.clear();
                        break;
                    }
                }
            }
        }
    })
}

#[test]
fn rtu_master_on_a_pty_serves_two_slaves_and_times_out_on_a_third() {
    let pty = Pty::open().unwrap();
    let port = SerialPort::open(pty.slave_path(), 115_200).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let server = serve_pty(pty, vec![(1, bank(100)), (2, bank(200))], stop.clone());
    let mut timing = RtuTiming::serial(115_200);
    timing.response_timeout = Duration::from_millis(200);
    let mut m = RtuMaster::new(Box::new(port), timing);
    let mut out = [0u16; 4];
    for _ in 0..20 {
        m.read_holding(1, 1000, &mut out).unwrap();
        assert_eq!(out, [100, 101, 102, 103]);
        m.read_write(2, 1004, &mut out, 1004, &[9, 8]).unwrap();
        assert_eq!(out, [9, 8, 206, 207]);
    }
    let e = m.write_single(3, 1000, 1).unwrap_err();
    assert!(matches!(e, MasterError::Timeout { slave: 3, .. }), "{e}");
    m.read_input(2, 2000, &mut out).unwrap();
    assert_eq!(out, [456, 457, 458, 459]);
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
    assert_eq!((m.counters(1).responses, m.counters(2).responses), (20, 21));
    assert_eq!(m.counters(3).timeouts, 1);
    assert_eq!(m.counters(1).errors() + m.counters(2).errors(), 0);
}

// ------------------------------------------------------------------ TCP

/// A Modbus TCP server for one connection: unit `unit` answers from `bank`; when
/// `stale_first` is set, each answer is preceded by a copy carrying the previous transaction
/// id (a late answer the master must skip).
fn serve_mbap(listener: TcpListener, unit: u8, mut bank: Bank, stale_first: bool) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let (mut s, _) = listener.accept().unwrap();
        let mut buf = Vec::new();
        let mut chunk = [0u8; 512];
        let mut pdu = Vec::new();
        let mut out = Vec::new();
        loop {
            let n = match s.read(&mut chunk) {
                Ok(0) | Err(_) => return,
                Ok(n) => n,
            };
            buf.extend_from_slice(&chunk[..n]);
            while let Ok(adu) = tcp::decode(&buf) {
                pdu.clear();
                out.clear();
                if adu.header.unit == unit || adu.header.unit == 0xFF {
                    respond(&mut bank, adu.pdu, true, &mut pdu, &mut |_| {});
                } else {
                    let _ = Response::Exception {
                        function: adu.pdu[0],
                        code: Exception::Other(0x0B),
                    }
                    .encode(&mut pdu);
                }
                let t = adu.header.transaction;
                if stale_first {
                    tcp::encode(t.wrapping_sub(1), adu.header.unit, &pdu, &mut out);
                }
                tcp::encode(t, adu.header.unit, &pdu, &mut out);
                let len = adu.len;
                buf.drain(..len);
                s.write_all(&out).unwrap();
            }
        }
    })
}

#[test]
fn modbus_tcp_master_reads_writes_and_skips_late_answers() {
    for stale in [false, true] {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let server = serve_mbap(l, 1, bank(100), stale);
        let mut m = TcpMaster::connect(addr, Duration::from_secs(2)).unwrap();
        let mut out = [0u16; 3];
        for i in 0..10u16 {
            m.write_single(1, 1000, i).unwrap();
            m.read_write(1, 1000, &mut out, 1001, &[i + 1, i + 2]).unwrap();
            assert_eq!(out, [i, i + 1, i + 2]);
        }
        let e = m.read_holding(7, 1000, &mut out).unwrap_err();
        assert!(
            matches!(
                e,
                MasterError::Exception {
                    code: Exception::Other(0x0B),
                    ..
                }
            ),
            "{e}"
        );
        let c = m.counters(1);
        assert_eq!((c.requests, c.responses, c.errors()), (20, 20, 0), "{c:?}");
        assert_eq!(c.stray_bytes > 0, stale, "late answers skipped and counted");
        drop(m);
        server.join().unwrap();
    }
}

#[test]
fn modbus_tcp_master_times_out_on_a_server_that_never_answers() {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap();
    let keep = std::thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut b = [0u8; 64];
        while matches!(s.read(&mut b), Ok(n) if n > 0) {}
    });
    let mut m = TcpMaster::connect(addr, Duration::from_millis(50)).unwrap();
    let mut out = [0u16; 1];
    let t0 = Instant::now();
    let e = m.read_holding(1, 0, &mut out).unwrap_err();
    assert!(matches!(e, MasterError::Timeout { .. }), "{e}");
    assert!(t0.elapsed() >= Duration::from_millis(50));
    assert_eq!(m.counters(1).timeouts, 1);
    drop(m);
    keep.join().unwrap();
}

#[test]
fn rtu_over_tcp_uses_the_rtu_master_on_a_socket() {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap();
    let server = std::thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut b = bank(900);
        let mut buf = Vec::new();
        let mut chunk = [0u8; 512];
        let (mut pdu, mut out) = (Vec::new(), Vec::new());
        loop {
            let n = match s.read(&mut chunk) {
                Ok(0) | Err(_) => return,
                Ok(n) => n,
            };
            buf.extend_from_slice(&chunk[..n]);
            while let Ok(f) = rtu::decode_request(&buf) {
                if f.slave == 9 {
                    pdu.clear();
                    out.clear();
                    respond(&mut b, f.pdu, false, &mut pdu, &mut |_| {});
                    if !pdu.is_empty() {
                        rtu::encode(9, &pdu, &mut out);
                        s.write_all(&out).unwrap();
                    }
                }
                let len = f.len;
                buf.drain(..len);
            }
        }
    });
    let t = TcpTransport::connect(addr, Duration::from_secs(2)).unwrap();
    let mut timing = RtuTiming::over_tcp();
    timing.response_timeout = Duration::from_millis(100);
    let mut m = RtuMaster::new(Box::new(t), timing);
    let mut out = [0u16; 3];
    m.read_write(9, 1000, &mut out, 1000, &[0x0100, 0, 0]).unwrap();
    assert_eq!(out, [0x0100, 0, 0]);
    // A silent (no-exception) device: an illegal read is a timeout, not an exception.
    let e = m.read_holding(9, 5000, &mut out).unwrap_err();
    assert!(matches!(e, MasterError::Timeout { slave: 9, .. }), "{e}");
    m.read_input(9, 2000, &mut out).unwrap();
    assert_eq!(out, [900 + 0x100, 900 + 0x101, 900 + 0x102]);
    drop(m);
    server.join().unwrap();
}
