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

use std::iter::Enumerate;
use std::path::Path;
use std::str::Lines;

use super::error::{quoted, ErrorKind, RecordingError};

/// A CSV file being read: its header, and the data lines still to come.
pub(crate) struct CsvText<'t> {
    path: &'t Path,
    header: Vec<&'t str>,
    header_line: usize,
    lines: Enumerate<Lines<'t>>,
    fields: Vec<&'t str>,
}

/// One data line, split into as many fields as the header has columns.
pub(crate) struct Row<'c, 't> {
    path: &'c Path,
    header: &'c [&'t str],
    line: usize,
    fields: &'c [&'t str],
}

/// Is this line a comment or blank, to be skipped?
fn is_skipped(line: &str) -> bool {
    let trimmed = line.trim_start();
    trimmed.is_empty() || trimmed.starts_with('#')
}

/// Splits a line into trimmed fields.
fn split_fields<'t>(line: &'t str, out: &mut Vec<&'t str>) {
    out.clear();
    out.extend(line.split(',').map(str::trim));
}

impl<'t> CsvText<'t> {
    /// Finds and checks the header of `text`, read from `path`.
    pub(crate) fn parse(path: &'t Path, text: &'t str) -> Result<Self, RecordingError> {
        let mut lines = text.lines().enumerate();
        let (index, header_text) = lines
            .by_ref()
            .find(|(_, line)| !is_skipped(line))
            .ok_or_else(|| RecordingError::new(path, ErrorKind::EmptyFile))?;
        let mut header = Vec::new();
        split_fields(header_text, &mut header);
        let csv = Self {
            path,
            header,
            header_line: index + 1,
            lines,
            fields: Vec::new(),
        };
        csv.check_header()?;
        Ok(csv)
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

    /// The header names, in file order.
    pub(crate) fn names(&self) -> &[&'t str] {
        &self.header
    }

    /// The 0-based index of column `name`, if the header has it.
    pub(crate) fn find(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|n| *n == name)
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
        RecordingError::new(self.path, kind).at_line(self.header_line)
    }

    /// The next data line, skipping comments and blank lines; `None` at the end.
    pub(crate) fn next_row(&mut self) -> Option<Result<Row<'_, 't>, RecordingError>> {
        let (index, line) = self.lines.by_ref().find(|(_, line)| !is_skipped(line))?;
        split_fields(line, &mut self.fields);
        let row = Row {
            path: self.path,
            header: &self.header,
            line: index + 1,
            fields: &self.fields,
        };
        if row.fields.len() == row.header.len() {
            Some(Ok(row))
        } else {
            let kind = ErrorKind::ColumnCount {
                expected: row.header.len(),
                found: row.fields.len(),
            };
            Some(Err(RecordingError::new(self.path, kind).at_line(row.line)))
        }
    }
}

impl Row<'_, '_> {
    /// An error located at this line and the 0-based column `col`.
    pub(crate) fn error(&self, col: usize, kind: ErrorKind) -> RecordingError {
        let name = self.header.get(col).copied().unwrap_or_default();
        RecordingError::new(self.path, kind)
            .at_line(self.line)
            .at_column(col, name)
    }

    /// The finite number in 0-based column `col`.
    pub(crate) fn number(&self, col: usize) -> Result<f64, RecordingError> {
        let text = self.fields.get(col).copied().unwrap_or_default();
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
