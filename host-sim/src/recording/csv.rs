//! The CSV dialect of recordings: tokenizer, header, column lookup, numbers.
//!
//! Syntax, as `recording-v1.md` states it, with the choices it leaves open:
//! - fields are separated by `,`; there is no quoting;
//! - ASCII whitespace around a field or a header name is ignored, so `\r\n`
//!   line ends and `1.0, 2.0` are accepted;
//! - a line whose first non-blank character is `#` is a comment, anywhere;
//! - blank lines (empty or whitespace only) are skipped, anywhere;
//! - the first other line is the header; header names must be non-empty and
//!   unique, and every data line must have exactly as many fields;
//! - numbers are what `f64::from_str` accepts, and must be finite.

use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind as IoKind};
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::error::{quoted, ErrorKind, RecordingError};

/// Byte-order mark that some spreadsheet tools put at the start of UTF-8 files.
const BOM: &str = "\u{feff}";

/// A CSV file being read line by line: its header, and the data lines still to
/// come. Only the current line is held in memory, so a file of any length reads
/// in memory bounded by its longest line.
pub(crate) struct CsvReader<R> {
    path: PathBuf,
    input: R,
    header: Vec<String>,
    header_line: usize,
    /// 1-based number of the line in `text`.
    line: usize,
    bytes: Vec<u8>,
    consumed: u64,
    text: String,
    fields: Vec<Range<usize>>,
}

/// One data line, split into as many fields as the header has columns.
pub(crate) struct Row<'c> {
    path: &'c Path,
    header: &'c [String],
    line: usize,
    text: &'c str,
    fields: &'c [Range<usize>],
}

/// Is this line a comment or blank, to be skipped?
fn is_skipped(line: &str) -> bool {
    let trimmed = line.trim_start();
    trimmed.is_empty() || trimmed.starts_with('#')
}

/// Splits a line into the byte ranges of its trimmed fields (`str::trim`: Unicode
/// whitespace). A field that starts and ends with an ASCII byte other than whitespace,
/// as a recording's numbers do, needs no trimming: only the others go through
/// `str::trim` (the split and trim were 7 % of a 600 s `calibrate`, docs/performance.md).
fn split_fields(line: &str, out: &mut Vec<Range<usize>>) {
    out.clear();
    let bytes = line.as_bytes();
    let mut start = 0;
    loop {
        let end = bytes
            .get(start..)
            .and_then(|rest| rest.iter().position(|&b| b == b','))
            .map_or(line.len(), |k| start + k);
        out.push(trimmed(line, start..end));
        if end == line.len() {
            return;
        }
        start = end + 1;
    }
}

/// The range `field` of `line` without the whitespace `str::trim` removes.
fn trimmed(line: &str, field: Range<usize>) -> Range<usize> {
    let bytes = line.as_bytes();
    let plain = |b: Option<&u8>| b.is_some_and(|&b| b.is_ascii() && !char::from(b).is_whitespace());
    let last = field.end.checked_sub(1).and_then(|k| bytes.get(k));
    if field.start < field.end && plain(bytes.get(field.start)) && plain(last) {
        return field;
    }
    let text = line.get(field.clone()).unwrap_or_default();
    let lead = text.len() - text.trim_start().len();
    field.start + lead..field.start + lead + text.trim().len()
}

/// Opens `path` for reading; a missing file is [`ErrorKind::MissingFile`].
pub(crate) fn open(path: &Path) -> Result<BufReader<File>, RecordingError> {
    File::open(path).map(BufReader::new).map_err(|e| {
        let kind = if e.kind() == IoKind::NotFound {
            ErrorKind::MissingFile
        } else {
            ErrorKind::Io(e)
        };
        RecordingError::new(path, kind)
    })
}

impl<R: BufRead> CsvReader<R> {
    /// Finds and checks the header of `input`, read from `path`.
    pub(crate) fn new(path: &Path, input: R) -> Result<Self, RecordingError> {
        let mut csv = Self {
            path: path.to_path_buf(),
            input,
            header: Vec::new(),
            header_line: 0,
            line: 0,
            bytes: Vec::new(),
            consumed: 0,
            text: String::new(),
            fields: Vec::new(),
        };
        if !csv.next_line()? {
            return Err(RecordingError::new(path, ErrorKind::EmptyFile));
        }
        split_fields(&csv.text, &mut csv.fields);
        csv.header = csv
            .fields
            .iter()
            .map(|r| csv.text.get(r.clone()).unwrap_or_default().to_owned())
            .collect();
        csv.header_line = csv.line;
        csv.check_header()?;
        Ok(csv)
    }

    /// Reads the next line that is neither blank nor a comment into `text`
    /// (without its line end); `false` at the end of the file. Bytes that are
    /// not UTF-8 are [`ErrorKind::NotUtf8`] at their line.
    fn next_line(&mut self) -> Result<bool, RecordingError> {
        loop {
            self.bytes.clear();
            let n = self
                .input
                .read_until(b'\n', &mut self.bytes)
                .map_err(|e| RecordingError::new(&self.path, ErrorKind::Io(e)))?;
            if n == 0 {
                return Ok(false);
            }
            self.consumed += n as u64;
            self.line += 1;
            let bytes = std::mem::take(&mut self.bytes);
            let text = String::from_utf8(bytes).map_err(|_| {
                RecordingError::new(&self.path, ErrorKind::NotUtf8).at_line(self.line)
            })?;
            self.text = text;
            if self.line == 1 && self.text.starts_with(BOM) {
                self.text.drain(..BOM.len());
            }
            if self.text.ends_with('\n') {
                self.text.pop();
                if self.text.ends_with('\r') {
                    self.text.pop();
                }
            }
            if !is_skipped(&self.text) {
                return Ok(true);
            }
            self.bytes = std::mem::take(&mut self.text).into_bytes();
        }
    }

