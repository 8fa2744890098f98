//! Modbus PDUs (function code + data), the part shared by RTU and TCP: pure functions over
//! bytes that borrow from the frame and allocate nothing.
//!
//! The register functions handgate's hands use (Modbus Application Protocol Specification
//! V1.1b3, section 6; docs/sources.md "Modbus"):
//!
//! ```text
//! FC03 read holding    request  03 addr(2) count(2)               response 03 n(1) words(n)
//! FC04 read input      request  04 addr(2) count(2)               response 04 n(1) words(n)
//! FC06 write single    request  06 addr(2) value(2)               response: the request echoed
//! FC16 write multiple  request  10 addr(2) count(2) n(1) words(n) response 10 addr(2) count(2)
//! FC23 read/write      request  17 raddr(2) rcount(2) waddr(2) wcount(2) n(1) words(n)
//!                                                                 response 17 n(1) words(n)
//! exception            response (function | 0x80) code(1)
//! ```
//!
//! Words are big-endian. Quantity limits (the spec's): reads 1..=125 registers, FC16 writes
//! 1..=123, FC23 writes 1..=121; a byte count must be twice the quantity. A request outside
//! them is answered with exception 3 (illegal data value), an unknown function with exception
//! 1 ([`PduError::exception`]).

use std::fmt;

/// FC03.
pub const READ_HOLDING: u8 = 0x03;
/// FC04.
pub const READ_INPUT: u8 = 0x04;
/// FC06.
pub const WRITE_SINGLE: u8 = 0x06;
/// FC16.
pub const WRITE_MULTIPLE: u8 = 0x10;
/// FC23.
pub const READ_WRITE: u8 = 0x17;
/// Set in the function byte of an exception response.
pub const EXCEPTION_BIT: u8 = 0x80;

/// Most registers one read (FC03, FC04, FC23's read part) may ask for.
pub const MAX_READ: u16 = 125;
/// Most registers one FC16 may write.
pub const MAX_WRITE: u16 = 123;
/// Most registers FC23's write part may carry.
pub const MAX_READ_WRITE_WRITE: u16 = 121;
/// Largest PDU (a 256-byte RTU frame less slave id and CRC).
pub const MAX_PDU: usize = 253;

/// A Modbus exception code (spec section 7). Codes 1 to 4 are the ones a register server
/// answers; any other code a device sends decodes as [`Exception::Other`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
pub enum Exception {
    /// 1: the function code is not supported.
    #[error("illegal function (exception 1)")]
    IllegalFunction,
    /// 2: the address, or address + quantity, is outside the device's registers.
    #[error("illegal data address (exception 2)")]
    IllegalDataAddress,
    /// 3: a quantity, byte count or value is not allowed.
    #[error("illegal data value (exception 3)")]
    IllegalDataValue,
    /// 4: the device failed while performing the request.
    #[error("server device failure (exception 4)")]
    ServerDeviceFailure,
    /// Any other code (5 acknowledge, 6 busy, 0x0A/0x0B gateway, ...), as received.
    #[error("exception code {0}")]
    Other(u8),
}

impl Exception {
    pub fn code(self) -> u8 {
        match self {
            Exception::IllegalFunction => 1,
            Exception::IllegalDataAddress => 2,
            Exception::IllegalDataValue => 3,
            Exception::ServerDeviceFailure => 4,
            Exception::Other(c) => c,
        }
    }

    pub fn from_code(code: u8) -> Self {
        match code {
            1 => Exception::IllegalFunction,
            2 => Exception::IllegalDataAddress,
            3 => Exception::IllegalDataValue,
            4 => Exception::ServerDeviceFailure,
            c => Exception::Other(c),
        }
    }
}

/// Why a PDU does not decode (or a value cannot be encoded).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PduError {
    #[error("empty PDU")]
    Empty,
    /// A function code this codec does not handle.
    #[error("function 0x{0:02X} not supported")]
    Function(u8),
    /// The PDU is shorter or longer than its function and byte count say.
    #[error("function 0x{function:02X}: PDU of {len} bytes, expected {expected}")]
    Length { function: u8, len: usize, expected: usize },
    /// A register quantity outside the spec's range for the function.
    #[error("function 0x{function:02X}: quantity {count} outside 1..={max}")]
    Quantity { function: u8, count: u16, max: u16 },
    /// A byte count that is not twice the quantity (or odd, in a response).
    #[error("function 0x{function:02X}: byte count {byte_count}, expected {expected}")]
    ByteCount {
        function: u8,
        byte_count: u8,
        expected: usize,
    },
}

