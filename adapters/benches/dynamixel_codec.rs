//! Criterion: the Dynamixel Protocol 2.0 work of one EZGripper bus round, codec only (no
//! serial I/O): encode the sync write of the goal block and the sync read of the present
//! block for two grippers, then decode the two status replies from one byte stream.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use handgate_adapters::dynamixel::protocol::{Decoder, Request, Status, StatusError};

/// Block sizes of a round as the driver uses them (goal 18 B, present 25 B per servo minus
/// framing: see docs/ezgripper.md); the values are arbitrary.
const GOAL_LEN: u16 = 8;
const PRESENT_LEN: u16 = 15;

fn round(c: &mut Criterion) {
    let ids = [1u8, 2];
    let write = Request::SyncWrite {
        addr: 102,
        len: GOAL_LEN,
        entries: ids.iter().map(|&id| (id, vec![0x5A; GOAL_LEN as usize])).collect(),
    };
    let read = Request::SyncRead {
        addr: 126,
        len: PRESENT_LEN,
        ids: ids.to_vec(),
    };
    let mut replies = Vec::new();
    for &id in &ids {
        let st = Status {
            id,
            error: StatusError::from_byte(0),
            params: vec![0xFD; PRESENT_LEN as usize],
        };
        replies.extend(st.encode().expect("status encodes"));
    }
    c.bench_function("dynamixel/sync_write_encode_2", |b| {
        b.iter(|| black_box(&write).encode().unwrap())
    });
    c.bench_function("dynamixel/sync_read_encode_2", |b| {
        b.iter(|| black_box(&read).encode().unwrap())
    });
    c.bench_function("dynamixel/status_decode_2", |b| {
        b.iter(|| {
            let mut d = Decoder::new();
            d.push(black_box(&replies));
            let mut n = 0;
            while let Some(Ok(p)) = d.next_frame() {
                n += Status::from_packet(&p).map(|s| s.params.len()).unwrap_or(0);
            }
            n
        })
    });
    c.bench_function("dynamixel/round_codec_2", |b| {
        b.iter(|| {
            let w = black_box(&write).encode().unwrap();
            let r = black_box(&read).encode().unwrap();
            let mut d = Decoder::new();
            d.push(black_box(&replies));
            let mut n = w.len() + r.len();
            while let Some(Ok(p)) = d.next_frame() {
                n += Status::from_packet(&p).map(|s| s.params.len()).unwrap_or(0);
            }
            n
        })
    });
}

criterion_group!(benches, round);
criterion_main!(benches);
