//! The stream sessions: byte-exact answers (the Robotiq manual's frames), partial and
//! back-to-back frames, each refusal with its reason; then served by front::stream on a pty
//! and on loopback TCP and driven by the kit's own masters, with bad clients alongside.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::mpsc;

use crate::front::serve::{Inbox, Incoming, Queue};
use crate::front::stream::{serve_pty, serve_tcp, Session, StreamError, StreamLimits};
use crate::serial::SerialPort;

use super::master::{MasterError, RtuMaster, RtuTiming, TcpMaster, TcpTransport};
use super::pdu::*;
use super::rtu;
use super::server::{Bank, RegisterMap};
use super::session::{RtuSession, ServedMap, TcpSession};

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// A write a client made, as the front would receive it.
#[derive(Debug, Clone, PartialEq)]
struct Wrote {
    addr: u16,
    values: Vec<u16>,
}

/// A bank shared by every session of a front, as a front's image is.
#[derive(Clone)]
struct Shared(Arc<Mutex<Bank>>);

impl Shared {
    /// Robotiq-shaped: command registers at 0x03E8, status at 0x07D0 (FC03 and FC04 both
    /// read it, as the gripper answers both).
    fn robotiq() -> Self {
        Shared(Arc::new(Mutex::new(Bank {
            holding_base: 0x03E8,
            holding: vec![0; 3],
            input_base: 0x07D0,
            input: vec![0xB900, 0x00FF, 0xBD00],
        })))
    }
}

impl RegisterMap for Shared {
    fn read(&mut self, table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        let mut b = self.0.lock().unwrap();
        // The status registers answer FC03 too.
        let t = if addr >= b.input_base { Table::Input } else { table };
        b.read(t, addr, out)
    }
    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        self.0.lock().unwrap().write(addr, values)
    }
}

impl ServedMap for Shared {
    type Msg = Wrote;
    fn performed(&mut self, req: &Request<'_>, sink: &mut dyn FnMut(Wrote)) {
        let (addr, values) = match *req {
            Request::WriteSingle { addr, value } => (addr, vec![value]),
            Request::WriteMultiple { addr, values }
            | Request::ReadWrite {
                write_addr: addr,
                values,
                ..
            } => (addr, values.iter().collect()),
            _ => return,
        };
        sink(Wrote { addr, values });
    }
}

/// Feeds `input` as the stream server does: repeatedly, consuming, until nothing more is
/// consumed. Returns (output, commands, errors, bytes left).
fn feed<S: Session>(s: &mut S, input: &[u8]) -> (Vec<u8>, Vec<S::Msg>, Vec<StreamError>, usize) {
    let (mut out, mut msgs, mut errs) = (Vec::new(), Vec::new(), Vec::new());
    let mut buf = input.to_vec();
    while !buf.is_empty() {
        match s.on_bytes(&buf, Instant::now(), &mut out, &mut |m| msgs.push(m)) {
            Ok(0) => break,
            Ok(n) => {
                buf.drain(..n);
            }
            Err(e) => {
                match e.skip {
                    Some(n) if n < buf.len() => {
                        buf.drain(..n);
                    }
                    _ => buf.clear(),
                }
                errs.push(e);
            }
        }
    }
    (out, msgs, errs, buf.len())
}

fn reasons(errs: &[StreamError]) -> Vec<&'static str> {
    errs.iter().map(|e| e.reason).collect()
}

#[test]
fn rtu_session_answers_the_robotiq_manuals_frames_byte_for_byte() {
    let mut s = RtuSession::new(9, Shared::robotiq(), 115_200).exceptions(false);
    let (out, msgs, errs, left) = feed(&mut s, &hex("09 10 03 E8 00 03 06 09 00 00 FF FF FF 42 29"));
    assert_eq!(out, hex("09 10 03 E8 00 03 01 30"));
    assert_eq!(
        msgs,
        [Wrote {
            addr: 0x03E8,
            values: vec![0x0900, 0x00FF, 0xFFFF]
        }]
    );
    assert!(errs.is_empty() && left == 0);
    let (out, msgs, ..) = feed(&mut s, &hex("09 03 07 D0 00 03 04 0E"));
    assert_eq!(out, hex("09 03 06 B9 00 00 FF BD 00 1D 7C"));
    assert!(msgs.is_empty(), "a read is no command");
}

