//! The one error type of recording I/O: where it went wrong and why.
//!
//! Every error carries the file's path and, where they apply, the 1-based line,
//! the 1-based column with its header name, and the TOML key, so that a person
//! can find and fix the offending spot in a text editor.

use std::fmt;
use std::path::{Path, PathBuf};

/// Longest excerpt of a field or value quoted in a message, in characters.
const EXCERPT_CHARS: usize = 40;

/// A column of a CSV file: its 1-based position in the header and its name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    /// 1-based position in the header line.
    pub index: usize,
    /// Name given in the header line.
    pub name: String,
}

/// Why a recording could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A required file does not exist.
    #[error("file not found")]
    MissingFile,
    /// The file exists but could not be read or written.
    #[error("i/o error: {0}")]
    Io(#[source] std::io::Error),
    /// The bytes are not UTF-8 text.
    #[error("not UTF-8 text")]
    NotUtf8,
    /// `recording.toml` is not valid TOML (or a section is not a table).
    #[error("unreadable TOML: {0}")]
    Toml(String),
    /// A required key of `recording.toml` is absent.
    #[error("missing required key")]
    MissingKey,
    /// A key of `recording.toml` has a value of the wrong type or shape.
    #[error("expected {expected}, found {found}")]
    InvalidValue {
        /// What the contract asks for.
        expected: &'static str,
        /// What the file holds, quoted.
        found: String,
    },
    /// `format` is not `"slave-ins-recording"`.
    #[error("wrong format {found}: expected \"slave-ins-recording\"")]
    WrongFormat {
        /// The value found, quoted.
        found: String,
    },
    /// `version` is not the integer 1.
    #[error("unsupported version {found}: this reader knows version 1 only")]
    WrongVersion {
        /// The value found.
        found: String,
    },
    /// `slave_imu.output` is neither `"increments"` nor `"rates"`.
    #[error("bad output {found}: expected \"increments\" or \"rates\"")]
    BadOutput {
        /// The value found, quoted.
        found: String,
    },
    /// A nominal rate is zero or negative.
    #[error("rate must be positive, found {value} Hz")]
    NonPositiveRate {
        /// The rate found.
        value: f64,
    },
    /// A value lies outside the range it can physically take (latitude).
    #[error("{value} is outside [{min}, {max}]")]
    OutOfRange {
        /// The value found.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// A CSV file holds no header line (only blank or comment lines, or nothing).
    #[error("empty file: no header line")]
    EmptyFile,
    /// A CSV file has a header but not enough data lines.
    #[error("no samples: {needed}")]
    NoSamples {
        /// What the file needs at least.
        needed: &'static str,
    },
    /// A header field is empty (for example a trailing comma).
    #[error("empty column name in the header")]
    EmptyColumnName,
    /// Two header fields carry the same name.
    #[error("duplicate column name (first at column {first})")]
    DuplicateColumn {
        /// 1-based column of the first occurrence.
        first: usize,
    },
    /// A required column is absent from the header.
    #[error("missing required column `{name}`")]
    MissingColumn {
        /// Name of the missing column.
        name: String,
    },
    /// Some but not all of the optional master rate columns `wx,wy,wz`.
    #[error("column `{missing}` is missing: the optional columns wx,wy,wz come all together or not at all")]
    IncompleteMasterRate {
        /// Name of the first missing column.
        missing: String,
    },
    /// When writing: some master messages carry a rate and some do not.
    #[error("this message has no angular rate but the first one has (or the reverse): wx,wy,wz must be given for all messages or none")]
    MixedMasterRate,
    /// A data line has a different number of fields than the header.
    #[error("{found} fields, but the header has {expected} columns")]
    ColumnCount {
        /// Number of header columns.
        expected: usize,
        /// Number of fields on this line.
        found: usize,
    },
    /// A field is not a number `f64::from_str` accepts.
    #[error("not a number: {text}")]
    NotANumber {
        /// The field, quoted (and shortened if long).
        text: String,
    },
    /// A number is infinite or NaN.
    #[error("non-finite value {text}")]
    NonFinite {
        /// The field or value, quoted (and shortened if long).
        text: String,
    },
    /// Time does not strictly increase from the previous line.
    #[error("time not strictly increasing: {t} s after {prev} s")]
    TimeNotIncreasing {
        /// Time of the previous line.
        prev: f64,
        /// Time of this line.
        t: f64,
    },
    /// The attitude quaternion's norm differs from 1 by more than 1e-6.
    #[error("non-unit quaternion: norm {norm} differs from 1 by more than 1e-6")]
    NonUnitQuaternion {
        /// Norm found.
        norm: f64,
    },
    /// When writing: a truth column name that the reader would not give back.
    #[error("invalid truth column name {name}: {reason}")]
    InvalidColumnName {
        /// The name, quoted.
        name: String,
        /// Why it cannot be written.
        reason: &'static str,
    },
    /// When writing: truth columns and names, or a column and the times, differ in length.
    #[error("{what}: found {found}, expected {expected}")]
    LengthMismatch {
        /// What was counted.
        what: &'static str,
        /// Length of the time column.
        expected: usize,
        /// Length of this column.
        found: usize,
    },
}

/// A recording file could not be read or written: which file, where, and why.
///
/// `Display` gives one line: `path, line L, column C (name), key K: reason`,
/// with the parts that do not apply left out. Boxed to keep `Result`s small.
#[derive(Debug)]
pub struct RecordingError(Box<Details>);

/// The contents of a [`RecordingError`].
#[derive(Debug)]
struct Details {
    path: PathBuf,
    line: Option<usize>,
    column: Option<Column>,
    key: Option<String>,
    kind: ErrorKind,
}

impl RecordingError {
    /// An error about the file at `path`, without a location inside it yet.
    pub(crate) fn new(path: &Path, kind: ErrorKind) -> Self {
        Self(Box::new(Details {
            path: path.to_path_buf(),
            line: None,
            column: None,
            key: None,
            kind,
        }))
    }

    /// Sets the 1-based line number.
    pub(crate) fn at_line(mut self, line: usize) -> Self {
        self.0.line = Some(line);
        self
    }

    /// Sets the column: its 0-based index in the header, and its name.
    pub(crate) fn at_column(mut self, index0: usize, name: &str) -> Self {
        self.0.column = Some(Column {
            index: index0 + 1,
            name: name.to_owned(),
        });
        self
    }

    /// Sets the dotted TOML key, e.g. `master.rate_hz`.
    pub(crate) fn at_key(mut self, key: &str) -> Self {
        self.0.key = Some(key.to_owned());
        self
    }

    /// Why it failed.
    pub fn kind(&self) -> &ErrorKind {
        &self.0.kind
    }

    /// The file concerned.
    pub fn path(&self) -> &Path {
        &self.0.path
    }

    /// The 1-based line, where one applies.
    pub fn line(&self) -> Option<usize> {
        self.0.line
    }

    /// The column, where one applies.
    pub fn column(&self) -> Option<&Column> {
        self.0.column.as_ref()
    }

    /// The dotted TOML key, where one applies.
    pub fn key(&self) -> Option<&str> {
        self.0.key.as_deref()
    }
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.0;
        write!(f, "{}", d.path.display())?;
        if let Some(line) = d.line {
            write!(f, ", line {line}")?;
        }
        if let Some(column) = &d.column {
            let name = column.name.escape_debug();
            write!(f, ", column {} ({name})", column.index)?;
        }
        if let Some(key) = &d.key {
            write!(f, ", key {key}")?;
        }
        write!(f, ": {}", d.kind)
    }
}

impl std::error::Error for RecordingError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.0.kind {
            ErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// `text` shortened to a readable length for a message.
pub(crate) fn excerpt(text: &str) -> String {
    let mut chars = text.chars();
    let head: String = chars.by_ref().take(EXCERPT_CHARS).collect();
    if chars.next().is_some() {
        format!("{head}...")
    } else {
        head
    }
}

/// A CSV field quoted for a message (control characters escaped), shortened.
pub(crate) fn quoted(text: &str) -> String {
    format!("{:?}", excerpt(text))
}
