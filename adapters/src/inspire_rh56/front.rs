//! The RH56's own interface served for any hand (docs/fronts.md, "Inspire RH56"): a client
//! written for the hand (pyrh56 on its serial protocol, inspire-rh56dftp over Modbus TCP) reads
//! and writes the register file of a hand whose measured registers are the bound device's state,
//! and its ANGLE_SET writes become that device's commands. Pure: the image and the serial
//! protocol's session; the front's registry entry and servers are [`super::serve`].
//!
//! Rules (docs/fronts.md, "Bad input"):
//! - a write of ANGLE_SET (whole or in part) is a command: each angle 0..1000 (1000 = open)
//!   becomes its joint's target through the front's table (the Inspire FTP front's decode),
//!   -1 leaves that joint's target alone, out-of-range values are clamped by the device's table;
//! - FORCE_SET, SPEED_SET and the parameters are stored and read back, not carried (the
//!   canonical model has no force threshold or speed); CLEAR_ERROR is acknowledged;
//! - writes to measured registers or the tactile cells are refused (acknowledged with 0 on the
//!   serial protocol, exception 2 over Modbus), reads outside the file likewise (no answer on
//!   the serial protocol: the real hand's answer is not documented);
//! - a request for another id gets no answer (as on a shared line), counted `wrong_id`;
//! - garbage and bad checksums are skipped to the next header byte, counted and logged once.
//!
//! State: ANGLE_ACT and POS_ACT, ERROR, STATUS and TEMP as the Inspire FTP front encodes them
//! from the routed state; FORCE_ACT and CURRENT 0 (the canonical state has neither); the
//! tactile cells from the device's pads of those names (an Inspire FTP or RH56 DFTP), else 0.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use handgate_idl::inspire::{InspireHandCtrl, MODE_ANGLE};

use super::file::{touches, RegisterFile};
use super::proto::{self, FrameError, Request};
use super::regs::{self, FINGERS};
use crate::front::stream::{Session, StreamError};
use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{HandState, JointState};

/// What a client's write hands the front: the six ANGLE_SET values after the write (-1 = keep).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AngleWrite(pub [i16; FINGERS]);

/// The register file a front answers from, shared by its sessions and its publisher.
#[derive(Debug, Clone)]
pub struct Image {
    pub file: RegisterFile,
}

/// An [`Image`] shared between the front's publisher and its sessions.
pub type SharedImage = Arc<Mutex<Image>>;

impl Image {
    /// A hand with id `id` that has not been measured: every angle open, targets open,
    /// ERROR's communication bit set until the first state.
    pub fn new(id: u8) -> Self {
        let mut file = RegisterFile::default();
        file.put_byte(regs::HAND_ID, id);
        for i in 0..FINGERS {
            file.put_short(regs::ANGLE_SET, i, 1000);
            file.put_short(regs::ANGLE_ACT, i, 1000);
            file.put_short(regs::FORCE_SET, i, super::emulator::DEFAULT_FORCE);
            file.put_short(regs::SPEED_SET, i, super::emulator::DEFAULT_SPEED);
            file.put_byte(regs::ERROR + i as u16, regs::error_bits::COMMUNICATION);
        }
        Image { file }
    }

    /// The measured registers from the bound device's routed state `joints` (front order) and
    /// its state `st`.
    pub fn publish(&mut self, front: &DeviceTable, joints: &[JointState], st: &HandState) {
        let s = crate::inspire_ftp::front::encode_state(front, joints, st);
        for i in 0..FINGERS {
            let g = |v: &Vec<i16>| v.get(i).copied().unwrap_or(0);
            self.file.put_short(regs::ANGLE_ACT, i, g(&s.angle_act));
            // The actuator's 0..2000 stroke, as the emulated hand reads it (an assumption).
            self.file.put_short(regs::POS_ACT, i, 2 * (1000 - g(&s.angle_act)));
            self.file.put_short(regs::FORCE_ACT, i, 0);
            self.file
                .put_byte(regs::ERROR + i as u16, s.err.get(i).copied().unwrap_or(0));
            self.file
                .put_byte(regs::STATUS + i as u16, s.status.get(i).copied().unwrap_or(0));
            self.file
                .put_byte(regs::TEMP + i as u16, s.temperature.get(i).copied().unwrap_or(0));
        }
        for (name, addr, r, c) in regs::TACTILE_REGIONS {
            let pad = st.pads.iter().find(|p| p.name == name);
            for k in 0..(r * c) {
                let v = pad
                    .and_then(|p| p.pressure.get(k as usize))
                    .map_or(0, |v| v.round().clamp(0.0, f32::from(regs::TACTILE_MAX)) as u16);
                self.file.put(addr + 2 * k, &v.to_le_bytes());
            }
        }
    }

