//! The sample stream written by the QEMU image: one text line per record, exact bit patterns.
//!
//! Lines, ASCII, lowercase hex, fields separated by one space, each ending in `\n`:
//!
//! * `B cccccccc`: begin; `c` = number of samples that will follow (u32).
//! * `S iiiiiiii tttttttt gggggggg rrrrrrrr xxxxxxxx ss`: one record; `i` = sample index
//!   (u32), then the IEEE-754 bit patterns (u32) of the input temperature (°C), the input gyro
//!   rate (°/h), the compensated rate (°/h) and the correction (°/h), then the status bits
//!   (u8, [`compensator_core::Status`]).
//! * `E cccccccc`: end; `c` = number of `S` lines written.
//!
//! The image writes these lines to the semihosting *stderr* stream, so they never interleave
//! with the binary defmt frames on stdout.

use crate::record::Record;

/// Bytes in one `S` line, newline included.
pub const RECORD_LINE_LEN: usize = 50;
/// Bytes in a `B` or `E` line, newline included.
pub const MARK_LINE_LEN: usize = 11;

/// Where finished bytes go (semihosting on the board, a `Vec` in tests).
pub trait ByteSink {
    /// Writes all of `bytes`; `Err(())` if the host did not take them.
    #[allow(clippy::result_unit_err)] // semihosting reports no reason
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), ()>;
}

fn hex(out: &mut [u8], value: u32) {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let n = out.len();
    for (i, b) in out.iter_mut().enumerate() {
        let shift = 4 * (n - 1 - i);
        *b = DIGITS[((value >> shift) & 0xf) as usize];
    }
}

/// The `S` line of one record.
pub fn record_line(r: &Record) -> [u8; RECORD_LINE_LEN] {
    let mut line = [b' '; RECORD_LINE_LEN];
    line[0] = b'S';
    let words = [
        r.index,
        r.temp_c.to_bits(),
        r.gyro_dph.to_bits(),
        r.out.rate_dph.to_bits(),
        r.out.correction_dph.to_bits(),
    ];
    for (k, w) in words.iter().enumerate() {
        let at = 2 + 9 * k;
        hex(&mut line[at..at + 8], *w);
    }
    hex(&mut line[47..49], u32::from(r.out.status.0));
    line[49] = b'\n';
    line
}

/// A `B` (begin) or `E` (end) line with a count.
pub fn mark_line(tag: u8, count: u32) -> [u8; MARK_LINE_LEN] {
    let mut line = [b' '; MARK_LINE_LEN];
    line[0] = tag;
    hex(&mut line[2..10], count);
    line[10] = b'\n';
    line
}

/// Collects lines and hands them to the sink in blocks, since every semihosting call is a trap
/// to the host.
pub struct LineWriter<W: ByteSink, const CAP: usize> {
    sink: W,
    buf: heapless::Vec<u8, CAP>,
    written: u32,
    failed: bool,
}

impl<W: ByteSink, const CAP: usize> LineWriter<W, CAP> {
    /// A writer that sends `count` records; writes the `B` line.
    pub fn begin(sink: W, count: u32) -> Self {
        let mut w = LineWriter {
            sink,
            buf: heapless::Vec::new(),
            written: 0,
            failed: false,
        };
        w.push(&mark_line(b'B', count));
        w
    }

    fn push(&mut self, line: &[u8]) {
        if self.buf.len() + line.len() > CAP {
            self.flush();
        }
        if self.buf.extend_from_slice(line).is_err() {
            // A line longer than the whole buffer: send it directly.
            self.failed |= self.sink.write_all(line).is_err();
        }
    }

    fn flush(&mut self) {
        if !self.buf.is_empty() {
            self.failed |= self.sink.write_all(&self.buf).is_err();
            self.buf.clear();
        }
    }

    /// Appends the `S` line of a record.
    pub fn record(&mut self, r: &Record) {
        self.push(&record_line(r));
        self.written = self.written.wrapping_add(1);
    }

    /// Writes the `E` line, flushes, and returns the sink and whether every write succeeded.
    pub fn end(mut self) -> (W, bool) {
        self.push(&mark_line(b'E', self.written));
        self.flush();
        (self.sink, !self.failed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use compensator_core::{Compensated, Status};

    impl ByteSink for std::vec::Vec<u8> {
        fn write_all(&mut self, bytes: &[u8]) -> Result<(), ()> {
            self.extend_from_slice(bytes);
            Ok(())
        }
    }

    fn record(index: u32) -> Record {
        Record {
            index,
            temp_c: 25.5,
            gyro_dph: f32::NAN,
            out: Compensated {
                rate_dph: -7.125,
                correction_dph: 0.0,
                status: Status::GYRO_FAULT | Status::WARMING_UP,
            },
            temp_error: None,
            rate_error: None,
        }
    }

    #[test]
    fn line_layout() {
        let line = record_line(&record(0x1234));
        let text = std::str::from_utf8(&line).unwrap();
        // Bit patterns from the IEEE-754 definition: 25.5 = 1.59375·2⁴, −7.125 = −1.78125·2².
        assert_eq!(text, "S 00001234 41cc0000 7fc00000 c0e40000 00000000 09\n");
        assert_eq!(
            std::str::from_utf8(&mark_line(b'E', 20_000)).unwrap(),
            "E 00004e20\n"
        );
    }

    #[test]
    fn writer_blocks_and_frames() {
        // A buffer of 3 lines' worth forces several flushes.
        let mut w: LineWriter<std::vec::Vec<u8>, 150> = LineWriter::begin(std::vec::Vec::new(), 7);
        for i in 0..7 {
            w.record(&record(i));
        }
        let (out, ok) = w.end();
        assert!(ok);
        let text = std::string::String::from_utf8(out).unwrap();
        let lines: std::vec::Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 9);
        assert_eq!(lines[0], "B 00000007");
        assert_eq!(lines[8], "E 00000007");
        assert!(lines[7].starts_with("S 00000006 "));
    }
}