#[test]
fn rtu_session_waits_for_the_rest_and_cuts_back_to_back_frames() {
    let mut s = RtuSession::new(9, Shared::robotiq(), 115_200);
    let read = hex("09 03 07 D0 00 03 04 0E");
    let mut out = Vec::new();
    assert_eq!(s.on_bytes(&read[..5], Instant::now(), &mut out, &mut |_| {}), Ok(0));
    assert!(out.is_empty());
    let mut two = read.clone();
    two.extend(hex("09 10 03 E8 00 03 06 00 00 00 00 00 00 73 30"));
    let (out, msgs, errs, left) = feed(&mut s, &two);
    assert_eq!(
        out,
        [hex("09 03 06 B9 00 00 FF BD 00 1D 7C"), hex("09 10 03 E8 00 03 01 30")].concat()
    );
    assert_eq!(msgs.len(), 1);
    assert!(errs.is_empty() && left == 0);
}

#[test]
fn rtu_session_refusals_have_their_reasons() {
    let mut s = RtuSession::new(9, Shared::robotiq(), 115_200).exceptions(false);
    // Bad CRC: nothing answered, everything buffered dropped.
    let mut bad = hex("09 03 07 D0 00 03 04 0E");
    bad[7] ^= 1;
    let (out, _, errs, left) = feed(&mut s, &bad);
    assert!(out.is_empty());
    assert_eq!((reasons(&errs), left), (vec!["bad_crc"], 0));
    assert_eq!(errs[0].skip, None);
    // Another slave's request: skipped exactly, the next request answered.
    let mut other = Vec::new();
    rtu::encode(3, &hex("03 07 D0 00 03"), &mut other);
    other.extend(hex("09 03 07 D0 00 03 04 0E"));
    let (out, _, errs, _) = feed(&mut s, &other);
    assert_eq!(reasons(&errs), ["wrong_slave"]);
    assert_eq!(out, hex("09 03 06 B9 00 00 FF BD 00 1D 7C"));
    // A silent device: an illegal address and an unknown function are not answered, but
    // counted.
    let mut req = Vec::new();
    rtu::encode(9, &hex("03 00 00 00 01"), &mut req);
    rtu::encode(9, &hex("2B 0E 01 00"), &mut req);
    let (out, _, errs, _) = feed(&mut s, &req);
    assert!(out.is_empty());
    assert_eq!(reasons(&errs), ["illegal_address", "illegal_function"]);
    assert!(errs[0].detail.contains("not answered"), "{}", errs[0].detail);
    // The same with exceptions on.
    let mut s = s.exceptions(true);
    let (out, _, errs, _) = feed(&mut s, &req);
    let mut want = Vec::new();
    rtu::encode(9, &hex("83 02"), &mut want);
    rtu::encode(9, &hex("AB 01"), &mut want);
    assert_eq!(out, want);
    assert_eq!(reasons(&errs), ["illegal_address", "illegal_function"]);
}

#[test]
fn rtu_broadcast_writes_every_slave_and_answers_none() {
    let (a, b) = (Shared::robotiq(), Shared::robotiq());
    let mut s = RtuSession::new(1, a.clone(), 115_200).with_slave(2, b.clone());
    let mut req = Vec::new();
    rtu::encode(0, &hex("06 03 E9 00 2A"), &mut req);
    let (out, msgs, errs, _) = feed(&mut s, &req);
    assert!(out.is_empty() && errs.is_empty());
    assert_eq!(msgs.len(), 2);
    assert_eq!(a.0.lock().unwrap().holding[1], 42);
    assert_eq!(b.0.lock().unwrap().holding[1], 42);
}

