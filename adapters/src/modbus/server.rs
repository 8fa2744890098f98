//! The server (slave) side: a device's registers behind [`RegisterMap`], and [`answer`] /
//! [`respond`], which turn a request PDU into its response PDU. Pure: no I/O, no clock, no
//! allocation (reads go through a 125-word stack buffer).
//!
//! Exceptions (spec section 7 and the state diagrams of section 6): an unknown function is
//! exception 1; a quantity or byte count outside the spec's range exception 3; an address
//! range past 0xFFFF exception 2; anything else the map decides (2 for registers it does not
//! have, 3 for values it refuses, 4 when it fails). A device that never answers exceptions
//! (the Robotiq grippers stay silent) is served with `exceptions: false`: [`respond`] then
//! writes nothing and says why.

use super::pdu::{Exception, PduError, Regs, Request, Response, Table, MAX_READ, READ_HOLDING, READ_INPUT, READ_WRITE};

/// A device's registers as a server sees them. Addresses are the PDU's (0-based).
pub trait RegisterMap {
    /// Fills `out` with the `out.len()` registers of `table` from `addr` (`addr + out.len()`
    /// never passes 0x10000: [`answer`] checks it first).
    fn read(&mut self, table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception>;
    /// Writes `values` to the holding registers from `addr` (FC06, FC16, FC23's write part).
    /// All or nothing: on `Err` nothing may have changed.
    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception>;
}

fn check_range(addr: u16, count: usize) -> Result<(), Exception> {
    if addr as usize + count > 0x1_0000 {
        Err(Exception::IllegalDataAddress)
    } else {
        Ok(())
    }
}

fn read_into<M: RegisterMap + ?Sized>(
    map: &mut M,
    table: Table,
    addr: u16,
    count: u16,
    out: &mut Vec<u8>,
    function: u8,
) -> Result<(), Exception> {
    let n = count as usize;
    check_range(addr, n)?;
    let mut words = [0u16; MAX_READ as usize];
    let words = words.get_mut(..n).ok_or(Exception::IllegalDataValue)?;
    map.read(table, addr, words)?;
    let regs = Regs::from_words(words);
    let resp = match function {
        READ_HOLDING => Response::ReadHolding(regs),
        READ_INPUT => Response::ReadInput(regs),
        _ => Response::ReadWrite(regs),
    };
    resp.encode(out).map_err(|_| Exception::IllegalDataValue)
}

/// Performs `req` on `map` and appends the response PDU to `out`. On `Err` nothing was
/// appended; the caller sends the exception (or stays silent).
///
/// FC23 writes first, then reads (spec 6.17), so a read of the registers just written returns
/// the new values.
pub fn answer<M: RegisterMap + ?Sized>(map: &mut M, req: &Request<'_>, out: &mut Vec<u8>) -> Result<(), Exception> {
    match *req {
        Request::ReadHolding { addr, count } => read_into(map, Table::Holding, addr, count, out, READ_HOLDING),
        Request::ReadInput { addr, count } => read_into(map, Table::Input, addr, count, out, READ_INPUT),
        Request::WriteSingle { addr, value } => {
            map.write(addr, Regs::from_words(&[value]))?;
            Response::WriteSingle { addr, value }
                .encode(out)
                .map_err(|_| Exception::ServerDeviceFailure)
        }
        Request::WriteMultiple { addr, values } => {
            check_range(addr, values.len())?;
            map.write(addr, values)?;
            Response::WriteMultiple {
                addr,
                count: values.len() as u16,
            }
            .encode(out)
            .map_err(|_| Exception::IllegalDataValue)
        }
        Request::ReadWrite {
            read_addr,
            read_count,
            write_addr,
            values,
        } => {
            check_range(write_addr, values.len())?;
            check_range(read_addr, read_count as usize)?;
            map.write(write_addr, values)?;
            read_into(map, Table::Holding, read_addr, read_count, out, READ_WRITE)
        }
    }
}

/// What [`respond`] did with a request PDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// A normal response was appended.
    Answered,
    /// An exception response was appended.
    Exception { function: u8, code: Exception },
    /// The request earned an exception but the device sends none: nothing appended.
    Silent { function: u8, code: Exception },
    /// Nothing to answer (an empty PDU).
    Ignored,
}

impl Outcome {
    /// A short key for counters and logs, `None` for a normal answer.
    pub fn reason(&self) -> Option<&'static str> {
        let code = match self {
            Outcome::Answered => return None,
            Outcome::Ignored => return Some("empty_pdu"),
            Outcome::Exception { code, .. } | Outcome::Silent { code, .. } => code,
        };
        Some(match code {
            Exception::IllegalFunction => "illegal_function",
            Exception::IllegalDataAddress => "illegal_address",
            Exception::IllegalDataValue => "illegal_value",
            Exception::ServerDeviceFailure => "device_failure",
            Exception::Other(_) => "exception",
        })
    }
}

/// Decodes a request PDU, performs it and appends the response PDU (or its exception, when
/// `exceptions` is set) to `out`. `decoded` is told each request that decodes, before it is
/// performed (a front turns writes into commands there).
pub fn respond<M: RegisterMap + ?Sized>(
    map: &mut M,
    pdu: &[u8],
    exceptions: bool,
    out: &mut Vec<u8>,
    decoded: &mut dyn FnMut(&Request<'_>),
) -> Outcome {
    let (function, code) = match Request::decode(pdu) {
        Ok(req) => {
            decoded(&req);
            match answer(map, &req, out) {
                Ok(()) => return Outcome::Answered,
                Err(code) => (req.function(), code),
            }
        }
        Err(e) => match PduError::exception(&e) {
            Some(x) => x,
            None => return Outcome::Ignored,
        },
    };
    if !exceptions {
        return Outcome::Silent { function, code };
    }
    // Encoding an exception cannot fail.
    let _ = Response::Exception { function, code }.encode(out);
    Outcome::Exception { function, code }
}

/// A plain register bank: `holding` registers from `holding_base` and `input` registers from
/// `input_base`, every holding register writable. Enough for tests, simple emulators and a
/// device whose registers are an image; a device with side effects implements
/// [`RegisterMap`] itself.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Bank {
    pub holding_base: u16,
    pub holding: Vec<u16>,
    pub input_base: u16,
    pub input: Vec<u16>,
}

impl Bank {
    fn range(base: u16, len: usize, addr: u16, n: usize) -> Result<std::ops::Range<usize>, Exception> {
        let start = (addr as usize)
            .checked_sub(base as usize)
            .ok_or(Exception::IllegalDataAddress)?;
        if start + n > len {
            return Err(Exception::IllegalDataAddress);
        }
        Ok(start..start + n)
    }
}

impl RegisterMap for Bank {
    fn read(&mut self, table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        let (base, regs) = match table {
            Table::Holding => (self.holding_base, &self.holding),
            Table::Input => (self.input_base, &self.input),
        };
        let r = Self::range(base, regs.len(), addr, out.len())?;
        out.copy_from_slice(&regs[r]);
        Ok(())
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        let r = Self::range(self.holding_base, self.holding.len(), addr, values.len())?;
        values.copy_to(&mut self.holding[r]);
        Ok(())
    }
}
