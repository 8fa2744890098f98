//! Modbus served over a byte stream ([`crate::front::stream`]): [`RtuSession`] for RTU on a
//! pty or over TCP (UR's tool forwarder on port 54321), [`TcpSession`] for Modbus TCP. A
//! session answers from its [`ServedMap`]s (one per slave / unit id) and hands the commands
//! their writes make to the front.
//!
//! What is refused (returned as a [`StreamError`], so the stream server counts it per reason
//! and logs it once per client): `bad_crc`, `malformed` (RTU), `garbage` (an MBAP header that
//! is not Modbus), `wrong_slave` / `wrong_unit` (a frame for an id nobody serves here: on a
//! real multi-drop line another slave would answer, here nobody does), and the requests that
//! earned an exception (`illegal_function`, `illegal_address`, `illegal_value`,
//! `device_failure`), whether the exception was sent or, for a device that never answers one
//! (the Robotiq), not. A partial RTU frame followed by silence is dropped by the server
//! ([`Session::gap`], counted `partial_frame`).

use std::time::{Duration, Instant};

use crate::front::stream::{Session, StreamError};

use super::pdu::{Exception, Request, Response};
use super::rtu::{self, RtuError};
use super::server::{respond, Outcome, RegisterMap};
use super::tcp::{self, TcpError};

/// A register map behind a stream front: what its clients' requests do beyond reading and
/// writing registers.
pub trait ServedMap: RegisterMap + Send + 'static {
    /// The front's command type (its `TypedIo::Msg`).
    type Msg: Send + 'static;
    /// A request for this map arrived at `now` (an emulator advances to it; a front notes
    /// the client's traffic). Called before the request is performed.
    fn arrived(&mut self, _now: Instant) {}
    /// `req` was performed without exception: hand the commands it makes to `sink` (a write
    /// of the command registers becomes the device's command).
    fn performed(&mut self, _req: &Request<'_>, _sink: &mut dyn FnMut(Self::Msg)) {}
}

/// A plain bank serves reads and writes and makes no commands (tests, fuzzing, a device
/// image nobody commands through).
impl ServedMap for super::server::Bank {
    type Msg = ();
}

/// The least silence after which a partial RTU frame is dropped on a pty or over TCP. A pty
/// has no line timing: the gap is measured between the server thread's reads, which a loaded
/// machine delays by milliseconds, so the spec's 1.75 ms would drop frames a client wrote in
/// two pieces.
pub const STREAM_GAP_FLOOR: Duration = Duration::from_millis(5);

/// Runs one decoded frame's PDU against `map`; returns what to report for it, `None` when it
/// was answered normally.
fn serve_pdu<M: ServedMap>(
    map: &mut M,
    pdu: &[u8],
    now: Instant,
    exceptions: bool,
    out: &mut Vec<u8>,
    sink: &mut dyn FnMut(M::Msg),
) -> Outcome {
    map.arrived(now);
    let outcome = respond(map, pdu, exceptions, out, &mut |_| {});
    if outcome == Outcome::Answered {
        // An answered request decoded; decoding it again is a few comparisons.
        if let Ok(req) = Request::decode(pdu) {
            map.performed(&req, sink);
        }
    }
    outcome
}

/// `Ok(len)` for a normal answer, else the refusal to count (its text is only built then).
fn refusal(outcome: Outcome, len: usize, who: &'static str, id: u8) -> Result<usize, StreamError> {
    match (outcome, outcome.reason()) {
        (_, None) => Ok(len),
        (Outcome::Silent { function, code }, Some(reason)) => Err(StreamError::skipping(
            len,
            reason,
            format!("{who} {id}: function 0x{function:02X}: {code}; not answered (the device sends no exceptions)"),
        )),
        (Outcome::Exception { function, code }, Some(reason)) => Err(StreamError::skipping(
            len,
            reason,
            format!("{who} {id}: function 0x{function:02X}: answered {code}"),
        )),
        (_, Some(reason)) => Err(StreamError::skipping(len, reason, format!("{who} {id}: empty request"))),
    }
}

/// Modbus RTU served over a stream: one or more slave ids, each its own map.
pub struct RtuSession<M: ServedMap> {
    slaves: Vec<(u8, M)>,
    exceptions: bool,
    gap: Option<Duration>,
    pdu: Vec<u8>,
}

impl<M: ServedMap> RtuSession<M> {
    /// Slave `slave` answering from `map`, with exception responses, dropping partial frames
    /// after the frame gap at `baud` (at least [`STREAM_GAP_FLOOR`]).
    pub fn new(slave: u8, map: M, baud: u32) -> Self {
        Self {
            slaves: vec![(slave, map)],
            exceptions: true,
            gap: Some(rtu::frame_gap(baud).max(STREAM_GAP_FLOOR)),
            pdu: Vec::with_capacity(rtu::MAX_ADU),
        }
    }

    /// Another slave on the same line.
    pub fn with_slave(mut self, slave: u8, map: M) -> Self {
        self.slaves.push((slave, map));
        self
    }