    /// Header names must be non-empty and unique.
    fn check_header(&self) -> Result<(), RecordingError> {
        for (i, name) in self.header.iter().enumerate() {
            if name.is_empty() {
                return Err(self
                    .header_error(ErrorKind::EmptyColumnName)
                    .at_column(i, name));
            }
            if let Some(first) = self.header.iter().take(i).position(|n| n == name) {
                let kind = ErrorKind::DuplicateColumn { first: first + 1 };
                return Err(self.header_error(kind).at_column(i, name));
            }
        }
        Ok(())
    }

    /// Bytes of the file read so far.
    pub(crate) fn bytes_read(&self) -> u64 {
        self.consumed
    }

    /// The file being read.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// The header names, in file order.
    pub(crate) fn names(&self) -> &[String] {
        &self.header
    }

    /// The 0-based index of column `name`, if the header has it.
    pub(crate) fn find(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|n| n == name)
    }

    /// The 0-based indices of all of `names`; an error names the first one missing.
    pub(crate) fn require<const N: usize>(
        &self,
        names: [&str; N],
    ) -> Result<[usize; N], RecordingError> {
        let mut out = [0; N];
        for (slot, name) in out.iter_mut().zip(names) {
            *slot = self.find(name).ok_or_else(|| {
                self.header_error(ErrorKind::MissingColumn {
                    name: name.to_owned(),
                })
            })?;
        }
        Ok(out)
    }

    /// An error located at the header line.
    pub(crate) fn header_error(&self, kind: ErrorKind) -> RecordingError {
        RecordingError::new(&self.path, kind).at_line(self.header_line)
    }

    /// The next data line, skipping comments and blank lines; `None` at the end.
    pub(crate) fn next_row(&mut self) -> Option<Result<Row<'_>, RecordingError>> {
        match self.next_line() {
            Ok(true) => {}
            Ok(false) => return None,
            Err(e) => return Some(Err(e)),
        }
        split_fields(&self.text, &mut self.fields);
        if self.fields.len() != self.header.len() {
            let kind = ErrorKind::ColumnCount {
                expected: self.header.len(),
                found: self.fields.len(),
            };
            return Some(Err(RecordingError::new(&self.path, kind).at_line(self.line)));
        }
        Some(Ok(Row {
            path: &self.path,
            header: &self.header,
            line: self.line,
            text: &self.text,
            fields: &self.fields,
        }))
    }
}

impl Row<'_> {
    /// Its 1-based line number in the file.
    pub(crate) fn line(&self) -> usize {
        self.line
    }

    /// An error located at this line and the 0-based column `col`.
    pub(crate) fn error(&self, col: usize, kind: ErrorKind) -> RecordingError {
        let name = self.header.get(col).map_or("", String::as_str);
        RecordingError::new(self.path, kind)
            .at_line(self.line)
            .at_column(col, name)
    }

    /// The finite number in 0-based column `col`.
    pub(crate) fn number(&self, col: usize) -> Result<f64, RecordingError> {
        let text = self
            .fields
            .get(col)
            .and_then(|r| self.text.get(r.clone()))
            .unwrap_or_default();
        let value: f64 = text
            .parse()
            .map_err(|_| self.error(col, ErrorKind::NotANumber { text: quoted(text) }))?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.error(col, ErrorKind::NonFinite { text: quoted(text) }))
        }
    }

    /// The finite numbers in the 0-based columns `cols`, in that order.
    pub(crate) fn numbers<const N: usize>(
        &self,
        cols: &[usize; N],
    ) -> Result<[f64; N], RecordingError> {
        let mut out = [0.0; N];
        for (slot, &col) in out.iter_mut().zip(cols) {
            *slot = self.number(col)?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The split as `str::split` and `str::trim` give it, field by field.
    fn split_by_str(line: &str) -> Vec<Range<usize>> {
        let mut out = Vec::new();
        let mut start = 0;
        for field in line.split(',') {
            let lead = field.len() - field.trim_start().len();
            out.push(start + lead..start + lead + field.trim().len());
            start += field.len() + 1;
        }
        out
    }

    /// The split gives `str::split` and `str::trim`'s ranges on random lines of numbers,
    /// commas, ASCII whitespace (the vertical tab and form feed too), Unicode whitespace
    /// (no-break and em spaces) and multi-byte letters, empty fields and empty lines.
    #[test]
    fn split_fields_trims_as_str_trim_does() {
        let alphabet = [
            ",", ",", "1", "2.5e-3", "-", " ", "\t", "\u{b}", "\u{c}", "\r", "\u{a0}", "\u{2003}",
            "é", "x", "#",
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut out = Vec::new();
        for _ in 0..100_000 {
            let len = rng.gen_range(0..12);
            let line: String = (0..len)
                .map(|_| alphabet[rng.gen_range(0..alphabet.len())])
                .collect();
            split_fields(&line, &mut out);
            assert_eq!(out, split_by_str(&line), "{line:?}");
        }
    }
}
