//! The verdict of a run: PASS, WARN or FAIL with the findings behind it, each with a
//! code, a message and the numbers it rests on (`docs/verdict.md` lists every code and
//! justifies its threshold). Every command that calibrates (`calibrate`, `replay`,
//! `montecarlo`, `diagnose`) prints its verdict last, writes it into its JSON output
//! (`verdict`), and exits non-zero on FAIL: a run is worth what its verdict is worth.
//!
//! The findings come from three places: the recording itself before any filtering
//! ([`input`], [`motion`]), the configuration the run used ([`model`]), and what the
//! filter did with the data ([`run`]).

pub mod ensemble;
pub mod input;
pub mod model;
pub mod motion;
pub mod run;

use crate::calib::config::CalibConfig;
use crate::calib::master_steps::without_steps;
use crate::calib::run::CalibResult;
use crate::learn::increments::increment_noise;
use crate::learn::Learned;
use input::Scan;
use serde::Serialize;
use serde_json::{Map, Value};
use std::path::Path;

/// How much a finding weighs on the verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Severity {
    /// Said for the record (which default was taken, what was not checked); the
    /// verdict stays PASS.
    Note,
    /// The result may be usable, but a reader must know this: the verdict is WARN.
    Warn,
    /// The result cannot be trusted: the verdict is FAIL and the command exits non-zero.
    Fail,
}

impl Severity {
    /// The word printed and written for it.
    pub fn word(self) -> &'static str {
        match self {
            Severity::Note => "NOTE",
            Severity::Warn => "WARN",
            Severity::Fail => "FAIL",
        }
    }
}

/// One finding: what was seen, where, and the numbers behind it (SI units, named).
#[derive(Clone, Debug, Serialize)]
pub struct Finding {
    /// Its weight.
    pub severity: Severity,
    /// A stable code (`docs/verdict.md`), e.g. `time_no_overlap`.
    pub code: &'static str,
    /// What it means, in a sentence a reader can act on.
    pub message: String,
    /// Where: a file and line, a key, a sample's time; empty when it concerns the run.
    #[serde(rename = "where", skip_serializing_if = "String::is_empty")]
    pub location: String,
    /// The numbers behind it, by name.
    pub numbers: Map<String, Value>,
}

impl Finding {
    /// A finding with no location and no numbers yet.
    pub fn new(severity: Severity, code: &'static str, message: impl Into<String>) -> Self {
        Self {
            severity,
            code,
            message: message.into(),
            location: String::new(),
            numbers: Map::new(),
        }
    }

    /// Sets where it was seen.
    pub fn at(mut self, location: impl Into<String>) -> Self {
        self.location = location.into();
        self
    }

    /// Adds a number behind it (non-finite values are written as null).
    pub fn num(mut self, name: &str, value: f64) -> Self {
        let v = serde_json::Number::from_f64(value).map_or(Value::Null, Value::Number);
        self.numbers.insert(name.to_string(), v);
        self
    }

    /// Adds any JSON value behind it (lists of times, channel names).
    pub fn val(mut self, name: &str, value: Value) -> Self {
        self.numbers.insert(name.to_string(), value);
        self
    }
}

/// The verdict level of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Level {
    /// No warning and no failure.
    Pass,
    /// At least one warning, no failure.
    Warn,
    /// At least one failure.
    Fail,
}

/// All the findings of a run.
#[derive(Clone, Debug, Default)]
pub struct Verdict {
    /// In the order they were found.
    pub findings: Vec<Finding>,
}

impl Verdict {
    /// Adds findings.
    pub fn extend(&mut self, more: impl IntoIterator<Item = Finding>) {
        self.findings.extend(more);
    }

    /// The level: the heaviest finding's.
    pub fn level(&self) -> Level {
        match self.findings.iter().map(|f| f.severity).max() {
            Some(Severity::Fail) => Level::Fail,
            Some(Severity::Warn) => Level::Warn,
            _ => Level::Pass,
        }
    }