    /// A client's write of `data` at `addr`: stored where the hand takes writes (-1 in
    /// ANGLE_SET is stored as written: the hand reads back its kept target, this front the
    /// client's -1); `Some` when it touched ANGLE_SET (the six values now there).
    pub fn write(&mut self, addr: u16, data: &[u8]) -> Result<Option<AngleWrite>, super::file::Refused> {
        self.file.write(addr, data)?;
        if touches(addr, data.len(), regs::CLEAR_ERROR, 1) {
            self.file.put_byte(regs::CLEAR_ERROR, 0);
        }
        if !touches(addr, data.len(), regs::ANGLE_SET, regs::BLOCK) {
            return Ok(None);
        }
        // Only the angles this write set are commands; the others stay where they are (-1).
        let mut a = [-1i16; FINGERS];
        for (i, v) in a.iter_mut().enumerate() {
            let at = regs::ANGLE_SET + 2 * i as u16;
            if touches(addr, data.len(), at, 2) {
                *v = self.file.short(regs::ANGLE_SET, i);
            }
        }
        Ok(Some(AngleWrite(a)))
    }
}

/// The command an ANGLE_SET write is for the hand whose front table is `front`: the Inspire
/// FTP front's rules (angles 0..1000, 1000 = open, -1 = keep); `Ok(None)`: nothing to move.
pub fn decode(w: &AngleWrite, front: &DeviceTable) -> Result<Option<FrontCommand>, Rejection> {
    let msg = InspireHandCtrl {
        angle_set: w.0.to_vec(),
        mode: MODE_ANGLE,
        ..InspireHandCtrl::sdk_default()
    };
    crate::inspire_ftp::front::decode(&msg, front)
}

/// One client of the serial protocol (a pty): answers the hand with id `id` from the image.
pub struct SerialSession {
    pub id: u8,
    pub image: SharedImage,
    reply: Vec<u8>,
}

impl SerialSession {
    pub fn new(id: u8, image: SharedImage) -> Self {
        SerialSession {
            id,
            image,
            reply: Vec::with_capacity(proto::MAX_READ + 8),
        }
    }
}

impl Session for SerialSession {
    type Msg = AngleWrite;

    fn on_bytes(
        &mut self,
        input: &[u8],
        _now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(AngleWrite),
    ) -> Result<usize, StreamError> {
        let (req, n) = match proto::decode_request(input) {
            Ok(r) => r,
            Err(FrameError::Incomplete { .. }) => return Ok(0),
            Err(e) => return Err(StreamError::skipping(proto::resync(input), e.reason(), e.to_string())),
        };
        if req.id() != self.id {
            return Err(StreamError::skipping(
                n,
                "wrong_id",
                format!("a request for hand id {} (this front is hand id {})", req.id(), self.id),
            ));
        }
        let mut image = self.image.lock().unwrap_or_else(|p| p.into_inner());
        match req {
            Request::Read { id, addr, count } => {
                let mut data = [0u8; proto::MAX_READ];
                let data = &mut data[..count as usize];
                if let Err(e) = image.file.read(addr, data) {
                    return Err(StreamError::skipping(n, e.reason(), e.to_string()));
                }
                // MAX_READ bounds count: the reply always fits.
                let _ = proto::encode_read_reply(id, addr, data, &mut self.reply);
            }
            Request::Write { id, addr, data } => {
                let written = image.write(addr, data);
                proto::encode_write_ack(id, addr, written.is_ok(), &mut self.reply);
                if let Ok(Some(w)) = written {
                    sink(w);
                }
            }
        }
        out.extend_from_slice(&self.reply);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inspire_rh56::proto::{decode_reply, encode_read, encode_write, Reply};
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, Side};

    fn session() -> (SerialSession, SharedImage) {
        let image = Arc::new(Mutex::new(Image::new(1)));
        (SerialSession::new(1, image.clone()), image)
    }

    fn run(s: &mut SerialSession, input: &[u8]) -> (Result<usize, StreamError>, Vec<u8>, Vec<AngleWrite>) {
        let (mut out, mut got) = (Vec::new(), Vec::new());
        let r = s.on_bytes(input, Instant::now(), &mut out, &mut |w| got.push(w));
        (r, out, got)
    }

