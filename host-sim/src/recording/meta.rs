//! `recording.toml`: what the session was (site, lever arm, nominal rates).
//!
//! Parsed through `toml::Spanned` so that an error about a key's value names
//! both the key and its line. Unknown keys and sections are ignored. Numbers
//! may be written as TOML floats or integers.

use std::ops::Range;
use std::path::Path;

use serde::Deserialize;
use toml::{Spanned, Value};

use super::error::{excerpt, ErrorKind, RecordingError};
use super::text::line_of_offset;
use super::{rules, ImuOutput, RecordingMeta, Site};

/// The fixed value of the `format` key.
const FORMAT: &str = "slave-ins-recording";

/// The only `version` this code reads and writes.
const VERSION: i64 = 1;

/// A key's value with its place in the file, if the key is present.
type Key = Option<Spanned<Value>>;

/// The document as written, before any check.
#[derive(Deserialize)]
struct RawMeta {
    format: Key,
    version: Key,
    #[serde(default)]
    site: RawSite,
    #[serde(default)]
    lever_arm: RawLeverArm,
    #[serde(default)]
    slave_imu: RawSlave,
    #[serde(default)]
    master: RawMaster,
    #[serde(default)]
    notes: RawNotes,
}

/// `[site]`.
#[derive(Deserialize, Default)]
#[serde(expecting = "a table [site]")]
struct RawSite {
    lat_deg: Key,
    lon_deg: Key,
    height_m: Key,
}

/// `[lever_arm]`.
#[derive(Deserialize, Default)]
#[serde(expecting = "a table [lever_arm]")]
struct RawLeverArm {
    r0_m: Key,
}

/// `[slave_imu]`.
#[derive(Deserialize, Default)]
#[serde(expecting = "a table [slave_imu]")]
struct RawSlave {
    rate_hz: Key,
    output: Key,
}

/// `[master]`.
#[derive(Deserialize, Default)]
#[serde(expecting = "a table [master]")]
struct RawMaster {
    rate_hz: Key,
}

/// `[notes]`.
#[derive(Deserialize, Default)]
#[serde(expecting = "a table [notes]")]
struct RawNotes {
    text: Key,
}

/// Parses the text of `recording.toml` read from `path`.
pub(crate) fn parse(path: &Path, text: &str) -> Result<RecordingMeta, RecordingError> {
    let doc = Doc { path, text };
    let raw: RawMeta = toml::from_str(text).map_err(|e| {
        let message = e.message().trim().replace('\n', "; ");
        let err = RecordingError::new(path, ErrorKind::Toml(message));
        match e.span() {
            Some(span) => err.at_line(line_of_offset(text.as_bytes(), span.start)),
            None => err,
        }
    })?;
    doc.format(&raw.format)?;
    doc.version(&raw.version)?;
    let site = Site {
        lat_deg: doc.check("site.lat_deg", &raw.site.lat_deg, rules::latitude)?,
        lon_deg: doc.number("site.lon_deg", &raw.site.lon_deg)?,
        height_m: doc.number("site.height_m", &raw.site.height_m)?,
    };
    Ok(RecordingMeta {
        site,
        lever_arm_m: doc.vec3("lever_arm.r0_m", &raw.lever_arm.r0_m)?,
        slave_rate_hz: doc.check("slave_imu.rate_hz", &raw.slave_imu.rate_hz, rules::rate)?,
        slave_output: doc.output("slave_imu.output", &raw.slave_imu.output)?,
        master_rate_hz: doc.check("master.rate_hz", &raw.master.rate_hz, rules::rate)?,
        notes: doc.notes("notes.text", &raw.notes.text)?,
    })
}

/// The text of `recording.toml` for `meta`, declaring `output = "increments"`
/// because the writer always writes increments.
pub(crate) fn render(meta: &RecordingMeta) -> String {
    let f = |x: f64| Value::Float(x).to_string();
    let [x, y, z] = meta.lever_arm_m;
    let mut out = format!(
        "format = \"{FORMAT}\"\nversion = {VERSION}\n\n\
         [site]\nlat_deg = {}\nlon_deg = {}\nheight_m = {}\n\n\
         [lever_arm]\nr0_m = [{}, {}, {}]\n\n\
         [slave_imu]\nrate_hz = {}\noutput = \"increments\"\n\n\
         [master]\nrate_hz = {}\n",
        f(meta.site.lat_deg),
        f(meta.site.lon_deg),
        f(meta.site.height_m),
        f(x),
        f(y),
        f(z),
        f(meta.slave_rate_hz),
        f(meta.master_rate_hz),
    );
    if let Some(text) = &meta.notes {
        out.push_str("\n[notes]\ntext = ");
        out.push_str(&Value::String(text.clone()).to_string());
        out.push('\n');
    }
    out
}

