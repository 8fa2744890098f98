//! The bodies of handgate's libFuzzer targets (one `fuzz_targets/*.rs` file each calls one
//! function here) and the seed corpora (`gen_seeds`). Each body checks properties, not only
//! "does not panic": a CRC-fixed frame must decode and re-encode to the same bytes, the
//! emulator's joints never leave their limits, a decoded wire type re-encodes to bytes that
//! decode to the same bytes, an accepted front command resolves to targets inside the
//! device's limits with finite wire values.
//!
//! Input layout: byte 0 selects a variant (type, front, mode flags); the rest is the payload.

use std::time::{Duration, Instant};

use handgate_adapters::dex1::adapter::Variant;
use handgate_adapters::dex3::usb::codec::{
    parse_bus, parse_feedback, BusId, LinuxToMcuCmd, McuToLinuxState, MotorCmdFrame, MotorStatus, RisMode,
    BUS_BUFFER_SIZE, BUS_COUNT, CMD_FRAME_LEN, MOTOR_CMD_LEN, STATE_FRAME_LEN,
};
use handgate_adapters::dex3::usb::convert::apply_state;
use handgate_adapters::dex3::usb::crc::crc32_words;
use handgate_adapters::dex3::usb::emulator::{Dex3Emulator, EmulatorConfig, Reply};
use handgate_adapters::dex3::usb::scaling::Scalings;
use handgate_adapters::dex3::usb::wiring::WiringMap;
use handgate_adapters::dex3::{Dex3Measurement, Joint};
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{DeviceKind, JointState, SafeAction, Side};
use handgate_adapters::route as router;
use handgate_idl::{from_cdr, handgate as hg, ros2, to_cdr_be, to_cdr_le, unitree_go, unitree_hg};
use serde::{de::DeserializeOwned, Serialize};

/// Rewrites the frame CRC (last 4 bytes, over bytes 2..len-4) of a Dex3 USB frame.
pub fn fix_frame_crc(buf: &mut [u8]) {
    let n = buf.len();
    let crc = crc32_words(&buf[2..n - 4]);
    buf[n - 4..].copy_from_slice(&crc.to_le_bytes());
}

fn side_of(b: u8) -> Side {
    if b & 1 == 0 {
        Side::Left
    } else {
        Side::Right
    }
}

// ---------------------------------------------------------------- dex3_state_frame

/// Host side of the Dex3 USB link: a state frame as the MCU would send it.
/// flag bit 0: raw bytes (CRC as given); set: the payload is laid into a 1270-byte frame and
/// its CRC fixed, so the bus parser runs on arbitrary bus contents.
pub fn dex3_state_frame(data: &[u8]) {
    let Some((&flag, body)) = data.split_first() else {
        return;
    };
    let wiring = WiringMap::default();
    let scalings = Scalings::default();
    let mut meas = Dex3Measurement::empty(Instant::now());
    if flag & 1 == 0 {
        if let Ok(st) = McuToLinuxState::decode(body) {
            let _ = parse_feedback(&st);
            let _ = apply_state(&mut meas, &st, &wiring, &scalings);
        }
        // The bus walker on its own, with the size word taken from the input.
        if body.len() >= 5 {
            let size = u32::from_le_bytes([body[0], body[1], body[2], body[3]]);
            let bus = BusId::ALL[body[4] as usize % BUS_COUNT];
            let mut out = Default::default();
            parse_bus(bus, &body[5..], size, &mut out);
        }
        return;
    }
    let mut buf = [0u8; STATE_FRAME_LEN];
    let n = body.len().min(STATE_FRAME_LEN);
    buf[..n].copy_from_slice(&body[..n]);
    fix_frame_crc(&mut buf);
    let st = McuToLinuxState::decode(&buf).expect("a frame with a fixed CRC must decode");
    // Round trip: what decodes re-encodes to the same bytes.
    assert_eq!(st.encode()[..], buf[..], "state frame does not re-encode to its bytes");
    let parsed = parse_feedback(&st);
    let rep = apply_state(&mut meas, &st, &wiring, &scalings);
    assert_eq!(rep.counters, parsed.counters);
    // Every bus contributes at most buffer/smallest-packet packets.
    assert!(parsed.motors.len() + parsed.sensors.len() <= BUS_COUNT * BUS_BUFFER_SIZE / 26);
    for m in &meas.motors {
        assert!(!m.q.is_nan() || !m.present, "a present motor decoded to NaN");
    }
}

// ---------------------------------------------------------------- dex3_emulator_frame

