//! The RH56 over Modbus (RTU on RS-485, TCP on the DFTP's port 6000), on the kit
//! ([`crate::modbus`]): the register file as a [`RegisterMap`] (a request's address is the
//! file's byte address, each register the next two bytes: [`super::regs`]), for the emulated
//! hand ([`HandMap`], [`answer_tcp`]) and for the front's image ([`FrontMap`], served by the
//! kit's `RtuSession` / `TcpSession`).
//!
//! Both tables (FC03 holding, FC04 input) read the same file. A read outside the file or a
//! write where the hand takes none is exception 2 (illegal data address); the hand's own
//! answer is not documented (an assumption, docs/inspire-rh56.md).

use super::emulator::Rh56Hand;
use super::file::{words_to_bytes, Refused};
use super::front::{AngleWrite, SharedImage};
use crate::front::stream::StreamError;
use crate::modbus::server::{respond, RegisterMap};
use crate::modbus::session::ServedMap;
use crate::modbus::{tcp, Exception, Regs, Request, Table, TcpError};

fn exception(_: Refused) -> Exception {
    Exception::IllegalDataAddress
}

/// An emulated hand as a Modbus register map (stepped to the request's time by the caller).
pub struct HandMap<'a>(pub &'a mut Rh56Hand);

impl RegisterMap for HandMap<'_> {
    fn read(&mut self, _table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        self.0.read_words(addr, out).map_err(exception)
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        self.0.write_words(addr, values.iter()).map_err(exception)
    }
}

/// A front's image as a Modbus register map; an ANGLE_SET write becomes the front's command
/// once performed.
pub struct FrontMap {
    pub image: SharedImage,
    angles: Option<AngleWrite>,
}

impl FrontMap {
    pub fn new(image: SharedImage) -> Self {
        FrontMap { image, angles: None }
    }
}

impl RegisterMap for FrontMap {
    fn read(&mut self, _table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        let image = self.image.lock().unwrap_or_else(|p| p.into_inner());
        image.file.read_words(addr, out).map_err(exception)
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        let mut buf = [0u8; 2 * 123];
        let n = words_to_bytes(values.iter(), &mut buf);
        let mut image = self.image.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(a) = image.write(addr, &buf[..n]).map_err(exception)? {
            self.angles = Some(a);
        }
        Ok(())
    }
}

impl ServedMap for FrontMap {
    type Msg = AngleWrite;

    fn performed(&mut self, _req: &Request<'_>, sink: &mut dyn FnMut(AngleWrite)) {
        if let Some(a) = self.angles.take() {
            sink(a);
        }
    }
}

