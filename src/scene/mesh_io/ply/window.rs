//! A stream seen through a window of bounded size: the streamed parse of a
//! gzipped PLY reads the records the window holds, then keeps the record
//! cut off at its end (moved to the front) and reads on, so that no more
//! than the window is ever held of the inflated body.

use std::io::{ErrorKind, Read};

pub(super) struct Window<R> {
    reader: R,
    /// The bytes held, from offset `start` of the stream on.
    buf: Vec<u8>,
    start: usize,
    /// How many bytes a refill brings the window to, unless what it keeps
    /// fills that already (a record longer than the window).
    size: usize,
    /// Whether `buf` reaches the end of the stream.
    ended: bool,
}

impl<R: Read> Window<R> {
    /// The window of `size` bytes on `reader`, the stream from offset
    /// `start` on; empty until the first refill.
    pub(super) fn new(start: usize, reader: R, size: usize) -> Self {
        Window {
            reader,
            buf: Vec::new(),
            start,
            size: size.max(1),
            ended: false,
        }
    }

    /// The bytes held, from offset [`start`](Self::start) of the stream.
    pub(super) fn bytes(&self) -> &[u8] {
        &self.buf
    }

    pub(super) fn start(&self) -> usize {
        self.start
    }

    /// The offset after the last byte held.
    pub(super) fn end(&self) -> usize {
        self.start + self.buf.len()
    }

    /// Whether the bytes held reach the end of the stream.
    pub(super) fn at_end(&self) -> bool {
        self.ended
    }

    /// Drops the bytes before offset `keep` (held, or the end) and reads
    /// on: up to the window's size, or that much more than is kept when the
    /// kept bytes fill the window already.
    pub(super) fn refill(&mut self, keep: usize) -> std::io::Result<()> {
        debug_assert!((self.start..=self.end()).contains(&keep));
        self.buf.drain(..keep - self.start);
        self.start = keep;
        let kept = self.buf.len();
        let target = match kept < self.size {
            true => self.size,
            false => kept + self.size,
        };
        self.buf.resize(target, 0);
        let mut filled = kept;
        let read = loop {
            if filled == target {
                break Ok(());
            }
            match self.reader.read(&mut self.buf[filled..]) {
                Ok(0) => {
                    self.ended = true;
                    break Ok(());
                }
                Ok(n) => filled += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => break Err(e),
            }
        };
        self.buf.truncate(filled);
        read
    }

    /// The length of the whole stream, read to its end (and dropped).
    pub(super) fn total(&mut self) -> std::io::Result<usize> {
        while !self.ended {
            self.refill(self.end())?;
        }
        Ok(self.end())
    }
}

#[cfg(test)]
mod tests {
    use super::Window;

    /// Refills keep what is asked, grow past the size only for a record
    /// longer than the window, and count the whole stream.
    #[test]
    fn refills_keep_the_tail_and_count_the_stream() {
        let data: Vec<u8> = (0..100).collect();
        let mut w = Window::new(4, &data[4..], 8);
        assert_eq!((w.start(), w.bytes()), (4, &[][..]));
        w.refill(4).unwrap();
        assert_eq!(w.bytes(), &data[4..12]);
        w.refill(6).unwrap();
        assert_eq!((w.start(), w.bytes()), (6, &data[6..14]));
        // Nothing dropped, the window full: 8 more.
        w.refill(6).unwrap();
        assert_eq!(w.bytes(), &data[6..22]);
        w.refill(21).unwrap();
        assert_eq!(w.bytes(), &data[21..29]);
        assert!(!w.at_end());
        assert_eq!(w.total().unwrap(), 100);
        assert!(w.at_end() && w.end() == 100);
        assert_eq!(w.total().unwrap(), 100);
    }
}
