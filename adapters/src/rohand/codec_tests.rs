//! The ROHand's codec and emulator core against frames built from OYMotion's protocol doc
//! (section 3's examples, with their CRC computed independently of the kit).

use std::time::{Duration, Instant};

use super::emulator::{angle_of, pos_of, RohandCore};
use super::*;
use crate::modbus::hand::EmulatorCore;
use crate::modbus::server::{respond, RegisterMap};
use crate::modbus::{rtu, Regs, Request, Response, Table};

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

fn core() -> RohandCore {
    RohandCore::new(&EmuSpec {
        slave: 2,
        start: vec![0.0; FINGERS],
        object_at: vec![None; FINGERS],
    })
}

/// The RTU answer of `core` to the request frame `req`.
fn answer(core: &mut RohandCore, req: &[u8]) -> Vec<u8> {
    let f = rtu::decode_request(req).unwrap();
    let mut out = Vec::new();
    let begin = rtu::begin(&mut out, f.slave);
    respond(core, f.pdu, true, &mut out, &mut |_| {});
    rtu::finish(&mut out, begin);
    out
}

#[test]
fn the_docs_frame_examples_decode_as_the_doc_reads_them() {
    let b1 = hex("11 03 00 6b 00 02 b7 47");
    let f = rtu::decode_request(&b1).unwrap();
    assert_eq!(f.slave, 0x11);
    assert_eq!(
        Request::decode(f.pdu).unwrap(),
        Request::ReadHolding { addr: 0x6B, count: 2 }
    );
    let b2 = hex("11 03 04 00 01 00 02 3b f3");
    let f = rtu::decode_response(&b2, 3).unwrap();
    assert_eq!(
        Response::decode(f.pdu).unwrap(),
        Response::ReadHolding(Regs::from_words(&[1, 2]))
    );
    let b3 = hex("11 06 00 6b 10 00 f7 46");
    let f = rtu::decode_request(&b3).unwrap();
    assert_eq!(
        Request::decode(f.pdu).unwrap(),
        Request::WriteSingle {
            addr: 0x6B,
            value: 0x1000
        }
    );
    let b4 = hex("11 10 00 01 00 02 04 00 0a 01 02 c6 f0");
    let f = rtu::decode_request(&b4).unwrap();
    assert_eq!(
        Request::decode(f.pdu).unwrap(),
        Request::WriteMultiple {
            addr: 1,
            values: Regs::from_words(&[0x000A, 0x0102])
        }
    );
    let b5 = hex("11 10 00 01 00 02 12 98");
    let f = rtu::decode_response(&b5, 0x10).unwrap();
    assert_eq!(
        Response::decode(f.pdu).unwrap(),
        Response::WriteMultiple { addr: 1, count: 2 }
    );
}

#[test]
fn the_core_answers_the_frames_a_rohand_client_sends() {
    let mut c = core();
    // FC03 ROH_FINGER_POS0..5 (1145) of slave 2: an open hand.
    assert_eq!(
        answer(&mut c, &hex("02 03 04 79 00 06 15 12")),
        hex("02 03 0c 00 00 00 00 00 00 00 00 00 00 00 00 d0 71")
    );
    // FC16 ROH_FINGER_POS_TARGET0..5 (1135) = 65535: echoed.
    assert_eq!(
        answer(
            &mut c,
            &hex("02 10 04 6f 00 06 0c ff ff ff ff ff ff ff ff ff ff ff ff 34 0f")
        ),
        hex("02 10 04 6f 00 06 71 15")
    );
    // Outside the register file: EC02; a write to the read-only ROH_FINGER_POS: EC02.
    assert_eq!(answer(&mut c, &hex("02 03 00 6b 00 02 b5 e4")), hex("02 83 02 30 f1"));
    assert_eq!(answer(&mut c, &hex("02 06 04 79 00 01 98 d0")), hex("02 86 02 33 a1"));
}

