//! The Robotiq front's servers with bad clients (docs/fronts.md "Bad input"): frames with a bad
//! CRC, for another slave, of no known shape, at addresses the gripper does not have, a
//! client that connects and never sends, 100 clients at once, a URCap line that is not the
//! protocol. Each is refused (nothing answered: the gripper sends no exceptions), counted by
//! reason and logged once, and a good client on the same front keeps being answered and
//! keeps commanding. Served on loopback TCP, driven by the Modbus kit's own master.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use tokio::sync::mpsc;

use super::emulator::Motion;
use super::front::{image, rtu_session_on, SharedImage, UrcapSession};
use super::regs::{Request, Status, REQUEST_ADDR, STATUS_ADDR};
use crate::front::serve::{Inbox, Incoming, Queue};
use crate::front::stream::{serve_tcp, StreamLimits, StreamServer};
use crate::modbus::master::{RtuMaster, RtuTiming, TcpTransport};
use crate::modbus::rtu;

const WAIT: Duration = Duration::from_secs(5);

fn inbox() -> (Inbox<Motion>, mpsc::Receiver<Incoming>) {
    let (tx, rx) = mpsc::channel(64);
    (Inbox::for_tests(Queue::new(tx)), rx)
}

fn limits(idle: Duration) -> StreamLimits {
    StreamLimits {
        max_clients: 16,
        idle,
        ..StreamLimits::default()
    }
}

fn rtu_front(im: &SharedImage, idle: Duration) -> (StreamServer, mpsc::Receiver<Incoming>) {
    let (inbox, rx) = inbox();
    let im = im.clone();
    let s = serve_tcp(
        SocketAddr::from(([127, 0, 0, 1], 0)),
        limits(idle),
        move || rtu_session_on(im.clone(), 9),
        inbox,
        "robotiq-test",
        "robotiq rtu-over-tcp",
    )
    .expect("serves");
    (s, rx)
}

fn master(addr: SocketAddr) -> RtuMaster {
    let t = TcpTransport::connect(addr, WAIT).expect("connects");
    RtuMaster::new(
        Box::new(t),
        RtuTiming {
            response_timeout: Duration::from_millis(300),
            ..RtuTiming::over_tcp()
        },
    )
}

/// One FC23 exchange as pyRobotiqGripper and the C++ SDK make it.
fn exchange(m: &mut RtuMaster, r: Request) -> Status {
    let mut w = [0u16; 3];
    m.read_write(9, STATUS_ADDR, &mut w, REQUEST_ADDR, &r.to_words())
        .expect("answered");
    Status::from_words(&w)
}