/// Device side of the Dex3 USB link: command frames into the emulator (`handle_frame`).
/// flag bit 0: side; bits 1-2: 0 raw frames (CRC as given), 1 frame CRC fixed, 2/3
/// structured: the payload is a list of motor packets (bus, mode, res, tor, spd, pos, kp, kd,
/// 15 bytes each) encoded with valid CRCs, so every motor-command path runs. After each
/// exchange the emulator's joints must be finite and inside their limits, and its reply must
/// be a valid state frame whose buses parse cleanly.
pub fn dex3_emulator_frame(data: &[u8]) {
    let Some((&flag, body)) = data.split_first() else {
        return;
    };
    let side = side_of(flag);
    let mut emu = Dex3Emulator::new(side, EmulatorConfig::default());
    let mut out = [0u8; STATE_FRAME_LEN];
    let mut frames: Vec<Vec<u8>> = Vec::new();
    match (flag >> 1) & 3 {
        0 => frames.extend(body.chunks(CMD_FRAME_LEN).map(<[u8]>::to_vec)),
        1 => {
            for c in body.chunks(CMD_FRAME_LEN) {
                let mut f = vec![0u8; CMD_FRAME_LEN];
                f[..c.len()].copy_from_slice(c);
                fix_frame_crc(&mut f);
                frames.push(f);
            }
        }
        _ => {
            // Up to 8 frames, each of the packets that fit.
            let mut cmd = LinuxToMcuCmd::default();
            let mut packets = 0;
            for p in body.chunks_exact(15) {
                let bus = p[0] as usize % BUS_COUNT;
                let f = MotorCmdFrame {
                    mode: RisMode::decode(p[1]),
                    res: p[2],
                    tor_des: i16::from_le_bytes([p[3], p[4]]),
                    spd_des: i16::from_le_bytes([p[5], p[6]]),
                    pos_des: i32::from_le_bytes([p[7], p[8], p[9], p[10]]),
                    k_pos: u16::from_le_bytes([p[11], p[12]]),
                    k_spd: u16::from_le_bytes([p[13], p[14]]),
                };
                if cmd.buses[bus].push(&f.encode(), bus).is_err() || p[0] >= 0xF0 {
                    frames.push(cmd.encode().to_vec());
                    cmd = LinuxToMcuCmd::default();
                    let _ = cmd.buses[bus].push(&f.encode(), bus);
                }
                packets += 1;
                if packets > 8 * (BUS_BUFFER_SIZE / MOTOR_CMD_LEN) * BUS_COUNT {
                    break;
                }
            }
            frames.push(cmd.encode().to_vec());
        }
    }
    for (i, f) in frames.iter().enumerate().take(16) {
        let reply = emu.handle_frame(f, &mut out);
        assert_eq!(reply, Reply::Frame, "no fault injected, so every exchange is answered");
        let st = McuToLinuxState::decode(&out).expect("the emulator's reply must pass its own CRC");
        let parsed = parse_feedback(&st);
        assert_eq!(
            parsed.counters.total(),
            0,
            "the emulator's reply buses must parse cleanly: {:?}",
            parsed.counters
        );
        // Let the physics run a little between frames (deterministic).
        emu.advance(Duration::from_millis(1 + (i as u64 * 7) % 50));
        for j in Joint::ALL {
            let q = emu.joint_q(j);
            let (lo, hi) = j.limits(side);
            assert!(
                q.is_finite() && q >= lo - 1e-4 && q <= hi + 1e-4,
                "joint {j:?} at {q} outside [{lo}, {hi}]"
            );
        }
    }
}

// ---------------------------------------------------------------- cdr_decode

/// Every wire type, in a fixed order (index = selector byte modulo the count). The names are
/// the fixture files' `module__Type` prefixes.
pub const TYPES: [&str; 19] = [
    "unitree_hg__MotorCmd_",
    "unitree_hg__MotorState_",
    "unitree_hg__PressSensorState_",
    "unitree_hg__IMUState_",
    "unitree_hg__HandCmd_",
    "unitree_hg__HandState_",
    "unitree_go__MotorCmd_",
    "unitree_go__MotorCmds_",
    "unitree_go__MotorState_",
    "unitree_go__MotorStates_",
    "builtin_interfaces__Time_",
    "std_msgs__Header_",
    "sensor_msgs__JointState_",
    "handgate__JointCmd_",
    "handgate__HandCmd_",
    "handgate__JointState_",
    "handgate__HandState_",
    "handgate__DeviceStatus_",
    "handgate__GatewayStatus_",
];

fn roundtrip<T: Serialize + DeserializeOwned>(bytes: &[u8]) {
    let Ok(v) = from_cdr::<T>(bytes) else { return };
    for enc in [to_cdr_le::<T> as fn(&T) -> _, to_cdr_be::<T>] {
        let b1 = enc(&v).expect("a decoded value must encode");
        let v2 = from_cdr::<T>(&b1).expect("what handgate encodes must decode");
        let b2 = enc(&v2).expect("re-encode");
        assert_eq!(b1, b2, "CDR round trip is not stable");
    }
}

/// CDR decoding of every wire type; what decodes must re-encode (both endiannesses) and
/// decode back to the same bytes.
pub fn cdr_decode(data: &[u8]) {
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    match sel as usize % TYPES.len() {
        0 => roundtrip::<unitree_hg::MotorCmd_>(body),
        1 => roundtrip::<unitree_hg::MotorState_>(body),
        2 => roundtrip::<unitree_hg::PressSensorState_>(body),
        3 => roundtrip::<unitree_hg::IMUState_>(body),
        4 => roundtrip::<unitree_hg::HandCmd_>(body),
        5 => roundtrip::<unitree_hg::HandState_>(body),
        6 => roundtrip::<unitree_go::MotorCmd_>(body),
        7 => roundtrip::<unitree_go::MotorCmds_>(body),
        8 => roundtrip::<unitree_go::MotorState_>(body),
        9 => roundtrip::<unitree_go::MotorStates_>(body),
        10 => roundtrip::<ros2::Time_>(body),
        11 => roundtrip::<ros2::Header_>(body),
        12 => roundtrip::<ros2::JointState_>(body),
        13 => roundtrip::<hg::JointCmd_>(body),
        14 => roundtrip::<hg::HandCmd_>(body),
        15 => roundtrip::<hg::JointState_>(body),
        16 => roundtrip::<hg::HandState_>(body),
        17 => roundtrip::<hg::DeviceStatus_>(body),
        _ => roundtrip::<hg::GatewayStatus_>(body),
    }
}

