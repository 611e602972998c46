//! The writer's checks: a recording is written only if the reader would give
//! it back unchanged. Errors name the file and the line it would have had.

use std::path::Path;

use super::error::{quoted, ErrorKind, RecordingError};
use super::layout::{
    imu_to_row, master_to_row, MASTER_COLUMNS, MASTER_LAT, MASTER_QW, MASTER_RATE_COLUMNS,
    SLAVE_INCREMENT_COLUMNS, TIME_COLUMN,
};
use super::rules::{self, TimeOrder};
use super::{ImuSample, MasterMsg, Truth};

/// Every value of a row is finite; `first` is the 0-based column of `values[0]`.
fn finite_row(
    path: &Path,
    line: usize,
    first: usize,
    values: &[f64],
    names: &[&str],
) -> Result<(), RecordingError> {
    for (i, (&x, name)) in values.iter().zip(names).enumerate() {
        rules::finite(x).map_err(|kind| {
            RecordingError::new(path, kind)
                .at_line(line)
                .at_column(first + i, name)
        })?;
    }
    Ok(())
}

/// An error at `line` and 0-based column `col` named `name`.
fn at(path: &Path, line: usize, col: usize, name: &str, kind: ErrorKind) -> RecordingError {
    RecordingError::new(path, kind)
        .at_line(line)
        .at_column(col, name)
}

/// The slave samples as `slave_imu.csv` will hold them: line 2 at `t0`, then one per sample.
pub(crate) fn slave(path: &Path, t0: f64, imu: &[ImuSample]) -> Result<(), RecordingError> {
    if imu.is_empty() {
        let needed = "at least one sample after imu_t0";
        return Err(RecordingError::new(path, ErrorKind::NoSamples { needed }));
    }
    let mut order = TimeOrder::default();
    let first = [t0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let rows = std::iter::once(first).chain(imu.iter().map(imu_to_row));
    for (i, row) in rows.enumerate() {
        let line = i + 2;
        finite_row(path, line, 0, &row, &SLAVE_INCREMENT_COLUMNS)?;
        let [t, ..] = row;
        order
            .next(t)
            .map_err(|kind| at(path, line, 0, TIME_COLUMN, kind))?;
    }
    Ok(())
}

/// The master messages as `master.csv` will hold them.
pub(crate) fn master(path: &Path, master: &[MasterMsg]) -> Result<(), RecordingError> {
    let Some(first) = master.first() else {
        let needed = "at least one message";
        return Err(RecordingError::new(path, ErrorKind::NoSamples { needed }));
    };
    let has_rate = first.omega_ib_bm_radps.is_some();
    let mut order = TimeOrder::default();
    for (i, m) in master.iter().enumerate() {
        let line = i + 2;
        let row = master_to_row(m);
        finite_row(path, line, 0, &row, &MASTER_COLUMNS)?;
        let [t, qw, qx, qy, qz, _, _, _, lat, _, _] = row;
        order
            .next(t)
            .map_err(|kind| at(path, line, 0, TIME_COLUMN, kind))?;
        rules::unit_quaternion([qw, qx, qy, qz])
            .map_err(|kind| at(path, line, MASTER_QW, "qw", kind))?;
        rules::latitude(lat).map_err(|kind| at(path, line, MASTER_LAT, "lat_deg", kind))?;
        match (has_rate, &m.omega_ib_bm_radps) {
            (true, Some(w)) => {
                finite_row(path, line, MASTER_COLUMNS.len(), w, &MASTER_RATE_COLUMNS)?
            }
            (false, None) => {}
            _ => return Err(RecordingError::new(path, ErrorKind::MixedMasterRate).at_line(line)),
        }
    }
    Ok(())
}

/// Why a truth column name would not come back from the reader as it is.
fn name_problem(name: &str) -> Option<&'static str> {
    if name.is_empty() {
        Some("empty")
    } else if name == TIME_COLUMN {
        Some("`t` is the time column")
    } else if name.trim() != name {
        Some("leading or trailing whitespace")
    } else if name.contains(',') {
        Some("contains a comma")
    } else if name.chars().any(char::is_control) {
        Some("contains a control character")
    } else {
        None
    }
}

/// The truth table as `truth.csv` will hold it: header `t,names...`, then rows.
pub(crate) fn truth(path: &Path, truth: &Truth) -> Result<(), RecordingError> {
    let header = |kind| RecordingError::new(path, kind).at_line(1);
    if truth.columns.len() != truth.names.len() {
        return Err(header(ErrorKind::LengthMismatch {
            what: "number of columns for the names",
            expected: truth.names.len(),
            found: truth.columns.len(),
        }));
    }
    for (i, name) in truth.names.iter().enumerate() {
        let col = i + 1;
        if let Some(reason) = name_problem(name) {
            let kind = ErrorKind::InvalidColumnName {
                name: quoted(name),
                reason,
            };
            return Err(header(kind).at_column(col, name));
        }
        if let Some(first) = truth.names.iter().take(i).position(|n| n == name) {
            let kind = ErrorKind::DuplicateColumn { first: first + 2 };
            return Err(header(kind).at_column(col, name));
        }
    }
    if truth.t.is_empty() {
        let needed = "at least one line of values";
        return Err(RecordingError::new(path, ErrorKind::NoSamples { needed }));
    }
    let mut order = TimeOrder::default();
    for (i, &t) in truth.t.iter().enumerate() {
        let line = i + 2;
        rules::finite(t)
            .and_then(|t| order.next(t))
            .map_err(|kind| at(path, line, 0, TIME_COLUMN, kind))?;
    }
    for (i, (name, column)) in truth.names.iter().zip(&truth.columns).enumerate() {
        let col = i + 1;
        if column.len() != truth.t.len() {
            let kind = ErrorKind::LengthMismatch {
                what: "values in this column",
                expected: truth.t.len(),
                found: column.len(),
            };
            return Err(RecordingError::new(path, kind).at_column(col, name));
        }
        for (j, &x) in column.iter().enumerate() {
            rules::finite(x).map_err(|kind| at(path, j + 2, col, name, kind))?;
        }
    }
    Ok(())
}
