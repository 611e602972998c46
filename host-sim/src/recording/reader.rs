//! Reading a recording folder into memory, checking it against the contract.

use std::path::Path;

use super::csv::CsvText;
use super::error::{ErrorKind, RecordingError};
use super::layout::{
    imu_from_row, master_from_row, MASTER_COLUMNS, MASTER_RATE_COLUMNS, SLAVE_INCREMENT_COLUMNS,
    SLAVE_RATE_COLUMNS, TIME_COLUMN,
};
use super::rules::{self, TimeOrder};
use super::text::read_text;
use super::{
    meta, ImuOutput, ImuSample, MasterMsg, Recording, Truth, MASTER_FILE, META_FILE, SLAVE_FILE,
    TRUTH_FILE,
};

/// Reads the recording in folder `dir` (format version 1).
///
/// `truth.csv` is read if present. Slave rates are converted to increments
/// with `dt = t - t_prev`. Any departure from the contract is an error that
/// names the file, line, column or key; nothing is guessed or dropped.
pub fn read_recording(dir: &Path) -> Result<Recording, RecordingError> {
    let meta_path = dir.join(META_FILE);
    let meta = meta::parse(&meta_path, &read_text(&meta_path)?)?;
    let slave_path = dir.join(SLAVE_FILE);
    let (imu_t0, imu) = parse_slave(&slave_path, &read_text(&slave_path)?, meta.slave_output)?;
    let master_path = dir.join(MASTER_FILE);
    let master = parse_master(&master_path, &read_text(&master_path)?)?;
    let truth_path = dir.join(TRUTH_FILE);
    let truth = match read_text(&truth_path) {
        Ok(text) => Some(parse_truth(&truth_path, &text)?),
        Err(e) if matches!(e.kind(), ErrorKind::MissingFile) => None,
        Err(e) => return Err(e),
    };
    Ok(Recording {
        meta,
        imu_t0,
        imu,
        master,
        truth,
    })
}

/// Parses `slave_imu.csv`: the clock-starting time and the samples as increments.
///
/// The first line's values are checked like any other (a malformed line is an
/// error wherever it is), then dropped: only its time is kept.
pub(crate) fn parse_slave(
    path: &Path,
    text: &str,
    output: ImuOutput,
) -> Result<(f64, Vec<ImuSample>), RecordingError> {
    let mut csv = CsvText::parse(path, text)?;
    let cols = csv.require(match output {
        ImuOutput::Increments => SLAVE_INCREMENT_COLUMNS,
        ImuOutput::Rates => SLAVE_RATE_COLUMNS,
    })?;
    let [t_col, ..] = cols;
    let mut order = TimeOrder::default();
    let mut t0 = None;
    let mut prev = None;
    let mut imu = Vec::new();
    while let Some(row) = csv.next_row() {
        let row = row?;
        let mut v = row.numbers(&cols)?;
        let [t, ..] = v;
        order.next(t).map_err(|kind| row.error(t_col, kind))?;
        match prev {
            None => t0 = Some(t),
            Some(t_prev) => {
                if output == ImuOutput::Rates {
                    let dt = t - t_prev;
                    for (x, &col) in v.iter_mut().zip(&cols).skip(1) {
                        *x = rules::finite(*x * dt).map_err(|kind| row.error(col, kind))?;
                    }
                }
                imu.push(imu_from_row(v));
            }
        }
        prev = Some(t);
    }
    match t0 {
        Some(t0) if !imu.is_empty() => Ok((t0, imu)),
        _ => Err(RecordingError::new(
            path,
            ErrorKind::NoSamples {
                needed: "a line that starts the clock and at least one sample after it",
            },
        )),
    }
}

/// The column indices of `wx,wy,wz` if the header has all three, `None` if
/// it has none; an error naming the first missing one otherwise.
fn master_rate_columns(csv: &CsvText<'_>) -> Result<Option<[usize; 3]>, RecordingError> {
    let found = MASTER_RATE_COLUMNS.map(|name| csv.find(name));
    if found.iter().all(Option::is_none) {
        return Ok(None);
    }
    let mut out = [0; 3];
    for ((slot, index), name) in out.iter_mut().zip(found).zip(MASTER_RATE_COLUMNS) {
        *slot = index.ok_or_else(|| {
            csv.header_error(ErrorKind::IncompleteMasterRate {
                missing: name.to_owned(),
            })
        })?;
    }
    Ok(Some(out))
}

/// Parses `master.csv`.
pub(crate) fn parse_master(path: &Path, text: &str) -> Result<Vec<MasterMsg>, RecordingError> {
    let mut csv = CsvText::parse(path, text)?;
    let cols = csv.require(MASTER_COLUMNS)?;
    let rate_cols = master_rate_columns(&csv)?;
    let [t_col, qw_col, _, _, _, _, _, _, lat_col, _, _] = cols;
    let mut order = TimeOrder::default();
    let mut master = Vec::new();
    while let Some(row) = csv.next_row() {
        let row = row?;
        let v = row.numbers(&cols)?;
        let [t, qw, qx, qy, qz, _, _, _, lat, _, _] = v;
        order.next(t).map_err(|kind| row.error(t_col, kind))?;
        rules::unit_quaternion([qw, qx, qy, qz]).map_err(|kind| row.error(qw_col, kind))?;
        rules::latitude(lat).map_err(|kind| row.error(lat_col, kind))?;
        let rate = rate_cols.map(|c| row.numbers(&c)).transpose()?;
        master.push(master_from_row(v, rate));
    }
    if master.is_empty() {
        return Err(RecordingError::new(
            path,
            ErrorKind::NoSamples {
                needed: "at least one message",
            },
        ));
    }
    Ok(master)
}

/// Parses `truth.csv`, keeping every column besides `t` in file order.
pub(crate) fn parse_truth(path: &Path, text: &str) -> Result<Truth, RecordingError> {
    let mut csv = CsvText::parse(path, text)?;
    let [t_col] = csv.require([TIME_COLUMN])?;
    let (data_cols, names): (Vec<usize>, Vec<String>) = csv
        .names()
        .iter()
        .enumerate()
        .filter(|(_, name)| **name != TIME_COLUMN)
        .map(|(i, name)| (i, (*name).to_owned()))
        .unzip();
    let mut t = Vec::new();
    let mut columns = vec![Vec::new(); names.len()];
    let mut order = TimeOrder::default();
    while let Some(row) = csv.next_row() {
        let row = row?;
        let time = row.number(t_col)?;
        order.next(time).map_err(|kind| row.error(t_col, kind))?;
        t.push(time);
        for (column, &col) in columns.iter_mut().zip(&data_cols) {
            column.push(row.number(col)?);
        }
    }
    if t.is_empty() {
        return Err(RecordingError::new(
            path,
            ErrorKind::NoSamples {
                needed: "at least one line of values",
            },
        ));
    }
    Ok(Truth { names, t, columns })
}
