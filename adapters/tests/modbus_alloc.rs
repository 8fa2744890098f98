//! The Modbus kit's hot path allocates nothing: an RTU master's transaction (encode, send,
//! receive, decode, check, copy out) against an RTU session answering from a register map,
//! and a Modbus TCP session answering MBAP requests, counted by a global allocator installed
//! in this test binary only.
//!
//! Everything runs on the test's own thread (the master's transport hands each request to the
//! session in memory), and allocations are counted per thread, so nothing else running in the
//! process is counted. Counts are per transaction, after a warm-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::{Duration, Instant};

use handgate_adapters::front::stream::Session;
use handgate_adapters::modbus::master::{RtuMaster, RtuTiming};
use handgate_adapters::modbus::server::Bank;
use handgate_adapters::modbus::session::{RtuSession, TcpSession};
use handgate_adapters::modbus::tcp;
use handgate_adapters::serial::{Transport, TransportError};

struct Counting;

thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: defers to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as ours.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as ours.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: same contract as ours.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocs() -> u64 {
    ALLOCS.with(Cell::get)
}

fn robotiq_bank() -> Bank {
    Bank {
        holding_base: 1000,
        holding: vec![0; 3],
        input_base: 2000,
        input: vec![0x3100, 0x00FF, 0xBD00],
    }
}

/// A line whose only slave is an RTU session, in memory: a write is served at once and the
/// answer waits in `pending` for the master's reads.
struct InMemoryLine {
    session: RtuSession<Bank>,
    pending: Vec<u8>,
    at: usize,
}

impl Transport for InMemoryLine {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        self.pending.clear();
        self.at = 0;
        let n = self
            .session
            .on_bytes(bytes, Instant::now(), &mut self.pending, &mut |()| {})
            .expect("the master's requests are valid");
        assert_eq!(n, bytes.len());
        Ok(())
    }
    fn read(&mut self, buf: &mut [u8], _timeout: Duration) -> Result<usize, TransportError> {
        let n = buf.len().min(self.pending.len() - self.at);
        buf[..n].copy_from_slice(&self.pending[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
    fn clear_input(&mut self) -> Result<(), TransportError> {
        self.at = self.pending.len();
        Ok(())
    }
}

#[test]
fn modbus_rtu_transaction_allocates_nothing() {
    let line = InMemoryLine {
        session: RtuSession::new(9, robotiq_bank(), 115_200).exceptions(false),
        pending: Vec::with_capacity(512),
        at: 0,
    };
    let mut timing = RtuTiming::over_tcp();
    timing.response_timeout = Duration::from_secs(1);
    let mut m = RtuMaster::new(Box::new(line), timing);
    let mut status = [0u16; 3];
    let mut cycle = |m: &mut RtuMaster, i: u16| {
        m.read_write(9, 1000, &mut status, 1000, &[0x0900, i, 0xFFFF]).unwrap();
        assert_eq!(status, [0x0900, i, 0xFFFF]);
        m.read_input(9, 2000, &mut status).unwrap();
        m.write_multiple(9, 1001, &[i, 0x00FF]).unwrap();
        m.write_single(9, 1000, 0x0100).unwrap();
        m.read_holding(9, 1000, &mut status[..2]).unwrap();
    };
    for i in 0..10 {
        cycle(&mut m, i);
    }
    let before = allocs();
    for i in 0..1000 {
        cycle(&mut m, i);
    }
    let n = allocs() - before;
    assert_eq!(n, 0, "{n} allocations in 5000 transactions");
    assert_eq!(m.counters(9).responses, 5050);
}

#[test]
fn modbus_tcp_session_answers_without_allocating() {
    let mut s = TcpSession::new(1, robotiq_bank());
    let mut requests = Vec::new();
    for (k, pdu) in [
        &[0x17u8, 0x03, 0xE8, 0x00, 0x03, 0x03, 0xE8, 0x00, 0x01, 0x02, 0x09, 0x00][..],
        &[0x04, 0x07, 0xD0, 0x00, 0x03],
        &[0x10, 0x03, 0xE8, 0x00, 0x02, 0x04, 0x00, 0x01, 0x00, 0x02],
    ]
    .iter()
    .enumerate()
    {
        tcp::encode(k as u16, 1, pdu, &mut requests);
    }
    let mut out = Vec::with_capacity(1024);
    let serve = |s: &mut TcpSession<Bank>, out: &mut Vec<u8>| {
        out.clear();
        let mut at = 0;
        while at < requests.len() {
            at += s.on_bytes(&requests[at..], Instant::now(), out, &mut |()| {}).unwrap();
        }
        assert_eq!(out.len(), 3 * tcp::MBAP_LEN + (2 + 6) + (2 + 6) + 5);
    };
    serve(&mut s, &mut out);
    let before = allocs();
    for _ in 0..1000 {
        serve(&mut s, &mut out);
    }
    let n = allocs() - before;
    assert_eq!(n, 0, "{n} allocations in 3000 requests");
}
