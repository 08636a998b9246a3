//! OMG CDR (XCDR1, little endian), as ROS 2 serializes its messages: a 4-byte encapsulation
//! header, then each primitive aligned to its own size counted from just after the header,
//! strings as a `u32` length that counts their closing NUL, sequences as a `u32` count.
//!
//! One encoder for both middlewares: rmw_zenoh carries the payload whole, DDS (RTPS) carries
//! the header in its serialized-payload element and the body after it ([`crate::dds`] splits
//! them).

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

    /// A `uint8` (or `char`, `byte`).
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }

    /// A `bool` (one byte, 0 or 1).
    pub fn bool(&mut self, v: bool) -> &mut Self {
        self.u8(u8::from(v))
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

    /// A sequence's element count (the elements follow).
    pub fn count(&mut self, n: usize) -> &mut Self {
        self.u32(n as u32)
    }

    /// A `float32[]` (unbounded sequence).
    pub fn f32_seq(&mut self, v: &[f32]) -> &mut Self {
        self.count(v.len());
        for &x in v {
            self.f32(x);
        }
        self
    }

    /// A `uint8[]` (unbounded sequence of bytes).
    pub fn bytes(&mut self, v: &[u8]) -> &mut Self {
        self.count(v.len());
        self.buf.extend_from_slice(v);
        self
    }

    /// A fixed-size `uint8[N]` array (no count).
    pub fn byte_array(&mut self, v: &[u8]) -> &mut Self {
        self.buf.extend_from_slice(v);
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
    /// Bytes left after the message.
    #[error("CDR payload has {0} bytes after its message")]
    Trailing(usize),
    /// A string that is not NUL-terminated UTF-8.
    #[error("CDR string at offset {0} is not NUL-terminated UTF-8")]
    BadString(usize),
}

impl<'a> Reader<'a> {
    /// A reader of `payload`, which must start with [`HEADER_LE`].
    pub fn new(payload: &'a [u8]) -> Result<Reader<'a>, CdrError> {
        match payload.get(..4) {
            Some(h) if h == HEADER_LE => Ok(Reader { buf: &payload[4..], at: 0 }),
            h => Err(CdrError::Encapsulation(h.unwrap_or(payload).to_vec())),
        }
    }

    fn slice(&mut self, n: usize) -> Result<&'a [u8], CdrError> {
        let end = self.at.checked_add(n).ok_or(CdrError::Short { at: self.at, needed: n })?;
        let bytes = self.buf.get(self.at..end).ok_or(CdrError::Short { at: self.at, needed: n })?;
        self.at = end;
        Ok(bytes)
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        self.at = self.at.div_ceil(N) * N;
        Ok(self.slice(N)?.try_into().expect("N bytes"))
    }

    /// A `uint8`.
    pub fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.slice(1)?[0])
    }

    /// A `bool`.
    pub fn bool(&mut self) -> Result<bool, CdrError> {
        Ok(self.u8()? != 0)
    }

    /// An `int32`.
    pub fn i32(&mut self) -> Result<i32, CdrError> {
        Ok(i32::from_le_bytes(self.take::<4>()?))
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.take::<4>()?))
    }

    /// A `float32`.
    pub fn f32(&mut self) -> Result<f32, CdrError> {
        Ok(f32::from_le_bytes(self.take::<4>()?))
    }

    /// A `float64`.
    pub fn f64(&mut self) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.take::<8>()?))
    }

    /// A sequence's element count, refused when the payload cannot hold that many elements of
    /// at least `min_size` bytes (so a corrupt count allocates nothing).
    pub fn count(&mut self, min_size: usize) -> Result<usize, CdrError> {
        let n = self.u32()? as usize;
        let left = self.buf.len().saturating_sub(self.at);
        if n.saturating_mul(min_size.max(1)) > left {
            return Err(CdrError::Short { at: self.at, needed: n.saturating_mul(min_size.max(1)) });
        }
        Ok(n)
    }

    /// A `string`.
    pub fn string(&mut self) -> Result<String, CdrError> {
        let at = self.at;
        let n = self.count(1)?;
        let bytes = self.slice(n)?;
        match bytes.split_last() {
            Some((0, text)) => std::str::from_utf8(text).map(str::to_string).map_err(|_| CdrError::BadString(at)),
            _ => Err(CdrError::BadString(at)),
        }
    }

    /// A `float32[]`.
    pub fn f32_seq(&mut self) -> Result<Vec<f32>, CdrError> {
        let n = self.count(4)?;
        (0..n).map(|_| self.f32()).collect()
    }

    /// A `uint8[]`.
    pub fn bytes(&mut self) -> Result<Vec<u8>, CdrError> {
        let n = self.count(1)?;
        Ok(self.slice(n)?.to_vec())
    }

    /// Ends the read: an error unless the payload is used up (up to 3 bytes of padding may
    /// follow, as RTPS pads a payload to a multiple of four). Decoders end with it so that a
    /// payload of another type (a TwistStamped read as a Twist) is refused, not misread.
    pub fn finish(self) -> Result<(), CdrError> {
        match self.buf.len().saturating_sub(self.at) {
            0..=3 => Ok(()),
            extra => Err(CdrError::Trailing(extra)),
        }
    }

    /// A fixed-size `uint8[N]`.
    pub fn byte_array<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        Ok(self.slice(N)?.try_into().expect("N bytes"))
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
        w.u32(7).f64(-1.5).string("uav3").bool(true).f32_seq(&[1.0, 2.0]).bytes(&[9, 8]).byte_array(&[1, 2, 3]);
        let b = w.finish();
        let mut r = Reader::new(&b).expect("header");
        assert_eq!(r.u32(), Ok(7));
        assert_eq!(r.f64(), Ok(-1.5));
        assert_eq!(r.string().as_deref(), Ok("uav3"));
        assert_eq!(r.bool(), Ok(true));
        assert_eq!(r.f32_seq(), Ok(vec![1.0, 2.0]));
        assert_eq!(r.bytes(), Ok(vec![9, 8]));
        assert_eq!(r.byte_array::<3>(), Ok([1, 2, 3]));
        assert!(matches!(r.f64(), Err(CdrError::Short { .. })));
        assert_eq!(r.finish(), Ok(()));
        assert!(matches!(Reader::new(&[0, 0, 0, 0, 1]), Err(CdrError::Encapsulation(_))));
        let mut r = Reader::new(&b).expect("header");
        r.u32().expect("u32");
        assert!(matches!(r.finish(), Err(CdrError::Trailing(_))), "bytes left over");
    }

    #[test]
    fn a_corrupt_count_or_string_is_refused_without_allocating() {
        let mut w = Writer::new();
        w.u32(u32::MAX);
        let b = w.finish();
        assert!(matches!(Reader::new(&b).expect("header").f32_seq(), Err(CdrError::Short { .. })));
        let mut w = Writer::new();
        w.u32(2).u8(b'a').u8(b'b');
        let b = w.finish();
        assert_eq!(Reader::new(&b).expect("header").string(), Err(CdrError::BadString(0)), "no closing NUL");
    }
}