#[test]
fn fingers_move_at_their_speed_and_stop_on_an_object() {
    let mut object = vec![None; FINGERS];
    object[1] = Some(20_000.0);
    let mut c = RohandCore::new(&EmuSpec {
        slave: 2,
        start: vec![0.0; FINGERS],
        object_at: object,
    });
    let t0 = Instant::now();
    c.step(t0);
    c.write(reg::POS_TARGET, Regs::from_words(&[65535; 6])).unwrap();
    c.write(reg::SPEED, Regs::from_words(&[32768])).unwrap(); // the thumb at half speed
    c.step(t0 + Duration::from_millis(500));
    let mut pos = [0u16; 6];
    c.read(Table::Holding, reg::POS, &mut pos).unwrap();
    assert!((16_000..=16_800).contains(&pos[0]), "{pos:?}");
    assert!((20_000..=20_001).contains(&pos[1]), "held by the object: {pos:?}");
    assert!((32_000..=33_500).contains(&pos[2]), "{pos:?}");
    let mut st = [0u16; 6];
    c.read(Table::Holding, reg::FINGER_STATUS, &mut st).unwrap();
    assert_eq!(st[..3], [status::CLOSING, status::FORCE_REACHED, status::CLOSING]);
    let mut force = [0u16; 2];
    c.read(Table::Holding, reg::FORCE, &mut force).unwrap();
    assert_eq!(force, [0, 15000]);
    c.step(t0 + Duration::from_millis(1100));
    c.read(Table::Holding, reg::POS, &mut pos).unwrap();
    assert_eq!(pos[2], 65535);
    c.read(Table::Holding, reg::FINGER_STATUS, &mut st).unwrap();
    assert_eq!(st[2], status::POS_REACHED);
    // Angle registers follow the doc's ends: the middle finger closed at 97.81 deg.
    let mut angle = [0u16; 6];
    c.read(Table::Holding, reg::ANGLE, &mut angle).unwrap();
    assert_eq!(angle[2] as i16, 9781);
    // An angle target sets the position target.
    c.write(reg::ANGLE_TARGET + 3, Regs::from_words(&[17654])).unwrap();
    let mut t = [0u16; 1];
    c.read(Table::Holding, reg::POS_TARGET + 3, &mut t).unwrap();
    assert_eq!(t[0], 0);
    let p = pos_of(1, angle_of(1, 30_000.0));
    assert!((29_950..=30_050).contains(&p), "{p}");
}

#[test]
fn state_and_targets_through_the_table() {
    let table = Rohand::table(Side::Right);
    let mut regs = [0u16; Rohand::STATE.1 as usize];
    let at = |r: u16| (r - Rohand::STATE.0) as usize;
    for i in 0..FINGERS {
        regs[at(reg::POS) + i] = 65535;
        regs[at(reg::FINGER_STATUS) + i] = status::POS_REACHED;
    }
    regs[at(reg::FINGER_STATUS) + 1] = status::FORCE_REACHED;
    regs[at(reg::FORCE) + 4] = CONTACT_FORCE_MN;
    let mut st = HandState::empty(FINGERS);
    Rohand::state(&table, &regs, &mut st);
    for (i, j) in st.joints.iter().enumerate() {
        assert!((j.q - span(i)).abs() < 1e-4, "{i}: {}", j.q);
    }
    assert!((span(5) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    assert_eq!(st.contact, [false, true, false, false, true, false]);
    assert_eq!(st.faults, 0);
    regs[at(reg::FINGER_STATUS) + 2] = status::STUCK;
    Rohand::state(&table, &regs, &mut st);
    assert_eq!(st.faults, faults::HARDWARE);
    assert_eq!(st.mode, status::STUCK as u8);
    // The closed posture is every register at 65535 (OYMotion's fist).
    let crate::mapping::ClosureMap::Postures { closed, .. } = &table.closure else {
        panic!("postures")
    };
    let wire: Vec<f32> = table.joints.iter().zip(closed).map(|(j, q)| j.q_to_wire(*q)).collect();
    let mut out = [0u16; FINGERS];
    Rohand::targets(&wire, &mut out);
    assert_eq!(out, [65535; FINGERS]);
    Rohand::targets(&[-5.0, 1e9, 100.4, 0.0, 0.0, 0.0], &mut out);
    assert_eq!(out[..3], [0, 65535, 100]);
}
