//! OMG CDR (XCDR1, little endian), as ROS 2 serializes its messages: a 4-byte encapsulation
//! header, then each primitive aligned to its own size counted from just after the header,
//! strings as a `u32` length that counts their closing NUL, sequences as a `u32` count.

/// The encapsulation header of a little-endian plain CDR payload (`CDR_LE`).
pub const HEADER_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A CDR writer.
#[derive(Debug, Clone)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Default for Writer {
    fn default() -> Self {
        Writer::new()
    }
}

impl Writer {
    /// A payload that starts with the little-endian encapsulation header.
    pub fn new() -> Writer {
        Writer { buf: HEADER_LE.to_vec() }
    }

    /// Pads with zeros until the body (after the header) is a multiple of `n` long.
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - HEADER_LE.len()).is_multiple_of(n) {
            self.buf.push(0);
        }
    }

    /// A primitive's little-endian bytes, aligned to its own size.
    fn primitive<const N: usize>(&mut self, bytes: [u8; N]) -> &mut Self {
        self.align(N);
        self.buf.extend_from_slice(&bytes);
        self
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.primitive(v.to_le_bytes())
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.primitive(v.to_le_bytes())
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.primitive(v.to_le_bytes())
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.primitive(v.to_le_bytes())
    }

    /// A `string`: length with the NUL, the bytes, the NUL.
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }

    /// A `float32[]` (unbounded sequence).
    pub fn f32_seq(&mut self, v: &[f32]) -> &mut Self {
        self.u32(v.len() as u32);
        for &x in v {
            self.f32(x);
        }
        self
    }

    /// The payload.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// A CDR reader over a payload with its encapsulation header.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

/// Why a payload could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    /// Not little-endian plain CDR.
    #[error("not a little-endian CDR payload (encapsulation {0:02x?})")]
    Encapsulation(Vec<u8>),
    /// Shorter than its contents.
    #[error("CDR payload ends early (needed {needed} bytes at offset {at})")]
    Short {
        /// Offset in the body.
        at: usize,
        /// Bytes needed there.
        needed: usize,
    },
}

impl<'a> Reader<'a> {
    /// A reader of `payload`, which must start with [`HEADER_LE`].
    pub fn new(payload: &'a [u8]) -> Result<Reader<'a>, CdrError> {
        match payload.get(..4) {
            Some(h) if h == HEADER_LE => Ok(Reader { buf: &payload[4..], at: 0 }),
            h => Err(CdrError::Encapsulation(h.unwrap_or(payload).to_vec())),
        }
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        self.at = self.at.div_ceil(N) * N;
        let bytes = self.buf.get(self.at..self.at + N).ok_or(CdrError::Short { at: self.at, needed: N })?;
        self.at += N;
        Ok(bytes.try_into().expect("N bytes"))
    }

    /// A `float64`.
    pub fn f64(&mut self) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.take::<8>()?))
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.take::<4>()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_align_to_their_size_after_the_header() {
        let mut w = Writer::new();
        w.u32(1).f64(2.0).string("ab").f32_seq(&[0.5]);
        let b = w.finish();
        assert_eq!(&b[..4], &HEADER_LE);
        assert_eq!(&b[4..8], &1u32.to_le_bytes());
        assert_eq!(&b[8..12], &[0, 0, 0, 0], "padding to 8 before the f64");
        assert_eq!(&b[12..20], &2.0f64.to_le_bytes());
        assert_eq!(&b[20..24], &3u32.to_le_bytes(), "the length counts the NUL");
        assert_eq!(&b[24..27], b"ab\0");
        assert_eq!(&b[27..28], &[0], "padding to 4 before the count");
        assert_eq!(&b[28..32], &1u32.to_le_bytes());
        assert_eq!(&b[32..36], &0.5f32.to_le_bytes());
    }

    #[test]
    fn a_reader_reads_what_the_writer_wrote_and_refuses_short_or_foreign_payloads() {
        let mut w = Writer::new();
        w.u32(7).f64(-1.5);
        let b = w.finish();
        let mut r = Reader::new(&b).expect("header");
        assert_eq!(r.u32(), Ok(7));
        assert_eq!(r.f64(), Ok(-1.5));
        assert!(matches!(r.f64(), Err(CdrError::Short { .. })));
        assert!(matches!(Reader::new(&[0, 0, 0, 0, 1]), Err(CdrError::Encapsulation(_))));
    }
}
