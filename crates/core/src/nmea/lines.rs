//! A byte stream (TCP, serial) cut into lines, in bounded memory.

use super::MAX_LINE_BYTES;

/// Cuts a byte stream into lines of at most [`MAX_LINE_BYTES`]. A longer line is dropped up
/// to its end and reported once as [`Line::TooLong`]; the buffer never grows past the limit.
#[derive(Debug, Default)]
pub struct LineBuffer {
    buf: Vec<u8>,
    /// Inside an over-long line: drop bytes until the next `\n`.
    skipping: bool,
}

/// One item out of a [`LineBuffer`].
#[derive(Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// A complete line, without its `\n`.
    Complete(&'a [u8]),
    /// A line longer than [`MAX_LINE_BYTES`] was dropped.
    TooLong,
}

impl LineBuffer {
    /// An empty buffer (capacity [`MAX_LINE_BYTES`]).
    pub fn new() -> Self {
        Self {
            buf: Vec::with_capacity(MAX_LINE_BYTES),
            skipping: false,
        }
    }

    /// Feeds `bytes`, calling `f` on every line completed (and once per over-long line).
    pub fn push(&mut self, bytes: &[u8], mut f: impl FnMut(Line<'_>)) {
        for chunk in bytes.split_inclusive(|b| *b == b'\n') {
            let (body, ends) = match chunk.split_last() {
                Some((b'\n', body)) => (body, true),
                _ => (chunk, false),
            };
            if !self.skipping {
                if self.buf.len() + body.len() > MAX_LINE_BYTES {
                    self.buf.clear();
                    self.skipping = true;
                    f(Line::TooLong);
                } else {
                    self.buf.extend_from_slice(body);
                }
            }
            if ends {
                if !self.skipping {
                    f(Line::Complete(&self.buf));
                }
                self.buf.clear();
                self.skipping = false;
            }
        }
    }

    /// Bytes held (at most [`MAX_LINE_BYTES`]).
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    /// Whether no partial line is held.
    pub fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }

    /// The buffer's allocation [bytes] (stays at [`MAX_LINE_BYTES`]).
    pub fn capacity(&self) -> usize {
        self.buf.capacity()
    }

    /// Forgets a partial line (a reconnection).
    pub fn clear(&mut self) {
        self.buf.clear();
        self.skipping = false;
    }
}