    /// `false`: a request that earns an exception is not answered at all (the Robotiq
    /// grippers); the client times out. It is still counted and logged.
    pub fn exceptions(mut self, on: bool) -> Self {
        self.exceptions = on;
        self
    }

    /// The silence after which a partial frame is dropped (`None`: never).
    pub fn gap(mut self, gap: Option<Duration>) -> Self {
        self.gap = gap;
        self
    }

    pub fn map(&mut self, slave: u8) -> Option<&mut M> {
        self.slaves.iter_mut().find(|(id, _)| *id == slave).map(|(_, m)| m)
    }
}

impl<M: ServedMap> Session for RtuSession<M> {
    type Msg = M::Msg;

    fn on_bytes(
        &mut self,
        input: &[u8],
        now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(M::Msg),
    ) -> Result<usize, StreamError> {
        let frame = match rtu::decode_request(input) {
            Ok(f) => f,
            Err(RtuError::Incomplete { .. }) => return Ok(0),
            // Where a frame with a bad CRC or no known shape ends is unknown: everything
            // buffered goes, as a slave discards until the line falls silent.
            Err(e) => return Err(StreamError::new(e.reason(), format!("{e}"))),
        };
        if frame.slave == rtu::BROADCAST {
            // Every slave performs a broadcast write; none answers.
            for (_, map) in &mut self.slaves {
                self.pdu.clear();
                serve_pdu(map, frame.pdu, now, false, &mut self.pdu, sink);
            }
            return Ok(frame.len);
        }
        let Some((id, map)) = self.slaves.iter_mut().find(|(id, _)| *id == frame.slave) else {
            return Err(StreamError::skipping(
                frame.len,
                "wrong_slave",
                format!("a request for slave {}, which is not served here", frame.slave),
            ));
        };
        self.pdu.clear();
        let outcome = serve_pdu(map, frame.pdu, now, self.exceptions, &mut self.pdu, sink);
        if !self.pdu.is_empty() {
            rtu::encode(*id, &self.pdu, out);
        }
        refusal(outcome, frame.len, "slave", *id)
    }

    fn gap(&self) -> Option<Duration> {
        self.gap
    }
}

/// Modbus TCP served over a stream: MBAP frames, one map per unit id (or every unit id to
/// one map: most Modbus TCP devices ignore it).
pub struct TcpSession<M: ServedMap> {
    units: Vec<(u8, M)>,
    any_unit: bool,
    exceptions: bool,
    pdu: Vec<u8>,
}

impl<M: ServedMap> TcpSession<M> {
    /// Unit `unit` answering from `map`, other units refused.
    pub fn new(unit: u8, map: M) -> Self {
        Self {
            units: vec![(unit, map)],
            any_unit: false,
            exceptions: true,
            pdu: Vec::with_capacity(tcp::MAX_ADU),
        }
    }

    /// Every unit id answered by `map` (and echoed).
    pub fn any_unit(map: M) -> Self {
        Self {
            any_unit: true,
            ..Self::new(0, map)
        }
    }

    pub fn with_unit(mut self, unit: u8, map: M) -> Self {
        self.units.push((unit, map));
        self
    }

    /// `false`: requests that earn an exception are not answered.
    pub fn exceptions(mut self, on: bool) -> Self {
        self.exceptions = on;
        self
    }

    pub fn map(&mut self, unit: u8) -> Option<&mut M> {
        self.units.iter_mut().find(|(id, _)| *id == unit).map(|(_, m)| m)
    }
}

impl<M: ServedMap> Session for TcpSession<M> {
    type Msg = M::Msg;

    fn on_bytes(
        &mut self,
        input: &[u8],
        now: Instant,
        out: &mut Vec<u8>,
        sink: &mut dyn FnMut(M::Msg),
    ) -> Result<usize, StreamError> {
        let adu = match tcp::decode(input) {
            Ok(a) => a,
            Err(TcpError::Incomplete { .. }) => return Ok(0),
            // Not Modbus (or out of step): nothing buffered can be trusted.
            Err(e) => return Err(StreamError::new("garbage", format!("{e}"))),
        };
        let h = adu.header;
        let found = if self.any_unit {
            self.units.first_mut()
        } else {
            self.units.iter_mut().find(|(id, _)| *id == h.unit)
        };
        let Some((_, map)) = found else {
            if self.exceptions {
                // What a gateway answers when the target does not respond.
                let start = tcp::begin(out, h.transaction, h.unit);
                let function = adu.pdu[0] & !super::pdu::EXCEPTION_BIT;
                let _ = Response::Exception {
                    function,
                    code: Exception::Other(0x0B),
                }
                .encode(out);
                tcp::finish(out, start);
            }
            return Err(StreamError::skipping(
                adu.len,
                "wrong_unit",
                format!("a request for unit {}, which is not served here", h.unit),
            ));
        };
        self.pdu.clear();
        let outcome = serve_pdu(map, adu.pdu, now, self.exceptions, &mut self.pdu, sink);
        if !self.pdu.is_empty() {
            tcp::encode(h.transaction, h.unit, &self.pdu, out);
        }
        refusal(outcome, adu.len, "unit", h.unit)
    }
}