#[test]
fn tcp_session_answers_mbap_and_refuses_garbage_and_other_units() {
    let mut s = TcpSession::new(1, Shared::robotiq());
    let (out, msgs, errs, _) = feed(&mut s, &hex("12 34 00 00 00 06 01 04 07 D0 00 01"));
    assert_eq!(out, hex("12 34 00 00 00 05 01 04 02 B9 00"));
    assert!(msgs.is_empty() && errs.is_empty());
    let (out, msgs, _, _) = feed(&mut s, &hex("00 07 00 00 00 09 01 10 03 E8 00 01 02 01 00"));
    assert_eq!(out, hex("00 07 00 00 00 06 01 10 03 E8 00 01"));
    assert_eq!(
        msgs,
        [Wrote {
            addr: 0x03E8,
            values: vec![0x0100]
        }]
    );
    // Unit 2 is nobody: exception 0x0B (gateway target failed to respond).
    let (out, _, errs, _) = feed(&mut s, &hex("00 08 00 00 00 06 02 03 03 E8 00 01"));
    assert_eq!(out, hex("00 08 00 00 00 03 02 83 0B"));
    assert_eq!(reasons(&errs), ["wrong_unit"]);
    // An HTTP request on the port: garbage, dropped whole.
    let (out, _, errs, left) = feed(&mut s, b"GET / HTTP/1.1\r\nHost: x\r\n\r\n");
    assert!(out.is_empty());
    assert_eq!((reasons(&errs), left), (vec!["garbage"], 0));
    // Half a frame: waits.
    let (out, _, errs, left) = feed(&mut s, &hex("00 09 00 00 00 06 01 03"));
    assert!(out.is_empty() && errs.is_empty());
    assert_eq!(left, 8);
    // Any unit answered by one map.
    let mut s = TcpSession::any_unit(Shared::robotiq());
    let (out, ..) = feed(&mut s, &hex("00 01 00 00 00 06 FF 03 07 D0 00 01"));
    assert_eq!(out, hex("00 01 00 00 00 05 FF 03 02 B9 00"));
}

// ------------------------------------------------------------------ served

fn inbox() -> (Inbox<Wrote>, mpsc::Receiver<Incoming>) {
    let (tx, rx) = mpsc::channel(256);
    (Inbox::for_tests(Queue::new(tx)), rx)
}

fn link(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("hg-modbus-{}-{name}", std::process::id()))
}

#[test]
fn a_pty_front_serves_two_slaves_to_the_rtu_master() {
    let (inbox, mut rx) = inbox();
    let (a, b) = (Shared::robotiq(), Shared::robotiq());
    let (ma, mb) = (a.clone(), b.clone());
    let path = link("pty");
    let server = serve_pty(
        &path,
        move || {
            RtuSession::new(1, ma.clone(), 115_200)
                .with_slave(2, mb.clone())
                .exceptions(false)
        },
        inbox,
        "modbus-test",
        "modbus rtu",
    )
    .unwrap();
    let port = SerialPort::open(&path, 115_200).unwrap();
    let mut timing = RtuTiming::serial(115_200);
    timing.response_timeout = Duration::from_millis(300);
    let mut m = RtuMaster::new(Box::new(port), timing);
    let mut st = [0u16; 3];
    for i in 0..50u16 {
        m.read_write(1, 0x07D0, &mut st, 0x03E8, &[0x0900, i, 0xFFFF]).unwrap();
        assert_eq!(st, [0xB900, 0x00FF, 0xBD00]);
        m.read_input(2, 0x07D0, &mut st).unwrap();
    }
    assert_eq!(a.0.lock().unwrap().holding, [0x0900, 49, 0xFFFF]);
    // Nobody is slave 3: a timeout for the master, a refusal counted by the front.
    let e = m.read_holding(3, 0x07D0, &mut st).unwrap_err();
    assert!(matches!(e, MasterError::Timeout { slave: 3, .. }), "{e}");
    // A silent illegal read: a timeout too, counted under its reason.
    let e = m.read_holding(2, 0x0000, &mut st).unwrap_err();
    assert!(matches!(e, MasterError::Timeout { slave: 2, .. }), "{e}");
    m.read_holding(1, 0x07D0, &mut st).unwrap();
    let c = &server.counters;
    assert_eq!((c.refused_of("wrong_slave"), c.refused_of("illegal_address")), (1, 1));
    assert_eq!(m.counters(1).errors(), 0);
    // Every write reached the front's inbox, in order, from one writer.
    let mut got = Vec::new();
    while let Ok(x) = rx.try_recv() {
        got.push(x);
    }
    assert_eq!(got.len(), 50);
    let last = got.last().unwrap().msg.downcast_ref::<Wrote>().unwrap();
    assert_eq!(last.values, [0x0900, 49, 0xFFFF]);
    assert!(got.iter().all(|x| x.writer.handle == got[0].writer.handle));
    drop(server);
    assert!(!path.exists(), "the link goes with the server");
}

