//! The byte stream under a reader: the file itself, or its gzip
//! decompression when it starts with the gzip magic bytes.

use std::io::{self, BufRead, BufReader, Read};

use flate2::bufread::GzDecoder;

/// The first two bytes of every gzip member (RFC 1952).
pub(crate) const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Below this many decompressed bytes the expansion ratio is not checked:
/// a small file of repetitive text may legitimately compress very well.
pub(crate) const EXPANSION_CHECK_AFTER_BYTES: u64 = 16 << 20;

/// Bytes after the last complete gzip member that do not start another
/// member.
#[derive(Debug, thiserror::Error)]
#[error("trailing bytes after the end of the gzip data")]
pub(crate) struct TrailingGarbage;

/// The gzip stream expands more than the limit allows.
#[derive(Debug, thiserror::Error)]
#[error("gzip data expands more than {limit}-fold")]
pub(crate) struct ExpansionExceeded {
    pub(crate) limit: u64,
}

/// A reader that gives back the bytes peeked from it before going on, and
/// counts what it handed out (the compressed size, under a decoder).
pub(crate) struct Prefixed<R> {
    head: [u8; 2],
    head_pos: usize,
    head_len: usize,
    inner: R,
    consumed: u64,
}

impl<R: Read> Read for Prefixed<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.head_pos < self.head_len {
            let n = (self.head_len - self.head_pos).min(buf.len());
            buf[..n].copy_from_slice(&self.head[self.head_pos..self.head_pos + n]);
            self.head_pos += n;
            self.consumed += n as u64;
            return Ok(n);
        }
        let n = self.inner.read(buf)?;
        self.consumed += n as u64;
        Ok(n)
    }
}

/// Concatenated gzip members, decoded one after the other. Unlike a
/// decoder that takes whatever follows a member as the next header, it
/// tells a cut-off member (`UnexpectedEof`) from bytes after the last
/// member that are not gzip at all ([`TrailingGarbage`]).
pub(crate) struct GzipMembers<R: Read> {
    /// `None` between members (and at the end).
    member: Option<GzDecoder<BufReader<Prefixed<R>>>>,
    /// The compressed stream between members.
    between: Option<BufReader<Prefixed<R>>>,
    /// Decompressed bytes produced so far.
    produced: u64,
    max_ratio: Option<u64>,
}

impl<R: Read> GzipMembers<R> {
    fn new(inner: Prefixed<R>, max_ratio: Option<u64>) -> Self {
        GzipMembers {
            member: Some(GzDecoder::new(BufReader::with_capacity(64 * 1024, inner))),
            between: None,
            produced: 0,
            max_ratio,
        }
    }

    fn compressed(&self) -> u64 {
        match (&self.member, &self.between) {
            (Some(m), _) => m.get_ref().get_ref().consumed,
            (None, Some(b)) => b.get_ref().consumed,
            (None, None) => 0,
        }
    }
}

impl<R: Read> Read for GzipMembers<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            if let Some(member) = &mut self.member {
                let n = member.read(buf)?;
                if n > 0 {
                    self.produced += n as u64;
                    if let Some(limit) = self.max_ratio {
                        if self.produced > EXPANSION_CHECK_AFTER_BYTES
                            && self.produced > limit.saturating_mul(self.compressed().max(1))
                        {
                            return Err(io::Error::new(
                                io::ErrorKind::InvalidData,
                                ExpansionExceeded { limit },
                            ));
                        }
                    }
                    return Ok(n);
                }
                // The member ended (its trailer checked): look at what follows.
                let done = self.member.take().expect("member present");
                self.between = Some(done.into_inner());
            }
            let Some(mut rest) = self.between.take() else {
                return Ok(0);
            };
            let head = rest.fill_buf()?;
            if head.is_empty() {
                return Ok(0);
            }
            let starts_member = if head.len() >= 2 {
                head[..2] == GZIP_MAGIC
            } else {
                // One byte left in the buffer: it is a member's start only
                // if it is the magic's first byte (the decoder then reads on).
                head[0] == GZIP_MAGIC[0]
            };
            if !starts_member {
                return Err(io::Error::new(io::ErrorKind::InvalidData, TrailingGarbage));
            }
            self.member = Some(GzDecoder::new(rest));
        }
    }
}

