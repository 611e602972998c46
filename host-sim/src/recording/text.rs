//! Reading a recording file as text, with errors that say where the bytes went wrong.

use std::io::ErrorKind as IoKind;
use std::path::Path;

use super::error::{ErrorKind, RecordingError};

/// Byte-order mark that some spreadsheet tools put at the start of UTF-8 files.
const BOM: char = '\u{feff}';

/// Reads the whole file at `path` as UTF-8 text, without a leading byte-order mark.
///
/// A missing file is [`ErrorKind::MissingFile`]; bytes that are not UTF-8 are
/// [`ErrorKind::NotUtf8`] at the line of the first bad byte.
pub(crate) fn read_text(path: &Path) -> Result<String, RecordingError> {
    let bytes = std::fs::read(path).map_err(|e| {
        let kind = if e.kind() == IoKind::NotFound {
            ErrorKind::MissingFile
        } else {
            ErrorKind::Io(e)
        };
        RecordingError::new(path, kind)
    })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = line_of_offset(e.as_bytes(), valid);
        RecordingError::new(path, ErrorKind::NotUtf8).at_line(line)
    })?;
    Ok(match text.strip_prefix(BOM) {
        Some(rest) => rest.to_owned(),
        None => text,
    })
}

/// 1-based line number of byte `offset` in `bytes` (lines end with `\n`).
pub(crate) fn line_of_offset(bytes: &[u8], offset: usize) -> usize {
    let end = offset.min(bytes.len());
    bytes.iter().take(end).filter(|&&b| b == b'\n').count() + 1
}
