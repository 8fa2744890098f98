//! XCDR2 (`D_CDR2`) encoding of `@appendable` types: what lets a type grow by appended members
//! without breaking its older readers (docs/wire-types.md, "Status: frozen, and its extension").
//!
//! The `cdr` crate (and so the serde path of cyclonedds-rs) knows only plain CDR (XCDR1), where
//! a member appended to a struct moves every later byte of a sequence of it. In XCDR2 every
//! appendable struct starts with a DHEADER (u32: the bytes of its members that follow), and so
//! does every sequence whose elements are not primitive (strings, structs): a reader that knows
//! fewer members reads those and jumps to the end the DHEADER gives, and a reader that knows
//! more members than a sample holds gives the missing ones their default. The rules used here,
//! checked byte for byte against CycloneDDS Python 0.10.2's serialiser of the same
//! declarations (`tests/tests/status_compat.rs`):
//!
//! - encapsulation header `00 09 00 00` (D_CDR2, little endian; `00 08` is big endian, read
//!   too); the options' low two bits count the zero bytes padding the sample to a multiple of 4
//!   (added by the DDS binding, as for every type);
//! - alignment relative to the first byte after the header, at most 4 (a u64 is 4-aligned);
//! - an appendable struct: DHEADER, then its members; the DHEADER counts the bytes from after
//!   itself to the end of the last member (no trailing padding);
//! - a string: u32 length including the NUL, the bytes, the NUL;
//! - a sequence of primitives: u32 count, elements; a sequence of strings or structs: DHEADER
//!   (bytes of count and elements), u32 count, elements.

use crate::cdr_codec::cdr_string::MAX_STRING;

/// D_CDR2 little endian (what [`Writer`] writes).
pub const D_CDR2_LE: [u8; 2] = [0x00, 0x09];
/// D_CDR2 big endian (read).
pub const D_CDR2_BE: [u8; 2] = [0x00, 0x08];

/// A sample that cannot be read as XCDR2 of its type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Xcdr2Error {
    #[error("not an XCDR2 D_CDR2 sample (encapsulation {0:02x} {1:02x})")]
    Encapsulation(u8, u8),
    #[error("sample truncated at byte {0}")]
    Truncated(usize),
    #[error("a DHEADER at byte {at} announces {len} bytes past its enclosing end")]
    Delimiter { at: usize, len: u32 },
    #[error("string of {0} bytes (max {MAX_STRING})")]
    LongString(usize),
    #[error("string not NUL-terminated or not UTF-8")]
    BadString,
    #[error("sequence of {0} elements cannot fit in the bytes left")]
    LongSequence(u32),
}

/// Writes one D_CDR2 little-endian sample, header first.
#[derive(Debug)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Default for Writer {
    fn default() -> Self {
        Self::new()
    }
}

impl Writer {
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(256);
        buf.extend_from_slice(&D_CDR2_LE);
        buf.extend_from_slice(&[0, 0]);
        Self { buf }
    }

    /// The sample's bytes (header first, no trailing padding).
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }

    fn align(&mut self, n: usize) {
        let pos = self.buf.len() - 4;
        let pad = (n - pos % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A u64: 4-aligned in XCDR2.
    pub fn u64(&mut self, v: u64) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }

    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// A DHEADER around what `body` writes (an appendable struct, or a sequence of
    /// non-primitive elements).
    pub fn delimited(&mut self, body: impl FnOnce(&mut Self)) {
        self.align(4);
        let at = self.buf.len();
        self.buf.extend_from_slice(&[0; 4]);
        body(self);
        let len = (self.buf.len() - at - 4) as u32;
        self.buf[at..at + 4].copy_from_slice(&len.to_le_bytes());
    }

    /// A sequence of non-primitive elements: DHEADER, count, each element as `each` writes it.
    pub fn sequence<T>(&mut self, items: &[T], mut each: impl FnMut(&mut Self, &T)) {
        self.delimited(|w| {
            w.u32(items.len() as u32);
            for x in items {
                each(w, x);
            }
        });
    }
}