/// Waits (polling, at most [`WAIT`]) until the server's counter for `reason` reaches `n`.
fn refused(s: &StreamServer, reason: &str, n: u64) {
    let deadline = Instant::now() + WAIT;
    while s.counters.refused_of(reason) < n {
        assert!(
            Instant::now() < deadline,
            "{reason}: {} of {n} after {WAIT:?}: {:?}",
            s.counters.refused_of(reason),
            s.counters.refused()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    assert_eq!(s.counters.refused_of(reason), n, "{:?}", s.counters.refused());
}

/// Nothing arrives on `s` within `d` (the gripper does not answer a bad request).
fn silent(s: &mut TcpStream, d: Duration) {
    s.set_read_timeout(Some(d)).unwrap();
    let mut b = [0u8; 64];
    match s.read(&mut b) {
        Ok(0) => panic!("closed instead of staying silent"),
        Ok(n) => panic!("answered {:02X?}", &b[..n]),
        Err(e) => assert!(
            matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut),
            "{e}"
        ),
    }
}

fn frame(slave: u8, pdu: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    rtu::encode(slave, pdu, &mut out);
    out
}

/// A bad CRC, another slave's frame, garbage and an address the gripper lacks: none answered,
/// each counted by reason; the same connection's next good request is answered, and a good
/// client alongside activates the image and commands through it all along.
#[test]
fn bad_frames_are_refused_by_reason_and_good_clients_go_on() {
    let im = image(Instant::now());
    let (server, mut cmds) = rtu_front(&im, Duration::from_secs(30));
    let addr = server.local_addr.unwrap();
    let mut good = master(addr);
    exchange(&mut good, Request::default());
    let s = exchange(
        &mut good,
        Request {
            act: true,
            ..Request::default()
        },
    );
    assert!(s.act, "{s:?}");

    let mut bad = TcpStream::connect(addr).unwrap();
    // FC03 of the status with its CRC's last byte flipped.
    let mut f = frame(9, &[0x03, 0x07, 0xD0, 0x00, 0x03]);
    *f.last_mut().unwrap() ^= 0xFF;
    bad.write_all(&f).unwrap();
    silent(&mut bad, Duration::from_millis(200));
    refused(&server, "bad_crc", 1);
    // Another slave's request: on a shared line another gripper would answer; here nobody.
    bad.write_all(&frame(5, &[0x03, 0x07, 0xD0, 0x00, 0x03])).unwrap();
    silent(&mut bad, Duration::from_millis(200));
    refused(&server, "wrong_slave", 1);
    // An address the gripper does not have: no exception response.
    bad.write_all(&frame(9, &[0x03, 0x00, 0x00, 0x00, 0x03])).unwrap();
    silent(&mut bad, Duration::from_millis(200));
    refused(&server, "illegal_address", 1);
    // Garbage: a function no Modbus device has, then silence: dropped after the frame gap.
    bad.write_all(&[0x09, 0x99, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC])
        .unwrap();
    silent(&mut bad, Duration::from_millis(200));
    refused(&server, "partial_frame", 1);
    // The same connection, a good request: answered.
    bad.set_read_timeout(Some(WAIT)).unwrap();
    bad.write_all(&frame(9, &[0x04, 0x07, 0xD0, 0x00, 0x03])).unwrap();
    let mut answer = [0u8; 11];
    bad.read_exact(&mut answer).unwrap();
    assert_eq!(&answer[..3], &[0x09, 0x04, 0x06], "{answer:02X?}");

    // The good client was never disturbed: it activates and commands.
    let deadline = Instant::now() + WAIT;
    while !exchange(
        &mut good,
        Request {
            act: true,
            ..Request::default()
        },
    )
    .activated()
    {
        assert!(Instant::now() < deadline, "the front's image activates");
        std::thread::sleep(Duration::from_millis(5));
    }
    exchange(&mut good, Request::go(200, 255, 100));
    let got = cmds.blocking_recv().expect("a command");
    let m = got.msg.downcast_ref::<Motion>().expect("a Motion");
    assert_eq!(
        *m,
        Motion::Go {
            position: 200,
            speed: 255,
            force: 100
        }
    );
    assert!(
        got.writer
            .label
            .as_deref()
            .unwrap_or("")
            .contains("robotiq rtu-over-tcp"),
        "{:?}",
        got.writer.label
    );
}

/// A client that connects and never sends is closed after the idle time (counted), and 100
/// clients at once get 16 served and 84 refused (closed at once, counted), the served ones
/// answered; once they leave, a new client is served.
#[test]
fn silent_clients_time_out_and_a_crowd_is_capped() {
    let im = image(Instant::now());
    let (server, _cmds) = rtu_front(&im, Duration::from_millis(300));
    let addr = server.local_addr.unwrap();
    let mut quiet = TcpStream::connect(addr).unwrap();
    quiet.set_read_timeout(Some(WAIT)).unwrap();
    let mut b = [0u8; 8];
    assert_eq!(quiet.read(&mut b).unwrap_or(0), 0, "closed by the server");
    refused(&server, "idle", 1);

    let crowd: Vec<TcpStream> = (0..100).map(|_| TcpStream::connect(addr).unwrap()).collect();
    refused(&server, "too_many_clients", 84);
    let mut served = 0;
    let mut closed = 0;
    for mut c in crowd {
        c.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
        c.write_all(&frame(9, &[0x03, 0x07, 0xD0, 0x00, 0x03])).ok();
        let mut a = [0u8; 11];
        match c.read(&mut a) {
            Ok(0) | Err(_) => closed += 1,
            Ok(_) => {
                assert_eq!(&a[..3], &[0x09, 0x03, 0x06], "{a:02X?}");
                served += 1
            }
        }
    }
    assert_eq!((served, closed), (16, 84));
    // The crowd gone, a newcomer is served.
    let deadline = Instant::now() + WAIT;
    loop {
        let mut m = master(addr);
        let mut w = [0u16; 3];
        if m.read_write(9, STATUS_ADDR, &mut w, REQUEST_ADDR, &[0, 0, 0]).is_ok() {
            break;
        }
        assert!(Instant::now() < deadline, "a client after the crowd is served");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The URCap socket: a line that is not the protocol is not answered (counted `bad_command`),
/// the next one is; several commands on one line answered in order.
#[test]
fn urcap_lines_that_are_not_the_protocol_are_refused() {
    let im = image(Instant::now());
    let (inbox, _rx) = inbox();
    let i2 = im.clone();
    let server = serve_tcp(
        SocketAddr::from(([127, 0, 0, 1], 0)),
        limits(Duration::from_secs(30)),
        move || UrcapSession::new(i2.clone()),
        inbox,
        "robotiq-test",
        "robotiq urcap",
    )
    .unwrap();
    let mut c = TcpStream::connect(server.local_addr.unwrap()).unwrap();
    c.write_all(b"HELLO WORLD\n").unwrap();
    silent(&mut c, Duration::from_millis(200));
    refused(&server, "bad_command", 1);
    c.set_read_timeout(Some(WAIT)).unwrap();
    c.write_all(b"SET ACT 1 GTO 1\r\n").unwrap();
    let mut a = [0u8; 3];
    c.read_exact(&mut a).unwrap();
    assert_eq!(&a, b"ack");
    c.write_all(b"GET ACT GET PRE\n").unwrap();
    let mut a = [0u8; 11];
    c.read_exact(&mut a).unwrap();
    assert_eq!(&a, b"ACT 1\nPRE 0");
}