// ---------------------------------------------------------------- front_decode

/// The fronts, as the selector's low 3 bits pick them; the payload is the CDR of the front's
/// command type.
pub const FRONTS: [&str; 8] = [
    "dex3-left",
    "dex3-right",
    "dex1-go-left",
    "dex1-go-right",
    "dex1-actuator-left",
    "dex1-actuator-right",
    "dex1-hg",
    "canonical",
];

const KINDS: [DeviceKind; 4] = [
    DeviceKind::Dex3,
    DeviceKind::Dex1,
    DeviceKind::Ezgripper,
    DeviceKind::HandSdk,
];

fn check_targets(dtable: &DeviceTable, body: &handgate_adapters::model::CommandBody) {
    let measured = vec![JointState::default(); dtable.joint_count()];
    // What a front accepted the device must accept too: a front that passes a command the
    // device then refuses counts one bad sample twice (front + device) and logs it as a
    // device fault.
    let targets = match dtable.resolve(body, None, &measured) {
        Ok(t) => t,
        Err(e) => panic!("front accepted a command the device table refuses: {e} ({body:?})"),
    };
    assert_eq!(targets.len(), dtable.joint_count());
    for (j, t) in dtable.joints.iter().zip(&targets) {
        assert!(t.is_finite(), "non-finite target {t:?} for {}", j.name);
        assert!(
            t.q >= j.limits.min && t.q <= j.limits.max,
            "{} commanded to {} outside [{}, {}]",
            j.name,
            t.q,
            j.limits.min,
            j.limits.max
        );
        assert!(t.kp >= 0.0 && t.kp <= dtable.max_kp && t.kd >= 0.0 && t.kd <= dtable.max_kd);
        assert!(t.tau.abs() <= dtable.max_tau);
    }
    for w in dtable.to_wire(&targets) {
        assert!(
            [w.q, w.dq, w.tau, w.kp, w.kd].iter().all(|x| x.is_finite()),
            "a target inside limits became a non-finite wire value: {w:?}"
        );
    }
}

/// Front decoders fed with CDR-decoded messages; what a front accepts, routed to a device of
/// any kind (selector bits 3-4) and resolved, must stay inside that device's limits.
pub fn front_decode(data: &[u8]) {
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let dkind = KINDS[(sel as usize >> 3) % KINDS.len()];
    let dside = side_of(sel >> 5);
    let Ok(dtable) = dkind.table(dside, &TableOverrides::default()) else {
        return;
    };
    let front = sel & 7;
    let side = side_of(front);
    let (fkind, params) = match front {
        0 | 1 => (DeviceKind::Dex3, TableOverrides::default()),
        2..=6 => (DeviceKind::Dex1, TableOverrides::default()),
        _ => {
            let Ok(m) = from_cdr::<hg::HandCmd_>(body) else { return };
            if let Ok(b) = handgate_adapters::front::canonical::decode_cmd(&m, &dtable, SafeAction::Hold) {
                check_targets(&dtable, &b);
            }
            return;
        }
    };
    let Ok(ftable) = fkind.table(side, &params) else {
        return;
    };
    let measured = vec![JointState::default(); ftable.joint_count()];
    let decoded = match front {
        0 | 1 => from_cdr::<unitree_hg::HandCmd_>(body)
            .ok()
            .map(|m| handgate_adapters::dex3::front::decode_cmd(&m, &ftable, &measured)),
        2 | 3 => from_cdr::<unitree_go::MotorCmds_>(body)
            .ok()
            .map(|m| handgate_adapters::dex1::front::decode_go(&m, Variant::Go, side, &ftable)),
        4 | 5 => from_cdr::<unitree_go::MotorCmds_>(body)
            .ok()
            .map(|m| handgate_adapters::dex1::front::decode_go(&m, Variant::Actuator, side, &ftable)),
        _ => from_cdr::<unitree_hg::HandCmd_>(body)
            .ok()
            .map(|m| handgate_adapters::dex1::front::decode_hg(&m, &ftable)),
    };
    if let Some(Ok(c)) = decoded {
        let body = router::route_command(&ftable, &dtable, &c.joints);
        check_targets(&dtable, &body);
    }
}

// ---------------------------------------------------------------- seeds