/// Reads one D_CDR2 sample of an appendable type: members past the end of their struct (a
/// sample of an older layout) read as their default; members this reader does not know (a
/// sample of a later layout) are skipped.
#[derive(Debug)]
pub struct Reader<'a> {
    /// The bytes after the encapsulation header.
    data: &'a [u8],
    pos: usize,
    /// The end of the innermost delimited body being read.
    end: usize,
    le: bool,
}

impl<'a> Reader<'a> {
    /// A reader of `bytes`, encapsulation header first.
    pub fn new(bytes: &'a [u8]) -> Result<Self, Xcdr2Error> {
        if bytes.len() < 4 {
            return Err(Xcdr2Error::Truncated(0));
        }
        let le = match [bytes[0], bytes[1]] {
            D_CDR2_LE => true,
            D_CDR2_BE => false,
            _ => return Err(Xcdr2Error::Encapsulation(bytes[0], bytes[1])),
        };
        let data = &bytes[4..];
        Ok(Self {
            data,
            pos: 0,
            end: data.len(),
            le,
        })
    }

    /// Whether the innermost delimited body has no member left (what follows takes defaults).
    fn done(&self) -> bool {
        self.pos >= self.end
    }

    fn align(&mut self, n: usize) {
        self.pos += (n - self.pos % n) % n;
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], Xcdr2Error> {
        let b = self
            .data
            .get(self.pos..self.pos + N)
            .filter(|_| self.pos + N <= self.end)
            .ok_or(Xcdr2Error::Truncated(self.pos))?;
        self.pos += N;
        Ok(b.try_into().expect("N bytes"))
    }