    #[test]
    fn an_angle_write_is_acknowledged_and_handed_on_and_reads_answer_from_the_image() {
        let (mut s, image) = session();
        let mut req = Vec::new();
        let data: Vec<u8> = [100i16, 200, 300, 400, 500, 600]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        encode_write(1, regs::ANGLE_SET, &data, &mut req).unwrap();
        let (r, out, got) = run(&mut s, &req);
        assert_eq!(r, Ok(req.len()));
        assert_eq!(got, vec![AngleWrite([100, 200, 300, 400, 500, 600])]);
        assert_eq!(
            decode_reply(&out).unwrap().0,
            Reply::WriteAck {
                id: 1,
                addr: regs::ANGLE_SET,
                ok: true
            }
        );
        // One finger (pyrh56's move_finger(..., base="hold")): only it is a command.
        encode_write(1, regs::ANGLE_SET + 6, &700i16.to_le_bytes(), &mut req).unwrap();
        let (_, _, got) = run(&mut s, &req);
        assert_eq!(got, vec![AngleWrite([-1, -1, -1, 700, -1, -1])]);
        image.lock().unwrap().file.put_short(regs::ANGLE_ACT, 0, 321);
        encode_read(1, regs::ANGLE_ACT, 12, &mut req).unwrap();
        let (_, out, _) = run(&mut s, &req);
        match decode_reply(&out).unwrap().0 {
            Reply::Read { data, .. } => assert_eq!(&data[..2], &321i16.to_le_bytes()),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_input_is_refused_with_its_reason_and_what_to_skip() {
        let (mut s, _) = session();
        let mut req = Vec::new();
        encode_read(2, regs::ANGLE_ACT, 12, &mut req).unwrap();
        let (r, out, _) = run(&mut s, &req);
        let e = r.unwrap_err();
        assert_eq!((e.reason, e.skip), ("wrong_id", Some(9)));
        assert!(out.is_empty());
        encode_read(1, regs::ANGLE_ACT, 12, &mut req).unwrap();
        req[8] ^= 0xFF;
        let e = run(&mut s, &req).0.unwrap_err();
        assert_eq!((e.reason, e.skip), ("bad_checksum", Some(9)));
        let e = run(&mut s, &[0x00, 0x13, 0xEB, 0x90]).0.unwrap_err();
        assert_eq!((e.reason, e.skip), ("garbage", Some(2)));
        assert_eq!(run(&mut s, &req[..4]).0, Ok(0), "half a frame waits");
        // A write to a measured register is acknowledged with 0 and commands nothing.
        encode_write(1, regs::ANGLE_ACT, &[0; 12], &mut req).unwrap();
        let (r, out, got) = run(&mut s, &req);
        assert_eq!(r, Ok(req.len()));
        assert!(got.is_empty());
        assert!(matches!(
            decode_reply(&out).unwrap().0,
            Reply::WriteAck { ok: false, .. }
        ));
        encode_read(1, 5120, 8, &mut req).unwrap();
        assert_eq!(run(&mut s, &req).0.unwrap_err().reason, "out_of_range");
    }

    #[test]
    fn angles_decode_through_the_inspire_table_and_minus_one_keeps() {
        let t = DeviceKind::InspireRh56
            .table(Side::Left, &TableOverrides::default())
            .unwrap();
        let c = decode(&AngleWrite([0, -1, 1000, -1, -1, -1]), &t).unwrap().unwrap();
        assert!((c.joints[0].unwrap().q - 1.7).abs() < 1e-5);
        assert!(c.joints[1].is_none());
        assert!(c.joints[2].unwrap().q.abs() < 1e-5);
        assert_eq!(decode(&AngleWrite([-1; 6]), &t), Ok(None));
    }

    #[test]
    fn the_image_reads_the_state_and_the_pads() {
        let t = DeviceKind::InspireRh56
            .table(Side::Left, &TableOverrides::default())
            .unwrap();
        let mut st = HandState::empty(6);
        st.freshness = crate::model::Freshness::Fresh;
        for (j, q) in st.joints.iter_mut().zip([1.7, 0.0, 0.85, 0.0, 0.0, -0.1]) {
            j.q = q;
            j.temperature = Some(40.0);
        }
        st.pads.push(crate::model::Pad {
            name: "index_pad".into(),
            rows: 10,
            cols: 8,
            pressure: vec![5000.0; 80],
            temperature: Vec::new(),
        });
        let mut im = Image::new(1);
        let joints = st.joints.clone();
        im.publish(&t, &joints, &st);
        assert_eq!(im.file.shorts(regs::ANGLE_ACT), [0, 1000, 500, 1000, 1000, 1000]);
        assert_eq!(im.file.byte(regs::TEMP), 40);
        assert_eq!(im.file.byte(regs::ERROR), 0);
        let mut w = [0u16; 2];
        im.file.read_words(4320, &mut w).unwrap();
        assert_eq!(w, [4095, 4095]);
        im.file.read_words(3950, &mut w).unwrap();
        assert_eq!(w, [0, 0]);
    }
}