/// Seed inputs per target: (target, name, bytes). CDR seeds come from the committed golden
/// fixtures (`tests/fixtures/golden/*.json`, `cdr_le_hex`, written by unitree_sdk2py /
/// CycloneDDS Python); Dex3 frames from the codec and the emulator.
/// Dynamixel Protocol 2.0 stream decoder, fed in chunks of (byte 0 % 64 + 1) bytes: every
/// packet it yields re-encodes (`encode_packet`) to bytes that decode to the same packet, and
/// the status/request views never panic.
pub fn dynamixel_packet(data: &[u8]) {
    use handgate_adapters::dynamixel::protocol::{encode_packet, is_fast_reply, Decoder, Request, Status};
    let Some((&step, body)) = data.split_first() else {
        return;
    };
    let mut d = Decoder::new();
    for chunk in body.chunks(step as usize % 64 + 1) {
        d.push(chunk);
        while let Some(frame) = d.next_frame() {
            let Ok(p) = frame else { continue };
            let _ = Status::from_packet(&p);
            let _ = Request::from_packet(&p);
            if is_fast_reply(p.id, p.instruction) {
                // Sent unstuffed: `dynamixel_fast_sync_reply`'s property, not this one.
                continue;
            }
            let bytes = encode_packet(p.id, p.instruction, &p.params).expect("a decoded packet re-encodes");
            let mut again = Decoder::new();
            again.push(&bytes);
            assert_eq!(again.next_frame().and_then(Result::ok).as_ref(), Some(&p));
        }
    }
}

/// The Inspire RH56 serial protocol (`inspire_rh56::proto`): the bytes as a stream of
/// requests and of replies, resynchronised past garbage as the emulator and the front do.
/// Every request that decodes re-encodes to its own bytes and is answered by an emulated line
/// without panicking; every reply that decodes re-encodes to its own bytes.
pub fn rh56_proto(data: &[u8]) {
    use handgate_adapters::inspire_rh56::emulator::{HandSpec, Line, Rh56Hand};
    use handgate_adapters::inspire_rh56::proto::{
        decode_reply, decode_request, encode_read, encode_read_reply, encode_write, encode_write_ack, resync,
        FrameError, Reply, Request,
    };
    let mut line = Line::new(vec![Rh56Hand::new(HandSpec::new(1)), Rh56Hand::new(HandSpec::new(2))]);
    let now = std::time::Instant::now();
    let (mut out, mut again) = (Vec::new(), Vec::new());
    let mut rest = data;
    while !rest.is_empty() {
        match decode_request(rest) {
            Ok((req, n)) => {
                match req {
                    Request::Read { id, addr, count } => encode_read(id, addr, count as usize, &mut again).unwrap(),
                    Request::Write { id, addr, data } => encode_write(id, addr, data, &mut again).unwrap(),
                }
                assert_eq!(again, rest[..n], "a decoded request re-encodes to its bytes");
                let _ = line.answer(&req, now, &mut out);
                rest = &rest[n..];
            }
            Err(FrameError::Incomplete { .. }) => break,
            Err(_) => rest = &rest[resync(rest).max(1)..],
        }
    }
    let mut rest = data;
    while !rest.is_empty() {
        match decode_reply(rest) {
            Ok((r, n)) => {
                match r {
                    Reply::Read { id, addr, data } => encode_read_reply(id, addr, data, &mut again).unwrap(),
                    Reply::WriteAck { id, addr, ok } => {
                        encode_write_ack(id, addr, ok, &mut again);
                        // Any result byte but 1 reads as refused; only 0 and 1 re-encode.
                        if rest[7] > 1 {
                            again[7] = rest[7];
                            again[8] = rest[8];
                        }
                    }
                }
                assert_eq!(again, rest[..n], "a decoded reply re-encodes to its bytes");
                rest = &rest[n..];
            }
            Err(FrameError::Incomplete { .. }) => break,
            Err(_) => rest = &rest[1..],
        }
    }
}

/// Dynamixel Fast Sync Read replies (a status from the broadcast id, unstuffed): byte 0 is
/// each device's data length (% 32), the rest a byte stream fed whole. Every reply the
/// decoder yields whose entries parse re-encodes (`encode_fast_sync_reply`) to a frame that
/// decodes to the same entries.
pub fn dynamixel_fast_sync_reply(data: &[u8]) {
    use handgate_adapters::dynamixel::protocol::{
        encode_fast_sync_reply, fast_sync_entries, is_fast_reply, Decoder, FastEntry,
    };
    let Some((&len, body)) = data.split_first() else {
        return;
    };
    let len = len as usize % 32;
    let mut d = Decoder::new();
    d.push(body);
    let mut out = Vec::new();
    while let Some(frame) = d.next_frame() {
        let Ok(p) = frame else { continue };
        if !is_fast_reply(p.id, p.instruction) {
            continue;
        }
        let Ok(entries) = fast_sync_entries(&p.params, len) else {
            continue;
        };
        let entries: Vec<FastEntry<'_>> = entries.collect();
        if entries.iter().any(|e| e.id > 252) {
            continue;
        }
        encode_fast_sync_reply(entries.len(), len, &mut out, |i, data| {
            data.copy_from_slice(entries[i].data);
            (entries[i].id, entries[i].error)
        })
        .expect("parsed entries re-encode");
        let mut again = Decoder::new();
        again.push(&out);
        let q = again.next_frame().and_then(Result::ok).expect("a re-encoded reply decodes");
        let back: Vec<FastEntry<'_>> = fast_sync_entries(&q.params, len).expect("and parses").collect();
        assert_eq!(back, entries);
    }
}

// ---------------------------------------------------------------- modbus_rtu_frame / modbus_mbap

/// The register bank the Modbus targets serve: Robotiq-shaped (command registers at 0x03E8,
/// status at 0x07D0).
fn modbus_bank() -> handgate_adapters::modbus::server::Bank {
    handgate_adapters::modbus::server::Bank {
        holding_base: 0x03E8,
        holding: vec![0; 6],
        input_base: 0x07D0,
        input: vec![0x3100, 0x00FF, 0xBD00],
    }
}