/// The number a TOML value holds. Integers count: people write `rate_hz = 200`.
fn toml_number(value: &Value) -> Option<f64> {
    match value {
        Value::Float(x) => Some(*x),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// The file being parsed, for locating errors.
struct Doc<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Doc<'_> {
    /// An error about `key`, at the line of `span` if known.
    fn error(&self, key: &str, span: Option<Range<usize>>, kind: ErrorKind) -> RecordingError {
        let err = RecordingError::new(self.path, kind);
        let err = match span {
            Some(span) => err.at_line(line_of_offset(self.text.as_bytes(), span.start)),
            None => err,
        };
        err.at_key(key)
    }

    /// The value of a required key.
    fn required<'v>(
        &self,
        key: &str,
        value: &'v Key,
    ) -> Result<&'v Spanned<Value>, RecordingError> {
        value
            .as_ref()
            .ok_or_else(|| self.error(key, None, ErrorKind::MissingKey))
    }

    /// An error saying the key's value is not of the expected shape.
    fn invalid(&self, key: &str, value: &Spanned<Value>, expected: &'static str) -> RecordingError {
        let found = excerpt(&value.get_ref().to_string());
        self.error(
            key,
            Some(value.span()),
            ErrorKind::InvalidValue { expected, found },
        )
    }

    /// `format` must be the fixed string.
    fn format(&self, value: &Key) -> Result<(), RecordingError> {
        let value = self.required("format", value)?;
        match value.get_ref() {
            Value::String(s) if s == FORMAT => Ok(()),
            other => Err(self.error(
                "format",
                Some(value.span()),
                ErrorKind::WrongFormat {
                    found: excerpt(&other.to_string()),
                },
            )),
        }
    }

    /// `version` must be the integer 1.
    fn version(&self, value: &Key) -> Result<(), RecordingError> {
        let value = self.required("version", value)?;
        match value.get_ref() {
            Value::Integer(VERSION) => Ok(()),
            other => Err(self.error(
                "version",
                Some(value.span()),
                ErrorKind::WrongVersion {
                    found: excerpt(&other.to_string()),
                },
            )),
        }
    }

    /// A finite number (TOML float or integer).
    fn number(&self, key: &str, value: &Key) -> Result<f64, RecordingError> {
        let value = self.required(key, value)?;
        self.as_number(key, value)
    }

    /// A finite number that also satisfies `rule`.
    fn check(
        &self,
        key: &str,
        value: &Key,
        rule: fn(f64) -> Result<f64, ErrorKind>,
    ) -> Result<f64, RecordingError> {
        let spanned = self.required(key, value)?;
        let x = self.as_number(key, spanned)?;
        rule(x).map_err(|kind| self.error(key, Some(spanned.span()), kind))
    }

    /// The finite number held by a present key.
    fn as_number(&self, key: &str, value: &Spanned<Value>) -> Result<f64, RecordingError> {
        let x = toml_number(value.get_ref()).ok_or_else(|| self.invalid(key, value, "a number"))?;
        rules::finite(x).map_err(|kind| self.error(key, Some(value.span()), kind))
    }

    /// An array of exactly three finite numbers.
    fn vec3(&self, key: &str, value: &Key) -> Result<[f64; 3], RecordingError> {
        let spanned = self.required(key, value)?;
        let items = match spanned.get_ref() {
            Value::Array(items) if items.len() == 3 => items,
            _ => return Err(self.invalid(key, spanned, "an array of 3 numbers")),
        };
        let mut out = [0.0; 3];
        for (slot, item) in out.iter_mut().zip(items) {
            let x = toml_number(item)
                .ok_or_else(|| self.invalid(key, spanned, "an array of 3 numbers"))?;
            *slot = rules::finite(x).map_err(|kind| self.error(key, Some(spanned.span()), kind))?;
        }
        Ok(out)
    }

    /// `"increments"` or `"rates"`.
    fn output(&self, key: &str, value: &Key) -> Result<ImuOutput, RecordingError> {
        let value = self.required(key, value)?;
        match value.get_ref() {
            Value::String(s) if s == "increments" => Ok(ImuOutput::Increments),
            Value::String(s) if s == "rates" => Ok(ImuOutput::Rates),
            other => Err(self.error(
                key,
                Some(value.span()),
                ErrorKind::BadOutput {
                    found: excerpt(&other.to_string()),
                },
            )),
        }
    }

    /// The optional free text for people.
    fn notes(&self, key: &str, value: &Key) -> Result<Option<String>, RecordingError> {
        match value {
            None => Ok(None),
            Some(spanned) => match spanned.get_ref() {
                Value::String(s) => Ok(Some(s.clone())),
                _ => Err(self.invalid(key, spanned, "a string")),
            },
        }
    }
}