impl PduError {
    /// What a server answers to a request that fails to decode this way: the function to
    /// echo (without the exception bit) and the exception. `None` for an empty PDU (nothing
    /// to answer to).
    pub fn exception(&self) -> Option<(u8, Exception)> {
        match *self {
            PduError::Empty => None,
            PduError::Function(f) => Some((f & !EXCEPTION_BIT, Exception::IllegalFunction)),
            PduError::Length { function, .. }
            | PduError::Quantity { function, .. }
            | PduError::ByteCount { function, .. } => Some((function, Exception::IllegalDataValue)),
        }
    }
}

/// Register words, big-endian as on the wire, borrowed from a frame (or from the caller's
/// `u16` slice when building a request). Nothing is copied until the caller reads them.
#[derive(Clone, Copy)]
pub struct Regs<'a>(RegsInner<'a>);

#[derive(Clone, Copy)]
enum RegsInner<'a> {
    Be(&'a [u8]),
    Words(&'a [u16]),
}

impl<'a> Regs<'a> {
    /// Big-endian words; `None` for an odd number of bytes.
    pub fn from_be_bytes(bytes: &'a [u8]) -> Option<Self> {
        (bytes.len() % 2 == 0).then_some(Regs(RegsInner::Be(bytes)))
    }

    pub fn from_words(words: &'a [u16]) -> Self {
        Regs(RegsInner::Words(words))
    }

    pub fn len(&self) -> usize {
        match self.0 {
            RegsInner::Be(b) => b.len() / 2,
            RegsInner::Words(w) => w.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn get(&self, i: usize) -> Option<u16> {
        match self.0 {
            RegsInner::Be(b) => b.get(2 * i..2 * i + 2).map(|w| u16::from_be_bytes([w[0], w[1]])),
            RegsInner::Words(w) => w.get(i).copied(),
        }
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = u16> + 'a {
        let regs = *self;
        (0..regs.len()).map(move |i| regs.get(i).unwrap_or_default())
    }

    /// Copies the words into `out[..len()]`; `out` must be at least `len()` long.
    pub fn copy_to(&self, out: &mut [u16]) {
        for (o, v) in out.iter_mut().zip(self.iter()) {
            *o = v;
        }
    }

    /// Appends the words big-endian.
    pub fn write_be(&self, out: &mut Vec<u8>) {
        match self.0 {
            RegsInner::Be(b) => out.extend_from_slice(b),
            RegsInner::Words(w) => {
                for v in w {
                    out.extend_from_slice(&v.to_be_bytes());
                }
            }
        }
    }
}

impl PartialEq for Regs<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl Eq for Regs<'_> {}

impl fmt::Debug for Regs<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// The register table a read names: FC03 (and FC23) read holding registers, FC04 input
/// registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Table {
    Holding,
    Input,
}

/// A request PDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request<'a> {
    ReadHolding {
        addr: u16,
        count: u16,
    },
    ReadInput {
        addr: u16,
        count: u16,
    },
    WriteSingle {
        addr: u16,
        value: u16,
    },
    WriteMultiple {
        addr: u16,
        values: Regs<'a>,
    },
    /// FC23: the server writes first, then reads (spec 6.17).
    ReadWrite {
        read_addr: u16,
        read_count: u16,
        write_addr: u16,
        values: Regs<'a>,
    },
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([b[at], b[at + 1]])
}

fn check_len(function: u8, pdu: &[u8], expected: usize) -> Result<(), PduError> {
    if pdu.len() == expected {
        Ok(())
    } else {
        Err(PduError::Length {
            function,
            len: pdu.len(),
            expected,
        })
    }
}

fn check_quantity(function: u8, count: u16, max: u16) -> Result<(), PduError> {
    if (1..=max).contains(&count) {
        Ok(())
    } else {
        Err(PduError::Quantity { function, count, max })
    }
}

/// `count` words after a byte count at `pdu[at]`, the byte count being `2 * count`, ending
/// the PDU.
fn words_after_count<'a>(function: u8, pdu: &'a [u8], at: usize, count: u16) -> Result<Regs<'a>, PduError> {
    if pdu.len() <= at {
        return Err(PduError::Length {
            function,
            len: pdu.len(),
            expected: at + 1 + 2 * count as usize,
        });
    }
    let byte_count = pdu[at];
    if byte_count as usize != 2 * count as usize {
        return Err(PduError::ByteCount {
            function,
            byte_count,
            expected: 2 * count as usize,
        });
    }
    check_len(function, pdu, at + 1 + byte_count as usize)?;
    Ok(Regs(RegsInner::Be(&pdu[at + 1..])))
}