#[test]
fn rtu_over_tcp_front_survives_half_frames_and_garbage_from_other_clients() {
    let (inbox, _rx) = inbox();
    let map = Shared::robotiq();
    let server = serve_tcp(
        "127.0.0.1:0".parse().unwrap(),
        StreamLimits::default(),
        move || RtuSession::new(9, map.clone(), 115_200).exceptions(false),
        inbox,
        "modbus-test",
        "modbus rtu-over-tcp",
    )
    .unwrap();
    let addr = server.local_addr.unwrap();
    let mut timing = RtuTiming::over_tcp();
    timing.response_timeout = Duration::from_millis(300);
    let mut m = RtuMaster::new(
        Box::new(TcpTransport::connect(addr, Duration::from_secs(1)).unwrap()),
        timing,
    );
    let mut st = [0u16; 3];
    m.read_holding(9, 0x07D0, &mut st).unwrap();
    // A second client sends half a request and falls silent; a third sends garbage.
    let mut half = TcpStream::connect(addr).unwrap();
    half.write_all(&hex("09 03 07 D0")).unwrap();
    let mut junk = TcpStream::connect(addr).unwrap();
    junk.write_all(&hex("09 03 55 55 55 55 55 55")).unwrap();
    junk.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let mut b = [0u8; 16];
    assert!(!matches!(junk.read(&mut b), Ok(n) if n > 0), "garbage earns no answer");
    for _ in 0..20 {
        m.read_holding(9, 0x07D0, &mut st).unwrap();
        assert_eq!(st, [0xB900, 0x00FF, 0xBD00]);
    }
    // The half frame is dropped after the gap, the garbage as a bad CRC, each counted.
    let t0 = Instant::now();
    while server.counters.refused_of("partial_frame") == 0 && t0.elapsed() < Duration::from_secs(5) {
        m.read_holding(9, 0x07D0, &mut st).unwrap();
    }
    let refused = server.counters.refused();
    assert_eq!(refused.get("partial_frame"), Some(&1), "{refused:?}");
    assert_eq!(refused.get("bad_crc"), Some(&1), "{refused:?}");
    assert_eq!(m.counters(9).errors(), 0);
}

#[test]
fn modbus_tcp_front_serves_the_tcp_master_while_garbage_is_refused() {
    let (inbox, mut rx) = inbox();
    let map = Shared::robotiq();
    let server = serve_tcp(
        "127.0.0.1:0".parse().unwrap(),
        StreamLimits::default(),
        move || TcpSession::new(1, map.clone()),
        inbox,
        "modbus-test",
        "modbus tcp",
    )
    .unwrap();
    let addr = server.local_addr.unwrap();
    let mut m = TcpMaster::connect(addr, Duration::from_millis(500)).unwrap();
    let mut junk = TcpStream::connect(addr).unwrap();
    junk.write_all(b"GET / HTTP/1.1\r\n\r\n").unwrap();
    let mut st = [0u16; 2];
    for i in 0..30u16 {
        m.write_multiple(1, 0x03E8, &[i, i + 1]).unwrap();
        m.read_holding(1, 0x03E8, &mut st).unwrap();
        assert_eq!(st, [i, i + 1]);
    }
    let e = m.read_holding(5, 0x03E8, &mut st).unwrap_err();
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
    let t0 = Instant::now();
    while server.counters.refused_of("garbage") == 0 && t0.elapsed() < Duration::from_secs(5) {
        m.read_holding(1, 0x03E8, &mut st).unwrap();
    }
    assert_eq!(server.counters.refused_of("garbage"), 1);
    assert_eq!(server.counters.refused_of("wrong_unit"), 1);
    let mut n = 0;
    while rx.try_recv().is_ok() {
        n += 1;
    }
    assert_eq!(n, 30);
}
