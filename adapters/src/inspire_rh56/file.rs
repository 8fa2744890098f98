//! The RH56's register file as bytes (the layout of [`super::regs`]): what the emulated hand
//! keeps and what the fronts answer from. Reads anywhere inside it; writes only where the hand
//! takes them ([`regs::writable`]). Modbus sees it two bytes a register ([`RegisterFile::read_words`]).

use super::regs::{self, FINGERS};

/// Why a register access was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    #[error("bytes {addr}..{} are outside the register file (1000..5124)", *.addr as usize + *.len)]
    OutOfRange { addr: u16, len: usize },
    #[error("bytes {addr}..{} are read-only", *.addr as usize + *.len)]
    ReadOnly { addr: u16, len: usize },
}

impl Refused {
    /// The counter key of the refusal.
    pub fn reason(&self) -> &'static str {
        match self {
            Refused::OutOfRange { .. } => "out_of_range",
            Refused::ReadOnly { .. } => "read_only",
        }
    }
}

/// Bytes FILE_START..FILE_END.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RegisterFile {
    bytes: Vec<u8>,
}

impl Default for RegisterFile {
    fn default() -> Self {
        RegisterFile {
            bytes: vec![0; (regs::FILE_END - regs::FILE_START) as usize],
        }
    }
}

fn at(addr: u16) -> usize {
    (addr - regs::FILE_START) as usize
}

impl RegisterFile {
    /// Short `i` of the six-short block at `block`.
    pub fn short(&self, block: u16, i: usize) -> i16 {
        let o = at(block) + 2 * i;
        i16::from_le_bytes([self.bytes[o], self.bytes[o + 1]])
    }

    pub fn put_short(&mut self, block: u16, i: usize, v: i16) {
        let o = at(block) + 2 * i;
        self.bytes[o..o + 2].copy_from_slice(&v.to_le_bytes());
    }

    /// The six shorts of `block`.
    pub fn shorts(&self, block: u16) -> [i16; FINGERS] {
        std::array::from_fn(|i| self.short(block, i))
    }

    pub fn byte(&self, addr: u16) -> u8 {
        self.bytes[at(addr)]
    }

    pub fn put_byte(&mut self, addr: u16, v: u8) {
        self.bytes[at(addr)] = v;
    }

    /// Writes bytes anywhere in the file (the owner's own updates; no permission check).
    pub fn put(&mut self, addr: u16, data: &[u8]) {
        self.bytes[at(addr)..at(addr) + data.len()].copy_from_slice(data);
    }

    /// Reads `out.len()` bytes from `addr`.
    pub fn read(&self, addr: u16, out: &mut [u8]) -> Result<(), Refused> {
        if !regs::readable(addr, out.len()) {
            return Err(Refused::OutOfRange { addr, len: out.len() });
        }
        out.copy_from_slice(&self.bytes[at(addr)..at(addr) + out.len()]);
        Ok(())
    }

    /// A client's write: only where the hand takes writes.
    pub fn write(&mut self, addr: u16, data: &[u8]) -> Result<(), Refused> {
        if !regs::readable(addr, data.len()) {
            return Err(Refused::OutOfRange { addr, len: data.len() });
        }
        if !regs::writable(addr, data.len()) {
            return Err(Refused::ReadOnly { addr, len: data.len() });
        }
        self.put(addr, data);
        Ok(())
    }

    /// Modbus's view: register `addr + k` is the little-endian short at bytes `addr + 2k`.
    pub fn read_words(&self, addr: u16, out: &mut [u16]) -> Result<(), Refused> {
        let len = 2 * out.len();
        if !regs::readable(addr, len) {
            return Err(Refused::OutOfRange { addr, len });
        }
        let base = at(addr);
        for (k, w) in out.iter_mut().enumerate() {
            *w = u16::from_le_bytes([self.bytes[base + 2 * k], self.bytes[base + 2 * k + 1]]);
        }
        Ok(())
    }
}

/// Whether a write of `len` bytes at `addr` touches the `reg_len` bytes at `reg`.
pub fn touches(addr: u16, len: usize, reg: u16, reg_len: usize) -> bool {
    addr as usize + len > reg as usize && (addr as usize) < reg as usize + reg_len
}

/// Words as the file's bytes (each little-endian), into `buf`; the bytes written.
pub fn words_to_bytes(values: impl Iterator<Item = u16>, buf: &mut [u8]) -> usize {
    let mut n = 0;
    for (k, v) in values.take(buf.len() / 2).enumerate() {
        buf[2 * k..2 * k + 2].copy_from_slice(&v.to_le_bytes());
        n = 2 * k + 2;
    }
    n
}
