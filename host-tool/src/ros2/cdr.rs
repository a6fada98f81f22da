//! OMG CDR as ROS 2 serialises messages (XCDR1, little-endian): a 4-byte encapsulation header,
//! then each field aligned to its own size from the end of that header; strings as a `u32`
//! length counting a terminating NUL, then the bytes and the NUL; sequences as a `u32` count,
//! then the elements; fixed arrays as their elements alone.

use thiserror::Error;

/// The encapsulation header of little-endian plain CDR (`CDR_LE`).
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A message that does not decode as the type it claims.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CdrError {
    /// The bytes end inside a field.
    #[error("message ends at byte {at} inside `{field}` (it has {len} bytes)")]
    Truncated {
        field: &'static str,
        at: usize,
        len: usize,
    },
    /// Not little-endian plain CDR.
    #[error("encapsulation {0:02x?} is not little-endian CDR (00 01)")]
    Encapsulation([u8; 2]),
    /// A string that is not NUL-terminated UTF-8.
    #[error("`{0}` is not a NUL-terminated UTF-8 string")]
    BadString(&'static str),
}

/// Reads fields in order from a CDR message.
#[derive(Debug)]
pub struct CdrReader<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> CdrReader<'a> {
    /// A reader past the encapsulation header.
    pub fn new(message: &'a [u8]) -> Result<Self, CdrError> {
        let Some((head, body)) = message.split_first_chunk::<4>() else {
            return Err(CdrError::Truncated {
                field: "encapsulation header",
                at: 0,
                len: message.len(),
            });
        };
        if head[..2] != CDR_LE[..2] {
            return Err(CdrError::Encapsulation([head[0], head[1]]));
        }
        Ok(Self { body, at: 0 })
    }

    fn take<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], CdrError> {
        let start = self.at.next_multiple_of(N.clamp(1, 8));
        let bytes = self.body.get(start..start + N).ok_or(CdrError::Truncated {
            field,
            at: start + 4,
            len: self.body.len() + 4,
        })?;
        self.at = start + N;
        Ok(bytes.try_into().expect("N bytes"))
    }

    pub fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        self.take::<8>(field).map(f64::from_le_bytes)
    }

    pub fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        self.take::<4>(field).map(i32::from_le_bytes)
    }

    pub fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        self.take::<4>(field).map(u32::from_le_bytes)
    }

    pub fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        self.take::<1>(field).map(|[b]| b)
    }

    pub fn string(&mut self, field: &'static str) -> Result<&'a str, CdrError> {
        let len = self.u32(field)? as usize;
        let bytes =
            self.body
                .get(self.at..self.at.saturating_add(len))
                .ok_or(CdrError::Truncated {
                    field,
                    at: self.at + 4,
                    len: self.body.len() + 4,
                })?;
        self.at += len;
        match bytes.split_last() {
            // ROS 2 writes an empty string as length 1 (the NUL); some writers as 0.
            None => Ok(""),
            Some((0, text)) => std::str::from_utf8(text).map_err(|_| CdrError::BadString(field)),
            Some(_) => Err(CdrError::BadString(field)),
        }
    }

    /// Skips `n` f64s (a fixed array such as a covariance).
    pub fn skip_f64s(&mut self, n: usize, field: &'static str) -> Result<(), CdrError> {
        for _ in 0..n {
            self.f64(field)?;
        }
        Ok(())
    }
}

/// Writes fields in order into a CDR message.
#[derive(Debug)]
pub struct CdrWriter {
    bytes: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    pub fn new() -> Self {
        Self {
            bytes: CDR_LE.to_vec(),
        }
    }

    fn align(&mut self, n: usize) {
        while !(self.bytes.len() - 4).is_multiple_of(n) {
            self.bytes.push(0);
        }
    }

    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.bytes.extend(v.to_le_bytes());
        self
    }

    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.bytes.extend(v.to_le_bytes());
        self
    }

    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.bytes.extend(v.to_le_bytes());
        self
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.bytes.extend(v.to_le_bytes());
        self
    }

    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.align(2);
        self.bytes.extend(v.to_le_bytes());
        self
    }

    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.bytes.push(v);
        self
    }

    pub fn bool(&mut self, v: bool) -> &mut Self {
        self.u8(u8::from(v))
    }

    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(u32::try_from(s.len() + 1).expect("string under 4 GiB"));
        self.bytes.extend(s.as_bytes());
        self.bytes.push(0);
        self
    }

    /// A sequence of bytes (`uint8[]`).
    pub fn byte_sequence(&mut self, b: &[u8]) -> &mut Self {
        self.u32(u32::try_from(b.len()).expect("sequence under 4 GiB"));
        self.bytes.extend(b);
        self
    }

    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_aligned_from_the_end_of_the_header() {
        let mut w = CdrWriter::new();
        w.u8(7).f64(1.5).string("ab").u32(9).f64(-2.0);
        let bytes = w.finish();
        // u8 at 0, f64 at 8, string length at 16, "ab\0" at 20..23, u32 at 24, f64 at 32.
        assert_eq!(bytes.len(), 4 + 40);
        let mut r = CdrReader::new(&bytes).expect("test value");
        assert_eq!(r.u8("a").expect("test value"), 7);
        assert_eq!(r.f64("b").expect("test value"), 1.5);
        assert_eq!(r.string("c").expect("test value"), "ab");
        assert_eq!(r.u32("d").expect("test value"), 9);
        assert_eq!(r.f64("e").expect("test value"), -2.0);
        assert!(matches!(
            r.f64("f"),
            Err(CdrError::Truncated { field: "f", .. })
        ));
    }

    #[test]
    fn big_endian_and_short_messages_are_refused() {
        assert!(matches!(
            CdrReader::new(&[0, 0, 0, 0, 1]),
            Err(CdrError::Encapsulation([0, 0]))
        ));
        assert!(CdrReader::new(&[0, 1]).is_err());
    }
}
