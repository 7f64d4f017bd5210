//! One bounded frame scanner for the binary log formats (UBX, RTCM 3): a frame starts with a
//! sync byte, its header tells its length, a checksum closes it. What a format differs in —
//! header size, sync byte, how the length is read, which checksum — is its [`Framing`].
//!
//! A header that is not one, or a frame whose checksum fails, costs one byte: the search
//! resumes one byte after its start, so a corrupted length cannot swallow good frames. Skipped
//! bytes, checksum failures and a frame cut by the end of the input are counted in
//! [`RawStats`]; memory is the buffer given, whatever the input's size.

use super::RawStats;
use std::io::Read;
use std::marker::PhantomData;

/// How one format frames its messages.
pub trait Framing {
    /// Bytes of header needed to know a frame's length.
    const HEADER: usize;
    /// Bytes handed to [`Self::frame_len`] when the input has them (at least `HEADER`): a
    /// format whose length is found by searching for a terminator (NMEA) looks further.
    const LOOKAHEAD: usize = Self::HEADER;
    /// Whether a frame may start with this byte (a short tail starting with it is a cut
    /// frame).
    fn is_sync(b: u8) -> bool;
    /// The whole frame's length (header, payload, checksum) from a header (`HEADER` to
    /// `LOOKAHEAD` bytes), or `None` when the bytes are not a header.
    fn frame_len(header: &[u8]) -> Option<usize>;
    /// Whether the checksum of a whole frame holds.
    fn check(frame: &[u8]) -> bool;
}

/// Streams the whole frames of format `F` out of a reader, in a bounded buffer.
pub struct FrameScanner<R: Read, F: Framing> {
    src: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
    format: PhantomData<F>,
}

impl<R: Read, F: Framing> FrameScanner<R, F> {
    /// A scanner of `src` with a buffer of `capacity` bytes (at least the longest frame).
    pub fn new(src: R, capacity: usize) -> Self {
        FrameScanner {
            src,
            buf: vec![0; capacity],
            start: 0,
            end: 0,
            eof: false,
            format: PhantomData,
        }
    }

    /// Make at least `n` bytes available from `start` unless the input ends; returns how many are.
    fn fill(&mut self, n: usize, stats: &mut RawStats) -> std::io::Result<usize> {
        while self.end - self.start < n && !self.eof {
            if self.start > 0 {
                self.buf.copy_within(self.start..self.end, 0);
                self.end -= self.start;
                self.start = 0;
            }
            let got = self.src.read(&mut self.buf[self.end..])?;
            if got == 0 {
                self.eof = true;
            }
            self.end += got;
            stats.bytes += got as u64;
        }
        Ok(self.end - self.start)
    }

    /// The next whole frame (header through checksum) whose checksum holds, or `None` at the
    /// end of the input.
    pub fn next_frame(&mut self, stats: &mut RawStats) -> std::io::Result<Option<&[u8]>> {
        loop {
            let avail = self.fill(F::HEADER, stats)?;
            if avail < F::HEADER {
                if avail > 0 {
                    if F::is_sync(self.buf[self.start]) {
                        stats.truncated_frames += 1;
                    }
                    stats.skipped_bytes += avail as u64;
                    self.start = self.end;
                }
                return Ok(None);
            }
            let look = self.fill(F::LOOKAHEAD, stats)?.min(F::LOOKAHEAD);
            let Some(len) = F::frame_len(&self.buf[self.start..self.start + look]) else {
                self.start += 1;
                stats.skipped_bytes += 1;
                continue;
            };
            let avail = self.fill(len, stats)?;
            if avail < len {
                stats.truncated_frames += 1;
                stats.skipped_bytes += avail as u64;
                self.start = self.end;
                return Ok(None);
            }
            let s = self.start;
            if !F::check(&self.buf[s..s + len]) {
                stats.checksum_failures += 1;
                stats.skipped_bytes += 1;
                self.start += 1;
                continue;
            }
            self.start += len;
            stats.frames += 1;
            return Ok(Some(&self.buf[s..s + len]));
        }
    }
}