    fn raw_u32(&mut self) -> Result<u32, Xcdr2Error> {
        self.align(4);
        let b = self.take::<4>()?;
        Ok(if self.le {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// A u8 member (its default when the struct ended before it).
    pub fn u8(&mut self) -> Result<u8, Xcdr2Error> {
        if self.done() {
            return Ok(0);
        }
        Ok(self.take::<1>()?[0])
    }

    pub fn bool(&mut self) -> Result<bool, Xcdr2Error> {
        Ok(self.u8()? != 0)
    }

    pub fn u32(&mut self) -> Result<u32, Xcdr2Error> {
        if self.done() {
            return Ok(0);
        }
        self.raw_u32()
    }

    pub fn u64(&mut self) -> Result<u64, Xcdr2Error> {
        if self.done() {
            return Ok(0);
        }
        self.align(4);
        let b = self.take::<8>()?;
        Ok(if self.le {
            u64::from_le_bytes(b)
        } else {
            u64::from_be_bytes(b)
        })
    }

    pub fn f32(&mut self) -> Result<f32, Xcdr2Error> {
        if self.done() {
            return Ok(0.0);
        }
        Ok(f32::from_bits(self.raw_u32()?))
    }

    pub fn string(&mut self) -> Result<String, Xcdr2Error> {
        if self.done() {
            return Ok(String::new());
        }
        let len = self.raw_u32()? as usize;
        if len > MAX_STRING {
            return Err(Xcdr2Error::LongString(len));
        }
        let bytes = self
            .data
            .get(self.pos..self.pos + len)
            .filter(|_| self.pos + len <= self.end)
            .ok_or(Xcdr2Error::Truncated(self.pos))?;
        self.pos += len;
        match bytes.split_last() {
            Some((0, s)) => String::from_utf8(s.to_vec()).map_err(|_| Xcdr2Error::BadString),
            _ => Err(Xcdr2Error::BadString),
        }
    }

    /// A `u32` member appended to an appendable struct: 0 when the enclosing struct ended
    /// before it (a writer of an earlier layout).
    pub fn u32_or_default(&mut self) -> Result<u32, Xcdr2Error> {
        if self.done() {
            return Ok(0);
        }
        self.u32()
    }

    /// A delimited body (an appendable struct, a sequence of non-primitive elements): reads
    /// its DHEADER, runs `body` within it, and continues after it whatever `body` left unread.
    pub fn delimited<R>(&mut self, body: impl FnOnce(&mut Self) -> Result<R, Xcdr2Error>) -> Result<R, Xcdr2Error> {
        let at = self.pos;
        let len = self.raw_u32()?;
        let end = self
            .pos
            .checked_add(len as usize)
            .filter(|e| *e <= self.end)
            .ok_or(Xcdr2Error::Delimiter { at, len })?;
        let outer = std::mem::replace(&mut self.end, end);
        let r = body(self);
        self.end = outer;
        self.pos = end;
        r
    }

    /// An appendable struct member: its default when the enclosing struct ended before it.
    pub fn appendable<R: Default>(
        &mut self,
        body: impl FnOnce(&mut Self) -> Result<R, Xcdr2Error>,
    ) -> Result<R, Xcdr2Error> {
        if self.done() {
            return Ok(R::default());
        }
        self.delimited(body)
    }

    /// A sequence of non-primitive elements, each read by `each` (empty when the enclosing
    /// struct ended before it). Each element takes at least 4 bytes (a DHEADER or a string's
    /// length): a count the bytes cannot hold is refused before anything is reserved.
    pub fn sequence<T>(
        &mut self,
        mut each: impl FnMut(&mut Self) -> Result<T, Xcdr2Error>,
    ) -> Result<Vec<T>, Xcdr2Error> {
        if self.done() {
            return Ok(Vec::new());
        }
        self.delimited(|r| {
            let n = r.raw_u32()?;
            if (n as usize).saturating_mul(4) > r.end - r.pos {
                return Err(Xcdr2Error::LongSequence(n));
            }
            let mut out = Vec::with_capacity(n as usize);
            for _ in 0..n {
                out.push(each(r)?);
            }
            Ok(out)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A struct of a later layout (one more member) and of an earlier one (one member fewer),
    /// each read by the other's reader.
    #[test]
    fn appended_members_are_skipped_and_missing_ones_default() {
        let later = |w: &mut Writer| {
            w.sequence(&[("a", 1.5f32, 7u64), ("bc", 2.5, 8)], |w, (s, f, x)| {
                w.delimited(|w| {
                    w.string(s);
                    w.f32(*f);
                    w.u64(*x); // appended
                })
            });
            w.u32(42); // appended
        };
        let mut w = Writer::new();
        w.delimited(later);
        let bytes = w.finish();
        let mut r = Reader::new(&bytes).unwrap();
        let v = r
            .delimited(|r| r.sequence(|r| r.delimited(|r| Ok((r.string()?, r.f32()?)))))
            .unwrap();
        assert_eq!(v, vec![("a".to_string(), 1.5), ("bc".to_string(), 2.5)]);

        let mut w = Writer::new();
        w.delimited(|w| w.sequence(&["x"], |w, s| w.delimited(|w| w.string(s))));
        let bytes = w.finish();
        let mut r = Reader::new(&bytes).unwrap();
        let v = r
            .delimited(|r| {
                let s = r.sequence(|r| r.delimited(|r| Ok((r.string()?, r.f32()?, r.u64()?))))?;
                Ok((s, r.u32()?))
            })
            .unwrap();
        assert_eq!(v, (vec![("x".to_string(), 0.0, 0)], 0));
    }

    #[test]
    fn lying_lengths_are_errors() {
        let mut w = Writer::new();
        w.delimited(|w| w.sequence(&["x"], |w, s| w.delimited(|w| w.string(s))));
        let good = w.finish();
        // The outer DHEADER past the end of the sample.
        let mut bad = good.clone();
        bad[4..8].copy_from_slice(&1000u32.to_le_bytes());
        assert!(matches!(
            Reader::new(&bad).unwrap().delimited(|r| r.u32()),
            Err(Xcdr2Error::Delimiter { .. })
        ));
        // A count of 2^32 - 1 elements.
        let mut bad = good.clone();
        bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        let r = Reader::new(&bad)
            .unwrap()
            .delimited(|r| r.sequence(|r| r.delimited(|r| r.string())));
        assert!(matches!(r, Err(Xcdr2Error::LongSequence(_))), "{r:?}");
        // Not XCDR2.
        assert!(matches!(
            Reader::new(&[0, 1, 0, 0, 1, 2, 3, 4]),
            Err(Xcdr2Error::Encapsulation(0, 1))
        ));
    }
}