impl<'a> Request<'a> {
    /// The function code.
    pub fn function(&self) -> u8 {
        match self {
            Request::ReadHolding { .. } => READ_HOLDING,
            Request::ReadInput { .. } => READ_INPUT,
            Request::WriteSingle { .. } => WRITE_SINGLE,
            Request::WriteMultiple { .. } => WRITE_MULTIPLE,
            Request::ReadWrite { .. } => READ_WRITE,
        }
    }

    /// Decodes a whole request PDU (exactly its bytes: a longer or shorter PDU is an error).
    pub fn decode(pdu: &'a [u8]) -> Result<Self, PduError> {
        let &function = pdu.first().ok_or(PduError::Empty)?;
        match function {
            READ_HOLDING | READ_INPUT => {
                check_len(function, pdu, 5)?;
                let (addr, count) = (be16(pdu, 1), be16(pdu, 3));
                check_quantity(function, count, MAX_READ)?;
                Ok(if function == READ_HOLDING {
                    Request::ReadHolding { addr, count }
                } else {
                    Request::ReadInput { addr, count }
                })
            }
            WRITE_SINGLE => {
                check_len(function, pdu, 5)?;
                Ok(Request::WriteSingle {
                    addr: be16(pdu, 1),
                    value: be16(pdu, 3),
                })
            }
            WRITE_MULTIPLE => {
                if pdu.len() < 6 {
                    return Err(PduError::Length {
                        function,
                        len: pdu.len(),
                        expected: 6,
                    });
                }
                let (addr, count) = (be16(pdu, 1), be16(pdu, 3));
                check_quantity(function, count, MAX_WRITE)?;
                let values = words_after_count(function, pdu, 5, count)?;
                Ok(Request::WriteMultiple { addr, values })
            }
            READ_WRITE => {
                if pdu.len() < 10 {
                    return Err(PduError::Length {
                        function,
                        len: pdu.len(),
                        expected: 10,
                    });
                }
                let (read_addr, read_count) = (be16(pdu, 1), be16(pdu, 3));
                let (write_addr, write_count) = (be16(pdu, 5), be16(pdu, 7));
                check_quantity(function, read_count, MAX_READ)?;
                check_quantity(function, write_count, MAX_READ_WRITE_WRITE)?;
                let values = words_after_count(function, pdu, 9, write_count)?;
                Ok(Request::ReadWrite {
                    read_addr,
                    read_count,
                    write_addr,
                    values,
                })
            }
            f => Err(PduError::Function(f)),
        }
    }

    /// Appends the request PDU to `out`. Refuses quantities the spec does not allow (so a
    /// frame handgate sends always decodes on the other side).
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), PduError> {
        let function = self.function();
        match *self {
            Request::ReadHolding { addr, count } | Request::ReadInput { addr, count } => {
                check_quantity(function, count, MAX_READ)?;
                out.push(function);
                out.extend_from_slice(&addr.to_be_bytes());
                out.extend_from_slice(&count.to_be_bytes());
            }
            Request::WriteSingle { addr, value } => {
                out.push(function);
                out.extend_from_slice(&addr.to_be_bytes());
                out.extend_from_slice(&value.to_be_bytes());
            }
            Request::WriteMultiple { addr, values } => {
                let count = quantity(function, &values, MAX_WRITE)?;
                out.push(function);
                out.extend_from_slice(&addr.to_be_bytes());
                out.extend_from_slice(&count.to_be_bytes());
                out.push((2 * count) as u8);
                values.write_be(out);
            }
            Request::ReadWrite {
                read_addr,
                read_count,
                write_addr,
                values,
            } => {
                check_quantity(function, read_count, MAX_READ)?;
                let count = quantity(function, &values, MAX_READ_WRITE_WRITE)?;
                out.push(function);
                out.extend_from_slice(&read_addr.to_be_bytes());
                out.extend_from_slice(&read_count.to_be_bytes());
                out.extend_from_slice(&write_addr.to_be_bytes());
                out.extend_from_slice(&count.to_be_bytes());
                out.push((2 * count) as u8);
                values.write_be(out);
            }
        }
        Ok(())
    }

    /// Bytes of this request's PDU.
    pub fn pdu_len(&self) -> usize {
        match self {
            Request::ReadHolding { .. } | Request::ReadInput { .. } | Request::WriteSingle { .. } => 5,
            Request::WriteMultiple { values, .. } => 6 + 2 * values.len(),
            Request::ReadWrite { values, .. } => 10 + 2 * values.len(),
        }
    }

    /// Bytes of the PDU of its normal (not exception) response: what a wire-time budget
    /// needs.
    pub fn response_pdu_len(&self) -> usize {
        match *self {
            Request::ReadHolding { count, .. } | Request::ReadInput { count, .. } => 2 + 2 * count as usize,
            Request::ReadWrite { read_count, .. } => 2 + 2 * read_count as usize,
            Request::WriteSingle { .. } | Request::WriteMultiple { .. } => 5,
        }
    }
}