/// Feeds `body` in chunks of `step` bytes to a stream session as front::stream's server does
/// (consumed bytes dropped, refusals skip what they say or clear the buffer) and hands every
/// reply to `check`.
fn modbus_feed<S: handgate_adapters::front::stream::Session>(
    session: &mut S,
    body: &[u8],
    step: usize,
    mut check: impl FnMut(&[u8]),
) {
    let now = Instant::now();
    let (mut buf, mut out) = (Vec::new(), Vec::new());
    for chunk in body.chunks(step) {
        buf.extend_from_slice(chunk);
        loop {
            out.clear();
            let r = session.on_bytes(&buf, now, &mut out, &mut |_| {});
            check(&out);
            match r {
                Ok(0) => break,
                Ok(n) => {
                    assert!(n <= buf.len(), "a session consumed more than it was given");
                    buf.drain(..n);
                }
                Err(e) => match e.skip {
                    Some(n) if n > 0 && n < buf.len() => {
                        buf.drain(..n);
                    }
                    _ => buf.clear(),
                },
            }
            if buf.is_empty() {
                break;
            }
        }
    }
}

/// Modbus RTU, both sides. Byte 0: bits 0-4 the chunk size - 1, bit 5 exceptions off, bits
/// 6-7 the function the master side expects (FC03, FC04, FC16, FC23). A request frame the
/// decoder cuts re-encodes to its bytes, a request PDU that decodes re-encodes to its bytes,
/// every reply the RTU session writes is a whole frame of the same slave whose PDU decodes;
/// the body read as an answer re-encodes the same way.
pub fn modbus_rtu_frame(data: &[u8]) {
    use handgate_adapters::modbus::pdu::{Request, Response};
    use handgate_adapters::modbus::rtu;
    use handgate_adapters::modbus::session::RtuSession;
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let mut re = Vec::new();
    // The decoder on its own, from every offset a stream could resynchronise at.
    for at in 0..body.len().min(16) {
        let b = &body[at..];
        if let Ok(f) = rtu::decode_request(b) {
            re.clear();
            rtu::encode(f.slave, f.pdu, &mut re);
            assert_eq!(re[..], b[..f.len], "a cut frame re-encodes to its bytes");
            if let Ok(req) = Request::decode(f.pdu) {
                re.clear();
                req.encode(&mut re).expect("a decoded request re-encodes");
                assert_eq!(re[..], f.pdu[..], "a decoded request re-encodes to its PDU");
            }
        }
    }
    // The server side: a session for slaves 9 and 1 fed in chunks.
    let mut session = RtuSession::new(9, modbus_bank(), 115_200)
        .with_slave(1, modbus_bank())
        .exceptions(sel & 0x20 == 0);
    modbus_feed(&mut session, body, (sel & 0x1F) as usize + 1, |out| {
        let mut rest = out;
        while !rest.is_empty() {
            let f = rtu::decode_response(rest, rest.get(1).map_or(0, |f| f & 0x7F))
                .expect("every reply is a whole RTU frame");
            assert!(f.slave == 9 || f.slave == 1, "a reply from slave {}", f.slave);
            Response::decode(f.pdu).expect("every reply's PDU decodes");
            rest = &rest[f.len..];
        }
    });
    // The master side: the body as the answer to a request.
    let function = [0x03, 0x04, 0x10, 0x17][(sel >> 6) as usize];
    if let Ok(f) = rtu::decode_response(body, function) {
        re.clear();
        rtu::encode(f.slave, f.pdu, &mut re);
        assert_eq!(re[..], body[..f.len]);
        if let Ok(resp) = Response::decode(f.pdu) {
            assert_eq!(resp.function() & 0x7F, function, "an answer of another function");
            re.clear();
            resp.encode(&mut re).expect("a decoded response re-encodes");
            assert_eq!(re[..], f.pdu[..], "a decoded response re-encodes to its PDU");
        }
    }
}

/// Modbus TCP (MBAP). Byte 0: bits 0-4 the chunk size - 1, bit 5 exceptions off, bit 6 any
/// unit. A frame the decoder cuts re-encodes to its bytes with a header that is Modbus and
/// within its length; every reply the TCP session writes is a whole frame whose PDU decodes.
pub fn modbus_mbap(data: &[u8]) {
    use handgate_adapters::modbus::pdu::Response;
    use handgate_adapters::modbus::session::TcpSession;
    use handgate_adapters::modbus::tcp;
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    if let Ok(adu) = tcp::decode(body) {
        assert_eq!(adu.header.protocol, 0);
        assert!(!adu.pdu.is_empty() && adu.len <= tcp::MAX_ADU);
        let mut re = Vec::new();
        tcp::encode(adu.header.transaction, adu.header.unit, adu.pdu, &mut re);
        assert_eq!(re[..], body[..adu.len], "a cut frame re-encodes to its bytes");
    }
    let session = if sel & 0x40 == 0 {
        TcpSession::new(1, modbus_bank())
    } else {
        TcpSession::any_unit(modbus_bank())
    };
    let mut session = session.exceptions(sel & 0x20 == 0);
    modbus_feed(&mut session, body, (sel & 0x1F) as usize + 1, |out| {
        let mut rest = out;
        while !rest.is_empty() {
            let adu = tcp::decode(rest).expect("every reply is a whole MBAP frame");
            Response::decode(adu.pdu).expect("every reply's PDU decodes");
            rest = &rest[adu.len..];
        }
    });
}

