//! The emulator backend of a register-mapped hand, at the [`Transport`] seam: a virtual RS-485
//! line. RTU frames written to it go to the emulator core of the addressed slave (advanced to
//! the request's time first); its answer becomes readable after the wire time of request and
//! reply at the line's baud rate, so the device loop runs at the rate a real line allows. A
//! slave id no core has stays silent, as on a real line. The same cores answer on a pty for
//! `handgate emulate <kind>` ([`serve_pty`]), through the kit's [`RtuSession`].

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::EmulatorCore;
use crate::front::stream::StreamServer;
use crate::modbus::pdu::{Regs, Table};
use crate::modbus::server::{respond, RegisterMap};
use crate::modbus::session::{RtuSession, ServedMap};
use crate::modbus::{rtu, Exception, RtuError};
use crate::serial::{Connector, Transport, TransportError};

/// The emulated hands of one line, by slave id.
pub type Cores<C> = Arc<Mutex<Vec<(u8, C)>>>;

/// The virtual line as a [`Connector`]. `unplugged`: while set, the line is gone (writes and
/// connects fail as an unplugged USB adapter's do).
pub struct EmulatedLine<C: EmulatorCore> {
    pub cores: Cores<C>,
    pub baud: u32,
    pub unplugged: Arc<AtomicBool>,
}

impl<C: EmulatorCore> EmulatedLine<C> {
    pub fn new(cores: Cores<C>, baud: u32) -> Self {
        Self {
            cores,
            baud,
            unplugged: Arc::default(),
        }
    }
}

impl<C: EmulatorCore> Connector for EmulatedLine<C> {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        if self.unplugged.load(Ordering::Relaxed) {
            return Err(TransportError::Disconnected);
        }
        Ok(Box::new(EmulatedPort {
            cores: self.cores.clone(),
            baud: self.baud,
            unplugged: self.unplugged.clone(),
            inbox: Vec::with_capacity(2 * rtu::MAX_ADU),
            reply: Vec::with_capacity(rtu::MAX_ADU),
            sent: 0,
            ready_at: Instant::now(),
        }))
    }

    fn describe(&self) -> String {
        format!("emulated Modbus RTU line @ {} baud", self.baud)
    }
}

/// Wire time of `bytes` at `baud` (11 bits a character, the kit's).
fn wire(bytes: usize, baud: u32) -> Duration {
    rtu::char_time(baud) * bytes as u32
}

struct EmulatedPort<C: EmulatorCore> {
    cores: Cores<C>,
    baud: u32,
    unplugged: Arc<AtomicBool>,
    inbox: Vec<u8>,
    reply: Vec<u8>,
    sent: usize,
    ready_at: Instant,
}

impl<C: EmulatorCore> Transport for EmulatedPort<C> {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        if self.unplugged.load(Ordering::Relaxed) {
            return Err(TransportError::Disconnected);
        }
        let start = Instant::now();
        self.inbox.extend_from_slice(bytes);
        loop {
            let used = match rtu::decode_request(&self.inbox) {
                Ok(f) => {
                    let mut cores = self.cores.lock().unwrap_or_else(|p| p.into_inner());
                    if let Some((_, core)) = cores.iter_mut().find(|(s, _)| *s == f.slave) {
                        core.step(start);
                        self.reply.clear();
                        let begin = rtu::begin(&mut self.reply, f.slave);
                        respond(core, f.pdu, true, &mut self.reply, &mut |_| {});
                        rtu::finish(&mut self.reply, begin);
                        self.ready_at = start + wire(f.len + self.reply.len(), self.baud);
                        self.sent = 0;
                    }
                    f.len
                }
                Err(RtuError::Incomplete { .. }) => break,
                Err(_) => self.inbox.len(),
            };
            self.inbox.drain(..used.min(self.inbox.len()));
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        if self.unplugged.load(Ordering::Relaxed) {
            return Err(TransportError::Disconnected);
        }
        let now = Instant::now();
        if self.sent >= self.reply.len() || self.ready_at > now + timeout {
            std::thread::sleep(timeout);
            return Ok(0);
        }
        if self.ready_at > now {
            std::thread::sleep(self.ready_at - now);
        }
        let n = (self.reply.len() - self.sent).min(buf.len());
        buf[..n].copy_from_slice(&self.reply[self.sent..self.sent + n]);
        self.sent += n;
        Ok(n)
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        self.reply.clear();
        self.sent = 0;
        Ok(())
    }
}

/// One core of a shared line, as the pty session's map.
struct Shared<C: EmulatorCore> {
    cores: Cores<C>,
    index: usize,
}

impl<C: EmulatorCore> Shared<C> {
    fn with<R>(&self, f: impl FnOnce(&mut C) -> Result<R, Exception>) -> Result<R, Exception> {
        let mut cores = self.cores.lock().unwrap_or_else(|p| p.into_inner());
        let (_, c) = cores.get_mut(self.index).ok_or(Exception::ServerDeviceFailure)?;
        f(c)
    }
}

impl<C: EmulatorCore> RegisterMap for Shared<C> {
    fn read(&mut self, table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        self.with(|c| c.read(table, addr, out))
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        self.with(|c| c.write(addr, values))
    }
}

impl<C: EmulatorCore> ServedMap for Shared<C> {
    type Msg = ();

    fn arrived(&mut self, now: Instant) {
        let _ = self.with(|c| {
            c.step(now);
            Ok(())
        });
    }
}

/// The hands `cores` answering Modbus RTU on a new pty linked at `link` (with exception
/// responses; a slave id nobody has is not answered). Stops when the server is dropped.
pub fn serve_pty<C: EmulatorCore>(
    link: &Path,
    cores: Cores<C>,
    baud: u32,
    label: &'static str,
) -> std::io::Result<StreamServer> {
    let slaves: Vec<u8> = cores
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .map(|(s, _)| *s)
        .collect();
    let Some(&first) = slaves.first() else {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "no slave to emulate",
        ));
    };
    let make = move || {
        let map = |index| Shared {
            cores: cores.clone(),
            index,
        };
        let mut session = RtuSession::new(first, map(0), baud);
        for (index, s) in slaves.iter().enumerate().skip(1) {
            session = session.with_slave(*s, map(index));
        }
        session
    };
    // The cores make no commands: the inbox only satisfies the server's signature.
    let (tx, _rx) = tokio::sync::mpsc::channel(1);
    let inbox = crate::front::serve::Inbox::for_tests(crate::front::serve::Queue::new(tx));
    crate::front::stream::serve_pty(link, make, inbox, label, label)
}