fn quantity(function: u8, values: &Regs<'_>, max: u16) -> Result<u16, PduError> {
    let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
    check_quantity(function, count, max)?;
    Ok(count)
}

/// A response PDU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response<'a> {
    ReadHolding(Regs<'a>),
    ReadInput(Regs<'a>),
    WriteSingle {
        addr: u16,
        value: u16,
    },
    WriteMultiple {
        addr: u16,
        count: u16,
    },
    ReadWrite(Regs<'a>),
    /// `function` without the exception bit.
    Exception {
        function: u8,
        code: Exception,
    },
}

impl<'a> Response<'a> {
    /// The function code as on the wire (with the exception bit for an exception).
    pub fn function(&self) -> u8 {
        match self {
            Response::ReadHolding(_) => READ_HOLDING,
            Response::ReadInput(_) => READ_INPUT,
            Response::WriteSingle { .. } => WRITE_SINGLE,
            Response::WriteMultiple { .. } => WRITE_MULTIPLE,
            Response::ReadWrite(_) => READ_WRITE,
            Response::Exception { function, .. } => function | EXCEPTION_BIT,
        }
    }

    /// Decodes a whole response PDU.
    pub fn decode(pdu: &'a [u8]) -> Result<Self, PduError> {
        let &function = pdu.first().ok_or(PduError::Empty)?;
        if function & EXCEPTION_BIT != 0 {
            check_len(function, pdu, 2)?;
            return Ok(Response::Exception {
                function: function & !EXCEPTION_BIT,
                code: Exception::from_code(pdu[1]),
            });
        }
        match function {
            READ_HOLDING | READ_INPUT | READ_WRITE => {
                if pdu.len() < 2 {
                    return Err(PduError::Length {
                        function,
                        len: pdu.len(),
                        expected: 2,
                    });
                }
                let byte_count = pdu[1];
                if byte_count % 2 == 1 || byte_count == 0 || byte_count as usize > 2 * MAX_READ as usize {
                    return Err(PduError::ByteCount {
                        function,
                        byte_count,
                        expected: 2 * (byte_count as usize / 2).clamp(1, MAX_READ as usize),
                    });
                }
                check_len(function, pdu, 2 + byte_count as usize)?;
                let regs = Regs(RegsInner::Be(&pdu[2..]));
                Ok(match function {
                    READ_HOLDING => Response::ReadHolding(regs),
                    READ_INPUT => Response::ReadInput(regs),
                    _ => Response::ReadWrite(regs),
                })
            }
            WRITE_SINGLE => {
                check_len(function, pdu, 5)?;
                Ok(Response::WriteSingle {
                    addr: be16(pdu, 1),
                    value: be16(pdu, 3),
                })
            }
            WRITE_MULTIPLE => {
                check_len(function, pdu, 5)?;
                let count = be16(pdu, 3);
                check_quantity(function, count, MAX_WRITE)?;
                Ok(Response::WriteMultiple {
                    addr: be16(pdu, 1),
                    count,
                })
            }
            f => Err(PduError::Function(f)),
        }
    }

    /// Appends the response PDU to `out`.
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), PduError> {
        let function = self.function();
        match *self {
            Response::ReadHolding(regs) | Response::ReadInput(regs) | Response::ReadWrite(regs) => {
                let count = quantity(function, &regs, MAX_READ)?;
                out.push(function);
                out.push((2 * count) as u8);
                regs.write_be(out);
            }
            Response::WriteSingle { addr, value } => {
                out.push(function);
                out.extend_from_slice(&addr.to_be_bytes());
                out.extend_from_slice(&value.to_be_bytes());
            }
            Response::WriteMultiple { addr, count } => {
                check_quantity(function, count, MAX_WRITE)?;
                out.push(function);
                out.extend_from_slice(&addr.to_be_bytes());
                out.extend_from_slice(&count.to_be_bytes());
            }
            Response::Exception { code, .. } => {
                out.push(function);
                out.push(code.code());
            }
        }
        Ok(())
    }
}