// ---------------------------------------------------------------- robotiq_front

/// A Robotiq's register image served as the Robotiq front and `handgate emulate robotiq` serve
/// it. Byte 0: bit 0 the URCap text socket (else Modbus RTU, slave 9, no exceptions), bit 1 the
/// image a front's (the fingers another device's, its measured position taken from the body)
/// or the emulated gripper's, bits 2-6 the chunk size - 1; the clock advances 3 ms a chunk.
/// Every RTU reply is a whole frame of slave 9 whose PDU decodes (never an exception); every
/// URCap answer is `ack` or `VAR n` lines with n a byte; the status decodes to a defined gSTA
/// (0, 1 or 3), the fingers stay between 0 and 255 counts.
pub fn robotiq_front(data: &[u8]) {
    use std::sync::{Arc, Mutex};

    use handgate_adapters::front::stream::Session;
    use handgate_adapters::modbus::pdu::Response;
    use handgate_adapters::modbus::rtu;
    use handgate_adapters::robotiq::emulator::{Gripper, Measured, Tuning};
    use handgate_adapters::robotiq::front::{rtu_session_on, UrcapSession};
    use handgate_adapters::robotiq::regs::Activation;
    use handgate_adapters::robotiq::Variant;
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let t0 = Instant::now();
    let tuning = Tuning {
        activation: Duration::from_millis(10),
        ..Tuning::default()
    };
    let external = sel & 2 != 0;
    let g = if external {
        Gripper::external(tuning, t0)
    } else {
        Gripper::new(
            Variant::TwoF85.spec(),
            tuning,
            0.0,
            body.first().map(|b| f32::from(*b)),
            t0,
        )
    };
    let image = Arc::new(Mutex::new(g));
    let urcap = sel & 1 != 0;
    let mut rtu_s = rtu_session_on(image.clone(), 9);
    let mut text_s = UrcapSession::new(image.clone());
    let step = ((sel >> 2) & 0x1F) as usize + 1;
    let (mut buf, mut out) = (Vec::new(), Vec::new());
    for (k, chunk) in body.chunks(step).enumerate() {
        let now = t0 + Duration::from_millis(3 * k as u64);
        if external {
            let b = chunk[0];
            image.lock().unwrap().set_measured(Measured {
                position: f32::from(b),
                contact: b & 1 == 1,
            });
        }
        buf.extend_from_slice(chunk);
        loop {
            out.clear();
            let r = if urcap {
                text_s.on_bytes(&buf, now, &mut out, &mut |_| {})
            } else {
                rtu_s.on_bytes(&buf, now, &mut out, &mut |_| {})
            };
            if urcap {
                let text = std::str::from_utf8(&out).expect("URCap answers are text");
                for line in text.split('\n').filter(|l| !l.is_empty()) {
                    if line != "ack" {
                        let (var, n) = line.split_once(' ').expect("`VAR n`");
                        assert!(var.len() == 3 && var.bytes().all(|c| c.is_ascii_uppercase()), "{line}");
                        n.parse::<u8>().expect("a byte");
                    }
                }
            } else {
                let mut rest = &out[..];
                while !rest.is_empty() {
                    let f = rtu::decode_response(rest, rest[1] & 0x7F).expect("every reply is a whole RTU frame");
                    assert_eq!(f.slave, 9);
                    let resp = Response::decode(f.pdu).expect("every reply's PDU decodes");
                    assert!(
                        !matches!(resp, Response::Exception { .. }),
                        "the gripper sends no exceptions"
                    );
                    rest = &rest[f.len..];
                }
            }
            match r {
                Ok(0) => break,
                Ok(n) => {
                    assert!(n <= buf.len());
                    buf.drain(..n);
                }
                Err(e) => match e.skip {
                    Some(n) if n > 0 && n < buf.len() => {
                        buf.drain(..n);
                    }
                    _ => buf.clear(),
                },
            }
            if buf.is_empty() {
                break;
            }
        }
        let mut g = image.lock().unwrap();
        g.step(now);
        let s = g.status();
        assert_ne!(s.activation, Activation::Unused, "gSTA 2 is never reported");
        let p = g.position();
        assert!(p.is_finite() && (0.0..=255.0).contains(&p), "fingers at {p}");
    }
}