/// The decoded byte stream of a data file.
pub(crate) enum Source<R: Read> {
    Plain(Prefixed<R>),
    Gzip(Box<GzipMembers<R>>),
}

impl<R: Read> Source<R> {
    /// Peeks at the first bytes and wraps a gzip decoder around the stream
    /// if they are the gzip magic. `detect_gzip` is false for formats that
    /// are never compressed, whose first bytes are data. `max_ratio` bounds
    /// decompressed over compressed bytes (checked past
    /// [`EXPANSION_CHECK_AFTER_BYTES`]).
    pub(crate) fn new(mut inner: R, detect_gzip: bool, max_ratio: Option<u64>) -> io::Result<Self> {
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
            consumed: 0,
        };
        Ok(if head_len == 2 && head == GZIP_MAGIC {
            Source::Gzip(Box::new(GzipMembers::new(prefixed, max_ratio)))
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
        let source = Source::new(Trickle(data), true, None).expect("source");
        assert!(!source.is_gzip());
        assert_eq!(read_all(source), data);
    }

    #[test]
    fn gzip_is_detected_even_when_the_magic_arrives_one_byte_at_a_time() {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        io::Write::write_all(&mut enc, b"hello\n").expect("compress");
        let gz = enc.finish().expect("finish");
        let source = Source::new(Trickle(&gz), true, None).expect("source");
        assert!(source.is_gzip());
        assert_eq!(read_all(source), b"hello\n");
    }

    fn gzip(data: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        io::Write::write_all(&mut enc, data).expect("compress");
        enc.finish().expect("finish")
    }

    fn read_err<R: Read>(mut r: R) -> io::Error {
        let mut out = Vec::new();
        r.read_to_end(&mut out).expect_err("a read error")
    }

    #[test]
    fn members_are_concatenated_and_garbage_after_them_is_not_a_truncation() {
        let mut two = gzip(b"a\n");
        two.extend(gzip(b"b\n"));
        assert_eq!(
            read_all(Source::new(&two[..], true, None).unwrap()),
            b"a\nb\n"
        );
        for garbage in [&b"x"[..], b"\n\n", b"garbage after the data"] {
            let mut bytes = gzip(b"a\n");
            bytes.extend_from_slice(garbage);
            let e = read_err(Source::new(&bytes[..], true, None).unwrap());
            assert!(
                e.get_ref().is_some_and(|e| e.is::<TrailingGarbage>()),
                "{garbage:?}: {e}"
            );
        }
        let whole = gzip(b"a\n");
        let cut = &whole[..whole.len() - 3];
        let e = read_err(Source::new(cut, true, None).unwrap());
        assert_eq!(e.kind(), io::ErrorKind::UnexpectedEof, "{e}");
    }

    #[test]
    fn expansion_beyond_the_ratio_is_refused_after_the_grace_bytes() {
        let zeros = vec![b'#'; (EXPANSION_CHECK_AFTER_BYTES as usize) * 2];
        let gz = gzip(&zeros);
        let e = read_err(Source::new(&gz[..], true, Some(100)).unwrap());
        assert!(
            e.get_ref().is_some_and(|e| e.is::<ExpansionExceeded>()),
            "{e}"
        );
        // Within the ratio, the same stream reads whole.
        assert_eq!(
            read_all(Source::new(&gz[..], true, Some(100_000)).unwrap()).len(),
            zeros.len()
        );
    }

    #[test]
    fn short_and_undetected_streams_stay_plain() {
        assert_eq!(
            read_all(Source::new(&[0x1f_u8][..], true, None).expect("source")),
            [0x1f]
        );
        assert_eq!(
            read_all(Source::new(&[][..], true, None).expect("source")),
            b""
        );
        let raw = Source::new(&GZIP_MAGIC[..], false, None).expect("source");
        assert!(!raw.is_gzip());
        assert_eq!(read_all(raw), GZIP_MAGIC);
    }
}
