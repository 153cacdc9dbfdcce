//! The first pass over a file, line by line: comments, the byte-order mark, line ends, how
//! many rows there are (so the columns are allocated once) and the first lines, from which the
//! format is detected. Nothing but a few lines is held: the whole text of a long record in
//! memory would double the peak (440 MB of text for 10⁷ samples beside their 240 MB of
//! columns).

use std::io::BufRead;

use super::super::RecordingError;

/// The UTF-8 byte-order mark some Windows tools write at the start of a file.
pub(super) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// How many content lines (header, units row, rows) the format is detected from.
const SAMPLE_LINES: usize = 64;

/// What the first pass found.
#[derive(Debug, Default)]
pub(super) struct Scan {
    /// The file started with a UTF-8 byte-order mark.
    pub bom: bool,
    /// Lines end in CR LF.
    pub crlf: bool,
    /// Comment lines without the leading `#`, in file order.
    pub comments: Vec<String>,
    /// 1-based numbers of the comment and blank lines, ascending: every other line is the
    /// header, the units row or a row, which gives each its line number in the second pass.
    pub skipped: Vec<usize>,
    /// Lines that are neither comments nor blank.
    pub content_lines: usize,
    /// Lines in all.
    pub total_lines: usize,
    /// The first content lines, with their line numbers.
    pub sample: Vec<(usize, String)>,
}

/// A line with nothing but spaces and separators: skipped like an empty line (spreadsheet
/// exports end with `;;;;` rows).
pub(super) fn is_blank(bytes: &[u8]) -> bool {
    bytes
        .iter()
        .all(|b| b.is_ascii_whitespace() || *b == b',' || *b == b';')
}

/// Reads every line of `input` once; `origin` names the source in errors.
pub(super) fn scan(input: &mut dyn BufRead, origin: &str) -> Result<Scan, RecordingError> {
    let err = |line: usize, message: String| RecordingError::Format {
        path: origin.to_string(),
        line,
        column: 0,
        message,
    };
    let utf8 = |line: usize, bytes: &[u8]| {
        String::from_utf8(bytes.to_vec())
            .map_err(|_| err(line, "not UTF-8 text: save the file as UTF-8".into()))
    };
    let mut s = Scan::default();
    let mut buf = Vec::with_capacity(256);
    loop {
        buf.clear();
        let n = input
            .read_until(b'\n', &mut buf)
            .map_err(|source| RecordingError::Io {
                path: origin.to_string(),
                source,
            })?;
        if n == 0 {
            break;
        }
        s.total_lines += 1;
        let line_no = s.total_lines;
        let mut line: &[u8] = &buf;
        if line_no == 1 {
            if line.starts_with(b"\xFF\xFE") || line.starts_with(b"\xFE\xFF") {
                return Err(err(
                    1,
                    "UTF-16 text (byte-order mark FF FE or FE FF): save the file as UTF-8".into(),
                ));
            }
            if let Some(rest) = line.strip_prefix(BOM) {
                s.bom = true;
                line = rest;
            }
        }
        line = line.strip_suffix(b"\n").unwrap_or(line);
        if let Some(l) = line.strip_suffix(b"\r") {
            s.crlf = true;
            line = l;
        }
        // The csv reader ends a row at a lone CR too; this pass would then count other lines
        // than it reads.
        if line.contains(&b'\r') {
            return Err(err(
                line_no,
                "a carriage return inside the line: line ends of CR alone are not read; \
                 convert them to LF or CR LF"
                    .into(),
            ));
        }
        if let Some(c) = line.strip_prefix(b"#") {
            s.comments.push(utf8(line_no, c)?);
            s.skipped.push(line_no);
            continue;
        }
        if is_blank(line) {
            s.skipped.push(line_no);
            continue;
        }
        s.content_lines += 1;
        if s.sample.len() < SAMPLE_LINES {
            s.sample.push((line_no, utf8(line_no, line)?));
        }
    }
    Ok(s)
}

/// The line numbers of the content lines, in order, from the scan's skipped lines.
#[derive(Debug)]
pub(super) struct LineNumbers<'a> {
    skipped: &'a [usize],
    next_skipped: usize,
    line: usize,
}

impl<'a> LineNumbers<'a> {
    pub(super) fn new(skipped: &'a [usize]) -> Self {
        LineNumbers {
            skipped,
            next_skipped: 0,
            line: 0,
        }
    }

    /// The line number of the next content line.
    pub(super) fn next_line(&mut self) -> usize {
        self.line += 1;
        while self.skipped.get(self.next_skipped) == Some(&self.line) {
            self.line += 1;
            self.next_skipped += 1;
        }
        self.line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_finds_comments_bom_crlf_and_line_numbers() {
        let text = b"\xEF\xBB\xBF# rig 4\r\nt;x\r\n\r\n1;2\r\n# mid\r\n;;\r\n3;4\r\n";
        let s = scan(&mut &text[..], "x").unwrap();
        assert!(s.bom && s.crlf);
        assert_eq!(s.comments, vec![" rig 4", " mid"]);
        assert_eq!(s.skipped, vec![1, 3, 5, 6]);
        assert_eq!((s.content_lines, s.total_lines), (3, 7));
        let lines: Vec<usize> = s.sample.iter().map(|(l, _)| *l).collect();
        assert_eq!(lines, vec![2, 4, 7]);
        let mut n = LineNumbers::new(&s.skipped);
        assert_eq!([n.next_line(), n.next_line(), n.next_line()], [2, 4, 7]);
    }

    #[test]
    fn scan_refuses_utf16_and_lone_carriage_returns() {
        let e = scan(&mut &b"\xFF\xFEt\0"[..], "x").unwrap_err();
        assert!(e.to_string().contains("UTF-16"), "{e}");
        let e = scan(&mut &b"a,b\r1,2\r"[..], "x").unwrap_err();
        assert!(e.to_string().contains("x:1:0: a carriage return"), "{e}");
    }
}