pub fn seeds(golden_dir: &std::path::Path) -> Vec<(&'static str, String, Vec<u8>)> {
    let mut out = Vec::new();
    // Golden CDR fixtures.
    if let Ok(rd) = std::fs::read_dir(golden_dir) {
        let mut files: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        files.sort();
        for p in files {
            let name = p.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
            let Some(idx) = TYPES.iter().position(|t| name.starts_with(&format!("{t}__"))) else {
                continue;
            };
            let Ok(text) = std::fs::read_to_string(&p) else {
                continue;
            };
            let Some(hex) = json_str(&text, "cdr_le_hex") else {
                continue;
            };
            let Some(bytes) = unhex(&hex) else { continue };
            let mut v = vec![idx as u8];
            v.extend_from_slice(&bytes);
            out.push(("cdr_decode", name.clone(), v));
            let front_sels: &[u8] = match TYPES[idx] {
                "unitree_hg__HandCmd_" => &[0, 1, 6, 0x08, 0x11],
                "unitree_go__MotorCmds_" => &[2, 3, 4, 5, 0x0A, 0x13],
                "handgate__HandCmd_" => &[7, 0x0F, 0x17, 0x1F],
                _ => &[],
            };
            for &s in front_sels {
                let mut v = vec![s];
                v.extend_from_slice(&bytes);
                out.push(("front_decode", format!("{name}_sel{s:02x}"), v));
            }
        }
    }
    // Valid front commands built here (the fixtures' HandCmd_ has 7 motors; Dex1 needs 1/2).
    let hand = unitree_hg::HandCmd_ {
        motor_cmd: (0..7)
            .map(|i| unitree_hg::MotorCmd_ {
                mode: RisMode::new(i as u8, MotorStatus::Foc, false).encode(),
                q: 0.3,
                kp: 1.5,
                kd: 0.1,
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    };
    out.push((
        "front_decode",
        "dex3_valid".into(),
        prefixed(0, &to_cdr_le(&hand).unwrap_or_default()),
    ));
    for (s, n) in [(2u8, 1usize), (4, 2)] {
        let m = unitree_go::MotorCmds_::with_len(n);
        out.push((
            "front_decode",
            format!("dex1_valid_{n}"),
            prefixed(s, &to_cdr_be(&m).unwrap_or_default()),
        ));
    }
    // Dex3 state frames from the emulator, and command frames from the host codec.
    for side in [0u8, 1] {
        let mut emu = Dex3Emulator::new(side_of(side), EmulatorConfig::default());
        let mut cmd = LinuxToMcuCmd::default();
        for (bus, id) in [(0usize, 0u8), (1, 1), (2, 2), (3, 0), (4, 1)] {
            let f = MotorCmdFrame {
                mode: RisMode::new(id, MotorStatus::Foc, side == 1),
                pos_des: 4000,
                k_pos: 300,
                k_spd: 20,
                ..Default::default()
            };
            let _ = cmd.buses[bus].push(&f.encode(), bus);
        }
        let frame = cmd.encode();
        out.push(("dex3_emulator_frame", format!("cmd_side{side}"), prefixed(side, &frame)));
        out.push((
            "dex3_emulator_frame",
            format!("cmd_fixed_side{side}"),
            prefixed(side | 2, &frame),
        ));
        let mut reply = [0u8; STATE_FRAME_LEN];
        let _ = emu.handle_frame(&frame, &mut reply);
        out.push(("dex3_state_frame", format!("state_side{side}"), prefixed(0, &reply)));
        out.push((
            "dex3_state_frame",
            format!("state_fixed_side{side}"),
            prefixed(1, &reply),
        ));
        let empty = LinuxToMcuCmd::default().encode();
        let _ = emu.handle_frame(&empty, &mut reply);
        out.push((
            "dex3_state_frame",
            format!("state_idle_side{side}"),
            prefixed(1, &reply),
        ));
    }
    let mut structured = vec![4u8];
    for i in 0..14u8 {
        structured.extend_from_slice(&[i % 5, 0x10 | (i % 3), 0, 0, 0, 0, 0, 0x40, 0x1F, 0, 0, 0x2C, 1, 20, 0]);
    }
    out.push(("dex3_emulator_frame", "structured".into(), structured));
    // Dynamixel packets: ping, a read, a sync read and a status with stuffed bytes.
    {
        use handgate_adapters::dynamixel::protocol::encode_packet;
        let packets: [(u8, u8, &[u8]); 4] = [
            (1, 0x01, &[]),
            (1, 0x02, &[0x84, 0x00, 0x04, 0x00]),
            (0xFE, 0x82, &[0x84, 0x00, 0x04, 0x00, 0x01, 0x02]),
            (2, 0x55, &[0x00, 0xFF, 0xFF, 0xFD, 0x01]),
        ];
        let mut stream = vec![7u8];
        for (k, (id, inst, params)) in packets.iter().enumerate() {
            if let Ok(b) = encode_packet(*id, *inst, params) {
                let mut v = vec![64u8];
                v.extend_from_slice(&b);
                out.push(("dynamixel_packet", format!("packet_{k}"), v));
                stream.extend_from_slice(&b);
            }
        }
        out.push(("dynamixel_packet", "stream".to_string(), stream));
        // A LEAP Hand's fast sync read reply: 16 servos, present current..position (10 bytes).
        let mut reply = Vec::new();
        let ok = handgate_adapters::dynamixel::protocol::encode_fast_sync_reply(16, 10, &mut reply, |i, d| {
            d.copy_from_slice(&[0xFF, 0xFF, 0xFD, 0, 0, 0, (i * 16) as u8, 8, 0, 0]);
            (i as u8, handgate_adapters::dynamixel::protocol::StatusError::OK)
        });
        if ok.is_ok() {
            let mut v = vec![10u8];
            v.extend_from_slice(&reply);
            out.push(("dynamixel_fast_sync_reply", "leap_16".to_string(), v));
        }
    }
    // RH56 serial protocol: pyrh56's read of ANGLE_ACT, write of ANGLE_SET and CLEAR_ERROR,
    // a reply and an acknowledgement, then all of them in one stream after garbage.
    {
        use handgate_adapters::inspire_rh56::proto::{encode_read, encode_read_reply, encode_write, encode_write_ack};
        let mut frames: Vec<Vec<u8>> = Vec::new();
        let mut b = Vec::new();
        if encode_read(1, 1546, 12, &mut b).is_ok() {
            frames.push(b.clone());
        }
        if encode_write(
            2,
            1486,
            &[0xE8, 0x03, 0xFF, 0xFF, 0, 0, 0xF4, 0x01, 0, 0, 0x84, 0x03],
            &mut b,
        )
        .is_ok()
        {
            frames.push(b.clone());
        }
        if encode_write(1, 1004, &[1], &mut b).is_ok() {
            frames.push(b.clone());
        }
        if encode_read_reply(1, 1546, &[0xE8, 0x03, 0xE8, 0x03], &mut b).is_ok() {
            frames.push(b.clone());
        }
        encode_write_ack(2, 1486, true, &mut b);
        frames.push(b.clone());
        let mut stream = vec![0x00, 0x13, 0x37, 0xEB];
        for (k, f) in frames.iter().enumerate() {
            out.push(("rh56_proto", format!("frame_{k}"), f.clone()));
            stream.extend_from_slice(f);
        }
        out.push(("rh56_proto", "stream".to_string(), stream));
    }
    // The Robotiq front: the manual's activation and move frames on RTU (chunk 32), a URCap
    // session's lines.
    {
        let rtu = [
            "09 10 03 E8 00 03 06 00 00 00 00 00 00 73 30",
            "09 10 03 E8 00 03 06 09 00 00 FF FF FF 42 29",
            "09 03 07 D0 00 03 04 0E",
        ];
        let mut stream = vec![0x7Cu8];
        for r in rtu {
            stream.extend_from_slice(&modbus_hex(r));
        }
        out.push(("robotiq_front", "rtu_activate_close".to_string(), stream.clone()));
        stream[0] = 0x7E;
        out.push(("robotiq_front", "rtu_front_image".to_string(), stream));
        let lines = b"SET ACT 0\nSET ACT 1\nGET STA\nSET POS 255 SPE 255 FOR 100 GTO 1\nGET ACT GET OBJ GET POS\n";
        out.push(("robotiq_front", "urcap".to_string(), prefixed(0x7D, lines)));
        out.push(("robotiq_front", "urcap_front".to_string(), prefixed(0x0F, lines)));
    }
    // Modbus: the Robotiq manual's RTU frames (requests, and answers for the master side), and
    // Modbus TCP frames built from the spec's PDUs.
    {
        use handgate_adapters::modbus::tcp;
        let requests = [
            "09 10 03 E8 00 03 06 00 00 00 00 00 00 73 30",
            "09 03 07 D0 00 01 85 CF",
            "09 10 03 E8 00 03 06 09 00 00 FF FF FF 42 29",
            "09 03 07 D0 00 03 04 0E",
            "01 03 00 00 00 0A C5 CD",
        ];
        let mut stream = vec![0x07u8];
        for (k, r) in requests.iter().enumerate() {
            let b = modbus_hex(r);
            out.push(("modbus_rtu_frame", format!("request_{k}"), prefixed(0x1F, &b)));
            stream.extend_from_slice(&b);
        }
        out.push(("modbus_rtu_frame", "stream".to_string(), stream));
        for (k, (r, sel)) in [
            ("09 10 03 E8 00 03 01 30", 0x80u8),
            ("09 03 06 B9 00 00 FF BD 00 1D 7C", 0x00),
        ]
        .iter()
        .enumerate()
        {
            out.push((
                "modbus_rtu_frame",
                format!("answer_{k}"),
                prefixed(*sel | 0x1F, &modbus_hex(r)),
            ));
        }
        let pdus = [
            "03 00 6B 00 03",
            "04 07 D0 00 03",
            "06 03 E8 00 01",
            "10 03 E8 00 03 06 09 00 00 FF FF FF",
            "17 07 D0 00 03 03 E8 00 03 06 09 00 00 FF FF FF",
        ];
        let mut stream = vec![0x05u8];
        for (k, p) in pdus.iter().enumerate() {
            let mut f = Vec::new();
            tcp::encode(k as u16, 1, &modbus_hex(p), &mut f);
            out.push(("modbus_mbap", format!("request_{k}"), prefixed(0x1F, &f)));
            stream.extend_from_slice(&f);
        }
        out.push(("modbus_mbap", "stream".to_string(), stream));
    }
    out
}

fn modbus_hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .filter_map(|b| u8::from_str_radix(b, 16).ok())
        .collect()
}

fn prefixed(b: u8, bytes: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(bytes.len() + 1);
    v.push(b);
    v.extend_from_slice(bytes);
    v
}

/// The string value of `"key": "..."` in a flat JSON text (the fixtures' hex fields).
fn json_str(text: &str, key: &str) -> Option<String> {
    let at = text.find(&format!("\"{key}\""))?;
    let rest = &text[at + key.len() + 2..];
    let start = rest.find('"')? + 1;
    let end = rest[start..].find('"')? + start;
    Some(rest[start..end].to_string())
}

fn unhex(s: &str) -> Option<Vec<u8>> {
    if s.len() & 1 == 1 {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).ok())
        .collect()
}
