//! The byte stream under a reader: the file itself, or its gzip
//! decompression when it starts with the gzip magic bytes.

use std::io::{self, Read};

use flate2::read::MultiGzDecoder;

/// The first two bytes of every gzip member (RFC 1952).
pub(crate) const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// A reader that gives back the bytes peeked from it before going on.
pub(crate) struct Prefixed<R> {
    head: [u8; 2],
    head_pos: usize,
    head_len: usize,
    inner: R,
}

impl<R: Read> Read for Prefixed<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.head_pos < self.head_len {
            let n = (self.head_len - self.head_pos).min(buf.len());
            buf[..n].copy_from_slice(&self.head[self.head_pos..self.head_pos + n]);
            self.head_pos += n;
            return Ok(n);
        }
        self.inner.read(buf)
    }
}

/// The decoded byte stream of a data file.
pub(crate) enum Source<R: Read> {
    Plain(Prefixed<R>),
    Gzip(MultiGzDecoder<Prefixed<R>>),
}

impl<R: Read> Source<R> {
    /// Peeks at the first bytes and wraps a gzip decoder around the stream
    /// if they are the gzip magic. `detect_gzip` is false for formats that
    /// are never compressed, whose first bytes are data.
    pub(crate) fn new(mut inner: R, detect_gzip: bool) -> io::Result<Self> {
        let mut head = [0u8; 2];
        let mut head_len = 0;
        if detect_gzip {
            // One read may return a single byte (pipes, sockets), so read
            // until both bytes are in or the stream ends.
            while head_len < head.len() {
                match inner.read(&mut head[head_len..]) {
                    Ok(0) => break,
                    Ok(n) => head_len += n,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(e),
                }
            }
        }
        let prefixed = Prefixed {
            head,
            head_pos: 0,
            head_len,
            inner,
        };
        Ok(if head_len == 2 && head == GZIP_MAGIC {
            Source::Gzip(MultiGzDecoder::new(prefixed))
        } else {
            Source::Plain(prefixed)
        })
    }

    pub(crate) fn is_gzip(&self) -> bool {
        matches!(self, Source::Gzip(_))
    }
}

impl<R: Read> Read for Source<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Source::Plain(r) => r.read(buf),
            Source::Gzip(r) => r.read(buf),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hands out one byte per read, as a slow pipe may.
    struct Trickle<'a>(&'a [u8]);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            if self.0.is_empty() || buf.is_empty() {
                return Ok(0);
            }
            buf[0] = self.0[0];
            self.0 = &self.0[1..];
            Ok(1)
        }
    }

    fn read_all<R: Read>(mut r: R) -> Vec<u8> {
        let mut out = Vec::new();
        r.read_to_end(&mut out).expect("read");
        out
    }

    #[test]
    fn plain_stream_is_returned_whole_including_peeked_bytes() {
        let data = b"t,dthx\n1,2\n";
        let source = Source::new(Trickle(data), true).expect("source");
        assert!(!source.is_gzip());
        assert_eq!(read_all(source), data);
    }

    #[test]
    fn gzip_is_detected_even_when_the_magic_arrives_one_byte_at_a_time() {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        io::Write::write_all(&mut enc, b"hello\n").expect("compress");
        let gz = enc.finish().expect("finish");
        let source = Source::new(Trickle(&gz), true).expect("source");
        assert!(source.is_gzip());
        assert_eq!(read_all(source), b"hello\n");
    }

    #[test]
    fn short_and_undetected_streams_stay_plain() {
        assert_eq!(
            read_all(Source::new(&[0x1f_u8][..], true).expect("source")),
            [0x1f]
        );
        assert_eq!(read_all(Source::new(&[][..], true).expect("source")), b"");
        let raw = Source::new(&GZIP_MAGIC[..], false).expect("source");
        assert!(!raw.is_gzip());
        assert_eq!(read_all(raw), GZIP_MAGIC);
    }
}
