//! Writing a recording folder (format version 1) that reads back bit-exactly.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::Path;

use super::error::{ErrorKind, RecordingError};
use super::layout::{
    imu_to_row, master_to_row, MASTER_COLUMNS, MASTER_RATE_COLUMNS, SLAVE_INCREMENT_COLUMNS,
    TIME_COLUMN,
};
use super::{
    check, meta, MasterMsg, Recording, Truth, MASTER_FILE, META_FILE, SLAVE_FILE, TRUTH_FILE,
};

/// Writes `rec` into folder `dir` (created if needed), so that
/// [`read_recording`](super::read_recording) gives it back bit-exactly.
///
/// - The slave file always holds increments (`output = "increments"`), with
///   a first line at `imu_t0` and zero increments that only starts the clock.
/// - Numbers are written in Rust's shortest round-trip form (`{}`, or `{:e}`
///   outside `[1e-3, 1e16)` to keep extreme magnitudes short).
/// - Without truth, a `truth.csv` left in `dir` by an earlier write is removed.
///
/// Everything is checked before any file is touched: a recording the reader
/// would refuse is an error naming the file, line and column it would have had.
pub fn write_recording(dir: &Path, rec: &Recording) -> Result<(), RecordingError> {
    let meta_path = dir.join(META_FILE);
    let slave_path = dir.join(SLAVE_FILE);
    let master_path = dir.join(MASTER_FILE);
    let truth_path = dir.join(TRUTH_FILE);

    let meta_text = meta::render(&rec.meta);
    meta::parse(&meta_path, &meta_text)?;
    check::slave(&slave_path, rec.imu_t0, &rec.imu)?;
    check::master(&master_path, &rec.master)?;
    if let Some(truth) = &rec.truth {
        check::truth(&truth_path, truth)?;
    }

    fs::create_dir_all(dir).map_err(|e| RecordingError::new(dir, ErrorKind::Io(e)))?;
    write_file(&meta_path, |w| w.write_all(meta_text.as_bytes()))?;
    write_file(&slave_path, |w| write_slave(w, rec))?;
    write_file(&master_path, |w| write_master(w, &rec.master))?;
    match &rec.truth {
        Some(truth) => write_file(&truth_path, |w| write_truth(w, truth)),
        None => remove_if_present(&truth_path),
    }
}

/// Creates `path` and fills it with `body`.
fn write_file(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), RecordingError> {
    let io_error = |e| RecordingError::new(path, ErrorKind::Io(e));
    let mut w = BufWriter::new(File::create(path).map_err(io_error)?);
    body(&mut w).map_err(io_error)?;
    w.flush().map_err(io_error)
}

/// Removes a stale file; its absence is fine.
fn remove_if_present(path: &Path) -> Result<(), RecordingError> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => {
            Err(RecordingError::new(path, ErrorKind::Io(e)))
        }
        _ => Ok(()),
    }
}

/// Writes `x` so that `f64::from_str` gives back the same bits.
fn write_f64(w: &mut impl Write, x: f64) -> io::Result<()> {
    let magnitude = x.abs();
    if magnitude == 0.0 || (1e-3..1e16).contains(&magnitude) {
        write!(w, "{x}")
    } else {
        write!(w, "{x:e}")
    }
}

/// Writes numbers separated by commas (no line end).
fn write_fields(w: &mut impl Write, values: &[f64]) -> io::Result<()> {
    for (i, &x) in values.iter().enumerate() {
        if i > 0 {
            w.write_all(b",")?;
        }
        write_f64(w, x)?;
    }
    Ok(())
}

/// `slave_imu.csv`: header, the clock-starting line, then the samples.
fn write_slave(w: &mut impl Write, rec: &Recording) -> io::Result<()> {
    writeln!(w, "{}", SLAVE_INCREMENT_COLUMNS.join(","))?;
    write_fields(w, &[rec.imu_t0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])?;
    writeln!(w)?;
    for sample in &rec.imu {
        write_fields(w, &imu_to_row(sample))?;
        writeln!(w)?;
    }
    Ok(())
}

/// `master.csv`, with `wx,wy,wz` when the messages carry a rate (checked:
/// all of them or none).
fn write_master(w: &mut impl Write, master: &[MasterMsg]) -> io::Result<()> {
    write!(w, "{}", MASTER_COLUMNS.join(","))?;
    if master.iter().all(|m| m.omega_ib_bm_radps.is_some()) {
        write!(w, ",{}", MASTER_RATE_COLUMNS.join(","))?;
    }
    writeln!(w)?;
    for m in master {
        write_fields(w, &master_to_row(m))?;
        if let Some(rate) = &m.omega_ib_bm_radps {
            w.write_all(b",")?;
            write_fields(w, rate)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// `truth.csv`: `t` then the named columns, one line per time (lengths checked).
fn write_truth(w: &mut impl Write, truth: &Truth) -> io::Result<()> {
    write!(w, "{TIME_COLUMN}")?;
    for name in &truth.names {
        write!(w, ",{name}")?;
    }
    writeln!(w)?;
    let mut columns: Vec<_> = truth.columns.iter().map(|c| c.iter()).collect();
    for &t in &truth.t {
        write_f64(w, t)?;
        for x in columns.iter_mut().filter_map(Iterator::next) {
            w.write_all(b",")?;
            write_f64(w, *x)?;
        }
        writeln!(w)?;
    }
    Ok(())
}
