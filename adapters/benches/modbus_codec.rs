//! Criterion: the Modbus kit's share of a Robotiq-style exchange (FC23: write the 3 command
//! registers at 1000, read the 3 status registers at 2000, slave 9), without wire time:
//!
//! * `modbus/fc23_request_encode`: the master builds the RTU request frame;
//! * `modbus/fc23_session_answer`: an `RtuSession` cuts the request and answers it from a map;
//! * `modbus/fc23_response_decode`: the master cuts, checks and decodes the answer;
//! * `modbus/fc23_exchange_pty`: one whole `RtuMaster` transaction through a pty served by
//!   `front::stream::serve_pty` (two syscalls and a thread hand-over each way; the master's
//!   frame gap set to zero: the line's own timing is the device bench's business).

use std::time::{Duration, Instant};

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use handgate_adapters::front::serve::{Inbox, Queue};
use handgate_adapters::front::stream::{serve_pty, Session};
use handgate_adapters::modbus::master::{RtuMaster, RtuTiming};
use handgate_adapters::modbus::pdu::{Regs, Request, Response};
use handgate_adapters::modbus::rtu;
use handgate_adapters::modbus::server::Bank;
use handgate_adapters::modbus::session::RtuSession;
use handgate_adapters::serial::SerialPort;

fn bank() -> Bank {
    // Command registers 1000..1002 and status 2000..2002, both as holding registers here
    // (FC23 reads holding registers): one bank from 1000 to 2002.
    let mut holding = vec![0u16; 1003];
    holding[1000..].copy_from_slice(&[0x3100, 0x00FF, 0xBD00]);
    Bank {
        holding_base: 1000,
        holding,
        input_base: 0,
        input: Vec::new(),
    }
}

const COMMAND: [u16; 3] = [0x0900, 0x00FF, 0xFFFF];

fn fc23() -> Request<'static> {
    Request::ReadWrite {
        read_addr: 2000,
        read_count: 3,
        write_addr: 1000,
        values: Regs::from_words(&COMMAND),
    }
}

fn codec(c: &mut Criterion) {
    let mut frame = Vec::with_capacity(rtu::MAX_ADU);
    c.bench_function("modbus/fc23_request_encode", |b| {
        b.iter(|| {
            frame.clear();
            let start = rtu::begin(&mut frame, 9);
            black_box(fc23()).encode(&mut frame).unwrap();
            rtu::finish(&mut frame, start);
        })
    });
    let mut session = RtuSession::new(9, bank(), 115_200).exceptions(false);
    let mut answer = Vec::with_capacity(rtu::MAX_ADU);
    c.bench_function("modbus/fc23_session_answer", |b| {
        b.iter(|| {
            answer.clear();
            let n = session
                .on_bytes(black_box(&frame), Instant::now(), &mut answer, &mut |()| {})
                .unwrap();
            assert_eq!(n, frame.len());
        })
    });
    let mut status = [0u16; 3];
    c.bench_function("modbus/fc23_response_decode", |b| {
        b.iter(|| {
            let f = rtu::decode_response(black_box(&answer), 0x17).unwrap();
            assert_eq!(f.slave, 9);
            match Response::decode(f.pdu).unwrap() {
                Response::ReadWrite(r) if r.len() == 3 => r.copy_to(&mut status),
                other => panic!("{other:?}"),
            }
        })
    });
    assert_eq!(status, [0x3100, 0x00FF, 0xBD00]);
}

fn exchange(c: &mut Criterion) {
    let (tx, _rx) = tokio::sync::mpsc::channel(1024);
    let link = std::env::temp_dir().join(format!("hg-modbus-bench-{}", std::process::id()));
    let _server = serve_pty(
        &link,
        || RtuSession::new(9, bank(), 115_200).exceptions(false),
        Inbox::<()>::for_tests(Queue::new(tx)),
        "modbus-bench",
        "modbus rtu",
    )
    .unwrap();
    let port = SerialPort::open(&link, 115_200).unwrap();
    let mut timing = RtuTiming::serial(115_200);
    timing.gap = Duration::ZERO;
    timing.response_timeout = Duration::from_millis(500);
    let mut m = RtuMaster::new(Box::new(port), timing);
    let mut status = [0u16; 3];
    c.bench_function("modbus/fc23_exchange_pty", |b| {
        b.iter(|| m.read_write(9, 2000, &mut status, 1000, &COMMAND).unwrap())
    });
    assert_eq!(m.counters(9).errors(), 0);
}

criterion_group!(benches, codec, exchange);
criterion_main!(benches);