/// Cuts one Modbus TCP frame from `input` and answers it with `map` into `out` (a normal or
/// exception response, the MBAP header echoing the transaction and unit); `Ok(0)`: a partial
/// frame. A stream that is not Modbus (protocol id ≠ 0, an impossible length) is garbage.
pub fn answer_tcp(map: &mut dyn RegisterMap, input: &[u8], out: &mut Vec<u8>) -> Result<usize, StreamError> {
    let adu = match tcp::decode(input) {
        Ok(a) => a,
        Err(TcpError::Incomplete { .. }) => return Ok(0),
        Err(e) => return Err(StreamError::new(e.reason(), e.to_string())),
    };
    let start = tcp::begin(out, adu.header.transaction, adu.header.unit);
    let outcome = respond(map, adu.pdu, true, out, &mut |_| {});
    if out.len() == start + tcp::MBAP_LEN {
        // Nothing to answer (an empty PDU): no frame.
        out.truncate(start);
        let why = outcome.reason().unwrap_or("empty_pdu");
        return Err(StreamError::skipping(
            adu.len,
            why,
            "a Modbus TCP frame with an empty PDU",
        ));
    }
    tcp::finish(out, start);
    Ok(adu.len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::stream::Session;
    use crate::inspire_rh56::emulator::HandSpec;
    use crate::inspire_rh56::front::Image;
    use crate::inspire_rh56::regs;
    use crate::modbus::session::TcpSession;
    use std::sync::{Arc, Mutex};
    use std::time::Instant;

    /// inspire-rh56dftp 0.1.0's frames: FC16 of six angles at ANGLE_SET (unit 1), FC03 of six
    /// registers at ANGLE_ACT.
    fn fc16(tx: u16, addr: u16, values: &[u16]) -> Vec<u8> {
        let mut pdu = vec![0x10];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&(values.len() as u16).to_be_bytes());
        pdu.push(2 * values.len() as u8);
        for v in values {
            pdu.extend_from_slice(&v.to_be_bytes());
        }
        let mut out = Vec::new();
        tcp::encode(tx, 1, &pdu, &mut out);
        out
    }

    fn fc03(tx: u16, addr: u16, count: u16) -> Vec<u8> {
        let mut pdu = vec![0x03];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&count.to_be_bytes());
        let mut out = Vec::new();
        tcp::encode(tx, 1, &pdu, &mut out);
        out
    }

    #[test]
    fn the_dftp_clients_write_and_read_as_the_hand_answers() {
        let image = Arc::new(Mutex::new(Image::new(1)));
        let mut s = TcpSession::any_unit(FrontMap::new(image.clone()));
        let (mut out, mut got) = (Vec::new(), Vec::new());
        let req = fc16(7, regs::ANGLE_SET, &[1000, 1000, 1000, 1000, 1000, 0]);
        assert_eq!(
            s.on_bytes(&req, Instant::now(), &mut out, &mut |a| got.push(a)),
            Ok(req.len())
        );
        // The 12-byte acknowledgement the client drains: MBAP (tx 7, length 6, unit 1), FC16,
        // address, count.
        assert_eq!(out, [0, 7, 0, 0, 0, 6, 1, 0x10, 0x05, 0xCE, 0, 6]);
        assert_eq!(got, vec![AngleWrite([1000, 1000, 1000, 1000, 1000, 0])]);
        image.lock().unwrap().file.put_short(regs::ANGLE_ACT, 2, 0x1234);
        out.clear();
        let req = fc03(8, regs::ANGLE_ACT, 6);
        assert_eq!(s.on_bytes(&req, Instant::now(), &mut out, &mut |_| {}), Ok(req.len()));
        assert_eq!(out.len(), 9 + 12);
        assert_eq!(&out[9 + 4..9 + 6], &[0x12, 0x34], "big-endian on the wire");
        // A write to a measured register: exception 2, nothing commanded.
        out.clear();
        got.clear();
        let req = fc16(9, regs::ANGLE_ACT, &[0; 6]);
        let e = s
            .on_bytes(&req, Instant::now(), &mut out, &mut |a| got.push(a))
            .unwrap_err();
        assert_eq!(e.reason, "illegal_address");
        assert_eq!(&out[7..], &[0x90, 0x02]);
        assert!(got.is_empty());
        // Garbage (protocol id 0x1337) is refused whole; half a frame waits.
        out.clear();
        let e = s
            .on_bytes(
                &[0, 1, 0x13, 0x37, 0, 6, 1, 3, 0, 0, 0, 1],
                Instant::now(),
                &mut out,
                &mut |_| {},
            )
            .unwrap_err();
        assert_eq!((e.reason, e.skip), ("garbage", None));
        assert_eq!(s.on_bytes(&req[..5], Instant::now(), &mut out, &mut |_| {}), Ok(0));
    }

    #[test]
    fn the_emulated_hand_reads_tactile_cells_as_words() {
        let mut spec = HandSpec::new(1);
        spec.tactile = true;
        spec.object_at[0] = Some(500.0);
        let mut h = Rh56Hand::new(spec);
        let t0 = Instant::now();
        h.step(t0);
        {
            let mut m = HandMap(&mut h);
            m.write(regs::ANGLE_SET, Regs::from_words(&[0; 6])).unwrap();
        }
        h.step(t0 + std::time::Duration::from_secs(3));
        let mut m = HandMap(&mut h);
        let mut w = [0u16; 105];
        // inspire-rh56dftp's first batch: the pinky's tip and nail in one read from 3000.
        m.read(Table::Holding, 3000, &mut w).unwrap();
        assert!(w.iter().all(|v| *v == w[0] && *v > 0), "{w:?}");
        assert_eq!(
            m.read(Table::Holding, 5120, &mut [0; 4]),
            Err(Exception::IllegalDataAddress)
        );
    }
}