    /// The codes of the findings at or above `severity`.
    pub fn codes(&self, severity: Severity) -> Vec<&'static str> {
        self.findings
            .iter()
            .filter(|f| f.severity >= severity)
            .map(|f| f.code)
            .collect()
    }

    /// The `verdict` object of a JSON output: level and findings, heaviest first.
    pub fn to_json(&self) -> Value {
        let mut sorted = self.findings.clone();
        sorted.sort_by_key(|f| std::cmp::Reverse(f.severity));
        serde_json::json!({ "level": self.level(), "findings": sorted })
    }

    /// Inserts `verdict` into a JSON document (an object).
    pub fn insert_into(&self, doc: &mut Value) {
        if let Some(obj) = doc.as_object_mut() {
            obj.insert("verdict".into(), self.to_json());
        }
    }

    /// The lines printed at the end of a command: the level, then each finding,
    /// heaviest first.
    pub fn lines(&self) -> Vec<String> {
        let mut sorted: Vec<&Finding> = self.findings.iter().collect();
        sorted.sort_by_key(|f| std::cmp::Reverse(f.severity));
        let word = match self.level() {
            Level::Pass => "PASS",
            Level::Warn => "WARN",
            Level::Fail => "FAIL",
        };
        let count = |s| self.findings.iter().filter(|f| f.severity == s).count();
        let mut out = vec![format!(
            "verdict: {word} ({} failure(s), {} warning(s), {} note(s))",
            count(Severity::Fail),
            count(Severity::Warn),
            count(Severity::Note)
        )];
        for f in sorted {
            let at = if f.location.is_empty() {
                String::new()
            } else {
                format!(" [{}]", f.location)
            };
            out.push(format!(
                "  {} {}: {}{at}",
                f.severity.word(),
                f.code,
                f.message
            ));
        }
        out
    }

    /// Prints the verdict (last on stdout) and turns FAIL into the command's error, so
    /// that the process exits non-zero after every output was written.
    pub fn conclude(&self) -> Result<(), String> {
        for l in self.lines() {
            println!("{l}");
        }
        if self.level() == Level::Fail {
            Err(format!(
                "verdict FAIL: {}",
                self.codes(Severity::Fail).join(", ")
            ))
        } else {
            Ok(())
        }
    }
}

/// The verdict of a calibration of a recording seen by `scan`: the recording's
/// plausibility and, on its first [`input::PREFIX_SAMPLES`] samples, its units and
/// clocks (the master with the steps the run took out of its attitude taken out);
/// where the model came from (and, for a model given rather than learned, its
/// IMU noise against the increments'); what the run did.
pub fn of_calibration(
    scan: &mut Scan,
    config_file: Option<&Path>,
    learned: Option<&Learned>,
    cfg: &CalibConfig,
    res: &CalibResult,
) -> Verdict {
    let mut v = Verdict::default();
    v.extend(scan.findings());
    // The master as the filter saw it: its attitude steps taken out (a step inside a
    // block of the clock check spoils that block's rotation).
    let steps = cfg.master_attitude_steps.as_deref();
    v.extend(motion::check(&without_steps(scan.prefix(), steps)));
    v.extend(model::origin(config_file, learned));
    if learned.is_none() {
        match increment_noise(scan.prefix(), input::PREFIX_SAMPLES) {
            Ok(inc) => v.extend(model::noise_fit(cfg, &inc)),
            Err(e) => v.extend([Finding::new(
                Severity::Note,
                "noise_unchecked",
                format!("the declared IMU noise was not compared with the increments: {e}"),
            )]),
        }
    }
    v.extend(run::check(scan, cfg, res));
    v
}

/// Significant digits for messages: `v` with 3 of them.
pub fn g3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_is_the_heaviest_finding() {
        let mut v = Verdict::default();
        assert_eq!(v.level(), Level::Pass);
        v.extend([Finding::new(Severity::Note, "a", "x")]);
        assert_eq!(v.level(), Level::Pass);
        v.extend([Finding::new(Severity::Warn, "b", "y")]);
        assert_eq!(v.level(), Level::Warn);
        v.extend([Finding::new(Severity::Fail, "c", "z").num("n", f64::NAN)]);
        assert_eq!(v.level(), Level::Fail);
        assert!(v.conclude().is_err());
        let j = v.to_json();
        assert_eq!(j["level"], "FAIL");
        assert_eq!(j["findings"][0]["code"], "c");
        assert!(j["findings"][0]["numbers"]["n"].is_null());
    }

    #[test]
    fn three_significant_digits() {
        assert_eq!(g3(1234.4), "1234");
        assert_eq!(g3(0.012345), "0.0123");
        assert_eq!(g3(1.5e-7), "1.50e-7");
    }
}
